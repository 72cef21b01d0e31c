"""What a task synthesis achieved, for any kind of linkage (docs/fit.md): each item's miss measured on the
linkage (`annotate`: the tool frame at the recorded joint angles, into the pose records and
``info.fit``), the order in which the first driver visits the items, the summary table and the one-line
refusal when tolerances are not met. Used by the Bennett and 6R task syntheses.
"""
from __future__ import annotations

import math

import numpy as np

from synth.algebra.geometry import pose_difference
from synth.checks import VERIFY_SAMPLES, self_check
import json
from synth.errors import InputError, SynthesisError
from synth.infoparts import FitRecord, FitSummary
from synth.synthesis.bennett_core import ACCEPT_TOL
from synth.synthesis.conditioning import transmission_problem
from synth.task import Order, PoseSet, default_name

__all__ = ["make_task", "check_fitted", "first_built", "annotate", "visits_in_order", "visiting_order", "tolerance_problem",
           "error_rows", "item_kinds", "item_tolerances", "select"]


def visits_in_order(ts) -> bool:
    """Whether parameters ``ts`` (t_0 = inf first) are visited in the listed order by a joint turning one
    way through less than a turn: t_1 < t_2 < ... or t_1 > t_2 > ... (angle laws are monotonic in t)."""
    d = np.diff(np.asarray(ts, float)[1:])
    return bool(np.all(d > 0) or np.all(d < 0))


def visiting_order(ts) -> tuple:
    """Item indices in the order t increases from item 0 (at t = inf) on."""
    rest = np.argsort(np.asarray(ts, float)[1:], kind="stable") + 1
    return (0,) + tuple(int(i) for i in rest)


def annotate(linkage, ps: PoseSet, summary: FitSummary) -> bool:
    """Measure every item's miss on the linkage (tool frame at the recorded joint angles), store it in
    the pose records (``error``, ``tolerance``, ``exact``, ``kind``) and ``info.fit`` (a `FitRecord`). A point's record
    becomes the tool pose reached at its position, and ``linkage.checks`` is then re-measured against
    those records (its pose figures would otherwise compare with an orientation the task left free).
    Returns whether every tolerance is met."""
    kinds = item_kinds(ps)
    tol = np.zeros((len(ps), 2)) if ps.tolerance is None else np.asarray(ps.tolerance, float)
    angles = {j.name: np.array([r.joint_angles[j.name] for r in linkage.poses]) for j in linkage.joints}
    T = linkage.tool_pose(angles)  # (N, 4, 4): every item at once
    dt, dr = pose_difference(T, ps.matrices)
    point = np.array([k == "point" for k in kinds])
    dr = np.where(point, 0.0, dr)
    pos = ps.matrices[:, :3, 3]
    size = max(float(np.sqrt(np.mean(np.sum((pos - pos.mean(0)) ** 2, 1)))), 1e-300)  # the items' spread
    ok = []
    for i, rec in enumerate(linkage.poses):
        rec.kind = kinds[i]
        if point[i]:  # the tool pose reached there, at the given position (docs/points.md)
            rec.matrix = np.array(T[i])
            rec.matrix[:3, 3] = ps.matrices[i, :3, 3]
        rec.error = (float(dt[i]), float(dr[i]))
        exact = bool(tol[i, 0] == 0 and (point[i] or tol[i, 1] == 0))
        rec.exact, rec.tolerance = exact, (None if exact else (float(tol[i, 0]), float(tol[i, 1])))
        lim_t = tol[i, 0] if tol[i, 0] > 0 else 1e-9 * size
        lim_r = tol[i, 1] if tol[i, 1] > 0 else 1e-9
        ok.append(bool(dt[i] <= lim_t * (1 + 1e-9) and dr[i] <= lim_r * (1 + 1e-9)))
    if point.any() and linkage.checks:  # the point records now hold the tool poses reached: check those
        linkage.checks = self_check(linkage, int(linkage.checks.get("samples", VERIFY_SAMPLES)))
    rated = ~np.isinf(tol[:, 0])
    names = [ps.names[i] for i in summary.visit] if summary.visit else None
    fit = FitRecord(
        method=summary.method, seeds=summary.seeds, refined=summary.refined, iterations=summary.iterations,
        order=ps.order.value, visit_order=None if names is None else tuple(names),
        rms_position_error=float(np.sqrt(np.mean(dt[rated] ** 2))) if rated.any() else 0.0,
        max_position_error=float(dt.max()),
        rms_angle_error=float(np.sqrt(np.mean(dr[~point] ** 2))) if (~point).any() else 0.0,
        max_angle_error=float(dr.max()), within_tolerance=bool(all(ok)),
        failing=tuple(i for i, good in enumerate(ok) if not good))
    linkage.info = linkage.info.replace(fit=fit, fit_summary=None)
    return all(ok)


def select(linkages, ps: PoseSet, top: int | None, best_effort: bool, what: str) -> list:
    """The annotated ``linkages`` (best first) that answer the task: with ``order: listed`` only those visiting
    the poses in the listed order, those within every tolerance first, at most ``top``. SynthesisError when
    none follows the listed order, or (unless ``best_effort``) the best misses a tolerance
    (`tolerance_problem`); ``what`` names the linkages ("Bennett", "6R")."""
    if ps.order is Order.LISTED:
        listed = [lk for lk in linkages if visits_in_order([r.t for r in lk.poses])]
        if not listed:
            raise SynthesisError(f"{ps.source}: no {what} linkage found visits the poses in the listed order (the "
                                 f"best visits {', '.join(linkages[0].info.fit.visit_order)})")
        linkages = listed
    linkages = sorted(linkages, key=lambda lk: not lk.info.fit.within_tolerance)
    if not linkages[0].info.fit.within_tolerance and not best_effort:
        raise SynthesisError(f"{ps.source}: {tolerance_problem(linkages[0], ps)}")
    return linkages[:top] if top else linkages


