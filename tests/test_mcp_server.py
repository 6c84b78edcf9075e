"""`procedura-brep mcp` (issue 26.1) driven through the official SDK's client over stdio: every
tool answers with structured content and a short text, and a failing call leaves the server
alive and warm."""

from __future__ import annotations

import asyncio
import os
import sys
import time
from pathlib import Path

import pytest

LAMP = (Path(__file__).parent / "program" / "lamp.py").read_text()
TOOLS = {"new_program", "check", "edit_params", "splice_part", "render", "build", "export", "simulate",
         "mate_vocabulary"}


def _session(script):
    """Run ``script(client)`` against a fresh `procedura-brep mcp` over stdio."""
    from mcp import Client, StdioServerParameters

    async def main():
        params = StdioServerParameters(command=sys.executable, args=["-m", "procedura_brep", "mcp"],
                                       env={**os.environ, "PROCEDURA_BREP_SERVER": "off"})
        async with Client(params) as client:
            return await script(client)
    return asyncio.run(main())


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_tools_answer_structured_and_a_failure_leaves_the_server_warm(tmp_path):
    async def script(client):
        out = {"tools": {t.name for t in (await client.list_tools()).tools}}
        t = time.perf_counter()
        out["first"] = await client.call_tool("check", {"program": LAMP, "name": "lamp"})
        out["first_s"] = time.perf_counter() - t
        out["broken"] = await client.call_tool("check", {"program": LAMP.replace("Box(90,", "Box(1 / 0,"),
                                                         "name": "lamp"})
        out["bad_param"] = await client.call_tool("edit_params", {"program": LAMP, "params": {"arm_len": 1}})
        out["runaway"] = await client.call_tool("check", {"program": LAMP.replace(
            "    return Box(90,", "    while True:\n        pass\n    return Box(90,"), "time_limit_s": 2})
        t = time.perf_counter()
        out["second"] = await client.call_tool("check", {"program": LAMP, "name": "lamp"})
        out["second_s"] = time.perf_counter() - t
        out["render"] = await client.call_tool("render", {"program": LAMP, "views": ["iso_se"], "size": 96})
        out["edit"] = await client.call_tool("edit_params", {"program": LAMP, "params": {"post_h": 100}})
        out["vocab"] = await client.call_tool("mate_vocabulary", {})
        out["ref"] = await client.read_resource("procedura-brep://reference")
        out["build"] = await client.call_tool("build", {"program": LAMP, "out_dir": str(tmp_path / "run"),
                                                        "name": "lamp"})
        uris = out["build"].structured_content["resources"]
        out["run_files"] = {f: await client.read_resource(u) for f, u in uris.items()}
        out["templates"] = [t.uri_template for t in (await client.list_resource_templates()).resource_templates]
        from mcp import MCPError
        try:
            await client.read_resource("procedura-brep://runs/elsewhere/report.json")
            out["unknown_run"] = "served"
        except MCPError as exc:
            out["unknown_run"] = str(exc)
        return out

    got = _session(script)
    assert TOOLS <= got["tools"]
    first, second = got["first"], got["second"]
    assert not first.is_error and first.structured_content["passed"] is True
    assert first.content[0].text == "all gates pass"
    assert {"base", "post", "arm"} == set(first.structured_content["parts"])
    broken = got["broken"].structured_content  # a program that fails is an answer, with its codes
    assert broken["passed"] is False and "ZeroDivisionError" in got["broken"].content[0].text
    assert broken["findings"][0]["code"] == "part-exception" and broken["findings"][0]["part"] == "arm"
    assert got["bad_param"].is_error and "arm_len" in got["bad_param"].content[0].text  # a bad call
    runaway = got["runaway"]  # a program that runs out of time: an error, and the server lives on
    # out of time: the CPU limit, or the wall-clock one first when the machine is loaded
    assert runaway.is_error and ("CPU time limit" in runaway.content[0].text
                                 or "wall-clock limit" in runaway.content[0].text), runaway.content[0].text
    assert not second.is_error and second.structured_content == first.structured_content  # alive, same
    assert got["second_s"] < got["first_s"]  # warm: the worker and its part cache
    img = got["render"].content[1]
    assert img.type == "image" and img.mime_type == "image/png" and len(img.data) > 100
    assert "arm" in got["render"].structured_content["legend"]
    edit = got["edit"].structured_content
    assert "post_h = 100" in edit["program"] and isinstance(edit["passed"], bool)
    assert {t["type"] for t in got["vocab"].structured_content["types"]} >= {"revolute", "key", "bolt_pattern"}
    assert "Reply with five blocks" in got["ref"].contents[0].text
    build = got["build"].structured_content
    assert build["status"] == "ok" and "model.step" in build["files"]
    # the run directory's report, mates, summary and sheet as resources, and no other path
    files = got["run_files"]
    assert set(files) == {"report.json", "mates.json", "summary.md", "sheet.png"}
    assert '"status": "ok"' in files["report.json"].contents[0].text
    assert "arm_pivot" in files["mates.json"].contents[0].text
    sheet = files["sheet.png"].contents[0]
    assert sheet.mime_type == "image/png" and len(sheet.blob) > 1000
    assert "procedura-brep://runs/{run}/sheet.png" in got["templates"]
    assert "unknown run 'elsewhere'" in got["unknown_run"]


def test_streamable_http_behind_the_flag():
    import socket
    import subprocess

    from mcp import Client
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "procedura_brep", "mcp", "--http", str(port)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
                break
            except OSError:
                time.sleep(0.2)

        async def main():
            async with Client(f"http://127.0.0.1:{port}/mcp") as client:
                return await client.call_tool("mate_vocabulary", {})
        res = asyncio.run(main())
        assert not res.is_error and len(res.structured_content["types"]) >= 13
    finally:
        proc.terminate()
        proc.wait(10)
