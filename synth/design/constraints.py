"""The task's constraints on where the mechanism goes, and its practical size (docs/drive.md).

``constraints`` (`synth.task.Constraints`, ``../shared/docs/OUTPUT.md`` "Additions (turn 3)"):

* ``base``: every joint on the root link has its axis through the box. Measured as the distance of each
  axis (a line) from the box, exactly (`line_box_distance`).
* ``max_speed_ratio``: |d theta_j / d theta_driver| of every joint over the task range
  (`synth.drive.speed_ratio`, exact).
* ``envelope``: every written solid stays inside the box over the task range: the design's bars
  (capsules) and its hubs and pins (cylinders; the meshes are inscribed in both) at samples evenly spaced
  in total joint rotation (`envelope_excess`).

``max_extent``: the linkage's extent (`synth.checks.extent`: RMS distance of its joint sites and tool
positions from their centroid) at most this (metres); by default `EXTENT_FACTOR` times the task's spread
(RMS distance of the pose positions from their centroid; no default when they coincide).

`admissible` filters a synthesis's candidates (best first) by what can be judged before the physical
design (base, speed ratio, extent), trying every joint on the base as the driver when the speed ratio
is constrained and no driver is given; when none passes it raises `SynthesisError` naming each violated
constraint and by how much at the candidate that came closest. Lengths in metres, angles in radians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.algebra.geometry import line_box_distance, spread
from synth.design.sampling import even_samples, t_of_phi
from synth.design.model import capsules
from synth.design.search import task_phi_range
from synth.design.sizes import EXTENT_FACTOR
from synth.drive import base_joints, driver_joint, speed_ratio, task_range, with_driver
from synth.errors import SynthesisError
from synth.linkage import Linkage
from synth.task import Box, Constraints

__all__ = ["Violation", "default_max_extent", "compact_first", "kinematic_violations", "admissible",
           "envelope_excess", "envelope_violation", "refusal"]

BOX_TOL = 1e-9  # an axis within this fraction of the linkage's extent of the box passes through it
ENVELOPE_SAMPLES = 48  # samples per joint over the task range for the envelope
COMPACT_FACTOR = 3.0  # with limits (constraints, --max-extent): candidates up to this many times the smallest first


@dataclass(frozen=True)
class Violation:
    """A constraint a design does not meet: ``constraint`` ("constraints.base", "constraints.envelope",
    "constraints.max_speed_ratio" or "max_extent"), ``excess`` (metres beyond the box or the extent
    limit; for the speed ratio the ratio minus its limit), ``what`` (the offending joint or link) and
    ``value``/``limit`` (the ratio or extent and its limit; NaN for boxes)."""

    constraint: str
    excess: float
    what: str
    value: float = math.nan
    limit: float = math.nan

    def sentence(self, scale: float = 1.0, unit: str = "m", driver: str = "the driver") -> str:
        """In words, lengths in the input unit (``scale`` metres per unit)."""
        if self.constraint == "constraints.base":
            return f"constraints.base: the axis of {self.what} misses the base box by {self.excess / scale:.4g} {unit}"
        if self.constraint == "constraints.envelope":
            return f"constraints.envelope: {self.what} leaves the envelope by {self.excess / scale:.4g} {unit}"
        if self.constraint == "constraints.max_speed_ratio":
            return (f"constraints.max_speed_ratio: {self.what} turns {self.value:.4g} times as fast as {driver} "
                    f"(limit {self.limit:g}, over by {self.excess:.3g})")
        return (f"the linkage's extent is {self.value / scale:.4g} {unit}, more than --max-extent "
                f"{self.limit / scale:.4g} {unit}")


# ----------------------------------------------------------------------------------------- base box
def _base_violations(linkage: Linkage, box: Box, E: float) -> list[Violation]:
    roots = [j for j in linkage.joints if j.parent == "base"]
    dist = line_box_distance(np.array([j.point for j in roots]), np.array([j.direction for j in roots]), box)
    return [Violation("constraints.base", float(x), j.name) for j, x in zip(roots, dist) if x > BOX_TOL * E]


# ----------------------------------------------------------------------------------------- size
def default_max_extent(linkage: Linkage) -> float:
    """`EXTENT_FACTOR` times the spread of the task's positions (metres); inf when they coincide."""
    if len(linkage.poses) < 2:
        return math.inf
    size = float(spread(np.array([p.matrix[:3, 3] for p in linkage.poses]))[1])
    return EXTENT_FACTOR * size if size > 0 else math.inf


