"""The choice of design: physical designs of candidate linkages, collision-free first, and the sentence
saying what a design achieves. Lengths in metres unless a ``scale`` (metres per ``unit``) is given for
messages; driver angles in radians (degrees in sentences)."""
from __future__ import annotations

import math

from synth.design.choose import design_for
from synth.design.constraints import envelope_violation, first_in_envelope
from synth.design.ranking import rank_buildable
from synth.design.search import collision_rank
from synth.design.sizes import check_sizes
from synth.errors import SynthesisError


def collision_sentence(report, scale: float, unit: str) -> str:
    """What the design achieves, in words (lengths in the input unit, driver angles in degrees)."""

    def length(x):
        return f"{x / scale:.3g} {unit}"

    lo, hi = (math.degrees(v) for v in report.driver_range)
    if report.free:
        where = ("over the full cycle" if report.range == "full" else
                 f"over the task range ({report.driver} from {lo:.1f} to {hi:.1f} deg)")
        thin = report.thinned
        if thin:
            clear = " / ".join(" and ".join(p) for p in thin["default_pairs"][:2]) or "colliding bodies"
            where += (f" (bars thinned to radius {length(thin['bar_radius'])}, pins to {length(thin['pin_radius'])}: "
                      f"{thin['scale']:g} x the defaults {length(thin['default_bar_radius'])}, "
                      f"{length(thin['default_pin_radius'])}, to clear {clear})")
        return f"collision-free {where}, clearance {length(report.clearance)}, min gap {length(report.min_distance)}"
    if report.pairs:
        p = report.pairs[0]
        a, b = p["bodies"]
        d = float(p["min_distance"])
        what = "collide" if d < 0 else f"come within {length(d)} (clearance {length(report.clearance)})"
        at = ""
        if p.get("driver_angles"):
            at = (f" at {report.driver} from {math.degrees(p['driver_angles'][0]):.1f} to "
                  f"{math.degrees(p['driver_angles'][1]):.1f} deg")
        more = f" (and {len(report.pairs) - 1} more pair(s))" if len(report.pairs) > 1 else ""
        return f"NOT collision-free: {a} and {b} {what}{at}{more}" + (f"; {report.message}" if report.message else "")
    return f"NOT collision-free: {report.message or 'no collision-free design was found'}"


class Designer:
    """Physical designs of a task's linkages: the sizes ``sizes`` (metres, `DesignOptions.sizes`) checked
    against each linkage's extent; messages name ``source`` with lengths in ``unit`` (``scale`` metres
    each); ``constraints``: the task's (`synth.task.Constraints`), whose base and envelope boxes place the
    mounting plate."""

    __slots__ = ("sizes", "source", "scale", "unit", "boxes")

    def __init__(self, sizes: dict, source: str, scale: float, unit: str, constraints=None):
        self.sizes, self.source, self.scale, self.unit = sizes, source, scale, unit
        self.boxes = (None, None) if constraints is None else (constraints.base, constraints.envelope)

    def design(self, linkage, **search):
        """The physical design of ``linkage`` (`synth.design.choose.design_for`); ``search``: further
        arguments of the design search (ranges, full_work, effort, work). InputError for sizes absurd for it."""
        check_sizes(self.sizes, linkage.extent(), scale=self.scale, unit=self.unit)
        return design_for(linkage, **self.sizes, mount_boxes=self.boxes, **search)

    def sentence(self, result) -> str:
        return collision_sentence(result.collision, self.scale, self.unit)

    def require_free(self, result) -> None:
        """SynthesisError (exit 1) with the collision sentence unless the design is collision-free."""
        if not result.collision.free:
            raise SynthesisError(f"{self.source}: {self.sentence(result)}")

    def choose(self, candidates, *, limit: int, work: float, what: str, constraints=None):
        """Design the best-scored ``candidates`` (best first, at most ``limit``) and keep the collision-free
        one first (full cycle, then task range; `synth.design.ranking.rank_buildable` within ``work`` gap
        evaluations, `synth.design.work`), then the score; with an envelope in ``constraints`` (the task's)
        the first design inside it (`synth.design.constraints.first_in_envelope`). Returns (linkage,
        DesignResult); ``linkage.info.design_choice`` says which candidate won; ``what``: the candidates'
        name in it."""
        candidates = list(candidates)
        ranked = rank_buildable(candidates, lambda lk, ranges, full_work, spent, effort: self.design(
            lk, ranges=ranges, full_work=full_work, work=spent, effort=effort), limit=limit, work=work)
        linkage, result = first_in_envelope(
            ranked, [c for c in candidates[:limit] if all(c is not lk for lk, _ in ranked)],
            lambda lk: self.design(lk, ranges=("task",)), constraints, source=self.source, scale=self.scale,
            unit=self.unit)
        k = next(i for i, c in enumerate(candidates) if c is linkage)
        linkage.info = linkage.info.replace(design_choice=(
            f"candidate {k + 1} of the {min(len(candidates), limit)} best-scored {what}: collision-free first (full "
            "cycle, then task range), then the score"))
        return linkage, result

    def rank(self, linkages, *, require_free: bool, what: str, progress=None, constraints=None):
        """The physical design of every ranked solution (`--top`), kept in the given (score) order, each
        with its collision report (#35: the ranking is the score's); with ``require_free`` only the
        collision-free ones (SynthesisError naming the best when there is none; ``what`` names the
        designs in it); with an envelope in ``constraints`` only the designs inside it.
        ``progress(items, label)``: an iterable wrapper showing progress (None: none). Returns
        (linkages, DesignResults)."""
        items = linkages if progress is None else progress(linkages, "collision-free design search: design")
        results = [self.design(lk) for lk in items]
        pairs = list(zip(linkages, results))
        if constraints is not None and constraints.envelope is not None:  # only the designs inside it
            first_in_envelope(pairs, [], None, constraints, source=self.source, scale=self.scale, unit=self.unit)
            pairs = [(lk, r) for lk, r in pairs if envelope_violation(lk, r.design, constraints) is None]
        if require_free:
            free = [(lk, r) for lk, r in pairs if r.collision.free]
            if not free:
                best = min(pairs, key=lambda p: collision_rank(p[1].collision))[1]
                raise SynthesisError(f"{self.source}: none of the {len(pairs)} best {what} is collision-free; "
                                     f"the best: {self.sentence(best)}")
            pairs = free
        return [lk for lk, _ in pairs], [r for _, r in pairs]
