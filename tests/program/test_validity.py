"""A part whose solid fails BRepCheck is reported with the operation that made it invalid and
the program line of that operation (issue 23: the message named no operation)."""

from __future__ import annotations

from pathlib import Path

from procedura_brep.program import compile_source

BOWTIE = Path(__file__).parent / "bowtie.py"


def test_an_invalid_solid_names_the_operation_and_its_line(worker):
    src = BOWTIE.read_text()
    model = compile_source(src, name="bowtie", worker=worker)
    (f,) = [f for f in model.findings if f.part == "block"]
    line = next(i for i, text in enumerate(src.splitlines(), start=1) if "wing = extrude(" in text)
    assert "not a valid B-rep" in f.message and "extrude at line" in f.message, f.message
    assert "already not a valid B-rep" in f.message  # the self-intersecting profile went in
    assert f.line == line


def test_tracing_restores_build123d_and_the_namespace():
    """The diagnosis patches build123d's operators and the program's functions while it reruns
    the part; afterwards both are the real ones again, even when the part raises."""
    import build123d as bd

    from procedura_brep.program.validity import invalid_origin
    glb = {"extrude": bd.extrude}
    before = (bd.Shape.__dict__["__add__"], bd.Shape.__dict__["cut"])

    def part():
        bd.Box(1, 1, 1) + bd.Box(1, 1, 1)
        raise RuntimeError("the part fails after a fuse")

    assert invalid_origin(part, glb) is None  # a valid fuse: nothing to name
    assert (bd.Shape.__dict__["__add__"], bd.Shape.__dict__["cut"]) == before
    assert glb["extrude"] is bd.extrude
