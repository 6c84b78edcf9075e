"""GLB: per-part colours read back from the file, smooth normals with crisp edges, and the
Khronos glTF validator (0 errors) when node and the ``gltf-validator`` package are present."""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from procedura_brep import kernel, materials
from procedura_brep.export.glb import glb_bytes
from procedura_brep.mates.placement import rot_x, trans
from procedura_brep.program.model import CompiledModel, CompiledPart

VALIDATOR_SCRIPT = Path(__file__).with_name("gltf_validate.js")
LAMP = Path(__file__).resolve().parents[1] / "program" / "lamp.py"
#: Env var naming the gltf-validator package folder (see docs/exports.md).
VALIDATOR_ENV = "PROCEDURA_GLTF_VALIDATOR"
PARTS = {"block": ("painted_steel", np.eye(4)),
         "roller": ("rubber", trans(0, 0, 40) @ rot_x(90)),
         "ball": ("brass", trans(60, 0, 20)),
         "cap": ("cast_iron", trans(-60, 0, 0))}


def _srgb_to_linear(c: float) -> float:  # IEC 61966-2-1, written out independently of glb.py
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


@pytest.fixture(scope="module")
def model() -> CompiledModel:
    import build123d as bd
    shapes = {"block": bd.Box(40, 30, 20), "roller": bd.Cylinder(10, 30),
              "ball": bd.Sphere(12), "cap": bd.chamfer(bd.Box(20, 20, 10).edges(), length=2)}
    parts = [CompiledPart(name=n, brep=kernel.write_brep(shapes[n].wrapped), placement=pl,
                          material=mat) for n, (mat, pl) in PARTS.items()]
    return CompiledModel(name="glb_rig", params={}, parts=parts, mates=[])


@pytest.fixture(scope="module")
def glb(model: CompiledModel) -> bytes:
    return glb_bytes(model)


def _chunks(data: bytes) -> tuple[dict, bytes]:
    magic, version, _ = struct.unpack_from("<III", data, 0)
    assert magic == 0x46546C67 and version == 2
    n, kind = struct.unpack_from("<II", data, 12)
    assert kind == 0x4E4F534A  # JSON
    tree = json.loads(data[20:20 + n])
    m, kind = struct.unpack_from("<II", data, 20 + n)
    assert kind == 0x004E4942  # BIN
    return tree, data[28 + n:28 + n + m]


def _accessor(tree: dict, binary: bytes, index: int) -> np.ndarray:
    acc = tree["accessors"][index]
    view = tree["bufferViews"][acc["bufferView"]]
    dtype = {5126: np.float32, 5125: np.uint32, 5123: np.uint16}[acc["componentType"]]
    width = {"SCALAR": 1, "VEC3": 3}[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    arr = np.frombuffer(binary, dtype=dtype, count=acc["count"] * width, offset=start)
    return arr.reshape(-1, width) if width > 1 else arr


def _primitives(data: bytes) -> dict[str, tuple[dict, np.ndarray, np.ndarray, np.ndarray]]:
    """``{node name: (material, positions, normals, triangles)}``."""
    tree, binary = _chunks(data)
    out = {}
    for node in tree["nodes"]:
        if "mesh" not in node:
            continue
        prim = tree["meshes"][node["mesh"]]["primitives"][0]
        attrs = prim["attributes"]
        assert "NORMAL" in attrs, node["name"]
        out[node["name"]] = (tree["materials"][prim["material"]],
                             _accessor(tree, binary, attrs["POSITION"]).astype(float),
                             _accessor(tree, binary, attrs["NORMAL"]).astype(float),
                             _accessor(tree, binary, prim["indices"]).reshape(-1, 3))
    return out


def test_colours_per_part(model: CompiledModel, glb: bytes) -> None:
    prims = _primitives(glb)
    assert sorted(prims) == sorted(PARTS)
    for p in model.parts:
        mat, *_ = prims[p.name]
        lib = materials.get(p.material)
        pbr = mat["pbrMetallicRoughness"]
        want = [_srgb_to_linear(c) for c in lib.rgb] + [1.0]
        assert pbr["baseColorFactor"] == pytest.approx(want, abs=1e-9), p.name
        assert pbr["metallicFactor"] == pytest.approx(lib.metalness)
        assert pbr["roughnessFactor"] == pytest.approx(lib.roughness)
    colours = {tuple(prims[n][0]["pbrMetallicRoughness"]["baseColorFactor"]) for n in PARTS}
    assert len(colours) == len(PARTS)  # four materials, four colours (none clipped to white)


def _face_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    c = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    return c / np.linalg.norm(c, axis=1)[:, None]


def test_normals_unit_and_consistent_with_winding(glb: bytes) -> None:
    for name, (_, v, n, f) in _primitives(glb).items():
        assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5), name
        fn = _face_normals(v, f)
        assert (np.einsum("ij,ij->i", n[f[:, 0]], fn) > 0).all(), name  # outward, as the faces


