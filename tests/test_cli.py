"""The CLI: build and edit end to end on the lamp program (CliRunner, sandboxed compiles)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app

LAMP = Path(__file__).parent / "program" / "lamp.py"
runner = CliRunner()


def invoke(*args: str):
    res = runner.invoke(app, list(args))
    assert "Traceback" not in res.output
    return res


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("lamp")
    res = invoke("build", str(LAMP), "-o", str(out), "--formats", "step")
    assert res.exit_code == 0, res.output
    return out


def test_build_writes_the_run_directory(built):
    for name in ("program.py", "model.step", "mates.json", "report.json"):
        assert (built / name).stat().st_size > 0
    assert (built / "program.py").read_text() == LAMP.read_text()


def test_mates_json_has_every_field(built):
    mates = json.loads((built / "mates.json").read_text())["mates"]
    by = {m["name"]: m for m in mates}
    peg, hinge = by["post_foot"], by["arm_pivot"]
    assert peg["type"] == "peg_socket" and peg["child"] == {"part": "post", "frame": "foot"}
    assert peg["parent"] == {"part": "base", "frame": "top"}
    assert peg["nominal"] == {"name": "spigot_d", "value_mm": 12.0}
    assert peg["fit"]["iso"] == "H7/k6" and peg["resolved_offset_mm"] == pytest.approx(peg["fit"]["offset"])
    assert peg["dof"]["count"] == 0 and peg["world_frame"]["origin_mm"] == pytest.approx([0, 0, 12])
    assert hinge["dof"] == {"count": 1, "translation": [], "rotation": ["z"]}
    assert hinge["limits"] == [-45, 45] and hinge["fit"]["iso"] == "H7/g6"


def test_report_json_per_part_and_mate(built):
    rep = json.loads((built / "report.json").read_text())
    assert rep["status"] == "ok"
    parts = {p["name"]: p for p in rep["parts"]}
    assert set(parts) == {"base", "post", "arm"}
    assert parts["base"]["material"] == "cast_iron" and parts["base"]["volume_mm3"] > 1e5
    assert parts["base"]["bbox_mm"] == [pytest.approx([-60, -60, 0]), pytest.approx([60, 60, 12])]
    assert all(m["residual_mm"] == 0.0 for m in rep["mates"])
    assert rep["timings"]["compile_s"] > 0 and rep["gates"]["passed"] is True


def test_build_missing_file_is_one_line(tmp_path):
    res = invoke("build", str(tmp_path / "nope.py"), "-o", str(tmp_path / "o"))
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "does not exist" in res.output
    assert str(tmp_path / "nope.py") in res.output


def test_build_failing_part_reports_and_writes_report(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(LAMP.read_text().replace("return Box(90, 14, 10", "return Box(90, 14, -10"))
    res = invoke("build", str(bad), "-o", str(tmp_path / "o"), "--formats", "step")
    assert res.exit_code != 0 and "part arm" in res.stderr and res.stdout == ""
    assert len([l for l in res.stderr.splitlines() if l.startswith("error:")]) == 1
    rep = json.loads((tmp_path / "o" / "report.json").read_text())
    assert rep["status"] == "failed" and rep["findings"][0]["part"] == "arm"


def test_edit_to_new_file_changes_only_the_param_line(tmp_path):
    new = tmp_path / "lamp2.py"
    res = invoke("edit", str(LAMP), "--set", "post_h=95", "-o", str(new), "--no-check")
    assert res.exit_code == 0, res.output
    a, b = LAMP.read_text().splitlines(), new.read_text().splitlines()
    assert [i for i, (x, y) in enumerate(zip(a, b)) if x != y] == [a.index(next(l for l in a if l.startswith("post_h")))]
    assert "post_h = 95.0   # mm" in new.read_text()


def test_edit_unknown_param_lists_params(tmp_path):
    res = invoke("edit", str(LAMP), "--set", "wheel_d=3", "-o", str(tmp_path / "x.py"))
    assert res.exit_code == 2 and "params: base_w, base_t" in res.output


def test_edit_that_breaks_a_mate_is_rejected(tmp_path):
    prog = tmp_path / "lamp.py"
    shutil.copy(LAMP, prog)
    res = invoke("edit", str(prog), "--set", "pin_d=900")
    assert res.exit_code == 1 and "rejected" in res.output and "arm_pivot" in res.output
    assert prog.read_text() == LAMP.read_text()


def test_edit_in_place_with_build(tmp_path):
    prog = tmp_path / "lamp.py"
    shutil.copy(LAMP, prog)
    res = invoke("edit", str(prog), "--set", "post_h=100", "--build", str(tmp_path / "b"))
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "b" / "report.json").read_text())
    post = next(p for p in rep["parts"] if p["name"] == "post")
    assert post["bbox_mm"][1][2] == pytest.approx(12 + 100, abs=1e-3)
    assert "post_h = 100.0" in prog.read_text()


def test_check_json_and_exit_codes(tmp_path):
    res = invoke("check", str(LAMP), "--json")
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["passed"] and data["n_vis"] == 0
    peg = data["mates"]["post_foot"]
    assert peg["area_mm2"] >= peg["area_limit_mm2"] and peg["penetration_mm"] <= peg["penetration_limit_mm"]
    # lift the post 0.5 mm off its seat: the mate gate fails on area -> exit 1
    lifted = tmp_path / "lifted.py"
    lifted.write_text(LAMP.read_text().replace('foot=Location((0, 0, 0))', 'foot=Location((0, 0, -0.5))'))
    res = invoke("check", str(lifted))
    assert res.exit_code == 1 and "FAIL" in res.output
    res = invoke("check", str(tmp_path / "missing.py"))
    assert res.exit_code == 2


def test_render_cli(tmp_path):
    res = invoke("render", str(LAMP), "-o", str(tmp_path / "r"), "--views", "iso_ne,front",
                 "--size", "128", "--sheet", "--mode", "clay")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "r" / "clay_iso_ne.png").exists() and (tmp_path / "r" / "clay_sheet.png").exists()
    res = invoke("render", str(LAMP), "-o", str(tmp_path / "r"), "--views", "sideways")
    assert res.exit_code == 2 and "sideways" in res.output


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_doctor_reports_every_component():
    res = invoke("doctor")
    names = ("CAD kernel", "MuJoCo", "OpenUSD", "render backend", "FreeCAD", "model")
    for name in names:
        assert name in res.output, res.output
    assert res.exit_code == (1 if "MISSING" in res.output else 0)
    res = invoke("doctor", "--model", "nonsense:model")
    assert "nonsense" in res.output and res.exit_code == 1


def test_export_ap242(tmp_path):
    res = invoke("export", str(LAMP), "-o", str(tmp_path), "--formats", "step", "--step-schema", "AP242")
    assert res.exit_code == 0, res.output
    assert "AP242_MANAGED_MODEL_BASED_3D_ENGINEERING" in (tmp_path / "model.step").read_text()


# --- user mistakes are exit 2 with a message that names the path (never "internal error") ---

def _one_error_line(res, code: int = 2) -> str:
    assert res.exit_code == code, res.output
    lines = [l for l in res.stderr.splitlines() if l.startswith("error:")]
    assert len(lines) == 1 and "internal error" not in lines[0], res.stderr
    return lines[0]


def test_output_that_is_a_file_is_exit_2(tmp_path):
    f = tmp_path / "taken"
    f.write_text("x")
    line = _one_error_line(invoke("build", str(LAMP), "-o", str(f)))
    assert line == f"error: cannot write output {f}: it exists and is not a directory"
    line = _one_error_line(invoke("build", str(LAMP), "-o", str(f / "sub")))
    assert line == f"error: cannot write output {f / 'sub'}: {f} is a file, not a directory"
    for cmd in (("export", str(LAMP)), ("render", str(LAMP)), ("generate", "a lamp", "--model",
                                                                "scripted:")):
        line = _one_error_line(invoke(*cmd, "-o", str(f)))
        assert line.startswith(f"error: cannot write output {f}: "), line
    assert f.read_text() == "x"


def test_output_refused_by_the_kernel_is_exit_2():
    # as root, mkdir under /sys is refused (EPERM) whatever the mode bits say: a real refusal
    line = _one_error_line(invoke("build", str(LAMP), "-o", "/sys/procedura-out"))
    assert line == "error: cannot write output /sys/procedura-out: permission denied"


def _as_nobody(*args: str) -> tuple[int, str]:
    """Run the CLI in a forked child that has switched to ``nobody`` (exit code, stderr).

    The venv's interpreter lives under /root, which nobody may not execute, so the child is a
    fork of this process, with everything the command loads loaded before the switch."""
    import os
    import pickle
    import pwd
    runner.invoke(app, ["build", str(LAMP), "-o", "/sys/procedura-warm"])  # load what it needs
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        code = 99
        try:
            os.close(r)
            nobody = pwd.getpwnam("nobody")
            os.setgroups([])
            os.setgid(nobody.pw_gid)
            os.setuid(nobody.pw_uid)
            res = runner.invoke(app, list(args))
            os.write(w, pickle.dumps((res.exit_code, res.stderr)))
            code = 0
        finally:
            os._exit(code)
    os.close(w)
    with os.fdopen(r, "rb") as fh:
        data = fh.read()
    os.waitpid(pid, 0)
    return pickle.loads(data)


def test_permission_denied_as_an_ordinary_user(tmp_path):
    """Tests run as root, which no mode bit stops; so the CLI runs as ``nobody`` (a real EACCES
    from the kernel) on a root-owned output folder and a root-only input file."""
    import os
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o755)
    os.chmod(tmp_path, 0o755)
    secret = tmp_path / "secret.py"
    secret.write_text(LAMP.read_text())
    secret.chmod(0o600)
    code, err = _as_nobody("build", str(LAMP), "-o", str(locked / "run"))
    assert code == 2, err
    assert err.strip() == f"error: cannot write output {locked / 'run'}: permission denied"
    code, err = _as_nobody("build", str(secret), "-o", str(locked / "run"))
    assert code == 2 and err.strip() == f"error: cannot read input {secret}: permission denied"
    assert not (locked / "run").exists()


def test_binary_input_names_the_file(tmp_path):
    png = tmp_path / "picture.py"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    line = _one_error_line(invoke("build", str(png), "-o", str(tmp_path / "o")))
    assert str(png) in line and "not UTF-8 text" in line and "0x89" in line
    for cmd in ("check", "simulate"):
        assert str(png) in _one_error_line(invoke(cmd, str(png)))


def test_simulate_a_directory_without_a_program_is_exit_2(tmp_path):
    line = _one_error_line(invoke("simulate", str(tmp_path)))
    assert f"{tmp_path} has no program.py" in line


def test_readme_documents_exit_codes_3_and_130():
    readme = (Path(__file__).parents[1] / "README.md").read_text()
    table = readme[readme.index("## Commands"):readme.index("## Outputs")]
    assert "3 internal error" in table and "130 interrupted" in table
    assert "procedura-brep simulate" in table and "2 no program" in table


# --- refused before the compile; lines and all findings shown ---

@pytest.fixture()
def no_compile(monkeypatch):
    def fail(*a, **k):
        raise AssertionError("compiled although the arguments were invalid")
    monkeypatch.setattr("procedura_brep.run.steps.compile_model", fail)


def test_render_bad_view_or_mode_refused_before_compile(tmp_path, no_compile):
    line = _one_error_line(invoke("render", str(LAMP), "-o", str(tmp_path), "--views", "bogus"))
    assert "'bogus'" in line and "iso_ne" in line and "front" in line
    line = _one_error_line(invoke("render", str(LAMP), "-o", str(tmp_path), "--mode", "wireframe"))
    assert "'wireframe'" in line and "parts, clay, pbr" in line
    line = _one_error_line(invoke("render", str(LAMP), "-o", str(tmp_path), "--size", "9"))
    assert "9" in line and "[32, 4096]" in line


TWO_BAD = LAMP.read_text().replace("return Box(90, 14, 10", "return Box(90, 14, -10").replace(
    "p = Cylinder(post_d / 2, post_h", "p = Cylinder(-post_d / 2, post_h")


ARM_BODY = "return Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))"


def _line_of(text: str, needle: str) -> int:
    return next(i for i, l in enumerate(text.splitlines(), 1) if needle in l)


def test_part_exception_shows_its_program_line(tmp_path):
    """A part that raises is the program's fault: exit 2 from build, as from check (they
    disagreed before: 1 and 2)."""
    bad = tmp_path / "bad.py"
    bad.write_text(LAMP.read_text().replace(ARM_BODY, "return [][3]"))
    res = invoke("check", str(bad))
    assert res.exit_code == 2 and "IndexError" in res.stderr, res.output
    res = invoke("build", str(bad), "-o", str(tmp_path / "o"), "--formats", "step")
    line = _one_error_line(res, code=2)
    assert "part arm" in line and "IndexError" in line
    assert f"line {_line_of(bad.read_text(), 'return [][3]')}" in line


def test_more_errors_are_listed_with_verbose_and_in_json(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(TWO_BAD)
    res = invoke("build", str(bad), "-o", str(tmp_path / "o"), "--formats", "step")
    assert "(+1 more" in _one_error_line(res, code=2) and "also:" not in res.stderr
    res = invoke("-v", "build", str(bad), "-o", str(tmp_path / "o"), "--formats", "step")
    also = [l for l in res.stderr.splitlines() if l.startswith("  also:")]
    assert len(also) == 1 and ("part arm" in also[0] or "part post" in also[0]), res.stderr
    res = invoke("check", str(bad), "--json")
    assert res.exit_code == 2
    data = json.loads(res.stdout)
    assert data["passed"] is False and data["compiled"] is False
    assert {f.get("part") for f in data["findings"]} >= {"arm", "post"}


def test_check_json_on_a_compile_error_is_json(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(LAMP.read_text().replace("# === assembly ===", "# === assembly ===\n("))
    res = invoke("check", str(bad), "--json")
    assert res.exit_code == 2, res.output
    data = json.loads(res.stdout)
    assert data["passed"] is False and data["compiled"] is False and data["error"]


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_build_simulate_names_the_failing_check(tmp_path):
    wide = tmp_path / "wide.py"
    wide.write_text(LAMP.read_text().replace("limits=(-45, 45)", "limits=(-100, 100)"))
    out = tmp_path / "o"
    res = invoke("build", str(wide), "-o", str(out), "--simulate", "--formats", "urdf,usd,mjcf")
    line = _one_error_line(res, code=1)
    assert "battery B2" in line and "gates_failed" not in line, line
    rep = json.loads((out / "report.json").read_text())
    assert rep["status"] == "battery_failed"
    assert any(f["code"] == "battery-B2" for f in rep["findings"])


# --- progress on stderr, stdout clean ---

def test_progress_goes_to_stderr_and_quiet_silences_it(tmp_path):
    res = invoke("build", str(LAMP), "-o", str(tmp_path / "o"), "--formats", "step")
    assert res.exit_code == 0
    assert res.stdout.startswith("built 3 parts") and res.stdout.count("\n") == 1
    for stage in ("compiling lamp", "writing 3 parts as step", "running the gates", "saving"):
        assert stage in res.stderr, res.stderr
    res = invoke("build", str(LAMP), "-o", str(tmp_path / "o"), "--formats", "step", "-q")
    assert res.exit_code == 0 and res.stderr == ""
    res = invoke("check", str(LAMP), "--json")
    assert json.loads(res.stdout)["passed"] and "running the gates" in res.stderr


def test_generate_replay_says_what_each_attempts_feedback_was(tmp_path):
    tape = Path(__file__).parents[1] / "examples" / "tapes" / "lamp_oneshot.jsonl"
    res = invoke("generate", "--one-shot", "a desk lamp with a swinging arm", "-o", str(tmp_path / "lamp"),
                 "--model", f"replay:{tape}", "--formats", "step")
    assert res.exit_code == 0, res.output
    err = res.stderr
    assert "attempt 1/3: asking replay:" in err and "attempt 2/3: asking replay:" in err
    assert "attempt 1/3: build failed: mate post_foot: nominal must be a param name" in err
    assert "feedback to the model: 1 finding(s): mate post_foot" in err
    assert "attempt 2/3: built" in err


# --- what a program says never reaches the terminal raw ---

def test_escape_sequences_in_an_exception_are_stripped(tmp_path):
    bad = tmp_path / "bad.py"
    evil = (r'raise ValueError("x\x1b[2K\x1b[1Gbuilt 3 parts, 2 mates\x1b]52;c;ZXZpbA==\x07'
            r'\x1b]0;t\x07\x9b1A" + "A" * 50000)')
    bad.write_text(LAMP.read_text().replace(ARM_BODY, evil))
    assert evil in bad.read_text()
    res = invoke("build", str(bad), "-o", str(tmp_path / "o"), "--formats", "step")
    line = _one_error_line(res, code=2)
    assert "built 3 parts" in line  # the text is shown, the escape sequences are not
    assert not any(c in res.output for c in "\x1b\r\x07\x9b")
    assert "ZXZpbA" not in line and "more characters]" in line
    assert len(res.output) < 5000


def test_check_tables_escape_markup():
    import contextlib
    import io

    from procedura_brep.console import print_check
    data = {"model": "[red]m", "passed": False, "triangles_per_part": {"[bold]p": 12},
            "findings": [{"part": "[bold]p", "severity": "error", "code": "[blink]c",
                          "message": "[link=https://evil.example]click[/link]\x1b]0;t\x07"}],
            "mates": {"[red]mate[/red]": {"passed": True, "area_mm2": 1.0, "area_limit_mm2": 0.5,
                                          "penetration_mm": 0.0, "penetration_limit_mm": 0.01}},
            "connectivity": {"n_vis": 0}, "metrics": {}}
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        print_check(data)
    text = buf.getvalue()
    assert "[red]mate[/red]" in text and "[bold]p" in text and "[blink]c" in text
    assert "[link=https://evil.example]click[/link]" in text and "\x1b" not in text


def test_check_verbose_lists_every_compile_error_after_the_first(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(TWO_BAD)
    res = invoke("-v", "check", str(bad))
    lines = [l for l in res.stderr.splitlines() if l.startswith(("error:", "  also:"))]
    assert res.exit_code == 2 and len(lines) == 2, res.stderr
    assert lines[0].startswith("error:") and "(+1 more" in lines[0] and lines[1].startswith("  also: part")


def test_verbose_after_the_subcommand_is_the_tool_s_own_detail():
    """Issue 26.4: `-v` works after the subcommand, as the README says, and shows this tool's
    DEBUG lines, not third-party ones (OpenGL flooded the terminal)."""
    import subprocess
    import sys

    from procedura_brep.cli import hoist_verbose
    assert hoist_verbose(["build", "p.py", "-o", "d", "-v"]) == ["-v", "build", "p.py", "-o", "d"]
    assert hoist_verbose(["check", "--verbose", "p.py", "--", "-v"]) == ["--verbose", "check", "p.py", "--", "-v"]
    code = ("import logging, sys\nfrom procedura_brep.cli import main_callback\nmain_callback(True)\n"
            "logging.getLogger('OpenGL.acceleratesupport').debug('third party')\n"
            "logging.getLogger('procedura_brep.x').debug('ours')\n")
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stderr
    assert "ours" in err and "third party" not in err
    run = subprocess.run([sys.executable, "-c", "import sys; sys.argv = ['procedura-brep', 'check', "
                          "'no_such_program.py', '-v']; from procedura_brep.cli import main; main()"],
                         capture_output=True, text=True)
    assert run.returncode == 2 and "does not exist" in run.stderr and "No such option" not in run.stderr


def test_the_module_entry_points_know_every_command():
    """Issue 25.1: `python -m procedura_brep.cli bench` said "No such command 'bench'" (main()
    ran before bench was defined), and layers.toml named a `__main__` that did not exist."""
    import subprocess
    import sys
    for cmd in (["-m", "procedura_brep.cli", "bench", "--help"], ["-m", "procedura_brep", "serve", "--help"]):
        run = subprocess.run([sys.executable, *cmd], capture_output=True, text=True)
        assert run.returncode == 0 and "Usage:" in run.stdout, (cmd, run.stderr[-300:])


def test_provider_errors_are_the_package_s_errors_and_config_mistakes_are_usage():
    """Issue 25.5: LLMError under the root error, so the CLI catches one type; a configuration
    mistake reaching the guard is the user's (exit 2), a provider failure a failure (exit 1)."""
    import typer

    from procedura_brep.cli import guarded
    from procedura_brep.errors import ProceduraError
    from procedura_brep.llm.errors import ConfigError, LLMError, ProviderError
    assert issubclass(LLMError, ProceduraError)
    for exc, code in ((ConfigError("no such provider 'nope'"), 2), (ProviderError("the server said 500"), 1)):
        def fail(exc=exc):
            raise exc
        with pytest.raises(typer.Exit) as got:
            guarded(fail)()
        assert got.value.exit_code == code


