"""The parts of `synth.info.LinkageInfo` that several kinds of linkage share (Bennett parameters, DH
table, Study form, score figures, a task's fit) and `Record`, the base of every info record: its fields,
in order, are linkage.json's ``info`` keys (a field made with `optional` is left out while None);
``to_dict`` writes them (numpy values kept: `synth.io.jsonout.plain` makes JSON types of them) and
``from_dict`` reads a document back. Lengths in metres, angles in radians, world frame.
"""
from __future__ import annotations

import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, is_dataclass

import numpy as np

__all__ = ["Record", "optional", "document", "load", "BennettParameters", "DHRow", "StudyForm", "ScoreParts",
           "FitSummary", "FitRecord"]


def optional(**kw):
    """A record field written only when it is not None (default None)."""
    return field(default=None, metadata={"optional": True}, **kw)


class Record:
    """Base of the info records: ``to_dict`` (fields in order, `optional` ones left out while None) and
    ``from_dict`` (its inverse for a document read back; a missing key gives None). ``MARK``: a key only
    this record's documents have, which tells it from the others of a union (`matches`)."""

    MARK: typing.ClassVar[str | None] = None

    def to_dict(self) -> dict:
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None and f.metadata.get("optional") or f.metadata.get("internal"):
                continue
            out[f.name] = document(v)
        return out

    @classmethod
    def from_dict(cls, d: Mapping):
        hints = typing.get_type_hints(cls)
        return cls(**{f.name: load(hints[f.name], d.get(f.name)) for f in fields(cls)
                      if f.init and not f.metadata.get("internal")})

    @classmethod
    def matches(cls, d: Mapping) -> bool:
        """Whether the document ``d`` is one of this record (for a field whose type is a union of records)."""
        return cls.MARK is None or cls.MARK in d

    def replace(self, **changes):
        """A copy with ``changes``: `dataclasses.replace` without a second ``__init__`` (records have no
        ``__post_init__``; the copy is on every synthesis's path)."""
        unknown = changes.keys() - self.__dataclass_fields__.keys()
        if unknown:
            raise TypeError(f"{type(self).__name__} has no fields {sorted(unknown)}")
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.__dict__.update(changes)
        return new


