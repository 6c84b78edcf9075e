"""STEP export: one named, coloured product per part under a root assembly, millimetres.

Built on raw OCP XCAF (no build123d): an ``XCAFApp`` document whose root assembly label is named
after the model holds one *part definition* per :class:`CompiledPart` (its LOCAL solid, named
exactly the part name, coloured from its material) and one component instance per part, located
by the part's world placement. ``STEPCAFControl_Writer`` turns that into AP214 (default) or
AP242 with ``PRODUCT`` entities named after the parts and ``NEXT_ASSEMBLY_USAGE_OCCURRENCE``
links carrying the placements.

Names written to the file are ASCII by construction (see :func:`step_name`); the header carries
a fixed time stamp so the same model always gives the same bytes.

:func:`read_step_parts` reads a STEP file back through XCAF (names, colours, volumes, world boxes);
tests and the bundle's round-trip check use it.
"""

from __future__ import annotations

import logging
import os
import re
import tempfile
import threading
import unicodedata
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from ..errors import KernelError, ProceduraError
from .step_order import canonical_step

if TYPE_CHECKING:
    from ..program.model import CompiledModel

log = logging.getLogger(__name__)

Schema = Literal["AP214", "AP242"]

#: Interface_Static ``write.step.schema`` value for each schema we offer.
SCHEMAS: dict[str, str] = {"AP214": "AP214IS", "AP242": "AP242DIS"}

#: FILE_NAME time stamp written to every header: fixed, so equal models give equal bytes.
HEADER_TIMESTAMP = "2000-01-01T00:00:00"

#: Fallback product name when a model name has no ASCII letter or digit left.
DEFAULT_ROOT_NAME = "model"

_NAME_RE = re.compile(r"^[a-z0-9_]+$")
_LOCK = threading.Lock()  # Interface_Static and the default messenger are process-global


class StepExportError(ProceduraError, ValueError):
    """The model cannot be written as STEP (a bad part name, a duplicate, a failed transfer)."""


@dataclass(frozen=True)
class StepPart:
    """One leaf product instance read back from a STEP file.

    Attributes:
        name: the product (part definition) name.
        rgb: surface colour (else generic colour) in sRGB 0..1, or None when uncoloured.
        volume: volume of the part definition's solid, mm^3.
        bbox: world axis-aligned box ((xmin, ymin, zmin), (xmax, ymax, zmax)), mm.
    """

    name: str
    rgb: tuple[float, float, float] | None
    volume: float
    bbox: tuple[tuple[float, float, float], tuple[float, float, float]]


def step_name(text: str) -> str:
    """The ASCII product name used for ``text``: identity on names already in ``[a-z0-9_]+``.

    Rule: Unicode NFKD decomposition, drop everything outside ASCII (accents, guillemets, Greek
    ...), lower-case, replace each run of characters outside ``[a-z0-9_]`` by one ``_``, strip
    leading/trailing ``_``; an empty result becomes ``"model"``.
    Example: ``'Rover «Ω» ü'`` -> ``'rover_u'``.
    """
    ascii_text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    name = re.sub(r"[^a-z0-9_]+", "_", ascii_text.lower()).strip("_")
    return name or DEFAULT_ROOT_NAME


def _check_part_names(model: CompiledModel) -> None:
    seen: set[str] = set()
    for part in model.parts:
        if not _NAME_RE.match(part.name):
            raise StepExportError(
                f"part name {part.name!r} is not a STEP product name: allowed characters are "
                f"[a-z0-9_]; rename the part (e.g. to {step_name(part.name)!r})")
        if part.name in seen:
            raise StepExportError(
                f"part name {part.name!r} occurs twice; part names must be unique")
        seen.add(part.name)
    if not model.parts:
        raise StepExportError(f"model {model.name!r} has no parts; nothing to write as STEP")


@contextmanager
def _quiet_occt() -> Iterator[None]:
    """Raise the default messenger's printers to failures only (the writer prints statistics)."""
    from OCP.Message import Message, Message_Gravity

    printers = list(Message.DefaultMessenger_s().Printers())
    levels = [p.GetTraceLevel() for p in printers]
    for p in printers:
        p.SetTraceLevel(Message_Gravity.Message_Fail)
    try:
        yield
    finally:
        for p, level in zip(printers, levels):
            p.SetTraceLevel(level)


def _set_statics(schema: Schema) -> None:
    """Set the global STEP write parameters (every call: another caller may have changed them)."""
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_Controller

    STEPControl_Controller.Init_s()
    for key, value in (("write.step.schema", SCHEMAS[schema]), ("write.step.unit", "MM"),
                       ("xstep.cascade.unit", "MM"), ("write.step.assembly", "On")):
        if not Interface_Static.SetCVal_s(key, value):
            raise KernelError(f"OCCT refused STEP parameter {key}={value!r}")


