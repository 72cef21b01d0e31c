"""Spatial 6R linkages fitted to over-determined tasks (docs/sixbar_fit.md): five or more poses, each exact or
within a tolerance, optionally with the direction of the tool's velocity, optionally in listed order.

Pipeline (conditioned frame, `synth.synthesis.cubic_fit`): seeds from exact sub-solutions (quadruples
with pose 0, scanned members of both cubic families through each, the other poses placed on them) ->
batched Levenberg-Marquardt over all seeds (`synth.synthesis.fit`, the cubic as three revolute factors so
that the Study condition holds throughout, pose parameters as unknowns, exact poses and velocities as
hard constraints made exact by a final projection) -> the best distinct fits refined further -> every
factorization of each fitted cubic and its 9 loops scored like the exact 6R scan
(`synth.synthesis.sixbar_loops.score_loops`, the pose parameters' separation in place of t3's) -> the
best candidates built (`synth.synthesis.assemble.two_branch_linkage`), self-checked, best first: fits
within every tolerance (and in listed order when asked) first, then the engineering score.

Conventions: pose 0 is at t = inf (all joint angles 0); ``linkage.poses[i].matrix`` is the pose the
linkage reaches (the target itself for exact poses), ``linkage.info["fit"]`` holds the targets' misses.
The poses are visited in the cyclic order of their parameters t_i (every joint angle is monotone in t),
reported as ``info["fit"]["order"]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.dq import dq_to_pose, normalize_dq
from synth.algebra.polynomial import pose_at, product_of_linear
from synth.blas import one_blas_thread
from synth.checks import DEFAULT_CHECK_SAMPLES, pose_difference, self_check
from synth.errors import SynthesisError
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.conic import condition, to_world
from synth.synthesis.cubic import PAIRS, PERMS
from synth.synthesis.cubic_fit import CubicModel, seeds, targets, unpack
from synth.synthesis.cubic_lm import levenberg_marquardt
from synth.synthesis.pointfit import parameter_separation
from synth.synthesis.sixbar import LOOP, checks_pass, loop_dh
from synth.synthesis.sixbar_loops import factor_members, loop_geometry, score_loops, score_warnings

__all__ = ["CubicFit", "fit_cubics", "fit_candidates", "visiting_order", "in_listed_order", "tolerance_failure"]

STAGE1 = 12  # LM iterations on every seed
KEEP_FITS = 6  # distinct best fits refined further
STAGE2 = 200  # LM iterations on those
DISTINCT = 1e-6  # fits closer than this in relative cost and parameters are one fit
MAX_ATTEMPTS = 8  # candidates built and checked before giving up
SLACK = 1e-9  # relative slack on a tolerance (rounding of the world-frame errors)


@dataclass
class CubicFit:
    """One fitted cubic motion: factors H (3, 8) and tool pose X0 (8,) at t = inf (conditioned frame),
    pose parameters ts (n,) (ts[0] = inf), the LM cost, and the world-frame misses of the targets:
    errors (n, 2) [metres, radians], ratio (n,) = the larger error / tolerance (0 for exact poses)."""

    H: np.ndarray
    X0: np.ndarray
    ts: np.ndarray
    cost: float
    errors: np.ndarray
    ratio: np.ndarray
    hard: float

    @property
    def within(self) -> bool:
        return bool(np.all(self.ratio <= 1 + SLACK))


def visiting_order(ts) -> list[int]:
    """The order in which the first driver, turning with increasing t from pose 0 (t = inf), meets the
    poses: 0, then the others by increasing parameter."""
    ts = np.asarray(ts, float)
    return [0] + (np.argsort(ts[1:], kind="stable") + 1).tolist()


def in_listed_order(ts) -> bool:
    """Whether the driver, turning one way through less than a turn from pose 0, meets the poses in the
    listed order: ts[1:] strictly increasing or strictly decreasing."""
    d = np.diff(np.asarray(ts, float)[1:])
    return bool(np.all(d > 0) or np.all(d < 0))


def _errors(T, ts, targets_w, tol):
    """World misses (n, 2) and ratios (n,) of the poses reached (T (n, 4, 4)) against the targets."""
    dt, dr = pose_difference(T, targets_w)
    err = np.stack([dt, dr], -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(tol > 0, err / np.where(tol > 0, tol, 1.0), 0.0)
    ratio = np.where(np.isinf(tol), 0.0, ratio)
    return err, ratio.max(-1)


def fit_cubics(poses, tolerance=None, velocity=None):
    """Fitted cubic motions through world poses (n, 4, 4) (metres) with tolerances (n, 2) [m, rad]
    (0: exact, inf: free; None: all exact) and velocities (n, 6) (NaN rows: none), best cost first.
    Returns (fits, conditioning, stats dict: seeds, quadruples, iterations). SynthesisError when no seed
    exists (every sampled quadruple degenerate or oval)."""
    T = np.asarray(poses, float)
    n = len(T)
    tol = np.zeros((n, 2)) if tolerance is None else np.asarray(tolerance, float)
    Tc, cond = condition(T)
    tg = targets(Tc, float(cond.scale), tol, velocity)
    model = CubicModel(tg)
    with one_blas_thread():
        x0, quads = seeds(tg, Tc)
        if not len(x0):
            raise SynthesisError("no quadruple of the poses (with pose 0) spans a real family of cubic motions "
                                 "(every one is degenerate or oval): no 6R motion to start a fit from")
        first = levenberg_marquardt(model, x0, jac=model.jac, iterations=STAGE1, polish=False)
        best = _distinct(first.x, first.cost + 1e8 * first.hard ** 2, KEEP_FITS)
        res = levenberg_marquardt(model, first.x[best], jac=model.jac, iterations=STAGE2)
    fits = [_fit_of(model, x, c, h, cond, T, tol) for x, c, h in zip(res.x, res.cost, res.hard)]
    fits.sort(key=lambda f: (not f.within, f.cost))
    stats = {"seeds": int(len(x0)), "quadruples": int(quads), "refined": int(len(best)),
             "iterations": int(first.iterations + res.iterations)}
    return fits, cond, stats


def _distinct(x, cost, k):
    """Indices of the k best rows by cost, skipping near duplicates."""
    out = []
    for i in np.argsort(cost, kind="stable").tolist():
        if not np.isfinite(cost[i]):
            continue
        if any(abs(cost[i] - cost[j]) <= DISTINCT * max(cost[j], 1e-30)
               and np.max(np.abs(x[i] - x[j])) < 1e-4 for j in out):
            continue
        out.append(i)
        if len(out) == k:
            break
    return np.array(out or [0], int)


def _fit_of(model, x, cost, hard, cond, T, tol) -> CubicFit:
    H, X0, theta = unpack(x[None], model.tg.n)
    ts = np.tan(theta[0])
    ts[0] = np.inf
    Tw = _reached(H[0], X0[0], ts, cond)
    err, ratio = _errors(Tw, ts, T, tol)
    return CubicFit(H=H[0], X0=X0[0], ts=ts, cost=float(cost), errors=err, ratio=ratio, hard=float(hard))


def _reached(H, X0, ts, cond):
    """World poses (n, 4, 4) reached at the parameters ts by the conditioned model (H, X0)."""
    Cw = to_world(product_of_linear(H), cond)
    ref = _world_pose(X0, cond)
    return pose_at(Cw, ts) @ ref


def _world_pose(X0, cond):
    """World 4x4 of a conditioned pose (dual quaternion)."""
    P = dq_to_pose(normalize_dq(X0))
    P[:3, 3] = P[:3, 3] * cond.scale + cond.centre
    return P


# ============================================================================ candidates and linkages
def _scored(fits):
    """Factor and score every fit's loops (one batch): MemberFactors, parts, valid (F, 9), score (F, 9)."""
    C = np.stack([product_of_linear(f.H) for f in fits])
    with np.errstate(all="ignore"):
        mf = factor_members(C, polish=True)
        im, sep = a1.root_conditioning(mf.roots)
        geo = loop_geometry(mf)
        tsep = np.array([parameter_separation(f.ts[1:]) for f in fits], float)
        finite = np.isfinite(C).all((-2, -1))
        parts, valid, score = score_loops(im, sep, ("parameter_separation", tsep), geo, mf.residual, mf.ok,
                                          finite, PAIRS)
    return mf, parts, valid, score