def test_box_edges_stay_crisp(glb: bytes) -> None:
    """Every corner of every triangle of a box (and a chamfered box) carries its face normal."""
    for name in ("block", "cap"):
        _, v, n, f = _primitives(glb)[name]
        fn = _face_normals(v, f)
        for k in range(3):
            assert np.einsum("ij,ij->i", n[f[:, k]], fn).min() > 1 - 1e-6, name
    _, v, _, _ = _primitives(glb)["block"]
    assert len(v) == 24  # 8 corners x 3 faces: split at every edge


def test_curved_surfaces_are_smooth(glb: bytes) -> None:
    """Cylinder side vertices carry the radial normal; sphere vertices the radial direction;
    the cylinder's flat caps stay flat."""
    _, v, n, f = _primitives(glb)["ball"]
    radial = (v - np.array([60.0, 0, 20])) / np.linalg.norm(v - np.array([60.0, 0, 20]), axis=1)[:, None]
    assert np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, radial), -1, 1))).max() < 5.0
    fn = _face_normals(v, f)
    assert np.einsum("ij,ij->i", n[f[:, 0]], fn).min() < 0.999  # not flat-shaded
    _, v, n, f = _primitives(glb)["roller"]  # axis along world Y through (0, 0, 40)
    rel = v - np.array([0.0, 0, 40])
    side = np.abs(n[:, 1]) < 0.5  # vertex copies on the side (the rims carry two copies)
    expect = rel[side] * np.array([1.0, 0, 1])
    expect /= np.linalg.norm(expect, axis=1)[:, None]
    assert side.sum() > 0
    assert np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n[side], expect), -1, 1))).max() < 1.0
    assert np.allclose(np.abs(n[~side, 1]), 1.0, atol=1e-6)  # flat caps
    assert np.allclose(np.abs(rel[~side, 1]), 15.0, atol=1e-6)


def _validator() -> tuple[list[str], dict[str, str]] | str:
    """(command, env) to run the validator script, or the reason it cannot run."""
    node = shutil.which("node")
    if node is None:
        return "node is not on PATH"
    env = dict(os.environ)
    path = env.get(VALIDATOR_ENV)
    if path:
        if not Path(path).exists():
            return f"{VALIDATOR_ENV}={path} does not exist"
    else:
        probe = subprocess.run([node, "-e", "require.resolve('gltf-validator')"],
                               capture_output=True, env=env)
        if probe.returncode != 0:
            return (f"npm package gltf-validator not found: npm install gltf-validator into a "
                    f"folder and set {VALIDATOR_ENV} to its node_modules/gltf-validator")
    return [node, str(VALIDATOR_SCRIPT)], env


