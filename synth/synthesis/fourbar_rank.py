"""Four-bars from pairs of dyads, judged as a planar designer does (docs/fourbar.md, section 3).

A pair of dyads (crank: fixed pivot A0, moving pivot A1; rocker: B0, B1; A1 and B1 on the coupler) is a
four-bar with ground |A0 B0|, crank r (the crank dyad's radius), coupler |A1 B1| and rocker s. For every
pose the four-bar is placed where its coupler is nearest to the pose (exactly at the pose for an exact
task: the crank angle of the crank dyad's moving pivot there) and is judged on:

* Grashof type: a crank-rocker, the crank the shortest link and s + l < p + q by GRASHOF_MARGIN of the
  longest link, so that the crank (the driver, joint h1) and the crank-coupler joint h2 turn fully;
* branch defect: every pose on the assembly branch of pose 0 (the side of B1 from the diagonal A1 B0);
* order defect (``order: listed``): the crank, turning one way through less than a turn, meets the poses
  in the listed order;
* transmission angle mu (between coupler and rocker) over the task range of the crank: min(mu, 180 - mu)
  at least ``min_transmission``;
* compactness: the largest distance of a pivot from the tool origins' centroid, in pose spreads.

Valid four-bars are ranked by ``cost = log10(extent) + TRANSMISSION_WEIGHT (1 - sin mu_min) + task error``
(the largest pose error over its tolerance, fits only), lowest first, ties by the order of the pairs.
Conditioned plane coordinates (`synth.synthesis.fourbar_plane`), vectorized over pairs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra.fourbar_loop import transmission_angle
from synth.synthesis.fourbar_dyads import Dyads, moving_points
from synth.synthesis.fourbar_plane import PlanarTask

TWO_PI = 2.0 * np.pi
GRASHOF_MARGIN = 0.02  # (p + q) - (s + l) at least this times l: a crank-rocker away from change points
TRANSMISSION_WEIGHT = 2.0
RANGE_SAMPLES = 48  # crank angles over the task range where the transmission angle is evaluated
FIT_SAMPLES = 360  # crank angles per turn where a fitted four-bar's coupler is compared with the poses
FIT_REFINE = 18  # refinements of each pose's crank angle (each: 9 samples over the last step, which shrinks 4-fold)
DISTINCT = 0.05  # two four-bars whose pivots are all closer than this (pose spreads) are one design


@dataclass
class FourBars:
    """N four-bars (conditioned plane coordinates, angles in rad): pivots ``A0, B0`` (N, 2), moving pivots
    ``wa, wb`` (N, 2) in the coupler (at pose 0's plane position), lengths ``ground, crank, coupler,
    rocker`` (N,), ``branch`` (N,) +-1, ``phi`` (N, k) absolute crank angles at the poses, ``error`` (N, k, 2)
    pose errors (position in pose spreads, angle), the judgement (``crank_rocker``, ``branch_ok``,
    ``order_ok``, ``transmission`` (N,) min(mu, pi - mu) over the ``task_range`` (N, 2) of crank rotation
    from pose 0 (start, signed span; NaN when already invalid), ``extent``, ``misfit``: the largest pose
    error over its tolerance), ``valid`` and ``cost`` (N,)."""

    A0: np.ndarray
    B0: np.ndarray
    wa: np.ndarray
    wb: np.ndarray
    ground: np.ndarray
    crank: np.ndarray
    coupler: np.ndarray
    rocker: np.ndarray
    branch: np.ndarray
    phi: np.ndarray
    error: np.ndarray
    crank_rocker: np.ndarray = None
    branch_ok: np.ndarray = None
    order_ok: np.ndarray = None
    transmission: np.ndarray = None
    task_range: np.ndarray = None
    extent: np.ndarray = None
    misfit: np.ndarray = None
    valid: np.ndarray = None
    cost: np.ndarray = None

    def __len__(self) -> int:
        return len(self.A0)

    @property
    def crank_ref(self) -> np.ndarray:
        """Crank angle at pose 0 from the ground line A0 -> B0 (N,)."""
        d = self.B0 - self.A0
        return self.phi[:, 0] - np.arctan2(d[:, 1], d[:, 0])


def _side(P, Q, X) -> np.ndarray:
    """Sign of the turn P -> Q -> X: +1 when X is counter-clockwise of Q seen from P (...)."""
    a, b = Q - P, X - P
    return np.sign(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0])


def pairs(task: PlanarTask, d: Dyads, exact: bool, weights=None) -> FourBars:
    """Every ordered pair (crank i, rocker j != i) of dyads ``d`` with distinct fixed pivots, placed at the
    poses: exactly (the crank dyad's moving pivot, ``exact``) or where the coupler is nearest (a fit, with
    `nearest_crank_angles`' ``weights``)."""
    i, j = np.nonzero(~np.eye(len(d), dtype=bool))
    keep = np.linalg.norm(d.centre[i] - d.centre[j], axis=1) > 1e-6
    i, j = i[keep], j[keep]
    A0, B0, wa, wb = d.centre[i], d.centre[j], d.circle[i], d.circle[j]
    Za, Zb = moving_points(task, wa), moving_points(task, wb)  # (N, k, 2)
    branch = _side(Za[:, 0], B0, Zb[:, 0])
    fb = FourBars(A0, B0, wa, wb, np.linalg.norm(B0 - A0, axis=1), d.radius[i], np.linalg.norm(wb - wa, axis=1),
                  d.radius[j], branch, np.zeros(Za.shape[:2]), np.zeros(Za.shape[:2] + (2,)))
    if exact:
        rel = Za - A0[:, None]
        fb.phi = np.arctan2(rel[..., 1], rel[..., 0])
        fb.branch_ok = np.all(_side(Za, B0[:, None], Zb) == branch[:, None], axis=1) & (branch != 0)
    else:
        fb.phi, fb.error = nearest_crank_angles(task, fb, weights)
        fb.branch_ok = branch != 0
    return fb


def coupler_poses(task: PlanarTask, fb: FourBars, phi, branch=None):
    """Tool origins (N, m, 2) and angles (N, m) of four-bars ``fb`` at absolute crank angles phi (N, m) on
    their assembly branch (NaN where the loop does not close)."""
    br = fb.branch if branch is None else branch
    A1 = fb.A0[:, None] + fb.crank[:, None, None] * np.stack([np.cos(phi), np.sin(phi)], -1)
    dv = fb.B0[:, None] - A1
    L = np.linalg.norm(dv, axis=-1)
    c, s = fb.coupler[:, None], fb.rocker[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_a = (c * c + L * L - s * s) / (2 * c * L)
        psi = np.arctan2(dv[..., 1], dv[..., 0]) + br[:, None] * np.arccos(np.where(np.abs(cos_a) <= 1, cos_a, np.nan))
    e = fb.wb - fb.wa
    beta = psi - np.arctan2(e[:, 1], e[:, 0])[:, None]  # coupler rotation from pose 0's plane position
    cb, sb = np.cos(beta), np.sin(beta)
    wa = fb.wa[:, None]
    tool = A1 - np.stack([cb * wa[..., 0] - sb * wa[..., 1], sb * wa[..., 0] + cb * wa[..., 1]], -1)
    return tool, beta


def _pose_misfit(task, tool, beta, weights):
    """Weighted squared pose error (N, m, k) of coupler poses (tool (N, m, 2), beta (N, m)) against every pose;
    weights (k, 2): 1 / tolerance of position (pose spreads) and angle."""
    dp = np.linalg.norm(tool[:, :, None] - task.qc, axis=-1)
    da = np.abs(np.angle(np.exp(1j * (beta[:, :, None] - task.theta))))
    return (dp * weights[:, 0]) ** 2 + (da * weights[:, 1]) ** 2, dp, da


def nearest_crank_angles(task: PlanarTask, fb: FourBars, weights=None):
    """For every four-bar and pose the crank angle (N, k) where the coupler is nearest the pose (weighted
    position and angle error; ``weights`` (k, 2), default 1 per pose spread and 1 per radian) and that error
    (N, k, 2): sampled over a turn, then refined around the best sample (counted work)."""
    k = len(task.theta)
    wts = np.ones((k, 2)) if weights is None else np.asarray(weights, float)
    phi = np.broadcast_to(np.linspace(0, TWO_PI, FIT_SAMPLES, endpoint=False), (len(fb), FIT_SAMPLES))
    cost, _, _ = _pose_misfit(task, *coupler_poses(task, fb, phi), wts)
    best = phi[np.arange(len(fb))[:, None], np.argmin(np.nan_to_num(cost, nan=np.inf), axis=1)]  # (N, k)
    step = TWO_PI / FIT_SAMPLES
    offsets = np.linspace(-1, 1, 9)
    for _ in range(FIT_REFINE):
        cand = best[:, :, None] + step * offsets  # (N, k, 9)
        tool, beta = coupler_poses(task, fb, cand.reshape(len(fb), -1))
        c, _, _ = _pose_misfit(task, tool, beta, wts)
        c = c.reshape(len(fb), k, 9, k)[:, np.arange(k), :, np.arange(k)].transpose(1, 0, 2)  # own pose
        best = np.take_along_axis(cand, np.argmin(np.nan_to_num(c, nan=np.inf), axis=2)[..., None], 2)[..., 0]
        step /= 4
    tool, beta = coupler_poses(task, fb, best)
    dp = np.linalg.norm(tool - task.qc, axis=-1)
    da = np.abs(np.angle(np.exp(1j * (beta - task.theta))))
    return best, np.stack([dp, da], -1)


def task_ranges(theta, listed: bool):
    """Task range of the crank (N, 2): (start, signed span) of its rotation from pose 0 through every
    pose's rotation ``theta`` (N, k) in [0, 2 pi); listed order: turning one way (the direction whose total
    is below a turn; ``order_ok`` False when neither), else the shortest arc. Returns (range, order_ok)."""
    N, k = theta.shape
    if listed:
        up = np.sum(np.mod(np.diff(theta, axis=1), TWO_PI), axis=1)
        down = np.sum(np.mod(-np.diff(theta, axis=1), TWO_PI), axis=1)
        span = np.where(up < TWO_PI, up, -down)
        ok = (up < TWO_PI) | (down < TWO_PI)
        return np.stack([np.zeros(N), span], -1), ok
    srt = np.sort(theta, axis=1)
    gaps = np.diff(np.concatenate([srt, srt[:, :1] + TWO_PI], axis=1), axis=1)
    g = np.argmax(gaps, axis=1)
    start = srt[np.arange(N), (g + 1) % k]
    return np.stack([start, TWO_PI - gaps[np.arange(N), g]], -1), np.ones(N, bool)


def judge(task: PlanarTask, fb: FourBars, *, listed: bool, min_transmission: float, tolerance=None) -> FourBars:
    """Fill the judgement of four-bars ``fb`` (module docstring): ``min_transmission`` in rad; ``tolerance``
    (k, 2) metres and radians per pose (fits: a pose error above it makes the four-bar invalid)."""
    lengths = np.stack([fb.ground, fb.crank, fb.coupler, fb.rocker], -1)
    srt = np.sort(lengths, axis=1)
    fb.crank_rocker = ((fb.crank <= srt[:, 0]) & (srt[:, 1] > fb.crank)
                       & (srt[:, 1] + srt[:, 2] - srt[:, 0] - srt[:, 3] >= GRASHOF_MARGIN * srt[:, 3]))
    theta = np.mod(fb.phi - fb.phi[:, :1], TWO_PI)
    fb.task_range, fb.order_ok = task_ranges(theta, listed)
    fb.transmission = np.full(len(fb), np.nan)
    m = np.flatnonzero(fb.crank_rocker & fb.branch_ok & fb.order_ok)  # the rest is invalid already
    s = np.linspace(0.0, 1.0, RANGE_SAMPLES)
    rot = np.concatenate([fb.task_range[m, :1] + fb.task_range[m, 1:] * s, theta[m]], axis=1)
    mu = transmission_angle(fb.ground[m, None], fb.crank[m, None], fb.coupler[m, None], fb.rocker[m, None],
                            fb.crank_ref[m, None], rot)
    fb.transmission[m] = np.min(np.minimum(mu, np.pi - mu), axis=1, initial=np.pi)
    piv = np.stack([fb.A0, fb.B0, fb.wa, fb.wb], 1)
    fb.extent = np.max(np.linalg.norm(piv - task.qc.mean(axis=0), axis=-1), axis=1)
    misfit = np.zeros(len(fb))
    within = np.ones(len(fb), bool)
    if tolerance is not None:
        tol = np.asarray(tolerance, float) / np.array([task.scale, 1.0])
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(tol > 0, fb.error / tol, np.where(fb.error > 0, np.inf, 0.0))
        misfit = np.max(ratio, axis=(1, 2), initial=0.0)
        within = misfit <= 1.0
    fb.misfit = misfit
    with np.errstate(invalid="ignore"):
        fb.valid = (fb.crank_rocker & fb.branch_ok & fb.order_ok & (fb.transmission >= min_transmission) & within
                    & np.all(np.isfinite(fb.error), axis=(1, 2)))
    with np.errstate(divide="ignore"):
        fb.cost = (np.log10(np.maximum(fb.extent, 1e-12)) + TRANSMISSION_WEIGHT * (1 - np.sin(fb.transmission))
                   + np.where(np.isfinite(misfit), misfit, 1e9))
    return fb


def best_distinct(fb: FourBars, top: int) -> list[int]:
    """Indices of up to ``top`` valid four-bars, lowest cost first, skipping any whose pivots all lie within
    DISTINCT of an already chosen one (neighbouring samples of one design)."""
    order = np.flatnonzero(fb.valid)
    order = order[np.argsort(fb.cost[order], kind="stable")]
    piv = np.concatenate([fb.A0, fb.B0, fb.wa, fb.wb], axis=1)
    chosen: list[int] = []
    for n in order:
        if all(np.max(np.abs(piv[n] - piv[m])) > DISTINCT for m in chosen):
            chosen.append(int(n))
            if len(chosen) >= top:
                break
    return chosen


def rejection_counts(fb: FourBars, min_transmission: float) -> dict[str, int]:
    """How many of the four-bars fail each criterion (for the refusal message)."""
    return {"not a crank-rocker": int(np.sum(~fb.crank_rocker)), "branch defect": int(np.sum(~fb.branch_ok)),
            "order defect": int(np.sum(~fb.order_ok)),
            f"transmission below {np.degrees(min_transmission):.0f} deg": int(np.sum(fb.transmission < min_transmission)),
            "outside the tolerances": int(np.sum(fb.misfit > 1.0))}