def fit_candidates(poses, names, tolerance=None, velocity=None, *, listed: bool = False, top: int | None = None,
                   best_effort: bool = False, check_samples: int = DEFAULT_CHECK_SAMPLES):
    """Built, self-checked 6R linkages fitted to the task, best first (within tolerance, listed order when
    ``listed``, then the engineering score), at most ``top``. SynthesisError when no fit meets the
    tolerances (the failing poses and by how much at the best fit; with ``best_effort`` the best fits are
    returned with ``info["fit"]["within_tolerance"] = False``), none is in listed order, or none builds."""
    T = np.asarray(poses, float)
    tol = np.zeros((len(T), 2)) if tolerance is None else np.asarray(tolerance, float)
    fits, cond, stats = fit_cubics(T, tol, velocity)
    usable = [f for f in fits if f.hard <= 1e-9 and np.all(np.isfinite(f.errors))]
    if not usable:
        raise SynthesisError("the fit cannot meet the exact poses and velocities together: no cubic 6R motion "
                             "passes through them (best constraint residual "
                             f"{min(f.hard for f in fits):.2g})")
    if not best_effort and not any(f.within for f in usable):
        raise SynthesisError(tolerance_failure(usable[0], names, tol))
    pool = usable if best_effort else [f for f in usable if f.within]
    if listed:
        ordered = [f for f in pool if in_listed_order(f.ts)]
        if not ordered:
            raise SynthesisError(f"order: listed, but none of the {len(pool)} fitted 6R motions visits the poses in "
                                 f"the listed order (the best visits them as {visiting_order(pool[0].ts)})")
        pool = ordered
    mf, parts, valid, score = _scored(pool)
    rank = [(not pool[i].within, -score[i, k], pool[i].cost, i, k) for i, k in zip(*np.nonzero(valid))]
    if not rank:
        raise SynthesisError("every fitted cubic motion has a nearly real or repeated norm factor or a translation "
                             "factor: no 6R linkage of it (the poses are close to a degenerate configuration)")
    out, tried = [], 0
    for *_, i, k in sorted(rank):
        lk = _build(pool[i], mf, parts, score, i, k, cond, T, names, tol, stats, check_samples)
        tried += 1
        if checks_pass(lk, float(cond.scale)):
            out.append(lk)
            if top and len(out) >= top:
                break
        elif tried >= MAX_ATTEMPTS and not out:
            break
    if not out:
        raise SynthesisError("the fitted 6R candidates do not pass the self-check (poses reached, closure): the "
                             "fit is numerically degenerate")
    return out