def kinematic_violations(linkage: Linkage, constraints: Constraints | None,
                         max_extent: float | None = None) -> list[Violation]:
    """What ``linkage`` (driven by its `driver_joint`) violates of the constraints that need no physical
    design (base box, speed ratio) and of the extent limit (None: `default_max_extent`)."""
    E = linkage.extent()
    limit = default_max_extent(linkage) if max_extent is None else max_extent
    out = []
    if E > limit:
        out.append(Violation("max_extent", E - limit, "the linkage", E, limit))
    if constraints is not None and constraints.base is not None:
        out += _base_violations(linkage, constraints.base, E)
    if constraints is not None and constraints.max_speed_ratio is not None:
        driver, lo, hi = task_range(linkage)
        ratio, _ = speed_ratio(linkage, driver, lo, hi)
        names = [j.name for j in linkage.joints]
        k = max((i for i, n in enumerate(names) if n != driver), key=lambda i: ratio[i])
        if ratio[k] > constraints.max_speed_ratio:
            out.append(Violation("constraints.max_speed_ratio", float(ratio[k] - constraints.max_speed_ratio),
                                 names[k], float(ratio[k]), constraints.max_speed_ratio))
    return out


def _badness(violations: list[Violation], E: float) -> float:
    """A single number to find the candidate that came closest: excesses in extents and in ratios."""
    return sum(v.excess / (E if v.constraint != "constraints.max_speed_ratio" else max(v.limit, 1e-12))
               for v in violations)


def admissible(candidates, constraints: Constraints | None, *, driver: str | None = None,
               max_extent: float | None = None, source: str = "", scale: float = 1.0,
               unit: str = "m") -> list[Linkage]:
    """The candidates (best first; each driven by ``driver`` when given, else by the joint on the base
    that meets the speed ratio best) that meet the base box, the speed ratio and the extent limit, in
    order. None meets them: `SynthesisError` naming each violation at the candidate that came closest
    (`refusal`; ``source``, ``scale``, ``unit``: the task file and its length unit for the message)."""
    candidates = list(candidates)
    passed, best = [], None
    for lk in candidates:
        variants = [with_driver(lk, driver)] if driver is not None else [lk]
        if driver is None and constraints is not None and constraints.max_speed_ratio is not None:
            variants += [with_driver(lk, j) for j in base_joints(lk) if j != driver_joint(lk)]
        scored = [(v, kinematic_violations(v, constraints, max_extent)) for v in variants]
        E = lk.extent()
        ok = [v for v, bad in scored if not bad]
        if ok:
            passed.append(ok[0])
            continue
        v, bad = min(scored, key=lambda x: _badness(x[1], E))
        if best is None or _badness(bad, E) < best[0]:
            best = (_badness(bad, E), v, bad)
    if passed:
        return passed
    _, v, bad = best
    raise refusal(v, bad, source=source, scale=scale, unit=unit, count=len(candidates))


def compact_first(linkages, factor: float = COMPACT_FACTOR) -> list:
    """The candidates (best first) with those at most ``factor`` times as large (`Linkage.extent`) as the most
    compact one first, each group in its order: among the members of a family or the scored 6R pairs
    meeting the task's limits, the compact ones are designed first."""
    linkages = list(linkages)
    if len(linkages) < 2:
        return linkages
    E = np.array([lk.extent() for lk in linkages])
    near = E <= factor * E.min()
    return [lk for lk, n in zip(linkages, near) if n] + [lk for lk, n in zip(linkages, near) if not n]


