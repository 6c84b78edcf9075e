"""The compile worker's start-up (issue 24.2): build123d imports packages it uses only to read
or write files (DXF, SVG, 3MF, glTF materials, STL clustering) or in a notebook; the zygote
stands in for them, so every cold CLI call waits less for its worker, and a use of one says
what is missing."""

from __future__ import annotations

import json
import subprocess
import sys

PROBE = r"""
import json, sys
from procedura_brep.program import worker
worker._stub_unused_imports()
import build123d
from build123d import Box, Cylinder
out = {"volume": (Box(10, 10, 10) - Cylinder(2, 20)).volume,
       "stood_in": sorted(r for r in worker.UNUSED_IMPORTS
                          if isinstance(getattr(sys.modules.get(r), "__spec__", None) and
                                        sys.modules[r].__spec__.loader, worker._Unused)),
       "real": sorted(m.split(".")[0] for m in sys.modules
                      if m.split(".")[0] in worker.UNUSED_IMPORTS
                      and not isinstance(sys.modules[m].__spec__.loader, worker._Unused))}
import ezdxf
try:
    ezdxf.readfile("x.dxf")
except ImportError as exc:
    out["error"] = str(exc)
print(json.dumps(out))
"""


def test_the_zygote_loads_none_of_the_file_packages_and_build123d_still_works():
    proc = subprocess.run([sys.executable, "-P", "-c", PROBE], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert abs(out["volume"] - (1000 - 3.141592653589793 * 4 * 10)) < 1e-6
    # every package build123d imports among them is a stand-in, none is the real one
    assert {"ezdxf", "svgpathtools", "lib3mf", "threejs_materials", "sklearn", "requests"} <= set(out["stood_in"])
    assert out["real"] == []
    assert "ezdxf.readfile is not loaded in the compile worker" in out["error"]
