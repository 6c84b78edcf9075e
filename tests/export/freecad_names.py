"""freecadcmd script: import a STEP headless and dump every object's Label to JSON.

Each object also records its TypeId and, where it has a shape, its volume (mm^3) and bounding
box (mm, including its placement) so the test can check units and placements independently.

Run as ``PROCEDURA_STEP=in.step PROCEDURA_JSON=out.json freecadcmd tests/export/freecad_names.py``
(freecadcmd takes a script path, not arguments, so the paths travel by environment variable).
Link groups must be off before importing: headless FreeCAD 0.20 segfaults building them.
"""

import json
import os

import FreeCAD

FreeCAD.ParamGet("User parameter:BaseApp/Preferences/Mod/Import").SetBool("UseLinkGroup", False)

import Import  # noqa: E402  (after the preference, on purpose)

step_path = os.environ["PROCEDURA_STEP"]
json_path = os.environ["PROCEDURA_JSON"]
doc = FreeCAD.newDocument("procedura_step")
Import.insert(step_path, doc.Name)
doc.recompute()
objects = []
for obj in doc.Objects:
    entry = {"name": obj.Name, "label": obj.Label, "type": obj.TypeId}
    shape = getattr(obj, "Shape", None)
    if shape is not None and not shape.isNull():
        entry["volume"] = shape.Volume
        box = shape.BoundBox
        entry["bbox"] = [[box.XMin, box.YMin, box.ZMin], [box.XMax, box.YMax, box.ZMax]]
    objects.append(entry)
with open(json_path, "w", encoding="utf-8") as fh:
    json.dump({"labels": [o["label"] for o in objects], "objects": objects}, fh, indent=1)
FreeCAD.closeDocument(doc.Name)
