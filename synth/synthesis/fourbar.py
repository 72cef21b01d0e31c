"""`mpsynth fourbar`: the classical planar four-bar through 3, 4 or 5 coplanar poses, or fitted to more
(docs/fourbar.md).

`fourbar_candidates` is the one entry point: the plane of the poses (`fourbar_plane`), the dyads by
Burmester theory or least squares (`fourbar_dyads`), every pair of them judged and ranked
(`fourbar_rank`), and the best distinct ones built as self-checked linkages (`fourbar_build`).
"""
from __future__ import annotations

import math

import numpy as np

from synth.checks import VERIFY_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.info import BarLengths, FourBarFigures, FourBarRecord, LinkageInfo
from synth.infoparts import FitSummary
from synth.synthesis.fourbar_build import fourbar_linkage
from synth.synthesis.fourbar_dyads import FIT_GRID, FIT_ITERATIONS, FIT_SEEDS, task_dyads
from synth.synthesis.fourbar_plane import plane_of_motion, with_velocities
from synth.synthesis.fourbar_rank import best_distinct, judge, pairs, rejection_counts
from synth.synthesis.taskfit import annotate, make_task
from synth.task import Order, default_name

MIN_TRANSMISSION_DEG = 40.0  # default lower bound of the transmission angle over the task range
EXACT_TOL = 1e-9  # relative pose and closure error of an exact four-bar (times the pose spread)
MAX_EXACT = 5  # a four-bar passes through at most five general poses


def fourbar_candidates(T, names, *, top: int = 1, min_transmission_deg: float = MIN_TRANSMISSION_DEG,
                       order: Order = Order.ANY, tolerance=None, velocity=None, source: str = "<poses>",
                       check_samples: int = VERIFY_SAMPLES) -> list:
    """Up to ``top`` planar four-bars (`synth.linkage.Linkage`, kind ``planar_fourbar``), best first, whose
    coupler carries the tool through the poses T (k, 4, 4) (metres, k >= 3, coplanar: InputError naming the
    pose otherwise). k <= 5: exactly; more: least squares, within ``tolerance`` (k, 2) (metres, radians;
    0 = exact, inf = free; None = exact). ``order`` LISTED: the crank meets the poses in the listed order.
    With a tolerance, or more than five poses, every pose record carries its miss and tolerance and
    ``info.fit`` the fit's figures (`synth.synthesis.taskfit.annotate`). ``velocity`` (k, 6) [w rad/s, v m/s]
    (NaN rows: none): the coupler's velocity direction at those poses, each a further exact condition
    (Hermite; at most five conditions in all). SynthesisError (with the count of candidates failing each
    criterion) when no four-bar qualifies."""
    T = np.asarray(T, float)
    k = len(T)
    given = 0 if velocity is None else int(np.any(~np.isnan(np.asarray(velocity, float)), axis=1).sum())
    if k + given < 3 or k < 2:
        raise InputError(f"{source}: mpsynth fourbar needs at least 3 poses (or 2 with a velocity), got {k}")
    task = plane_of_motion(T, names, source)
    if given:
        if k + given > MAX_EXACT:
            raise InputError(f"{source}: a four-bar meets at most {MAX_EXACT} conditions exactly (poses, and each "
                             f"velocity counts as one), got {k} poses and {given} velocities; drop velocities to fit "
                             "more poses")
        task = with_velocities(task, velocity, names, source)
    exact = k + given <= MAX_EXACT
    tol = None
    if not exact:
        tol = np.full((k, 2), 0.0) if tolerance is None else np.asarray(tolerance, float).reshape(k, 2)
        tol = np.maximum(tol, EXACT_TOL * np.array([task.scale, 1.0]))  # "exact" in a fit: to machine precision
    wts = None if tol is None else weights(tol, task.scale)
    dyads = task_dyads(task, None if wts is None else wts[:, 0] / max(wts[:, 0].max(), 1e-300))
    listed = order == Order.LISTED
    fb = judge(task, pairs(task, dyads, exact, wts), listed=listed, min_transmission=math.radians(min_transmission_deg),
               tolerance=tol)
    chosen = best_distinct(fb, top)
    if not chosen:
        raise no_fourbar(fb, dyads, k, math.radians(min_transmission_deg), tol is not None and tolerance is None)
    ps = make_task(T, names, tolerance=tolerance, order=order.value) if (tolerance is not None or not exact) else None
    out = []
    for rank, n in enumerate(chosen, start=1):
        info = describe(task, fb, n, dyads.method, rank, len(fb), min_transmission_deg, listed)
        linkage = fourbar_linkage(task, fb, n, T, names, info)
        linkage.checks = self_check(linkage, check_samples)
        accept(linkage, task.scale, exact or tolerance is None)
        if ps is not None:  # each pose's miss, its tolerance, info.fit (`synth.synthesis.taskfit.annotate`)
            summary = FitSummary("exact" if exact else "fit", seeds=0 if exact else len(FIT_GRID) ** 2,
                                 refined=0 if exact else FIT_SEEDS, iterations=0 if exact else FIT_ITERATIONS,
                                 visit=visit_order(fb, n))
            annotate(linkage, ps, summary)
            linkage.info = linkage.info.replace(fit=linkage.info.fit.replace(dyads=dyads.method))
        out.append(linkage)
    return out