def _new_document() -> Any:
    """An empty XCAF document whose length unit is the millimetre."""
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document
    from OCP.UnitsMethods import UnitsMethods_LengthUnit
    from OCP.XCAFApp import XCAFApp_Application
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    app = XCAFApp_Application.GetApplication_s()
    doc = TDocStd_Document(TCollection_ExtendedString("MDTV-XCAF"))
    app.InitDocument(doc)
    # One document unit is one millimetre (the one-argument overload means metres: a 1000x trap).
    mm = UnitsMethods_LengthUnit.UnitsMethods_LengthUnit_Millimeter
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 1.0, mm)
    return doc


def _build_document(model: CompiledModel, root_name: str) -> Any:
    """The XCAF document: root assembly -> one component per part -> part definition (local)."""
    from OCP.Quantity import Quantity_Color, Quantity_TypeOfColor
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_ColorType, XCAFDoc_DocumentTool

    from .. import kernel

    doc = _new_document()
    shapes = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    colors = XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    root = shapes.NewShape()
    TDataStd_Name.Set_s(root, TCollection_ExtendedString(root_name))
    for part in model.parts:
        rgb = model.material_of(part).rgb
        colour = Quantity_Color(*rgb, Quantity_TypeOfColor.Quantity_TOC_sRGB)
        label = shapes.AddShape(part.local_shape(), False, False)
        TDataStd_Name.Set_s(label, TCollection_ExtendedString(part.name))
        colors.SetColor(label, colour, XCAFDoc_ColorType.XCAFDoc_ColorSurf)
        colors.SetColor(label, colour, XCAFDoc_ColorType.XCAFDoc_ColorGen)
        location = TopLoc_Location(kernel.trsf(part.placement))
        instance = shapes.AddComponent(root, label, location)
        TDataStd_Name.Set_s(instance, TCollection_ExtendedString(part.name))
    shapes.UpdateAssemblies()
    return doc


def _make_deterministic(writer: Any, root_name: str) -> None:
    """Fix the header (name, time stamp, system) and renumber assembly-usage ids 1..n.

    OCCT numbers ``NEXT_ASSEMBLY_USAGE_OCCURRENCE`` ids from a process-wide counter, so without
    this the second export of the same model would differ from the first.
    """
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.StepRepr import StepRepr_NextAssemblyUsageOccurrence
    from OCP.TCollection import TCollection_HAsciiString

    step_model = writer.ChangeWriter().Model()
    usage = 0
    for i in range(1, step_model.NbEntities() + 1):
        entity = step_model.Value(i)
        if isinstance(entity, StepRepr_NextAssemblyUsageOccurrence):
            usage += 1
            entity.SetId(TCollection_HAsciiString(str(usage)))
    header = APIHeaderSection_MakeHeader(step_model)
    header.SetName(TCollection_HAsciiString(root_name))
    header.SetTimeStamp(TCollection_HAsciiString(HEADER_TIMESTAMP))
    header.SetAuthorValue(1, TCollection_HAsciiString("procedura-brep"))
    header.SetOrganizationValue(1, TCollection_HAsciiString("procedura-brep"))
    header.SetOriginatingSystem(TCollection_HAsciiString("procedura-brep (Open CASCADE XCAF)"))
    header.SetDescriptionValue(1, TCollection_HAsciiString(f"procedura-brep assembly {root_name}"))


def step_bytes(model: CompiledModel, *, schema: Schema = "AP214") -> bytes:
    """The STEP file of ``model``: a root assembly named after the model, one product per part.

    Each part becomes a part definition (its LOCAL solid, product name = part name, surface and
    generic colour = its material's rgb) instanced once in the root assembly at its world
    placement. Lengths are millimetres. The same model always gives the same bytes.

    Args:
        model: the compiled assembly; part names must be unique and match ``[a-z0-9_]+``.
        schema: ``"AP214"`` (AP214 IS, the default) or ``"AP242"`` (AP242 DIS).

    Returns:
        The ISO 10303-21 file as bytes (ASCII).

    Raises:
        StepExportError: an unknown schema, a bad or duplicate part name, or a failed transfer.
    """
    if schema not in SCHEMAS:
        raise StepExportError(f"schema {schema!r} is not supported; use one of {sorted(SCHEMAS)}")
    _check_part_names(model)
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType

    root_name = step_name(model.name)
    doc = _build_document(model, root_name)
    fd, path = tempfile.mkstemp(prefix="procedura_", suffix=".step")
    os.close(fd)
    try:
        with _LOCK, _quiet_occt():
            _set_statics(schema)
            writer = STEPCAFControl_Writer()
            writer.SetNameMode(True)
            writer.SetColorMode(True)
            writer.SetLayerMode(False)
            writer.SetPropsMode(False)
            try:
                done = writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
                if done:
                    _make_deterministic(writer, root_name)
                    status = writer.Write(path)
            except Exception as exc:  # OCCT raises Standard_Failure subclasses
                raise KernelError(f"STEP export of model {model.name!r} failed: {exc}") from exc
            if not done:
                raise StepExportError(f"STEP transfer of model {model.name!r} failed")
        if status != IFSelect_ReturnStatus.IFSelect_RetDone:
            raise StepExportError(f"writing STEP for model {model.name!r} failed: {status}")
        with open(path, "rb") as fh:
            data = canonical_step(fh.read().decode("ascii")).encode("ascii")
    finally:
        os.unlink(path)
    log.debug("STEP %s: %d parts, %d bytes", schema, len(model.parts), len(data))
    return data