def item_tolerances(ps: PoseSet) -> np.ndarray:
    """(N, 2) [metres, radians] of every item: 0 (exact) without tolerances; a point's angle free (inf)."""
    tol = np.zeros((len(ps), 2)) if ps.tolerance is None else np.array(ps.tolerance, float)
    tol[np.array([k == "point" for k in item_kinds(ps)], bool), 1] = np.inf
    return tol


def item_kinds(ps: PoseSet) -> list[str]:
    """"pose" or "point" for each item of the task."""
    return list(ps.kinds) if ps.kinds else ["pose"] * len(ps)


def error_rows(linkage, ps: PoseSet) -> list[tuple[str, str, str, str]]:
    """The summary table: (item, position error, angle error, tolerance) in the input's units (angles in
    degrees) for every item of an annotated linkage."""
    rows = []
    for i, rec in enumerate(linkage.poses):
        err = rec.error or (0.0, 0.0)
        angle = "-" if rec.kind == "point" else _angle(err[1])
        if rec.exact:
            tol = "exact"
        elif rec.tolerance is None:
            tol = "exact"
        else:
            tol = f"{_length(rec.tolerance[0], ps)} / " + ("-" if rec.kind == "point" else _angle(rec.tolerance[1]))
        rows.append((f"{i} {rec.name}", _length(err[0], ps), angle, tol))
    return rows


def tolerance_problem(linkage, ps: PoseSet) -> str:
    """One line naming the items whose tolerance the linkage misses, by how much (input units)."""
    parts = []
    for i in linkage.info.fit.failing:
        rec = linkage.poses[i]
        tol = (0.0, 0.0) if rec.exact else rec.tolerance
        parts.append(f"{rec.kind} {i} ({json.dumps(rec.name, ensure_ascii=False)}) missed by {_length(rec.error[0], ps)} / {_angle(rec.error[1])} "
                     f"(tolerance {_length(tol[0], ps)} / {_angle(tol[1])})")
    return ("tolerances not met at the best linkage found: " + "; ".join(parts) +
            " (--best-effort writes it anyway)")


def _length(x: float, ps: PoseSet) -> str:
    return "free" if math.isinf(x) else f"{x / ps.length_scale:.4g} {ps.length_unit}"


def _angle(x: float) -> str:
    return "free" if math.isinf(x) else f"{math.degrees(x):.4g} deg"


def make_task(poses, names=None, tolerance=None, velocity=None, order=None) -> PoseSet:
    """A `PoseSet` task from arrays: poses (N, 4, 4) metres, ``tolerance`` (2,) or (N, 2) [metres, radians]
    (0 exact, inf free; None: all exact), ``velocity`` (N, 6) [w rad/s, v m/s] (NaN rows: none), ``order``
    "any" or "listed". InputError on shapes and values."""
    T = np.asarray(poses, float)
    if T.ndim != 3 or T.shape[1:] != (4, 4) or not np.all(np.isfinite(T)):
        raise InputError(f"poses must be a finite array of shape (N, 4, 4), got {T.shape}")
    n = len(T)
    names = list(names) if names is not None else [default_name(i) for i in range(n)]
    tol = None
    if tolerance is not None:
        tol = np.broadcast_to(np.asarray(tolerance, float), (n, 2)).copy()
        if np.isnan(tol).any() or (tol < 0).any():
            raise InputError("tolerance must be >= 0 (inf: free) for every pose")
    vel = None
    if velocity is not None:
        vel = np.asarray(velocity, float).reshape(n, 6)
    try:
        order = Order(order or "any")
    except ValueError:
        raise InputError(f"order must be 'any' or 'listed', got {order!r}") from None
    return PoseSet(names=names, matrices=T, tolerance=tol, velocity=vel, order=order, named=[True] * n)


def check_fitted(linkage) -> None:
    """SynthesisError when the fitted linkage does not close (relative error above ACCEPT_TOL over
    VERIFY_SAMPLES parameters) or transmits badly (`synth.synthesis.conditioning.transmission_problem`)."""
    why = transmission_problem(linkage)
    if why:
        raise SynthesisError(why)
    checks = self_check(linkage, VERIFY_SAMPLES)
    rel = max(checks["max_closure_translation_error"] / checks["length_scale"], checks["max_closure_rotation_error"])
    if not rel <= ACCEPT_TOL:
        raise SynthesisError(f"the fitted linkage does not close to double precision (relative error {rel:.1e})")
    linkage.checks = checks


def first_built(candidates, build, top: int, skip=None) -> tuple[list, str | None]:
    """The first ``top`` checked linkages of ``candidates`` (best first), for the task fits: ``build(c)`` makes
    a candidate's linkage (a SynthesisError refuses it), `check_fitted` checks it; ``skip(c, kept)`` (optional,
    given the candidates built so far) passes over one before building it: None builds it, "" passes over
    silently, any other text is the reason. Returns (the linkages, the first reason a candidate was refused or
    None)."""
    out, kept, why = [], [], None
    for cand in candidates:
        reason = skip(cand, kept) if skip is not None else None
        if reason is not None:
            why = why or reason or None
            continue
        try:
            lk = build(cand)
            check_fitted(lk)
        except SynthesisError as e:
            why = why or str(e)
            continue
        out.append(lk)
        kept.append(cand)
        if len(out) >= top:
            break
    return out, why