def visit_order(fb, n: int) -> tuple:
    """Pose indices in the order the crank of four-bar n meets them from pose 0 on, turning the way of its
    task range."""
    theta = np.mod((fb.phi[n] - fb.phi[n, 0]) * np.sign(fb.task_range[n, 1] or 1.0), 2 * np.pi)
    return tuple(int(i) for i in np.argsort(theta, kind="stable"))


def fourbar(T, names=None, **options):
    """The best planar four-bar through the poses T (k, 4, 4), metres (`fourbar_candidates` with ``top=1``;
    ``options``: its keyword arguments)."""
    names = list(names) if names is not None else [default_name(i) for i in range(len(T))]
    return fourbar_candidates(T, names, top=1, **options)[0]


FOURBAR_RULE = ("crank-rocker (crank shortest, Grashof), no branch defect, no order defect with order: listed, "
                "transmission angle over the task range at least the minimum; then lowest log10(extent) + 2 (1 - "
                "sin(min transmission)) + largest pose error / tolerance")


def weights(tol, scale: float) -> np.ndarray:
    """Per-pose weights (k, 2) of position (per pose spread) and angle: 1 / tolerance, 0 where free."""
    tc = np.asarray(tol, float) / np.array([scale, 1.0])
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(tc), 1.0 / tc, 0.0)


def describe(task, fb, n: int, method: str, rank: int, count: int, min_transmission_deg: float,
             listed: bool) -> LinkageInfo:
    """The info of four-bar n: the plane, the lengths, the designer's figures and the rank."""
    s = task.scale
    lengths = BarLengths(ground=float(fb.ground[n] * s), crank=float(fb.crank[n] * s),
                         coupler=float(fb.coupler[n] * s), rocker=float(fb.rocker[n] * s))
    lo, span = fb.task_range[n]
    figures = FourBarFigures(
        lengths=lengths, grashof="crank-rocker", driver="h1", branch=int(fb.branch[n]),
        transmission_min_deg=float(np.degrees(fb.transmission[n])), min_transmission_deg=float(min_transmission_deg),
        task_range_deg=(float(np.degrees(lo)), float(np.degrees(lo + span))), order="listed" if listed else "any",
        extent=float(fb.extent[n]), cost=float(fb.cost[n]), rank=rank, candidates=int(count),
        valid_candidates=int(np.sum(fb.valid)), dyads=method)
    return LinkageInfo(synthesis=FourBarRecord(plane=task.describe(), fourbar=figures, score_rule=FOURBAR_RULE),
                       warnings=())


def accept(linkage, scale: float, exact: bool) -> None:
    """SynthesisError when the self-check shows an open loop (or, ``exact``, a missed pose) beyond EXACT_TOL
    relative to the pose spread ``scale``."""
    c = linkage.checks
    ext = max(scale, linkage.extent())
    bad = c["max_closure_translation_error"] > EXACT_TOL * ext or c["max_closure_rotation_error"] > EXACT_TOL
    if exact:
        bad |= c["max_pose_translation_error"] > EXACT_TOL * ext or c["max_pose_rotation_error"] > EXACT_TOL
    if bad:
        raise SynthesisError(f"the four-bar's self-check failed (pose error {c['max_pose_error']:.3g}, closure error "
                             f"{c['max_closure_error']:.3g}): the pose set is numerically degenerate")


def no_fourbar(fb, dyads, k: int, min_transmission: float, needs_tolerance: bool) -> SynthesisError:
    """The SynthesisError of a task without a qualifying four-bar: what failed, how often."""
    if len(fb) == 0:
        return SynthesisError(f"the {k} poses have {len(dyads)} dyad(s), too few for a four-bar "
                              "(e.g. fewer than two real Burmester points)")
    counts = ", ".join(f"{v} {what}" for what, v in rejection_counts(fb, min_transmission).items() if v)
    msg = f"none of the {len(fb)} four-bars from {len(dyads)} dyads qualifies ({counts}"
    if needs_tolerance:
        err = np.max(fb.error[..., 0], axis=1)
        msg += (f"; the closest misses a pose by {np.nanmin(err):.3g} pose spreads: {k} poses are met exactly only by "
                "luck, give the task a tolerance")
    return SynthesisError(msg + "); try another --min-transmission or other poses")