def _read_document(data: bytes) -> Any:
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPCAFControl import STEPCAFControl_Reader

    doc = _new_document()
    fd, path = tempfile.mkstemp(prefix="procedura_", suffix=".step")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        with _LOCK, _quiet_occt():
            from OCP.Interface import Interface_Static
            from OCP.STEPControl import STEPControl_Controller
            STEPControl_Controller.Init_s()
            Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
            reader = STEPCAFControl_Reader()
            reader.SetNameMode(True)
            reader.SetColorMode(True)
            try:
                status = reader.ReadFile(path)
                done = status == IFSelect_ReturnStatus.IFSelect_RetDone and reader.Transfer(doc)
            except Exception as exc:  # OCCT raises Standard_Failure subclasses
                raise KernelError(f"reading STEP failed: {exc}") from exc
            if not done:
                raise KernelError(f"reading STEP ({len(data)} bytes) failed: status {status}")
    finally:
        os.unlink(path)
    return doc


def _label_name(label: Any) -> str:
    from OCP.TDataStd import TDataStd_Name

    attr = TDataStd_Name()
    if label.FindAttribute(TDataStd_Name.GetID_s(), attr):
        return attr.Get().ToExtString()
    return ""


def _colour(colors: Any, label: Any, shape: Any) -> tuple[float, float, float] | None:
    """Surface then generic colour, on the instance first, then on the part definition."""
    from OCP.Quantity import Quantity_Color, Quantity_TypeOfColor
    from OCP.XCAFDoc import XCAFDoc_ColorType

    colour = Quantity_Color()
    for kind in (XCAFDoc_ColorType.XCAFDoc_ColorSurf, XCAFDoc_ColorType.XCAFDoc_ColorGen):
        if (shape is not None and colors.GetInstanceColor(shape, kind, colour)) or \
                colors.GetColor(label, kind, colour):
            r, g, b = colour.Values(Quantity_TypeOfColor.Quantity_TOC_sRGB)
            return (r, g, b)
    return None


def read_step_parts(data: bytes) -> list[StepPart]:
    """The leaf products of a STEP file, in file order, read back through XCAF.

    Assemblies are walked recursively; each leaf instance yields its part definition's name,
    colour, volume and world bounding box (component locations composed down the tree).

    Args:
        data: a STEP (ISO 10303-21) file.

    Returns:
        One :class:`StepPart` per leaf instance.

    Raises:
        KernelError: the file cannot be read or transferred.
    """
    from OCP.collections import Sequence_TDF_Label as TDF_LabelSequence
    from OCP.TDF import TDF_Label
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_DocumentTool, XCAFDoc_ShapeTool

    from .. import kernel

    doc = _read_document(data)
    shapes = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    colors = XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    out: list[StepPart] = []

    def walk(label: Any, location: Any, instance: Any) -> None:
        if XCAFDoc_ShapeTool.IsAssembly_s(label):
            children = TDF_LabelSequence()
            XCAFDoc_ShapeTool.GetComponents_s(label, children, False)
            for child in children:
                ref = TDF_Label()
                XCAFDoc_ShapeTool.GetReferredShape_s(child, ref)
                walk(ref, location.Multiplied(XCAFDoc_ShapeTool.GetLocation_s(child)), child)
            return
        local = XCAFDoc_ShapeTool.GetShape_s(label)
        placed = local.Moved(location)
        inst_shape = XCAFDoc_ShapeTool.GetShape_s(instance) if instance is not None else None
        rgb = _colour(colors, label, inst_shape)
        out.append(StepPart(name=_label_name(label), rgb=rgb, volume=kernel.volume(local),
                            bbox=kernel.bbox(placed)))

    roots = TDF_LabelSequence()
    shapes.GetFreeShapes(roots)
    for root in roots:
        walk(root, TopLoc_Location(), None)
    return out


def read_step_root_names(data: bytes) -> list[str]:
    """Names of the top-level (free) products of a STEP file; ours has exactly one."""
    from OCP.collections import Sequence_TDF_Label as TDF_LabelSequence
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc = _read_document(data)
    roots = TDF_LabelSequence()
    XCAFDoc_DocumentTool.ShapeTool_s(doc.Main()).GetFreeShapes(roots)
    return [_label_name(root) for root in roots]

