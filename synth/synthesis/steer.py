"""Steering a Bennett or 6R fit into the task's mounting box (docs/drive.md, "Using the freedom the task leaves").

A fit within tolerance leaves freedom: the poses may be missed by up to their tolerances, and the ground
axes (the first factors h1, k1 of the two factorizations of the fitted quadratic C = t^2 + c1 t + c0) move
with the fit. `into_base_box` re-fits the best seeds of `synth.synthesis.bennett_fit.fit_motion` with one
more residual row per ground axis: ``weight * d / tol``, d the distance of the axis from the base box
shrunk by `BOX_INSET` of its smallest half-size on every side (`synth.algebra.geometry.line_box_distance`;
zero inside, so a fit meeting the box trades nothing), tol the task's tightest position tolerance (conditioned
units). It runs for each weight of `WEIGHTS` from the unsteered fit (until every seed meets the box); the refusal and ranking downstream
(`synth.design.constraints.admissible`, `synth.synthesis.taskfit.select`) keep the steered fits that meet
the box and stay within tolerance. Counted work: `ITERATIONS` Jacobians per weight.

A 6R fit (`synth.synthesis.sixbar_fit.fit_cubics`) steers the loop pair (of its six factorizations) whose
farther ground axis is nearest the box. Point tasks (`synth.synthesis.points.point_candidates` with
``base_box``) rank the scanned members whose ground axes meet the box first (`ground_box_distance`), from
a scan `BOX_SCAN` times as large.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.algorithm1 import algorithm1, norm_roots, quadratics
from synth.algebra.dq import factor_lines
from synth.algebra.geometry import cross, line_box_distance
from synth.algebra.polynomial import norm_poly
from synth.synthesis.fit import LMResult, levenberg_marquardt
from synth.task import Box

__all__ = ["ground_axes", "into_base_box", "conditioned_box", "ground_box_distance", "WEIGHTS", "BOX_INSET"]

WEIGHTS = (1.0, 10.0, 100.0)  # penalty weights tried, each from the unsteered fit
BOX_INSET = 0.1  # the penalty's box: the base box shrunk by this fraction of its smallest half-size
FD_STEP = 1e-7  # forward-difference step of the penalty rows in the coefficients (conditioned units)
ITERATIONS = 40  # Jacobians per steered refinement, at most
BOX_SCAN = 4  # point tasks with a base box: this many times the default scan
_ORDERS = np.array([[0, 1], [1, 0]])  # the two factorizations: their first factors are the ground axes


def ground_axes(coef, orders=_ORDERS):
    """(points (..., F, 3), directions (..., F, 3)) of the first factors of the factorizations ``orders``
    (F, n) (quadratic indices left to right; default: the two of a Bennett motion) of the monic motions with
    coefficients ``coef`` (..., n, 8) (c_0 .. c_{n-1}; conditioned frame): the possible ground axes of their
    linkages (a Bennett linkage's h1, k1). Unit directions; NaN where C does not factor."""
    coef = np.asarray(coef, float)
    C = np.concatenate([coef, np.broadcast_to(np.eye(8)[0], coef.shape[:-2] + (1, 8))], -2)
    with np.errstate(all="ignore"):
        z = norm_roots(norm_poly(C))
        H, ok = algorithm1(C[..., None, :, :], quadratics(z)[..., np.asarray(orders), :])  # (..., F, n, 8)
        lines, _ = factor_lines(H[..., 0, :])  # (..., F, 2, 3): direction, moment
    u, m = lines[..., 0, :], lines[..., 1, :]
    bad = (~ok | ~np.isfinite(lines).all((-1, -2)))[..., None]
    return np.where(bad, np.nan, cross(u, m)), np.where(bad, np.nan, u)


def _loop_distances(p, u, pairs, box: Box) -> np.ndarray:
    """(..., 2) the distances from ``box`` of the two ground axes of the loop (a pair of factorizations,
    ``pairs`` (P, 2)) whose farther ground axis is nearest, from the first factors' points and directions
    ``p``, ``u`` (..., F, 3); 1e3 for axes that do not exist."""
    d = _axis_distances(p, u, box, 1e3)
    dh, dk = d[..., pairs[:, 0]], d[..., pairs[:, 1]]
    best = np.argmin(np.maximum(dh, dk), axis=-1)[..., None]
    return np.concatenate([np.take_along_axis(dh, best, -1), np.take_along_axis(dk, best, -1)], -1)


def conditioned_box(box: Box, cond, inset: float = 0.0) -> Box:
    """The box (world, metres) in the conditioned frame of ``cond`` (`synth.synthesis.conic.Conditioning`),
    shrunk by ``inset`` times its smallest half-size on every side."""
    lo = (np.asarray(box.lo, float) - cond.centre) / cond.scale
    hi = (np.asarray(box.hi, float) - cond.centre) / cond.scale
    pad = inset * float(np.min(hi - lo)) / 2
    return Box(lo + pad, hi - pad)


def _axis_distances(p, u, box: Box, missing: float) -> np.ndarray:
    """(...) the distances from ``box`` of the lines through ``p`` along ``u`` (..., 3); ``missing`` where
    they are not finite."""
    good = np.isfinite(u).all(-1) & np.isfinite(p).all(-1)
    with np.errstate(all="ignore"):
        d = line_box_distance(np.where(good[..., None], p, 0.0), np.where(good[..., None], u, 1.0), box)
    return np.where(good, d, missing)


def ground_box_distance(H, pairs, box: Box) -> np.ndarray:
    """(S, P) the larger distance from ``box`` of the two ground axes (first factors) of each loop: factors
    H (S, orders, n, 8) by order, loops ``pairs`` (P, 2) (the orders of branches h and k), as in
    `synth.synthesis.pointfit.PointScan`; NaN factors give inf."""
    with np.errstate(all="ignore"):
        lines, _ = factor_lines(H[:, :, 0])  # (S, orders, 2, 3)
    u, m = lines[..., 0, :], lines[..., 1, :]
    d = _axis_distances(cross(u, m), u, box, np.inf)
    return np.maximum(d[:, pairs[:, 0]], d[:, pairs[:, 1]])


def _motion_model(model):
    """The `synth.synthesis.fit.MotionModel` of ``model`` (a wrapper, e.g. `synth.synthesis.fit_order.ListedOrder`,
    keeps it as ``.model``)."""
    while not hasattr(model, "layout"):
        model = model.model
    return model


class _Penalized:
    """A motion-fit model (`synth.synthesis.fit.MotionModel`) with the ground axes' box distances as two
    more residual rows (``weight`` / ``tol`` each), their derivatives by forward differences."""

    def __init__(self, model, box: Box, weight: float, orders, pairs):
        self.model, self.box, self.scale, self.orders, self.pairs = model, box, weight, orders, pairs
        self.n = _motion_model(model).layout.n
        self.columns = 8 * self.n

    def _penalty(self, x):
        coef = x[..., :self.columns].reshape(x.shape[:-1] + (self.n, 8))
        p, u = ground_axes(coef, self.orders)
        return _loop_distances(p, u, self.pairs, self.box) * self.scale

    def rows(self, x):
        r, c = self.model.rows(x)
        return np.concatenate([r, self._penalty(x)], -1), c

    def constraints(self, x):
        return self.model.constraints(x)

    def jacobians(self, x):
        jac = self.model.jacobians(x)
        p = self._penalty(x)
        k = self.columns
        steps = x[:, None, :] + FD_STEP * np.eye(x.shape[-1])[:k]  # (S, k, P)
        dp = (self._penalty(steps) - p[:, None, :]) / FD_STEP  # (S, k, 2)
        Jp = np.zeros((x.shape[0], 2, jac.item_g.shape[-1]))
        Jp[:, :, :k] = np.swapaxes(dp, 1, 2)
        return jac.with_rows(p, Jp)


def into_base_box(model, res: LMResult, fixed, box: Box, cond, orders=_ORDERS,
                  pairs=np.array([[0, 1]])) -> tuple[LMResult, np.ndarray]:
    """Steered re-fits of the refined seeds ``res`` (of ``model``, columns ``fixed``) towards the base box
    (world frame, metres; ``cond`` the fit's `synth.synthesis.conic.Conditioning`), one batch per weight
    of `WEIGHTS`: (the results (W S seeds; cost and violation of the unpenalized ``model``), the seed
    index of each). ``orders`` (F, n), ``pairs`` (P, 2): the factorizations and the loops built of them
    (default: Bennett's; 6R: `synth.synthesis.cubic.PERMS`, ``PAIRS``): the loop whose ground axes are
    nearest the box is steered."""
    shrunk = conditioned_box(box, cond, BOX_INSET)
    w = _motion_model(model).task.weight[:, :3]
    tol = 1.0 / w.max() if (w > 0).any() else 1e-3  # the tightest position tolerance (conditioned)
    xs, cost, viol, its = [], [], [], 0
    for weight in WEIGHTS:
        penalized = _Penalized(model, shrunk, weight / tol, orders, pairs)
        out = levenberg_marquardt(penalized, res.x, fixed, ITERATIONS)
        r, c = model.rows(out.x)
        xs.append(out.x)
        cost.append((r * r).sum(-1))
        viol.append(np.abs(c).max(-1, initial=0.0))
        its += out.iterations
        if not penalized._penalty(out.x).any():  # every seed in the box: larger weights change nothing
            break
    seeds = np.tile(np.arange(len(res.x)), len(xs))
    return LMResult(np.concatenate(xs), np.concatenate(cost), np.concatenate(viol), its), seeds

