"""The gearbox golden (issue 27.5): a two-stage spur reduction with real teeth builds with every
gate passing (the coupling gate measures both meshes), and in MuJoCo one revolution of the input
turns the output by the product of the stage ratios, (z1 / z2) (z3 / z4), within 1 %."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from .harness import GOLDEN_DIR

pytestmark = pytest.mark.slow

PROGRAM = GOLDEN_DIR / "gearbox" / "program.py"
JOINTS = ("input_shaft_seat", "countershaft_seat", "output_shaft_seat")


def _param(name: str) -> float:
    hit = re.search(rf"^{name} = ([0-9.]+)", PROGRAM.read_text(encoding="utf-8"), re.M)
    assert hit, name
    return float(hit.group(1))


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("gearbox") / "run"
    done = subprocess.run([sys.executable, "-m", "procedura_brep", "build", str(PROGRAM), "-o", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return out


def test_builds_with_every_gate_passing(built):
    report = json.loads((built / "report.json").read_text())
    assert report["status"] == "ok" and report["gates"]["passed"]
    assert all(report["gates"]["verdicts"].values()), report["gates"]["verdicts"]
    assert len(report["parts"]) >= 10
    rows = report["gates"]["coupling"]["couplings"]
    z1, z2, z3, z4 = (_param(n) for n in ("z1", "z2", "z3", "z4"))
    stage1 = rows["countershaft_seat__input_shaft_seat"]
    stage2 = rows["output_shaft_seat__countershaft_seat"]
    assert stage1["teeth"] == {"input_shaft": z1, "countershaft": z2}  # measured from the solids
    assert stage2["teeth"] == {"countershaft": z3, "output_shaft": z4}
    m = _param("m")
    assert stage1["centre_mm"]["measured"] == pytest.approx(m * (z1 + z2) / 2, abs=1e-6)
    assert stage2["centre_mm"]["measured"] == pytest.approx(m * (z3 + z4) / 2, abs=1e-6)
    for row in (stage1, stage2):
        assert row["sweep"]["samples"] == row["sweep"]["of"] and row["sweep"]["max_depth_mm"] == 0.0


def test_one_input_revolution_turns_the_output_by_the_product_of_the_stages(built):
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(built / "model.xml"))
    m.opt.gravity[:] = 0.0  # the transmission, not the load: the housing floats free
    d = mujoco.MjData(m)
    adr = {n: int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in JOINTS}
    act = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "input_shaft_seat")
    assert act >= 0, "the input shaft has no actuator in model.xml"
    seconds = 4.0  # one revolution at a quarter turn per second (the exported speed servo)
    for _ in range(int(seconds / m.opt.timestep)):
        d.ctrl[act] = 2 * math.pi / seconds
        mujoco.mj_step(m, d)
    for _ in range(int(1.0 / m.opt.timestep)):  # stop and let the equalities settle
        d.ctrl[act] = 0.0
        mujoco.mj_step(m, d)
    q_in, q_out = d.qpos[adr["input_shaft_seat"]], d.qpos[adr["output_shaft_seat"]]
    assert q_in == pytest.approx(2 * math.pi, rel=0.01)  # the input turned one revolution
    z1, z2, z3, z4 = (_param(n) for n in ("z1", "z2", "z3", "z4"))
    expected = (z1 / z2) * (z3 / z4)  # two external meshes: the output turns the input's way
    assert q_out / q_in == pytest.approx(expected, rel=0.01)
    assert not [w for w in d.warning if w.number], "MuJoCo warnings"


def test_the_battery_passes_b8_included(built):
    done = subprocess.run([sys.executable, "-m", "procedura_brep", "simulate", str(built), "--json"],
                          capture_output=True, text=True, timeout=600)
    report = json.loads(done.stdout)
    failed = {c["id"]: c.get("message") for c in report["checks"] if not c["passed"]}
    assert done.returncode == 0 and report["passed"], failed
    b8 = next(c for c in report["checks"] if c["id"] == "B8")
    assert not b8.get("skipped") and b8["measured"]["max_ratio_rel_err"] < 0.01
    assert set(b8["measured"]["couplings"]) == {"countershaft_seat__input_shaft_seat",
                                                "output_shaft_seat__countershaft_seat"}
