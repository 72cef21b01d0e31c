"""The 6R side of a task file (`synth.task.PoseSet`): which synthesis answers it, and the linkages.

* four exact poses, no velocities: the exact scan of `synth.synthesis.sixbar` (``kind`` "exact");
* two exact poses with a full velocity at each: Hermite interpolation, exact
  (`synth.synthesis.sixbar_hermite`, ``kind`` "hermite");
* anything else that determines or over-determines the cubic (six conditions per pose, five per
  velocity, at least 22 with tolerances or 24 exact): a fit (`synth.synthesis.sixbar_fit`, ``kind`` "fit").

Every returned linkage carries, per pose, the miss at its recorded joint angles (``PoseRecord.error``,
metres and radians), its ``tolerance`` or ``exact`` (`annotate`), and ``info["fit"]``.
"""
from __future__ import annotations

import numpy as np

from synth.checks import DEFAULT_CHECK_SAMPLES, pose_difference
from synth.errors import InputError
from synth.task import Order, PoseSet

__all__ = ["task_kind", "sixbar_task", "annotate"]

CONDITIONS = 24  # a cubic motion through four exact poses: 4 x 6 conditions


def _tolerance(ps: PoseSet) -> np.ndarray:
    return np.zeros((len(ps), 2)) if ps.tolerance is None else np.asarray(ps.tolerance, float)


def _velocity(ps: PoseSet) -> np.ndarray:
    return np.full((len(ps), 6), np.nan) if ps.velocity is None else np.asarray(ps.velocity, float)


def task_kind(ps: PoseSet) -> str:
    """"exact" (four exact poses), "hermite" (two exact poses with full velocities) or "fit"; InputError
    when the task does not determine a cubic 6R motion (too few conditions)."""
    tol, vel = _tolerance(ps), _velocity(ps)
    exact = bool(np.all(tol == 0))
    given = np.isfinite(vel).any(-1)
    if exact and not given.any() and len(ps) == 4:
        return "exact"
    if exact and len(ps) == 2 and np.isfinite(vel).all():
        return "hermite"
    conditions = 6 * len(ps) + 5 * int(given.sum())
    if conditions < CONDITIONS - (2 if not exact or given.any() else 0) or len(ps) < 2:
        raise InputError(f"{ps.source}: a 6R linkage needs 4 poses (or 2 with a velocity at each, or more to fit), "
                         f"got {len(ps)}" + (f" with {int(given.sum())} velocities" if given.any() else ""))
    return "fit"


def sixbar_task(ps: PoseSet, *, top: int | None = None, best_effort: bool = False,
                check_samples: int = DEFAULT_CHECK_SAMPLES) -> list:
    """The best built and self-checked 6R linkages of a Hermite or fit task, best first (at most ``top``),
    annotated (`annotate`). ``order: listed`` keeps only linkages whose first driver visits the poses in
    the listed order. SynthesisError (with the reason) when there is none."""
    kind = task_kind(ps)
    listed = ps.order == Order.LISTED
    if kind == "hermite":
        from synth.synthesis.sixbar_hermite import hermite_candidates

        out = hermite_candidates(ps.matrices, _velocity(ps), ps.names, top=top, check_samples=check_samples)
    elif kind == "fit":
        from synth.synthesis.sixbar_fit import fit_candidates

        out = fit_candidates(ps.matrices, ps.names, _tolerance(ps), _velocity(ps), listed=listed, top=top,
                             best_effort=best_effort, check_samples=check_samples)
    else:
        raise InputError("four exact poses: use synth.synthesis.sixbar.sixbar_candidates")
    for lk in out:
        annotate(lk, ps)
    return out


def annotate(linkage, ps: PoseSet) -> None:
    """Each pose record's ``error`` (the miss of the target at the recorded joint angles, metres and
    radians), ``tolerance`` (None when exact) and ``exact``."""
    tol = _tolerance(ps)
    reached = np.array([linkage.tool_pose(rec.joint_angles) for rec in linkage.poses])
    dt, dr = pose_difference(reached, ps.matrices)
    for rec, a, b, t in zip(linkage.poses, dt.tolist(), dr.tolist(), tol):
        rec.error = (a, b)
        rec.exact = bool(np.all(t == 0))
        rec.tolerance = None if rec.exact else (float(t[0]), float(t[1]))
    within = all(rec.exact or (rec.error[0] <= rec.tolerance[0] * (1 + 1e-9) + 1e-12 and
                                rec.error[1] <= rec.tolerance[1] * (1 + 1e-9) + 1e-12) for rec in linkage.poses)
    linkage.info.setdefault("fit", {})["within_tolerance"] = within