def tolerance_failure(fit: CubicFit, names, tol) -> str:
    """One line naming the poses whose tolerance the best fit misses, and by how much."""
    bad = np.nonzero(fit.ratio > 1 + SLACK)[0]
    parts = [f"{i} ({names[i]!r}): {fit.errors[i, 0]:.3g} m / {np.degrees(fit.errors[i, 1]):.3g} deg, "
             f"{fit.ratio[i]:.3g} x its tolerance" for i in bad[:6].tolist()]
    more = f" and {len(bad) - 6} more" if len(bad) > 6 else ""
    return (f"no cubic 6R motion meets the tolerances: at the best fit pose{'s' if len(bad) > 1 else ''} "
            + "; ".join(parts) + more + " (loosen those tolerances, drop those poses, or use --best-effort)")


def _build(fit, mf, parts, score, i, k, cond, T, names, tol, stats, check_samples):
    """The world-frame Linkage of loop pair k of fit i, factors polished, with info["fit"]."""
    C = product_of_linear(fit.H)
    oh, ok_ = PAIRS[k]
    HK, _ = a1.polish(C, np.stack([mf.H[i, oh], mf.H[i, ok_]]))
    res = float(np.max(np.maximum(a1.multiply_back(C, HK), a1.study_violation(HK))))
    W = to_world(np.concatenate([HK[0], HK[1], C]), cond)
    H, K, Cw = W[:3], W[3:6], W[6:]
    ref = _world_pose(fit.X0, cond)
    reached = pose_at(Cw, fit.ts) @ ref
    reached[0] = ref
    exact = np.all(tol == 0, -1)
    reached[exact] = T[exact]  # exact poses: the targets (met to rounding; the self-check measures it)
    err, ratio = _errors(reached, fit.ts, T, tol)
    p = {key: float(v[i, k]) for key, v in parts.items()}
    info = {"task": "fit", "pair": int(k + 1), "score": float(score[i, k]), "score_parts": p,
            "orders": {"h": PERMS[oh].tolist(), "k": PERMS[ok_].tolist()},
            "norm_roots": [[float(z.real), float(z.imag)] for z in mf.roots[i]],
            "factorization_residual": res, "parameters": [None if np.isinf(t) else float(t) for t in fit.ts],
            "conditioning": {"centre": cond.centre.tolist(), "scale": float(cond.scale)},
            "fit": fit_info(err, ratio, tol, names, fit, stats)}
    lk = two_branch_linkage("6r", H, K, Cw, reached, names, fit.ts, info)
    lk.info["dh"] = loop_dh(lk, LOOP)
    lk.info["warnings"] = score_warnings(p, "motion")
    lk.checks = self_check(lk, check_samples)
    return lk


def fit_info(err, ratio, tol, names, fit, stats) -> dict:
    """info["fit"]: method, RMS and max errors of the toleranced poses, per-pose misses, seeds, order."""
    soft = ~np.all(tol == 0, -1)
    e = err[soft] if soft.any() else np.zeros((1, 2))
    return {"method": "cubic motion C = (t-h1)(t-h2)(t-h3) fitted by batched Levenberg-Marquardt from exact "
                      "quadruple sub-solutions (exact poses and velocities as constraints)",
            "rms_error": {"position": float(np.sqrt(np.mean(e[:, 0] ** 2))),
                          "angle": float(np.sqrt(np.mean(e[:, 1] ** 2)))},
            "max_error": {"position": float(e[:, 0].max()), "angle": float(e[:, 1].max())},
            "within_tolerance": bool(np.all(ratio <= 1 + SLACK)),
            "order": visiting_order(fit.ts), "listed_order": in_listed_order(fit.ts),
            "poses": [{"name": nm, "error": {"position": float(a), "angle": float(b)}, "ratio": float(r)}
                      for nm, (a, b), r in zip(names, err.tolist(), ratio.tolist())],
            **stats}
