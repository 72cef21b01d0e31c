"""Collision-free physical design of a linkage (the search over mounts, pins and bar shapes).

Interface shared by the synthesis commands and the exporters (docs/design.md):
``design_linkage(linkage, ...) -> DesignResult(design, collision)``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from synth.design.model import PhysicalDesign, straight_design


@dataclass
class CollisionReport:
    """What the design achieves. Lengths in metres, angles in radians.

    ``free``: no two bodies that share no joint come closer than ``clearance`` over ``range``
    ("full": the whole cycle; "task": the arc of the driving joint ``driver`` from ``driver_range[0]``
    to ``driver_range[1]`` (increasing, may exceed 2 pi) that visits every task pose);
    ``min_distance``: the certified smallest gap over that range (negative: the solids overlap);
    ``pairs``: the offending body pairs when not free ({"bodies": [a, b], "min_distance": d,
    "driver_angles": [lo, hi]}); ``message``: a sentence on what to change when not free."""

    free: bool
    range: str
    clearance: float
    min_distance: float
    driver: str
    driver_range: tuple[float, float]
    certified: bool = False
    pairs: list[dict] = field(default_factory=list)
    message: str = ""

    def to_dict(self) -> dict:
        return {"free": self.free, "range": self.range, "clearance": self.clearance,
                "min_distance": self.min_distance, "driver": self.driver,
                "driver_range": [float(self.driver_range[0]), float(self.driver_range[1])],
                "certified": self.certified, "pairs": self.pairs, "message": self.message}


@dataclass
class DesignResult:
    design: PhysicalDesign
    collision: CollisionReport


def design_linkage(linkage, *, pin_radius: float, bar_radius: float, hub_length: float,
                   hole_clearance: float = 0.0, clearance: float | None = None) -> DesignResult:
    """A physical design for ``linkage`` and what it achieves. (Placeholder until the search lands:
    the straight design, not checked.)"""
    clearance = 0.25 * bar_radius if clearance is None else clearance
    design = straight_design(linkage, pin_radius=pin_radius, bar_radius=bar_radius, hub_length=hub_length,
                             hole_clearance=hole_clearance, clearance=clearance)
    driver = linkage.joints[0].name
    report = CollisionReport(free=False, range="full", clearance=clearance, min_distance=float("nan"),
                             driver=driver, driver_range=(0.0, 6.283185307179586), certified=False,
                             message="not searched")
    return DesignResult(design, report)
