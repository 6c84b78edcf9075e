"""The offline viewer (issue 26.2): its data, its findings, the page in a real headless browser
(Debian's chromium driven by Playwright, opened from file://) and ``procedura-brep view``."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.export.bundle import write_bundle
from procedura_brep.export.viewer import findings_data, findings_js, viewer_data
from procedura_brep.program.sandbox import compile_source

ROOT = Path(__file__).resolve().parents[1]
ARM = ROOT / "golden" / "arm" / "program.py"
LAMP = ROOT / "tests" / "program" / "lamp.py"
#: Chromium's software GL here (WebGL2 works with it).
CHROMIUM_ARGS = ["--use-gl=swiftshader", "--enable-unsafe-swiftshader"]


def _cols(a: list[float]) -> np.ndarray:
    """A column-major 16-list (three.js) as a 4x4."""
    return np.asarray(a, dtype=float).reshape(4, 4).T


def _rz(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    return m


def _tz(mm: float) -> np.ndarray:
    m = np.eye(4)
    m[2, 3] = mm
    return m


def _about(joint_frame: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """The world transform of a motion in the joint's frame (about its axis, through its anchor)."""
    return joint_frame @ motion @ np.linalg.inv(joint_frame)


@pytest.fixture(scope="module")
def arm(worker, tmp_path_factory):
    """The golden arm (revolute chain, two prismatic fingers) and its viewer folder; the
    findings name a part and its pair partner."""
    model = compile_source(ARM.read_text(), name="arm", worker=worker)
    assert model.ok, model.findings
    out = tmp_path_factory.mktemp("arm")
    write_bundle(model, out, formats="viewer")
    report = {"status": "gates_failed", "findings": [
        {"code": "interference", "message": "forearm and wrist overlap by 0.4 mm3",
         "part": "forearm", "other": "wrist", "severity": "error"},
        {"code": "mate-area", "message": "hovers", "mate": "forearm_elbow", "severity": "warning"},
        {"code": "mesh-metrics", "message": "about the whole model", "severity": "info"}]}
    (out / "viewer" / "findings.js").write_bytes(findings_js(report))
    return model, articulate(model), out


@pytest.mark.slow  # compiles the arm (the module's fixture): over 3 s here
def test_data_frames_compose_to_the_placements_and_the_urdf_links(arm):
    model, art, _ = arm
    data = viewer_data(model, art)
    links = {lk["name"]: lk for lk in data["links"]}

    def world(name: str) -> np.ndarray:
        lk = links[name]
        rest = _cols(lk["rest"])
        return rest if lk["parent"] is None else world(lk["parent"]) @ rest

    for lk in art.links:  # the link frames are the URDF's (joint anchor, +Z the axis)
        np.testing.assert_allclose(world(lk.name), lk.frame, atol=1e-9)
    for p in data["parts"]:  # a part's node at rest is exactly its placement
        np.testing.assert_allclose(world(p["link"]) @ _cols(p["local"]),
                                   model.part(p["name"]).placement, atol=1e-9)
    assert [p["name"] for p in data["parts"]] == [p.name for p in model.parts]
    sliders = {d["name"]: d for j in data["joints"] for d in j["dofs"]}
    assert sliders["forearm_elbow"]["lower"] == pytest.approx(-65) and \
        sliders["forearm_elbow"]["upper"] == pytest.approx(135)
    assert (sliders["finger_l_slide"]["unit"], sliders["finger_l_slide"]["upper"]) == ("mm", pytest.approx(18))
    assert len(sliders) == len(art.joints)


def test_findings_data_merges_the_gates_rows_errors_first():
    report = {"status": "gates_failed",
              "findings": [{"code": "mate", "message": "hovers", "part": "arm", "severity": "error"}],
              "gates": {"findings": [
                  {"code": "origin", "message": "far from origin", "part": "post", "severity": "warning"},
                  {"code": "mate", "message": "hovers", "part": "arm", "severity": "error"}]}}
    data = findings_data(report)
    assert data["status"] == "gates_failed"
    assert [(f["code"], f["part"]) for f in data["findings"]] == [("mate", "arm"), ("origin", "post")]
    assert findings_data(None)["findings"] == [] and "no report" in findings_data(None)["note"]
    text = findings_js(report).decode()
    assert text.startswith("window.PROCEDURA_FINDINGS = ")
    assert json.loads(text.split(" = ", 1)[1].rstrip(";\n")) == data


