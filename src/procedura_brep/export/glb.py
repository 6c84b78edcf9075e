"""GLB export: one named node per part with its own metallic-roughness PBR material, built with
trimesh's glTF writer.

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
    part, named after the parts (vertices in world mm under the root)."""
    import trimesh
    from trimesh.visual.material import PBRMaterial

    scene = trimesh.Scene(base_frame="world")
    factors: dict[str, list[float]] = {}
    root = model.name or "model"
    scene.graph.update(frame_from="world", frame_to=root, matrix=GLTF_FROM_WORLD)
    for p in model.parts:
        mesh, normals = smooth_normals(part_mesh(p))
        m = model.material_of(p)
        name = f"{p.name}_{p.material}"
        factors[name] = [float(c) for c in srgb_to_linear(m.rgb)] + [1.0]
        # trimesh reads float colours as 0..1 but stores them as 8 bits: the exact factor is
        # written by _exact_colours below (8-bit linear loses dark colours)
        mat = PBRMaterial(name=name, baseColorFactor=np.array(factors[name]),
                          metallicFactor=float(m.metalness), roughnessFactor=float(m.roughness))
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, vertex_normals=normals, process=False,
                             visual=trimesh.visual.TextureVisuals(material=mat))
        tm.metadata["name"] = p.name
        scene.add_geometry(tm, node_name=p.name, geom_name=p.name, parent_node_name=root)

    def _finish(tree: dict) -> None:
        for entry in tree.get("materials", []):
            entry.setdefault("pbrMetallicRoughness", {})["baseColorFactor"] = factors[entry["name"]]
        _set_targets(tree)

    return scene.export(file_type="glb", include_normals=True, tree_postprocessor=_finish)


#: glTF bufferView targets: vertex attributes and triangle indices.
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def _set_targets(tree: dict) -> None:
    """Mark each bufferView used only by vertex attributes or only by indices with its target
    (the validator's BUFFER_VIEW_TARGET_MISSING hint); a view used both ways is left alone."""
    uses: dict[int, set[int]] = {}
    accessors = tree.get("accessors", [])
    for mesh in tree.get("meshes", []):
        for prim in mesh.get("primitives", []):
            for acc in prim.get("attributes", {}).values():
                uses.setdefault(accessors[acc].get("bufferView", -1), set()).add(ARRAY_BUFFER)
            if "indices" in prim:
                uses.setdefault(accessors[prim["indices"]].get("bufferView", -1),
                                set()).add(ELEMENT_ARRAY_BUFFER)
    views = tree.get("bufferViews", [])
    for view, targets in uses.items():
        if 0 <= view < len(views) and len(targets) == 1:
            views[view]["target"] = targets.pop()
