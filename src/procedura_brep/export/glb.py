"""GLB export: one named node per part with its own metallic-roughness PBR material, built with
its own glTF 2.0 writer (JSON and one binary buffer, no mesh library).

Colours: glTF's ``baseColorFactor`` is linear, the material library's ``rgb`` is sRGB (as
written to STEP and MTL), so the factor is :func:`srgb_to_linear` of it and a viewer shows the
library's colour. Normals: per-vertex, smooth within a surface and split at edges sharper than
``TOL.normal_crease_deg`` (:func:`.meshes.smooth_normals`), so curved faces look round and
boxes stay crisp.

glTF 2.0 is in metres with +Y up, so the part meshes (world mm, Z up, as the other mesh formats)
go under one root node ``<model>`` whose transform is :data:`GLTF_FROM_WORLD`: scale by 1e-3 and
rotate -90 deg about X, taking world (x, y, z) mm to glTF (x, z, -y) m.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..program.model import CompiledModel
from .meshes import part_mesh, smooth_normals

#: World (mm, Z up) to glTF (m, Y up): R_x(-90 deg) scaled by 1e-3; (x, y, z) -> (x, z, -y) m.
GLTF_FROM_WORLD = np.array([[1e-3, 0.0, 0.0, 0.0],
                            [0.0, 0.0, 1e-3, 0.0],
                            [0.0, -1e-3, 0.0, 0.0],
                            [0.0, 0.0, 0.0, 1.0]])


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded channels (0..1) to linear (IEC 61966-2-1), as glTF colour factors are."""
    c = np.asarray(c, dtype=float)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """The inverse of :func:`srgb_to_linear`."""
    c = np.asarray(c, dtype=float)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def glb_bytes(model: CompiledModel) -> bytes:
    """``model.glb`` bytes: a root node (:data:`GLTF_FROM_WORLD`) holding one node and mesh per
    part, named after the parts (vertices in world mm under the root).

    Each part's mesh is one triangle primitive with positions and unit normals (float32) and
    indices (uint32), each in its own buffer view (indices, positions, normals, part after
    part) of the one binary buffer, and its own material; an array equal to one written
    before (a twin's indices or normals) is not written again, its accessor is shared. A part
    without triangles keeps its node, without a mesh."""
    import json
    import struct

    root = model.name or "model"
    tree: dict[str, Any] = {
        "asset": {"version": "2.0", "generator": GENERATOR},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": root, "matrix": [float(x) for x in GLTF_FROM_WORLD.T.reshape(-1)]}],
        "meshes": [], "materials": [], "accessors": [], "bufferViews": [], "buffers": [],
    }
    if model.parts:  # glTF forbids empty arrays
        tree["nodes"][0]["children"] = list(range(1, len(model.parts) + 1))
    blobs: list[bytes] = []
    offset = 0
    known: dict[tuple[bytes, str, int], int] = {}  # twins share their arrays

    def add(data: np.ndarray, kind: str, component: int, target: int) -> int:
        nonlocal offset
        raw = data.tobytes()
        if (raw, kind, target) in known:
            return known[raw, kind, target]
        tree["bufferViews"].append({"buffer": 0, "byteOffset": offset, "byteLength": len(raw),
                                    "target": target})
        blobs.append(raw)
        offset += len(raw)  # float32 and uint32 data: every view starts 4-aligned
        flat = data.reshape(len(data), -1)
        tree["accessors"].append({"bufferView": len(tree["bufferViews"]) - 1,
                                  "componentType": component, "count": len(data), "type": kind,
                                  "min": flat.min(axis=0).tolist(), "max": flat.max(axis=0).tolist()})
        known[raw, kind, target] = len(tree["accessors"]) - 1
        return known[raw, kind, target]

    for p in model.parts:
        node: dict[str, Any] = {"name": p.name}
        tree["nodes"].append(node)
        mesh, normals = smooth_normals(part_mesh(p))
        if len(mesh.faces) == 0:
            continue
        m = model.material_of(p)
        tree["materials"].append({
            "name": f"{p.name}_{p.material}",
            # the exact linear factor, at full precision (not through 8 bits: dark colours)
            "pbrMetallicRoughness": {
                "baseColorFactor": [float(c) for c in srgb_to_linear(m.rgb)] + [1.0],
                "metallicFactor": float(m.metalness), "roughnessFactor": float(m.roughness)},
            "doubleSided": False})
        indices = add(np.ascontiguousarray(mesh.faces, dtype="<u4").reshape(-1), "SCALAR",
                      UNSIGNED_INT, ELEMENT_ARRAY_BUFFER)
        position = add(np.ascontiguousarray(mesh.vertices, dtype="<f4"), "VEC3", FLOAT,
                       ARRAY_BUFFER)
        normal = add(np.ascontiguousarray(normals, dtype="<f4"), "VEC3", FLOAT, ARRAY_BUFFER)
        node["mesh"] = len(tree["meshes"])
        tree["meshes"].append({"name": p.name, "primitives": [{
            "attributes": {"POSITION": position, "NORMAL": normal}, "indices": indices,
            "mode": TRIANGLES, "material": len(tree["materials"]) - 1}]})
    binary = b"".join(blobs)
    if binary:
        tree["buffers"].append({"byteLength": len(binary)})
    for key in ("meshes", "materials", "accessors", "bufferViews", "buffers"):
        if not tree[key]:  # glTF forbids empty arrays
            del tree[key]
    text = json.dumps(tree, separators=(",", ":"), allow_nan=False).encode()
    text += b" " * (-len(text) % 4)
    binary += bytes(-len(binary) % 4)
    chunks = struct.pack("<II", len(text), JSON_CHUNK) + text
    if binary:
        chunks += struct.pack("<II", len(binary), BIN_CHUNK) + binary
    return struct.pack("<III", GLB_MAGIC, 2, 12 + len(chunks)) + chunks


#: The ``asset.generator`` of the GLB.
GENERATOR = "procedura-brep"
#: GLB header magic ("glTF") and chunk types ("JSON", "BIN\0"), little-endian words.
GLB_MAGIC, JSON_CHUNK, BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
#: glTF accessor component types and the triangle-list primitive mode.
FLOAT, UNSIGNED_INT, TRIANGLES = 5126, 5125, 4
#: glTF bufferView targets: vertex attributes and triangle indices.
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963

