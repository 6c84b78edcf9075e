"""Readers for tests that check exported files (the glTF JSON chunk of a GLB)."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any


def glb_json(path: Path) -> dict[str, Any]:
    """The JSON chunk of a binary glTF file (header 12 bytes, then the chunk length and type)."""
    data = Path(path).read_bytes()
    return json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])


def glb_node_material(tree: dict[str, Any], node: str) -> dict[str, Any]:
    """The material of the first primitive of the mesh of the node named ``node``."""
    n = next(x for x in tree["nodes"] if x.get("name") == node)
    return tree["materials"][tree["meshes"][n["mesh"]]["primitives"][0]["material"]]


__all__ = ["glb_json", "glb_node_material"]
