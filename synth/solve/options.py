"""What a synthesis is asked for: typed options shared by the CLI, batch jobs and notebooks.

`DesignOptions` holds the physical-design sizes in the task's length unit (None: the defaults of
`synth.io.meshes.default_sizes`) and whether a collision-free design is required; `sizes` validates and
converts them to metres, in one place for every caller. `SynthesisOptions` holds the choice among
solutions (member, family, pair, top) and whether a physical design is to be made.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from synth.errors import InputError

SIZE_KEYS = ("pin_radius", "link_radius", "pin_length", "clearance", "hole_clearance")
GAPS = ("clearance", "hole_clearance")  # may be 0; the other sizes must be positive
MAX_SIZE = 1e9  # in the input unit: larger is a typo
MESH_SIZE_RANGE = (1e-6, 10.0)  # explicit mesh sizes, relative to the linkage's size (extent): a part
# ten times the mechanism's size is a typo, not a design (e.g. --pin-length 100000 gave a 132 m mesh)


def option_label(key: str) -> str:
    """The CLI's name of a size: ``--pin-radius``."""
    return f"--{key.replace('_', '-')}"


@dataclass(frozen=True, slots=True)
class DesignOptions:
    """Physical-design sizes in the task's length unit (None: default) and ``require_collision_free``
    (SynthesisError, exit 1, unless the design is collision-free)."""

    pin_radius: float | None = None
    link_radius: float | None = None
    pin_length: float | None = None
    clearance: float | None = None
    hole_clearance: float | None = None
    require_collision_free: bool = False

    def sizes(self, length_scale: float, label: Callable[[str], str] = option_label) -> dict:
        """The given sizes in metres (``length_scale``: metres per input unit), keyed as
        `synth.io.meshes.design_for`'s arguments; InputError (``label(key)`` naming the size) unless
        positive (clearances: non-negative) and below MAX_SIZE."""
        out = {}
        for key in SIZE_KEYS:
            v = getattr(self, key)
            if v is None:
                continue
            zero_ok = key in GAPS
            if not ((v > 0 or (zero_ok and v == 0)) and v < MAX_SIZE):
                raise InputError(f"{label(key)} must be a {'non-negative' if zero_ok else 'positive'} "
                                 f"length, got {v}")
            out[key] = v * length_scale
        return out


def check_mesh_sizes(sizes: dict, extent: float, scale: float, unit: str) -> None:
    """Refuse explicit sizes (metres, `DesignOptions.sizes`) that are absurd for a linkage of size
    ``extent`` (metres): outside MESH_SIZE_RANGE times the extent the meshes cannot be built. Messages use
    the input unit (``scale`` metres per ``unit``)."""
    lo, hi = MESH_SIZE_RANGE
    for key, v in sizes.items():
        if key in GAPS:
            if v > hi * extent:
                raise InputError(f"{option_label(key)} {v / scale:.6g} {unit} is out of range for a linkage "
                                 f"of size {extent / scale:.3g} {unit}")
            continue
        if not (lo * extent <= v <= hi * extent):
            raise InputError(
                f"{option_label(key)} {v / scale:.6g} {unit} is out of range for a linkage of size "
                f"{extent / scale:.3g} {unit}: give a value between {lo * extent / scale:.3g} and "
                f"{hi * extent / scale:.3g} {unit}")


@dataclass(frozen=True, slots=True)
class SynthesisOptions:
    """The choice among solutions and what to make of the chosen one.

    ``physical``: make the physical design (files, linkage.json, a required collision-free design);
    without it the best-scored linkage is returned undesigned. ``top``: point tasks and 6R: the N best
    designs, ranked (`Result.solutions`, `Result.index`). ``member``: Bennett of planar or spherical
    poses (lambda1, lambda2); 6R: lambda1, or (t3, lambda1, lambda2, lambda3) for planar or spherical
    poses. ``family`` (1|2) and ``pair`` (1..9): 6R. ``method``: curves ("auto", "translation",
    "rotation"). ``best_effort``: task fits (docs/fit.md): the best fit even when it misses a tolerance
    (else SynthesisError)."""

    design: DesignOptions = field(default_factory=DesignOptions)
    physical: bool = False
    top: int | None = None
    member: float | tuple | None = None
    family: int | None = None
    pair: int | None = None
    method: str = "auto"
    best_effort: bool = False

    @property
    def wants_design(self) -> bool:
        """Whether a physical design is made: asked for, or required collision-free."""
        return self.physical or self.design.require_collision_free

    @property
    def explicit(self) -> bool:
        """Whether a family, member or pair was chosen (then the scores choose, not the design search)."""
        return self.family is not None or self.member is not None or self.pair is not None