def test_the_battery_table_reads_as_quantities_not_python_dicts(capsys, monkeypatch):
    """Issue 26.4: `simulate`'s table printed a Python dict cut off mid-word."""
    from procedura_brep.console import print_battery
    monkeypatch.setenv("COLUMNS", "160")  # one cell a line: the test reads cells whole
    data = {"passed": True, "verified": True, "checks": [{
        "id": "B1", "name": "dynamic settle", "status": "pass", "message": "settled",
        "measured": {"max_drift_deg": 0.25, "root_speed_mps": 0.0, "finite": True,
                     "joints": {"arm_pivot": {"drift_deg": 0.25, "gravity_torque_Nm": 8.87}}},
        "limits": {"max_drift_deg": 1.0, "finite": True}}]}
    print_battery(data)
    out = capsys.readouterr().out
    assert "{'" not in out and "arm_pivot" not in out
    for cell in ("max drift 0.25 deg (limit 1)", "root speed 0 m/s", "finite: yes (limit yes)",
                 "joints: 1 (each in --json)"):
        assert cell in out, (cell, out)


def test_mistyped_names_get_a_did_you_mean(tmp_path):
    """Issue 26.4: a mistyped param, part, mate or material is answered with the closest name."""
    from procedura_brep import materials
    from procedura_brep.errors import EditError
    from procedura_brep.program.edit import set_params
    from procedura_brep.text import did_you_mean
    lamp = (Path(__file__).parent / "program" / "lamp.py").read_text()
    with pytest.raises(EditError, match=r"unknown param\(s\) post_hh \(did you mean 'post_h'\?\)"):
        set_params(lamp, {"post_hh": 100})
    with pytest.raises(materials.MaterialError, match=r"did you mean 'aluminium'\?"):
        materials.get("aluminum")
    assert did_you_mean("wheel_rx", ["wheel_fl", "wheel_rl", "chassis"]) == " (did you mean 'wheel_rl'?)"
    assert did_you_mean("zzz", ["wheel_fl", "chassis"]) == ""
    from procedura_brep.agent.revise import ReviseError, revise
    out = tmp_path / "lamp"
    out.mkdir()
    (out / "program.py").write_text(lamp)
    with pytest.raises(ReviseError, match=r"--part pots: not a part \(did you mean 'post'\?\)"):
        revise(out, "taller", model="scripted:", parts=["pots"])


def test_edit_with_build_says_what_it_rebuilt(tmp_path):
    """Issue 26.4: `edit --build` printed no "built" line."""
    prog = tmp_path / "lamp.py"
    prog.write_text((Path(__file__).parent / "program" / "lamp.py").read_text())
    res = CliRunner().invoke(app, ["edit", str(prog), "--set", "post_h=90", "--build", str(tmp_path / "run"), "-q"])
    assert res.exit_code == 0, res.output
    assert "set post_h=90" in res.output and "built 3 parts, 2 mates ->" in res.output and "status ok" in res.output