def refusal(linkage: Linkage, violations: list[Violation], *, source: str = "", scale: float = 1.0,
            unit: str = "m", count: int = 1) -> SynthesisError:
    """The `SynthesisError` (exit 1) for a task no design meets: every violation at the best design
    found, then what to change."""
    where = "the design" if count == 1 else f"the best of {count} designs"
    driver = driver_joint(linkage)
    parts = [v.sentence(scale, unit, driver) for v in violations]
    hints = []
    if any(v.constraint == "max_extent" for v in violations):
        spread = default_max_extent(linkage) / EXTENT_FACTOR
        times = f"{linkage.extent() / spread:.3g} x the task's spread: " if math.isfinite(spread) else ""
        hints.append(f"({times}nearly degenerate poses, e.g. nearly planar or nearly spherical ones, give huge "
                     "linkages; make them exactly planar or spherical, move them apart, or raise --max-extent)")
    if any(v.constraint == "constraints.max_speed_ratio" for v in violations):
        hints.append("(try --driver with another joint on the base, or relax max_speed_ratio)")
    prefix = f"{source}: " if source else ""
    return SynthesisError(f"{prefix}no design meets the task's limits; at {where}: " + "; ".join(parts)
                          + (" " + " ".join(hints) if hints else ""))


# ----------------------------------------------------------------------------------------- envelope
def envelope_excess(linkage: Linkage, design, box: Box) -> tuple[float, str]:
    """(metres, link) the largest distance by which a solid of ``design`` (`synth.design.model.capsules`:
    bars as capsules, hubs and pins as cylinders) leaves ``box`` over the task range (negative: inside
    with that margin), and the link of that solid."""
    lo, hi = task_phi_range(linkage)
    phis = even_samples(linkage, lo, hi, ENVELOPE_SAMPLES * len(linkage.joints))
    disp = linkage.displacements(linkage.angles_at(t_of_phi(phis)))
    worst, where = -math.inf, ""
    for c in capsules(linkage, design):
        D = disp[c.link]
        ends = np.stack([D[..., :3, :3] @ c.p0 + D[..., :3, 3], D[..., :3, :3] @ c.p1 + D[..., :3, 3]])  # (2, K, 3)
        n = ends[1] - ends[0]
        n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)
        pad = c.radius * (1.0 if c.part in ("bar", "plate") else np.sqrt(np.clip(1.0 - n * n, 0.0, 1.0)))  # (K, 3) or scalar
        out = max(float(np.max(ends + pad - box.hi)), float(np.max(box.lo - (ends - pad))))
        if out > worst:
            worst, where = out, c.link
    return worst, where


def envelope_violation(linkage: Linkage, design, constraints: Constraints | None) -> Violation | None:
    """The envelope `Violation` of a physical design (None when there is no envelope or it is met)."""
    if constraints is None or constraints.envelope is None:
        return None
    excess, link = envelope_excess(linkage, design, constraints.envelope)
    return Violation("constraints.envelope", excess, link) if excess > 0 else None


def first_in_envelope(designed, more, design, constraints: Constraints | None, *, source: str = "",
                      scale: float = 1.0, unit: str = "m"):
    """The first (linkage, `DesignResult`) whose design stays inside the envelope: among ``designed``
    (already designed, in preference order), then ``more`` linkages designed in turn by ``design(linkage)
    -> DesignResult``. No envelope: the first of ``designed``. None inside: `refusal` at the design that
    leaves it least."""
    designed = list(designed)
    if constraints is None or constraints.envelope is None:
        return designed[0]
    best = None

    def pairs():
        yield from designed
        for lk in more:
            yield lk, design(lk)

    count = 0
    for lk, result in pairs():
        count += 1
        v = envelope_violation(lk, result.design, constraints)
        if v is None:
            return lk, result
        if best is None or v.excess < best[1].excess:
            best = (lk, v)
    raise refusal(best[0], [best[1]], source=source, scale=scale, unit=unit, count=count)


def met_sentence(linkage: Linkage, design, constraints: Constraints, scale: float = 1.0, unit: str = "m") -> str:
    """What the written design achieves of the task's constraints, in words (lengths in the input unit)."""
    parts = []
    if constraints.base is not None:
        parts.append(f"base box ({', '.join(j.name for j in linkage.joints if j.parent == 'base')} through it)")
    if constraints.envelope is not None and design is not None:
        excess, _ = envelope_excess(linkage, design, constraints.envelope)
        parts.append(f"envelope (margin {-excess / scale:.3g} {unit})")
    if constraints.max_speed_ratio is not None:
        driver, lo, hi = task_range(linkage)
        ratio, _ = speed_ratio(linkage, driver, lo, hi)
        top = max(r for r, j in zip(ratio, linkage.joints) if j.name != driver)
        parts.append(f"max speed ratio {top:.3g} <= {constraints.max_speed_ratio:g}")
    return "met: " + ", ".join(parts)