def document(v):
    """``v`` with every record and dataclass as a dict (`Record.to_dict`), tuples as lists (numpy values kept)."""
    if isinstance(v, Record):
        return v.to_dict()
    if is_dataclass(v) and not isinstance(v, type):
        return {f.name: document(getattr(v, f.name)) for f in fields(v)}
    if isinstance(v, Mapping):
        return {k: document(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [document(x) for x in v]
    return v


def load(tp, v):
    """The value of type ``tp`` (a field's type) of the document value ``v`` (`Record.from_dict`)."""
    if v is None:
        return None
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        kinds = [a for a in args if a is not type(None)]
        for a in kinds:
            if isinstance(a, type) and issubclass(a, Record) and isinstance(v, Mapping) and a.matches(v):
                return a.from_dict(v)
        return load(kinds[0], v) if len(kinds) == 1 else v
    if isinstance(tp, type) and issubclass(tp, Record):
        return tp.from_dict(v) if isinstance(v, Mapping) else v
    if isinstance(tp, type) and is_dataclass(tp):
        return tp(**{f.name: np.asarray(v[f.name]) if isinstance(v[f.name], list) else v[f.name] for f in fields(tp)})
    if origin is tuple and isinstance(v, list):
        return tuple(load(args[0], x) for x in v)
    if origin in (Mapping, dict) and isinstance(v, Mapping) and len(args) == 2:
        return {k: load(args[1], x) for k, x in v.items()}
    return v


@dataclass
class BennettParameters(Record):
    """The Bennett parameters of a four-joint loop h1-h2-k2-k1 (`synth.algebra.geometry.bennett_parameters`):
    link lengths a, b (metres) and twists alpha, beta (rad), the mismatches of opposite sides, a / sin alpha,
    b / sin beta and the Bennett condition's residual (None where not finite: planar loops)."""

    a: float
    alpha: float
    b: float
    beta: float
    opposite_length_mismatch: float
    opposite_twist_mismatch: float
    a_over_sin_alpha: float | None
    b_over_sin_beta: float | None
    bennett_condition_residual: float | None

    @classmethod
    def of_row(cls, bp: Mapping, row: int = 0, finite: bool = False) -> BennettParameters:
        """Set ``row`` of a dict of arrays (`bennett_parameters`); ``finite``: non-finite values become None."""
        vals = {k: float(np.asarray(v).item(row)) for k, v in bp.items()}
        if finite:
            vals = {k: (x if np.isfinite(x) else None) for k, x in vals.items()}
        elif not np.isfinite(vals["bennett_condition_residual"]):
            vals["bennett_condition_residual"] = None
        return cls(**vals)


@dataclass
class DHRow(Record):
    """One joint's Denavit-Hartenberg parameters around a closed loop (`DHParameters.table`): the joint,
    the next one, a (m), alpha (rad), d (m), theta (rad)."""

    joint: str
    next: str
    a: float
    alpha: float
    d: float
    theta: float

    @staticmethod
    def table(rows) -> tuple[DHRow, ...]:
        """The rows of `synth.algebra.geometry.DHParameters.table` (dicts) as DHRows."""
        return tuple(DHRow(**r) for r in rows)


@dataclass
class StudyForm(Record):
    """The mixed Study form values B(D_i, D_j) of the poses' relative displacements (metres)."""

    B01: float
    B02: float
    B12: float

    @classmethod
    def of(cls, values) -> StudyForm:
        return cls(*map(float, values))

    @property
    def values(self) -> tuple[float, float, float]:
        return self.B01, self.B02, self.B12


@dataclass
class ScoreParts(Record):
    """The engineering score's named figures (`synth.synthesis.sixbar_loops.score_loops`), in the order of
    the score rule that made them (the rules differ in which figures they have)."""

    figures: tuple[tuple[str, float], ...]

    @classmethod
    def of(cls, parts: Mapping) -> ScoreParts:
        return cls(tuple((str(k), float(v)) for k, v in parts.items()))

    def to_dict(self) -> dict:
        return dict(self.figures)

    @classmethod
    def from_dict(cls, d: Mapping) -> ScoreParts:
        return cls(tuple(d.items()))

    def _get(self, name: str) -> float:
        return dict(self.figures)[name]

    conditioning = property(lambda self: self._get("conditioning"), doc="the loop's conditioning (0 .. 1)")
    extent = property(lambda self: self._get("extent"), doc="the linkage's extent per pose spread")
    min_twist = property(lambda self: self._get("min_twist"), doc="the smallest link twist (rad)")
    min_offset = property(lambda self: self._get("min_offset"), doc="the smallest offset per pose spread")


@dataclass
class FitSummary:
    """What a task synthesis achieved, before `synth.synthesis.taskfit.annotate` measures it: ``method``
    ("exact", "hermite", "fit"), seeds tried and refined, iterations, ``visit`` (item indices in the order
    the first driver visits them, from item 0 on)."""

    method: str
    seeds: int = 0
    refined: int = 0
    iterations: int = 0
    visit: tuple = ()


@dataclass
class FitRecord(Record):
    """A task's result (`synth.synthesis.taskfit.annotate`, docs/fit.md): method, seeds, refinement, the
    task's order ("any" | "listed") and the items in the order the first driver visits them, the RMS and
    largest position (m) and angle (rad) errors, whether every tolerance is met, the indices of the items
    that miss theirs; for a four-bar, its dyads' method."""

    method: str
    seeds: int
    refined: int
    iterations: int
    order: str
    visit_order: tuple[str, ...] | None
    rms_position_error: float
    max_position_error: float
    rms_angle_error: float
    max_angle_error: float
    within_tolerance: bool
    failing: tuple[int, ...]
    dyads: str | None = optional()
