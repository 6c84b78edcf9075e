"""MCP server benchmark (issue 26.1): the second `check` of a program through `procedura-brep
mcp` against a cold CLI `check` of it, measured in one run (target: ratio <= 0.2). The second
check of an unchanged program is answered from the server's memory; the benchmark also times an
`edit_params` of the last param (compile of the changed parts in the warm worker, and every gate
again in a limited child), the warm path of a program that changed.

Run: ``python benchmarks/mcp_check.py [--only rover] [--runs 3]`` (not named mcp.py: it would shadow the SDK).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def cold_check(program: Path) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "procedura_brep", "check", str(program), "-q"],
                   capture_output=True, env={**os.environ, "PROCEDURA_BREP_SERVER": "off"})
    return time.perf_counter() - t


def last_param(source: str) -> tuple[str, float]:
    from procedura_brep.program.sections import parse_sections
    sec = parse_sections(source)
    name = list(sec.params)[-1]
    return name, float(eval(sec.params[name].expr, {"__builtins__": {}}))  # a literal in the goldens


def server_checks(source: str, name: str, n: int) -> list[float]:
    from mcp import Client, StdioServerParameters

    async def main() -> list[float]:
        params = StdioServerParameters(command=sys.executable, args=["-m", "procedura_brep", "mcp"],
                                       env={**os.environ, "PROCEDURA_BREP_SERVER": "off"})
        out = []
        async with Client(params) as client:
            for _ in range(n):
                t = time.perf_counter()
                res = await client.call_tool("check", {"program": source, "name": name})
                out.append(time.perf_counter() - t)
                assert not res.is_error, res.content[0].text
            pname, value = last_param(source)
            t = time.perf_counter()
            res = await client.call_tool("edit_params", {"program": source, "name": name,
                                                         "params": {pname: value * 1.05}})
            out.append(time.perf_counter() - t)
            assert not res.is_error, res.content[0].text
        return out
    return asyncio.run(main())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="rover")
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    program = ROOT / "golden" / args.only / "program.py"
    colds, seconds, firsts, edits = [], [], [], []
    for _ in range(args.runs):  # the two take turns, so drift in the machine hits both
        colds.append(cold_check(program))
        times = server_checks(program.read_text(), args.only, 2)
        firsts.append(times[0])
        seconds.append(times[1])
        edits.append(times[2])
    cold, second, edit = statistics.median(colds), statistics.median(seconds), statistics.median(edits)
    print(f"{args.only}: cold CLI check median {cold:.2f} s; through the MCP server: first check "
          f"{statistics.median(firsts):.2f} s (worker start included), second {second:.2f} s "
          f"(second/cold {second / cold:.3f}, target <= 0.2), an edit_params of the last param "
          f"then its gates {edit:.2f} s (edit/cold {edit / cold:.3f}); {args.runs} runs")


if __name__ == "__main__":
    main()
