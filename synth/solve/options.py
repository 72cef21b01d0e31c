"""What a synthesis is asked for: typed options shared by the CLI, batch jobs and notebooks.

`DesignOptions` holds the physical-design sizes in the task's length unit (None: the defaults of
`synth.design.choose.default_sizes`) and whether a collision-free design is required; `sizes` validates and
converts them to metres, in one place for every caller (their bounds against the linkage's size:
`synth.design.sizes.check_sizes`). `SynthesisOptions` holds the choice among
solutions (member, family, pair, top) and whether a physical design is to be made.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from synth.design.sizes import CLEARANCE_KEYS, option_label
from synth.design.sizes import SIZE_KEYS as PART_KEYS
from synth.errors import InputError

SIZE_KEYS = PART_KEYS + CLEARANCE_KEYS
GAPS = CLEARANCE_KEYS  # may be 0; the other sizes must be positive


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
    slenderness: float | None = None  # longest bar / bar diameter at most (None: synth.design.sturdy's 25)
    pin_fit: str | None = None  # "press", "clip" or "plain" (None: press; synth.design.model.PIN_FITS)

    def sizes(self, length_scale: float, label: Callable[[str], str] = option_label) -> dict:
        """The given sizes in metres (``length_scale``: metres per input unit), keyed as
        `synth.design.choose.design_for`'s arguments; InputError (``label(key)`` naming the size) unless
        positive (clearances: non-negative) and finite."""
        out = {}
        for key in SIZE_KEYS:
            v = getattr(self, key)
            if v is None:
                continue
            zero_ok = key in GAPS
            if not ((v > 0 or (zero_ok and v == 0)) and math.isfinite(v)):  # absurd sizes: `check_sizes`
                raise InputError(f"{label(key)} must be a {'non-negative' if zero_ok else 'positive'} "
                                 f"length, got {v}")
            out[key] = v * length_scale
        if self.slenderness is not None:
            if not (math.isfinite(self.slenderness) and self.slenderness > 0):
                raise InputError(f"{label('slenderness')} must be a positive ratio (bar length / diameter), "
                                 f"got {self.slenderness}")
            out["slenderness"] = float(self.slenderness)  # a ratio: not scaled
        if self.pin_fit is not None:
            out["pin_fit"] = str(self.pin_fit)  # a choice, not a size
        return out


@dataclass(frozen=True, slots=True)
class SynthesisOptions:
    """The choice among solutions and what to make of the chosen one.

    ``physical``: make the physical design (files, linkage.json, a required collision-free design);
    without it the best-scored linkage is returned undesigned. ``top``: point tasks and 6R: the N best
    designs, ranked (`Result.solutions`, `Result.index`). ``member``: Bennett of planar or spherical
    poses (lambda1, lambda2); 6R: lambda1, or (t3, lambda1, lambda2, lambda3) for planar or spherical
    poses. ``family`` (1|2) and ``pair`` (1..9): 6R. ``method``: curves ("auto", "translation",
    "rotation"). ``best_effort``: task fits (docs/fit.md): the best fit even when it misses a tolerance
    (else SynthesisError). ``driver``: the joint the motor turns (a joint on the base; None: h1) and
    ``max_extent``: the largest extent accepted, in the task's length unit (None: 100 x the task's
    spread; docs/drive.md)."""

    design: DesignOptions = field(default_factory=DesignOptions)
    physical: bool = False
    top: int | None = None
    member: float | tuple | None = None
    family: int | None = None
    pair: int | None = None
    method: str = "auto"
    best_effort: bool = False
    driver: str | None = None
    max_extent: float | None = None

    @property
    def wants_design(self) -> bool:
        """Whether a physical design is made: asked for, or required collision-free."""
        return self.physical or self.design.require_collision_free

    @property
    def explicit(self) -> bool:
        """Whether a family, member or pair was chosen (then the scores choose, not the design search)."""
        return self.family is not None or self.member is not None or self.pair is not None
