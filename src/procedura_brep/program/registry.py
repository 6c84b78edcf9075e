"""Declarations recorded while a program module executes: materials, parts, frames, mates.

Kept free of build123d so the parent process can import it cheaply.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any, Callable, Literal

from ..config import MATERIAL
from ..errors import MateError, ProgramFormatError
from ..materials import MATERIALS, Material, MaterialError, declare

Detail = Literal["silhouette", "major", "sub"]
DETAILS: tuple[str, ...] = ("silhouette", "major", "sub")
#: Part, frame and mate names (checked with ``fullmatch``: ``$`` would accept a trailing newline).
NAME_RE = re.compile(r"[a-z][a-z0-9_]*")
MAX_NAME = 64


def valid_name(name: object) -> bool:
    """A part, frame or mate name: snake_case, at most ``MAX_NAME`` characters."""
    return isinstance(name, str) and len(name) <= MAX_NAME and NAME_RE.fullmatch(name) is not None


@dataclass
class PartDecl:
    name: str
    fn: Callable[[], Any]
    detail: str
    material: str
    description: str
    line: int
    end_line: int
    pieces: int = 1
    mass: float | None = None  # kg, @part(mass=...)
    hollow: float | None = None  # mm wall, @part(hollow=...)


@dataclass
class PaintDecl:
    """One ``@paint(part, material=...)`` declaration: a colour block cut from ``part``."""

    name: str
    part: str
    fn: Callable[[], Any]
    material: str
    description: str
    line: int
    end_line: int


@dataclass
class MateDecl:
    name: str
    child: str
    child_frame: str
    parent: str
    parent_frame: str
    type: str
    nominal: Any
    fit: str | None
    options: dict[str, Any]
    line: int | None


@dataclass
class CoupleDecl:
    """One ``couple(driven, driver, type, ...)`` declaration (checked at compile: see
    :mod:`procedura_brep.program.couplings`)."""

    driven: str
    driver: str
    type: str
    named: dict[str, Any]
    line: int | None


@dataclass
class Registry:
    """Everything one program declares, in declaration order."""

    parts: dict[str, PartDecl] = field(default_factory=dict)
    frames: dict[str, dict[str, Any]] = field(default_factory=dict)
    frame_lines: dict[str, int] = field(default_factory=dict)
    mates: list[MateDecl] = field(default_factory=list)
    materials: dict[str, Material] = field(default_factory=dict)  # the program's own, in order
    paints: list[PaintDecl] = field(default_factory=list)  # colour blocks, in program order
    couplings: list[CoupleDecl] = field(default_factory=list)  # couple(...), in program order

    @property
    def library(self) -> dict[str, Material]:
        """The built-in materials followed by the program's own declarations."""
        return {**MATERIALS, **self.materials}

    def add_material(self, name: str, line: int | None, **values: Any) -> None:
        """Validate and record a ``material(...)`` declaration (a bad one is a format error
        with the line, the value and the range)."""
        if len(self.materials) >= MATERIAL.max_declared:
            raise ProgramFormatError(f"a program may declare at most {MATERIAL.max_declared} "
                                     f"materials (config.MATERIAL.max_declared)", line=line)
        try:
            m = declare(name, library=self.library, **values)
        except MaterialError as exc:
            raise ProgramFormatError(str(exc), line=line) from None
        self.materials[m.name] = m

    def add_part(self, decl: PartDecl) -> None:
        if not valid_name(decl.name):
            raise ProgramFormatError(f"part name {decl.name!r} must be snake_case [a-z][a-z0-9_]*",
                                     line=decl.line)
        if decl.name in self.parts:
            raise ProgramFormatError(f"part {decl.name!r} is defined twice", line=decl.line)
        self.parts[decl.name] = decl

    def add_paint(self, decl: PaintDecl) -> None:
        """Record a colour block (its part is checked at compile: it may be declared later)."""
        for what, value in (("block name", decl.name), ("painted part", decl.part)):
            if not valid_name(value):
                raise ProgramFormatError(f"{what} {value!r:.80} must be snake_case [a-z][a-z0-9_]*",
                                         line=decl.line)
        if any(p.name == decl.name for p in self.paints):
            raise ProgramFormatError(f"block {decl.name!r} is painted twice", line=decl.line)
        self.paints.append(decl)

    def add_frames(self, part: str, frames: dict[str, Any], line: int | None) -> None:
        for fname in frames:
            if not valid_name(fname):
                raise ProgramFormatError(f"frame name {fname!r:.80} of part {part!r:.80} must be "
                                         f"snake_case [a-z][a-z0-9_]*", line=line)
        self.frames.setdefault(part, {}).update(frames)
        if line is not None:
            self.frame_lines.setdefault(part, line)

    def add_mate(self, decl: MateDecl) -> None:
        for what, value in (("mate name", decl.name), ("child part", decl.child),
                            ("child frame", decl.child_frame), ("parent part", decl.parent),
                            ("parent frame", decl.parent_frame)):
            if not valid_name(value):
                raise ProgramFormatError(f"{what} {value!r:.80} must be snake_case [a-z][a-z0-9_]*",
                                         line=decl.line)
        if any(m.name == decl.name for m in self.mates):
            raise MateError(decl.name, "a mate with this name is declared twice; pass name=...")
        self.mates.append(decl)

    def add_coupling(self, decl: CoupleDecl) -> None:
        for what, value in (("driven mate", decl.driven), ("driver mate", decl.driver)):
            if not valid_name(value):
                raise ProgramFormatError(f"couple: {what} {value!r:.80} must be a mate name "
                                         f"[a-z][a-z0-9_]*", line=decl.line)
        self.couplings.append(decl)


_ACTIVE: list[Registry] = []


def active() -> Registry:
    """The registry of the program being executed (the compiler pushes one per compile)."""
    if not _ACTIVE:
        _ACTIVE.append(Registry())
    return _ACTIVE[-1]


def push() -> Registry:
    reg = Registry()
    _ACTIVE.append(reg)
    return reg


def pop() -> None:
    if _ACTIVE:
        _ACTIVE.pop()