# ---- the page in a headless browser --------------------------------------------------------

@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed (pip install -e '.[dev]')")
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("no chromium on PATH (apt-get install chromium)")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        yield b
        b.close()


def _open(browser, folder: Path):
    """The page opened from the file system; returns it and its list of errors."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(f"console: {m.text}") if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(f"page: {e}"))
    page.on("requestfailed", lambda r: errors.append(f"request: {r.url}"))
    page.goto((folder / "viewer.html").as_uri())
    for _ in range(600):  # ready (the first frame drawn), or an error: no minute-long timeout
        if errors or page.evaluate("!!(window.viewer && window.viewer.ready)"):
            break
        page.wait_for_timeout(100)
    assert errors == [] and page.evaluate("window.viewer.ready"), errors
    return page, errors


def _world(page, name: str) -> np.ndarray:
    return _cols(page.evaluate("n => viewer.worldMatrix(n)", name))


def _slide(page, dof: str, value: float) -> None:
    """Set a joint slider as a person does: its value, then an input event."""
    page.evaluate("""([d, v]) => { const s = document.querySelector(`input[data-dof="${d}"]`);
                       s.value = String(v); s.dispatchEvent(new Event('input')); }""", [dof, value])


def _subtree_parts(art, joint: str) -> set[str]:
    return {p for lk in art.subtree(art.joint(joint).child) for p in art.link(lk).parts}


@pytest.mark.slow  # a browser start and a WebGL page: several seconds
def test_the_page_poses_isolates_and_lists_findings(browser, arm, tmp_path):
    model, art, folder = arm
    page, errors = _open(browser, folder)
    assert page.evaluate("viewer.gl"), "WebGL did not start"
    names = [p.name for p in model.parts]
    rows = page.eval_on_selector_all(".part-row", "rs => rs.map(r => r.dataset.part)")
    assert sorted(rows) == sorted(names)
    rest = {n: _world(page, n) for n in names}
    for n in names:
        np.testing.assert_allclose(rest[n], model.part(n).placement, atol=1e-6)

    # the shoulder by 30 deg, then the elbow by -20 deg: each subtree turns about its joint's
    # axis through its anchor (the URDF's frames), and nothing else moves
    _slide(page, "upper_arm_shoulder", 30)
    shoulder = _about(art.joint("upper_arm_shoulder").frame, _rz(30))
    moved = _subtree_parts(art, "upper_arm_shoulder")
    assert moved and moved != set(names)
    for n in names:
        want = shoulder @ rest[n] if n in moved else rest[n]
        np.testing.assert_allclose(_world(page, n), want, atol=1e-6, err_msg=n)
    _slide(page, "forearm_elbow", -20)
    elbow = shoulder @ _about(art.joint("forearm_elbow").frame, _rz(-20))
    inner = _subtree_parts(art, "forearm_elbow")
    for n in names:
        want = (elbow if n in inner else shoulder if n in moved else np.eye(4)) @ rest[n]
        np.testing.assert_allclose(_world(page, n), want, atol=1e-6, err_msg=n)
    # a finger slides 10 mm along its axis, inside the moved chain
    _slide(page, "finger_l_slide", 10)
    finger = elbow @ _about(art.joint("finger_l_slide").frame, _tz(10))
    np.testing.assert_allclose(_world(page, "finger_l"), finger @ rest["finger_l"], atol=1e-6)
    np.testing.assert_allclose(_world(page, "finger_r"), elbow @ rest["finger_r"], atol=1e-6)
    path = Path(os.environ.get("PROCEDURA_BREP_ARTIFACTS") or tmp_path) / "viewer_arm_posed.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(path))
    print(f"screenshot: {path}")
    page.click("#reset")
    np.testing.assert_allclose(_world(page, "finger_l"), rest["finger_l"], atol=1e-6)

    # isolate by a click on the name; again shows all; the box hides one part
    page.click('.part-row[data-part="forearm"] .name')
    assert [n for n in names if page.evaluate("n => viewer.visible(n)", n)] == ["forearm"]
    page.click('.part-row[data-part="forearm"] .name')
    assert all(page.evaluate("n => viewer.visible(n)", n) for n in names)
    page.click('.part-row[data-part="turret"] input')
    assert [n for n in names if not page.evaluate("n => viewer.visible(n)", n)] == ["turret"]
    page.click("#show-all")
    assert all(page.evaluate("n => viewer.visible(n)", n) for n in names)

    # a finding's click selects its part and shows it with its partner
    rows = page.locator(".finding")
    assert rows.count() == 3
    rows.nth(0).click()
    assert page.evaluate("viewer.selected()") == "forearm"
    assert sorted(page.evaluate("viewer.isolated()")) == ["forearm", "wrist"]
    assert "selected" in (page.get_attribute('.part-row[data-part="forearm"]', "class") or "")
    rows.nth(1).click()  # a mate's finding: its child and parent
    assert sorted(page.evaluate("viewer.isolated()")) == ["forearm", "upper_arm"]
    rows.nth(2).click()  # about the whole model: nothing to show, nothing changes
    assert sorted(page.evaluate("viewer.isolated()")) == ["forearm", "upper_arm"]

    # exploded: every part's centre moves away from the model's centre; mate frames on a toggle
    page.click("#show-all")
    before = page.evaluate("""() => viewer.parts().map(n => { const m = viewer.node(n);
        return m.userData.center.clone().applyMatrix4(m.matrixWorld).toArray(); })""")
    page.evaluate("""() => { const e = document.getElementById('explode'); e.value = '1';
                             e.dispatchEvent(new Event('input')); }""")
    after = page.evaluate("""() => viewer.parts().map(n => { const m = viewer.node(n);
        return m.userData.center.clone().applyMatrix4(m.matrixWorld).toArray(); })""")
    mid = (np.min(before, axis=0) + np.max(before, axis=0)) / 2
    grow = np.linalg.norm(np.asarray(after) - mid, axis=1) - np.linalg.norm(np.asarray(before) - mid, axis=1)
    assert (grow > -1e-6).all() and (grow > 1.0).sum() >= len(names) - 2, grow
    assert page.evaluate("viewer.node('turret').children.every(c => !c.visible)")
    page.check("#frames")
    assert page.evaluate("viewer.node('turret').children.length") >= 1
    assert page.evaluate("viewer.node('turret').children.every(c => c.visible)")
    assert errors == []
    page.close()


@pytest.mark.slow  # a real build plus a browser
def test_a_build_writes_the_viewer_and_its_final_findings(browser, tmp_path):
    from procedura_brep.run.build import build
    from procedura_brep.run.directory import BUILD_OUTPUTS
    out = tmp_path / "lamp"
    res = build(LAMP, out, formats=("step",), simulate=False)
    assert res.ok, res.reason
    assert {"viewer.html", "viewer"} <= set(BUILD_OUTPUTS)
    assert sorted(p.name for p in (out / "viewer").iterdir()) == [
        "LICENSE-three", "app.js", "data.js", "findings.js", "three.min.js"]
    text = (out / "viewer" / "findings.js").read_text()
    assert json.loads(text.split(" = ", 1)[1].rstrip(";\n"))["status"] == "ok"
    assert "viewer.html" in (out / "summary.md").read_text()
    page, errors = _open(browser, out)
    assert page.text_content("#status").startswith("status: ok")
    assert page.eval_on_selector_all(".part-row", "rs => rs.length") == 3
    assert errors == []
    page.close()
    # a failed rebuild with nothing to keep removes the viewer with the other models
    (out / "report.json").write_text(json.dumps({"status": "failed"}))
    bad = tmp_path / "bad.py"
    bad.write_text(LAMP.read_text().replace("return Box(90, 14, 10", "return Box(90, 14, 1/0"))
    res = build(bad, out, simulate=False)
    assert not res.ok and not (out / "viewer.html").exists() and not (out / "viewer").exists()


@pytest.mark.slow  # two compiles and a browser page
def test_a_cylindrical_joint_gets_two_sliders_and_a_ball_joint_a_note(browser, worker, tmp_path):
    from tests.sim.collar import program
    model = compile_source(program(), name="collar", worker=worker)
    art = articulate(model)
    dofs = {d["name"]: d for j in viewer_data(model, art)["joints"] for d in j["dofs"]}
    assert dofs["collar_bore__slide"]["unit"] == "mm" and dofs["collar_bore__turn"]["unit"] == "deg"
    assert (dofs["collar_bore__slide"]["lower"], dofs["collar_bore__slide"]["upper"]) == \
        (pytest.approx(-100), pytest.approx(120))
    write_bundle(model, tmp_path, formats="viewer")
    page, errors = _open(browser, tmp_path)
    rest = _world(page, "collar")
    _slide(page, "collar_bore__slide", 50)
    _slide(page, "collar_bore__turn", 90)
    want = _about(art.joint("collar_bore").frame, _tz(50) @ _rz(90)) @ rest
    np.testing.assert_allclose(_world(page, "collar"), want, atol=1e-6)
    np.testing.assert_allclose(_world(page, "column"), model.part("column").placement, atol=1e-6)
    assert errors == []
    page.close()

    ball = LAMP.read_text().replace('"revolute", nominal="pin_d", fit="clearance", limits=(-45, 45)',
                                    '"spherical", nominal="pin_d", fit="clearance", cone=30, features=False')
    model = compile_source(ball, name="lamp_ball", worker=worker)
    (joint,) = viewer_data(model, articulate(model))["joints"]
    assert joint["type"] == "spherical" and joint["dofs"] == [] and "not posed" in joint["note"]


@pytest.mark.slow  # a compile and a browser page
def test_coupled_joints_follow_their_driver_as_the_urdf_mimic(browser, worker, tmp_path):
    model = compile_source((ROOT / "tests" / "program" / "transmission.py").read_text(),
                           name="transmission", worker=worker)
    art = articulate(model)
    write_bundle(model, tmp_path, formats="viewer")
    page, errors = _open(browser, tmp_path)
    rest = {n: _world(page, n) for n in ("wheel", "rack", "nut", "pinion")}
    assert page.evaluate("document.querySelector('input[data-dof=wheel_hub]').disabled")
    _slide(page, "pinion_hub", 30)
    _slide(page, "screw_hub", 90)
    for part, joint in (("wheel", "wheel_hub"), ("rack", "rack_slide"), ("nut", "nut_slide")):
        head, ratio, offset = art.root_driver(joint)
        q = offset + ratio * math.radians(30 if head == "pinion_hub" else 90)  # SI
        motion = _tz(q * 1000) if art.joint(joint).kind.slides else _rz(math.degrees(q))
        np.testing.assert_allclose(_world(page, part), _about(art.joint(joint).frame, motion) @ rest[part],
                                   atol=1e-6, err_msg=part)
    np.testing.assert_allclose(_world(page, "pinion"),
                               _about(art.joint("pinion_hub").frame, _rz(30)) @ rest["pinion"], atol=1e-6)
    assert errors == []
    page.close()


# ---- procedura-brep view ----------------------------------------------------------------------

def test_view_refuses_a_directory_without_a_viewer(tmp_path):
    from typer.testing import CliRunner

    from procedura_brep.cli import app
    (tmp_path / "report.json").write_text("{}")
    res = CliRunner().invoke(app, ["view", str(tmp_path)])
    assert res.exit_code == 2
    assert "has no viewer" in res.output and "build it again" in res.output
    res = CliRunner().invoke(app, ["view", str(tmp_path / "missing")])
    assert res.exit_code == 2 and "does not exist" in res.output


def test_view_names_a_port_in_use(tmp_path):
    import socket

    from typer.testing import CliRunner

    from procedura_brep.cli import app
    (tmp_path / "viewer").mkdir()
    (tmp_path / "viewer.html").write_text("<!doctype html>")
    (tmp_path / "viewer" / "data.js").write_text("window.PROCEDURA_VIEWER = {};")
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen(1)
        port = busy.getsockname()[1]
        res = CliRunner().invoke(app, ["view", str(tmp_path), "--port", str(port)])
    assert res.exit_code == 2
    assert f"cannot serve {tmp_path} on 127.0.0.1:{port}: address already in use" in res.output


@pytest.mark.slow  # a CLI process start
def test_view_serves_the_page_on_loopback_until_ctrl_c(arm):
    _, _, folder = arm
    proc = subprocess.Popen([sys.executable, "-m", "procedura_brep", "view", str(folder)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline().strip()
        assert line.startswith("viewer: http://127.0.0.1:"), line
        url = line.split(" ", 1)[1]
        with urllib.request.urlopen(url, timeout=10) as r:
            assert r.status == 200 and b'src="viewer/app.js"' in r.read()
        with urllib.request.urlopen(url.replace("viewer.html", "viewer/data.js"), timeout=10) as r:
            assert r.read().startswith(b"window.PROCEDURA_VIEWER = ")
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "viewer stopped" in err and (folder / "viewer.html").as_uri() in err
