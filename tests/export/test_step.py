"""STEP export round trips: names, colours, volumes, world boxes, units, schema, ASCII naming.

The model is built by hand (no compiler): a filleted base plate, a rotated block, a bushing
(cylinder with a bore) and a tilted pin, each with its own material and a non-identity
placement (except the root plate). Everything is read back through OCP XCAF, and (when Debian's
``freecadcmd`` is installed) through FreeCAD.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from procedura_brep import kernel, materials
from procedura_brep.export.step import (
    StepExportError,
    read_step_parts,
    read_step_root_names,
    step_bytes,
    step_name,
)
from procedura_brep.mates.placement import rot_x, rot_y, rot_z, trans
from procedura_brep.program.model import CompiledModel, CompiledPart

FREECAD_SCRIPT = Path(__file__).with_name("freecad_names.py")
RGB_TOL = 1 / 255
VOLUME_RTOL = 1e-6
BBOX_TOL_MM = 1e-3

PARTS = {  # name -> (material, world placement)
    "base_plate": ("aluminium", np.eye(4)),
    "block": ("painted_steel", trans(10, 0, 12.5) @ rot_z(30)),
    "bushing": ("brass", trans(-20, 10, 30) @ rot_x(90) @ rot_z(45)),
    "pin_2": ("orange_plastic", trans(25, -15, 40) @ rot_y(-35) @ rot_x(20)),
}


def _shapes() -> dict:
    import build123d as bd

    plate = bd.fillet(bd.Box(80, 60, 5).edges().filter_by(bd.Axis.Z), radius=8)
    block = bd.Box(40, 30, 20)
    bushing = bd.Cylinder(10, 50) - bd.Cylinder(4, 50)
    pin = bd.chamfer(bd.Cylinder(3, 30).edges().group_by(bd.Axis.Z)[-1], length=0.5)
    return {"base_plate": plate, "block": block, "bushing": bushing, "pin_2": pin}


@pytest.fixture(scope="module")
def model() -> CompiledModel:
    shapes = _shapes()
    parts = [CompiledPart(name=name, brep=kernel.write_brep(shapes[name].wrapped),
                          placement=placement, material=material,
                          description=f"{name} ünïcode «Ω» description")
             for name, (material, placement) in PARTS.items()]
    return CompiledModel(name="test_rig", params={}, parts=parts, mates=[])


def _renamed(model: CompiledModel, name: str) -> CompiledModel:
    return CompiledModel(name=name, params={}, parts=model.parts, mates=[])


def _close(a, b, tol: float) -> bool:
    return bool(np.allclose(np.asarray(a, float), np.asarray(b, float), rtol=0.0, atol=tol))


@pytest.fixture(scope="module", params=["AP214", "AP242"])
def written(request, model: CompiledModel) -> tuple[str, bytes]:
    return request.param, step_bytes(model, schema=request.param)


def test_parts_round_trip(model: CompiledModel, written: tuple[str, bytes]) -> None:
    """Every part comes back once, exactly named, coloured, with its volume and world box."""
    _, data = written
    back = read_step_parts(data)
    assert [p.name for p in back] == [p.name for p in model.parts]
    for part, got in zip(model.parts, back):
        assert got.rgb is not None, part.name
        assert _close(got.rgb, materials.get(part.material).rgb, RGB_TOL), (part.name, got.rgb)
        want = kernel.volume(part.local_shape())
        assert got.volume == pytest.approx(want, rel=VOLUME_RTOL), part.name
        assert _close(got.bbox, kernel.bbox(part.shape()), BBOX_TOL_MM), (part.name, got.bbox)


def test_root_product_named_after_model(model: CompiledModel, written: tuple[str, bytes]) -> None:
    _, data = written
    assert read_step_root_names(data) == [model.name]
    products = re.findall(rb"PRODUCT\('([^']*)'", data)
    assert sorted(p.decode() for p in products) == sorted([model.name, *PARTS])


def test_schema_header(written: tuple[str, bytes]) -> None:
    schema, data = written
    header = data.split(b"ENDSEC;", 1)[0]
    expected = {"AP214": b"AUTOMOTIVE_DESIGN", "AP242": b"AP242_MANAGED_MODEL_BASED_3D"}[schema]
    assert expected in header


def test_millimetres(model: CompiledModel, written: tuple[str, bytes]) -> None:
    """The length unit is mm and raw coordinates are mm-sized (guards the 1000x unit trap)."""
    _, data = written
    assert b"SI_UNIT(.MILLI.,.METRE.)" in data
    assert b"SI_UNIT($,.METRE.)" not in data
    found = re.findall(rb"CARTESIAN_POINT\('[^']*',\(([^)]*)\)", data)
    points = np.array([[float(v) for v in pt.split(b",")] for pt in found if pt.count(b",") == 2])
    extent = max(abs(c) for p in model.parts for corner in kernel.bbox(p.shape()) for c in corner)
    assert np.abs(points).max() < 10 * extent  # surface origins may lie outside the parts
    for part in model.parts:  # each component placement's origin is written verbatim, in mm
        assert np.abs(points - part.placement[:3, 3]).max(axis=1).min() < 1e-9, part.name


def test_deterministic_bytes(model: CompiledModel) -> None:
    first = step_bytes(model)
    step_bytes(_renamed(model, "other"), schema="AP242")  # bumps OCCT's global counters
    assert step_bytes(model) == first


def test_non_ascii_model_name(model: CompiledModel) -> None:
    data = step_bytes(_renamed(model, "Rover «Ω» ü"))
    data.decode("ascii")  # the whole file is ASCII
    assert read_step_root_names(data) == ["rover_u"]
    assert [p.name for p in read_step_parts(data)] == list(PARTS)


@pytest.mark.parametrize(("text", "expected"), [
    ("test_rig", "test_rig"),
    ("Rover «Ω» ü", "rover_u"),
    ("Desk Lamp-2", "desk_lamp_2"),
    ("Ωμέγα", "model"),
    ("Crème brûlée__v2 ", "creme_brulee__v2"),
    ("", "model"),
])
def test_step_name_rule(text: str, expected: str) -> None:
    assert step_name(text) == expected
    assert re.fullmatch(r"[a-z0-9_]+", step_name(text))


@pytest.mark.parametrize("bad", ["Block", "wheel-left", "rad_ü"])
def test_bad_part_name_is_an_error(model: CompiledModel, bad: str) -> None:
    part = model.parts[1]
    broken = CompiledPart(name=bad, brep=part.brep, placement=part.placement)
    with pytest.raises(StepExportError, match=re.escape(repr(bad))):
        step_bytes(CompiledModel(name="m", params={}, parts=[model.parts[0], broken], mates=[]))


def test_duplicate_part_name_and_bad_schema_are_errors(model: CompiledModel) -> None:
    twice = CompiledModel(name="m", params={}, parts=[model.parts[0], model.parts[0]], mates=[])
    with pytest.raises(StepExportError, match="twice"):
        step_bytes(twice)
    with pytest.raises(StepExportError, match="AP203"):
        step_bytes(model, schema="AP203")  # type: ignore[arg-type]
    with pytest.raises(StepExportError, match="no parts"):
        step_bytes(CompiledModel(name="m", params={}, parts=[], mates=[]))


def test_concurrent_writers_keep_their_schema(model: CompiledModel) -> None:
    """Interface_Static is global: parallel AP214/AP242 writers must not swap schemas."""
    results: dict[str, list[bytes]] = {"AP214": [], "AP242": []}

    def work(schema: str) -> None:
        for _ in range(3):
            results[schema].append(step_bytes(model, schema=schema))  # type: ignore[arg-type]

    threads = [threading.Thread(target=work, args=(s,)) for s in results]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(b"AUTOMOTIVE_DESIGN" in d.split(b"ENDSEC;")[0] for d in results["AP214"])
    assert all(b"AP242" in d.split(b"ENDSEC;")[0] for d in results["AP242"])
    assert len(set(results["AP214"])) == 1 and len(set(results["AP242"])) == 1


@pytest.mark.freecad
@pytest.mark.skipif(shutil.which("freecadcmd") is None,
                    reason="needs Debian's freecad (apt-get install -y freecad)")
@pytest.mark.parametrize("schema", ["AP214", "AP242"])
def test_freecad_imports_names(model: CompiledModel, tmp_path: Path, schema: str) -> None:
    """Headless FreeCAD sees every part by name, the root by the model name, in mm, placed."""
    step_path, json_path = tmp_path / "model.step", tmp_path / "labels.json"
    step_path.write_bytes(step_bytes(model, schema=schema))  # type: ignore[arg-type]
    env = {**os.environ, "PROCEDURA_STEP": str(step_path), "PROCEDURA_JSON": str(json_path)}
    proc = subprocess.run([shutil.which("freecadcmd") or "freecadcmd", str(FREECAD_SCRIPT)],
                          env=env, capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0 and json_path.exists(), (proc.returncode, proc.stdout[-2000:],
                                                         proc.stderr[-2000:], sys.executable)
    dump = json.loads(json_path.read_text(encoding="utf-8"))
    assert set(PARTS) | {model.name} <= set(dump["labels"]), dump["labels"]
    by_label = {o["label"]: o for o in dump["objects"]}
    for part in model.parts:
        got = by_label[part.name]
        assert got["volume"] == pytest.approx(kernel.volume(part.local_shape()), rel=1e-6)
        assert _close(got["bbox"], kernel.bbox(part.shape(), optimal=False), 0.05), part.name
