"""The 6R side of a task file (`synth.task.PoseSet`, docs/sixbar_fit.md): which synthesis answers it, and
the linkages.

* four exact poses, no velocities: the exact scan of `synth.synthesis.sixbar` (``task_kind`` "exact"; the
  CLI's classic path unless the order is listed);
* two exact poses with a full velocity at each: Hermite interpolation, exact (`synth.synthesis.sixbar_hermite`);
* anything else that determines the cubic (six conditions per pose, three per point, five per velocity, at
  least 22): a fit (`synth.synthesis.sixbar_fit`; more than seven points: seeds from 7-subsets).

Every returned linkage has its poses' misses measured on it (`synth.synthesis.taskfit.annotate`: pose
records' ``error``, ``tolerance``, ``exact`` and ``info.fit``) and answers the order and tolerances
(`synth.synthesis.taskfit.select`).
"""
from __future__ import annotations

import numpy as np

from synth.checks import VERIFY_SAMPLES
from synth.errors import InputError
from synth.infoparts import FitSummary
from synth.synthesis.taskfit import annotate, item_kinds, select, visiting_order
from synth.task import Order, PoseSet

__all__ = ["task_kind", "is_sixbar_task", "sixbar_task", "CONDITIONS"]

CONDITIONS = 22  # a cubic 6R motion has 21 degrees of freedom; a task needs at least 22 conditions
POINTS_EXACT = 7  # items of a point task the exact point synthesis takes; more are fitted


def task_kind(ps: PoseSet) -> str:
    """"exact" (four exact poses, no velocity), "hermite" (two exact poses with a full velocity at each) or
    "fit"; InputError when the task does not determine a cubic 6R motion (fewer than 22 conditions)."""
    exact = ps.tolerance is None or bool(np.all(np.asarray(ps.tolerance) == 0))
    vel = np.full((len(ps), 6), np.nan) if ps.velocity is None else np.asarray(ps.velocity, float)
    given = np.isfinite(vel).any(-1)
    if exact and not given.any() and len(ps) == 4:
        return "exact"
    if exact and len(ps) == 2 and np.isfinite(vel).all():
        return "hermite"
    per_item = [3 if k == "point" else 6 for k in item_kinds(ps)]  # a point prescribes its position only
    if sum(per_item) + 5 * int(given.sum()) < CONDITIONS or len(ps) < 2:
        raise InputError(f"{ps.source}: a 6R linkage needs 4 poses (or 2 with a velocity at each, or more to fit), "
                         f"got {len(ps)}" + (f" with {int(given.sum())} velocities" if given.any() else ""))
    return "fit"


def is_sixbar_task(ps: PoseSet) -> bool:
    """Whether a pose set needs `sixbar_task` rather than the classic four-pose scan or, for a task with
    points, the exact point synthesis (up to POINTS_EXACT items, docs/points.md)."""
    if ps.has_points:
        return len(ps) > POINTS_EXACT
    return task_kind(ps) != "exact" or ps.order is Order.LISTED


def sixbar_task(ps: PoseSet, *, top: int | None = 1, best_effort: bool = False,
                check_samples: int = VERIFY_SAMPLES) -> list:
    """The best 6R linkages of a task, best first (at most ``top``), annotated. SynthesisError (with the
    reason) when there is none, none follows a listed order, or the tolerances are not met (unless
    ``best_effort``); InputError when the task does not determine a 6R motion."""
    kind = task_kind(ps)
    n = top or 1
    if kind == "hermite":
        from synth.synthesis.sixbar_hermite import hermite_candidates

        out = hermite_candidates(ps.matrices, ps.velocity, ps.names, top=n, check_samples=check_samples)
        summaries = [FitSummary("hermite", visit=(0, 1))] * len(out)
    elif kind == "fit":
        from synth.synthesis.sixbar_fit import fit_candidates

        out = fit_candidates(ps, top=n)
        summaries = [lk.info.fit_summary for lk in out]
    else:
        from synth.synthesis.sixbar import sixbar_candidates

        out = sixbar_candidates(ps.matrices, ps.names, top=None if ps.order is Order.LISTED else n, build=True,
                                check_samples=check_samples)
        summaries = [FitSummary("exact", visit=visiting_order([r.t for r in lk.poses])) for lk in out]
    for lk, s in zip(out, summaries):
        annotate(lk, ps, s)
    return select(out, ps, top, best_effort, "6R")
