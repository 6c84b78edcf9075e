"""GLB export: one named node per part with its own metallic-roughness PBR material, built with
trimesh's glTF writer.

glTF 2.0 is in metres with +Y up, so the part meshes (world mm, Z up, as the other mesh formats)
go under one root node ``<model>`` whose transform is :data:`GLTF_FROM_WORLD`: scale by 1e-3 and
rotate -90 deg about X, taking world (x, y, z) mm to glTF (x, z, -y) m.
"""

from __future__ import annotations

import numpy as np

from .. import materials
from ..program.model import CompiledModel
from .meshes import part_mesh

#: World (mm, Z up) to glTF (m, Y up): R_x(-90 deg) scaled by 1e-3; (x, y, z) -> (x, z, -y) m.
GLTF_FROM_WORLD = np.array([[1e-3, 0.0, 0.0, 0.0],
                            [0.0, 0.0, 1e-3, 0.0],
                            [0.0, -1e-3, 0.0, 0.0],
                            [0.0, 0.0, 0.0, 1.0]])


def glb_bytes(model: CompiledModel) -> bytes:
    """``model.glb`` bytes: a root node (:data:`GLTF_FROM_WORLD`) holding one node and mesh per
    part, named after the parts (vertices in world mm under the root)."""
    import trimesh
    from trimesh.visual.material import PBRMaterial

    scene = trimesh.Scene(base_frame="world")
    root = model.name or "model"
    scene.graph.update(frame_from="world", frame_to=root, matrix=GLTF_FROM_WORLD)
    for p in model.parts:
        mesh = part_mesh(p)
        m = materials.get(p.material)
        mat = PBRMaterial(name=f"{p.name}_{p.material}",
                          baseColorFactor=np.array([*m.rgb, 1.0]) * 255,
                          metallicFactor=float(m.metalness), roughnessFactor=float(m.roughness))
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False,
                             visual=trimesh.visual.TextureVisuals(material=mat))
        tm.metadata["name"] = p.name
        scene.add_geometry(tm, node_name=p.name, geom_name=p.name, parent_node_name=root)
    return scene.export(file_type="glb")