@pytest.mark.parametrize("which", ["rig", "lamp"])
def test_khronos_validator_reports_no_errors(which: str, glb: bytes, tmp_path: Path, worker) -> None:
    found = _validator()
    if isinstance(found, str):
        pytest.skip(found)
    cmd, env = found
    if which == "lamp":
        from procedura_brep.program import compile_source
        data = glb_bytes(compile_source(LAMP.read_text(), name="lamp", worker=worker))
    else:
        data = glb
    path = tmp_path / "model.glb"
    path.write_bytes(data)
    proc = subprocess.run([*cmd, str(path)], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    issues = json.loads(proc.stdout)["issues"]
    errors = [m for m in issues["messages"] if m["severity"] == 0]
    assert issues["numErrors"] == 0, errors[:10]
    assert issues["numWarnings"] == 0, issues["messages"][:10]


def test_twins_share_their_arrays() -> None:
    """Two copies of one shape, moved apart: the second's indices and normals are the first's
    accessors (written once), its positions its own; the file holds each array once."""
    import build123d as bd
    brep = kernel.write_brep(bd.Cylinder(10, 30).wrapped)
    parts = [CompiledPart(name=n, brep=brep, placement=trans(x, 0, 0), material="brass")
             for n, x in (("left", -50), ("right", 50))]
    data = glb_bytes(CompiledModel(name="twins", params={}, parts=parts, mates=[]))
    tree, binary = _chunks(data)
    left, right = (tree["meshes"][n["mesh"]]["primitives"][0] for n in tree["nodes"][1:])
    assert left["indices"] == right["indices"]
    assert left["attributes"]["NORMAL"] == right["attributes"]["NORMAL"]
    assert left["attributes"]["POSITION"] != right["attributes"]["POSITION"]
    assert len(tree["bufferViews"]) == len(tree["accessors"]) == 4
    assert len(binary) == tree["buffers"][0]["byteLength"] == sum(
        v["byteLength"] for v in tree["bufferViews"])
    prims = _primitives(data)
    assert np.allclose(prims["right"][1] - prims["left"][1], [100, 0, 0], atol=1e-4)


def test_views_accessors_and_padding() -> None:
    """The container as glTF 2.0 asks: chunk lengths multiples of 4 (JSON padded with spaces),
    the total length in the header, views 4-aligned inside the buffer, each accessor's min
    and max those of its data, the root node's matrix column-major; an empty model is a
    valid file with its root node only."""
    import build123d as bd
    parts = [CompiledPart(name="block", brep=kernel.write_brep(bd.Box(40, 30, 20).wrapped),
                          placement=trans(5, 0, 0), material="steel")]
    data = glb_bytes(CompiledModel(name="one", params={}, parts=parts, mates=[]))
    assert struct.unpack_from("<I", data, 8)[0] == len(data)
    n = struct.unpack_from("<I", data, 12)[0]
    assert n % 4 == 0 and data[20:20 + n].rstrip(b" ").endswith(b"}")
    tree, binary = _chunks(data)
    assert len(binary) % 4 == 0
    assert all(v["byteOffset"] % 4 == 0 for v in tree["bufferViews"])
    for i, acc in enumerate(tree["accessors"]):
        arr = _accessor(tree, binary, i).reshape(acc["count"], -1)
        assert acc["min"] == arr.min(axis=0).tolist() and acc["max"] == arr.max(axis=0).tolist()
    m = np.array(tree["nodes"][0]["matrix"]).reshape(4, 4).T  # column-major
    assert np.allclose(m @ [1000, 0, 0, 1], [1, 0, 0, 1]) and np.allclose(m @ [0, 1000, 0, 1], [0, 0, -1, 1])
    nothing = glb_bytes(CompiledModel(name="none", params={}, parts=[], mates=[]))
    n = struct.unpack_from("<I", nothing, 12)[0]
    assert struct.unpack_from("<I", nothing, 8)[0] == len(nothing) == 20 + n  # no BIN chunk
    empty = json.loads(nothing[20:])
    assert empty["nodes"] == [{"name": "none", "matrix": tree["nodes"][0]["matrix"]}]
    assert not any(k in empty for k in ("meshes", "accessors", "bufferViews", "buffers"))
