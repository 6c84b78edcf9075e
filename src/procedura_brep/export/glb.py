"""GLB export: one named node per part (world mm, as the other mesh formats) with its own
metallic-roughness PBR material, built with trimesh's glTF writer."""

from __future__ import annotations

import numpy as np

from .. import materials
from ..program.model import CompiledModel
from .meshes import part_mesh


def glb_bytes(model: CompiledModel) -> bytes:
    """``model.glb`` bytes: scene nodes and meshes named after the parts."""
    import trimesh
    from trimesh.visual.material import PBRMaterial

    scene = trimesh.Scene(base_frame="world")
    for p in model.parts:
        mesh = part_mesh(p)
        m = materials.get(p.material)
        mat = PBRMaterial(name=f"{p.name}_{p.material}",
                          baseColorFactor=np.array([*m.rgb, 1.0]) * 255,
                          metallicFactor=float(m.metalness), roughnessFactor=float(m.roughness))
        tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False,
                             visual=trimesh.visual.TextureVisuals(material=mat))
        tm.metadata["name"] = p.name
        scene.add_geometry(tm, node_name=p.name, geom_name=p.name)
    return scene.export(file_type="glb")
