"""OBJ + MTL export written by us: one group (``g``/``o``) per part, one PBR material per part.

trimesh's OBJ writer drops roughness and metalness, so the MTL is ours: ``Kd`` (base colour),
``Ka``/``Ks``, ``d``, ``illum``, and the PBR extension fields ``Pr`` (roughness), ``Pm``
(metallic). Material names are ``<part>_<material>`` so every part keeps its own entry even when
two parts share a material. Coordinates are world millimetres (as STEP), faces 1-based.
"""

from __future__ import annotations

import io

from ..program.model import CompiledModel
from .meshes import part_mesh


def mtl_name(part: str, material: str) -> str:
    return f"{part}_{material}"


def mtl_text(model: CompiledModel) -> str:
    """The ``model.mtl`` text."""
    out = io.StringIO()
    out.write(f"# procedura-brep materials for {model.name}\n")
    for p in model.parts:
        m = model.material_of(p)
        r, g, b = m.rgb
        out.write(f"\nnewmtl {mtl_name(p.name, p.material)}\n")
        out.write(f"Ka 0 0 0\nKd {r:.6f} {g:.6f} {b:.6f}\n")
        spec = 0.04 + 0.96 * m.metalness
        out.write(f"Ks {spec:.6f} {spec:.6f} {spec:.6f}\n")
        out.write(f"Ns {max(1.0, (1.0 - m.roughness) * 1000):.1f}\n")
        out.write(f"d 1\nillum 2\nPr {m.roughness:.6f}\nPm {m.metalness:.6f}\n")
    return out.getvalue()


def obj_text(model: CompiledModel, *, mtl_file: str = "model.mtl") -> str:
    """The ``model.obj`` text (world mm, one ``o``/``g`` per part)."""
    out = io.StringIO()
    out.write(f"# procedura-brep {model.name}: units mm, Z up\nmtllib {mtl_file}\n")
    base = 1
    for p in model.parts:
        mesh = part_mesh(p)
        out.write(f"\no {p.name}\ng {p.name}\nusemtl {mtl_name(p.name, p.material)}\n")
        out.write("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in mesh.vertices))
        out.write("".join(f"f {a + base} {b + base} {c + base}\n" for a, b, c in mesh.faces))
        base += len(mesh.vertices)
    return out.getvalue()


def obj_files(model: CompiledModel) -> dict[str, bytes]:
    """``{"model.obj": ..., "model.mtl": ...}``."""
    return {"model.obj": obj_text(model).encode(), "model.mtl": mtl_text(model).encode()}


def read_obj_groups(text: str) -> dict[str, int]:
    """``{group name: face count}`` of an OBJ text (round-trip tests)."""
    groups: dict[str, int] = {}
    cur = None
    for line in text.splitlines():
        if line.startswith("g "):
            cur = line[2:].strip()
            groups.setdefault(cur, 0)
        elif line.startswith("f ") and cur is not None:
            groups[cur] += 1
    return groups
