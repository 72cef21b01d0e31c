"""Bennett linkages for real tasks (docs/fit.md): any number of poses with tolerances, exact poses,
velocities and an order.

* 3 poses (no velocity): the exact synthesis (`synth.synthesis.bennett`), whatever the tolerances.
* 2 poses with a velocity (tool twist) at one of them: Hermite interpolation, exact: the conic in the
  plane of the kinematic image space spanned by the two poses and the tangent (twist times pose), met by
  the Study quadric (`hermite_conic`).
* more: a fit (`synth.synthesis.fit`): seeds from the exact conics through triples of poses (all, or a
  deterministic sample) and from Hermite pairs, each item projected onto each seed motion, the best
  seeds refined together by Levenberg-Marquardt with the Study condition, exact poses and velocities as
  equality constraints; the best refined motion (in the listed order when asked) is factored into the
  linkage as in exact synthesis.

Every item's miss is then measured on the linkage itself (the tool frame at the recorded joint angles)
and stored in its `PoseRecord` (``error``, ``tolerance``, ``exact``) and in ``info["fit"]``.
"""
from __future__ import annotations

import itertools

import numpy as np

from synth.algebra.dq import dq_inv, dq_to_pose, dq_translation, normalize_dq, pose_to_dq
from synth.blas import one_blas_thread
from synth.checks import VERIFY_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett_core import ACCEPT_TOL
from synth.synthesis.conditioning import transmission_problem
from synth.synthesis.conic import Conditioning, condition, conic, relative_displacements_dq
from synth.synthesis.fit import (ERRORS, Layout, MotionModel, homogeneous, levenberg_marquardt,
                                 task_arrays, _mul)
from synth.synthesis.taskfit import FitSummary, annotate, item_kinds, select, visiting_order
from synth.task import Order, PoseSet

__all__ = ["bennett_task", "is_task", "hermite_conic", "regauge", "fit_motion", "MAX_TRIPLES", "KEEP", "GRID"]

MAX_TRIPLES = 60  # seeds from triples of poses: all when there are at most this many, else a sample
GRID = 48  # parameter samples per seed motion for projecting the items onto it
KEEP = 4  # seeds refined by Levenberg-Marquardt
ITERATIONS = 40  # Jacobians per refinement, at most
EXACT_WEIGHT = 1e3  # weight of exact rows when ranking seeds (conditioned units)
FEASIBLE = 1e-10  # largest constraint violation of an accepted fit (conditioned units)
DEGREE = 2


# ------------------------------------------------------------------ gauge
def gauge_matrix(phi) -> np.ndarray:
    """M (..., 2, 2) mapping the homogeneous parameters (1, 0), (0, 1), (1, 1) to those of the items with
    angles ``phi`` (..., 3) (up to scale): the reparametrization putting them at t = inf, 0, 1."""
    w = np.stack([np.cos(phi), np.sin(phi)], -2)  # (..., 2, 3) columns
    det = w[..., 0, 0] * w[..., 1, 1] - w[..., 0, 1] * w[..., 1, 0]  # 0: two items at one point (NaN out)
    with np.errstate(all="ignore"):
        alpha = (w[..., 0, 2] * w[..., 1, 1] - w[..., 1, 2] * w[..., 0, 1]) / det
        beta = (w[..., 0, 0] * w[..., 1, 2] - w[..., 1, 0] * w[..., 0, 2]) / det
    return w[..., :2] * np.stack([alpha, beta], -1)[..., None, :]


GAUGE_ANGLES = np.array([0.0, np.pi / 3, 2 * np.pi / 3])  # where the gauge items are held (t = inf, +-1/sqrt 3)


def _gauge_items(phi) -> np.ndarray:
    """(S, 3): item 0 and the items a third and two thirds along the motion from it (cyclic order of the
    angles phi (S, N) on the projective line), which `fit_motion` holds at GAUGE_ANGLES (spread evenly,
    for well-conditioned coefficients)."""
    N = phi.shape[1]
    order = np.argsort(np.mod(phi - phi[:, :1], np.pi), axis=1, kind="stable")
    return np.stack([order[:, 0], order[:, max(1, N // 3)], order[:, max(2, (2 * N) // 3)]], 1)


def regauge(coef, ref, phi, M):
    """The same motion in the parameter t' with homogeneous (u, v) = M (u', v'): coefficients (..., n, 8)
    of the monic C'(t') = C(M(t')) lead^-1, reference lead Q and the items' new angles (..., N)."""
    n = coef.shape[-2]
    psi = (np.arange(n + 1) + 0.5) * (np.pi / (n + 1))
    uv = M @ np.stack([np.cos(psi), np.sin(psi)])  # (..., 2, n+1)
    rho, theta = np.hypot(uv[..., 0, :], uv[..., 1, :]), np.arctan2(uv[..., 1, :], uv[..., 0, :])
    values = homogeneous(coef, theta) * (rho ** n)[..., None]  # (..., n+1, 8)
    k = np.arange(n + 1)
    basis = np.cos(psi)[:, None] ** k * np.sin(psi)[:, None] ** (n - k)
    full = np.linalg.solve(basis, values)  # (..., n+1, 8): coefficients of C(M(.))
    lead = full[..., n, :]
    inv = dq_inv(lead)
    new = _mul(full[..., :n, :], inv[..., None, :])
    new_ref = normalize_dq(_mul(lead, ref))
    w = _inv2(M) @ np.stack([np.cos(phi), np.sin(phi)], -2)
    return new, new_ref, np.mod(np.arctan2(w[..., 1, :], w[..., 0, :]), np.pi)


def _inv2(M):
    """Inverses of 2x2 matrices (..., 2, 2) (NaN for singular ones)."""
    det = M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
    adj = np.stack([np.stack([M[..., 1, 1], -M[..., 0, 1]], -1), np.stack([-M[..., 1, 0], M[..., 0, 0]], -1)], -2)
    with np.errstate(all="ignore"):
        return adj / det[..., None, None]


# ------------------------------------------------------------------ seeds
def hermite_conic(Qa, Qb, twist):
    """The monic conic C (3, 8) with C(inf) = 1 (the pose Qa), C(0) ~ Qb Qa~ and tangent ``twist`` at t = inf
    (conditioned frame; twist (6,) = [w, velocity of the body point at the origin]): C = t^2 + (mu + xi) t
    + nu D_b, mu and nu from the Study condition. SynthesisError when no such conic is a motion."""
    D = relative_displacements_dq(np.stack([Qa, Qb]))[1]
    xi = np.zeros(8)
    xi[1:4], xi[5:8] = twist[:3], -np.asarray(twist[3:])
    if abs(D[4]) < 1e-12:
        raise SynthesisError("the two poses differ by a pure rotation or translation (zero pitch): no Bennett "
                             "motion passes through them with the given velocity")
    nu = -(xi[:4] @ xi[4:]) / D[4]
    mu = -(xi[:4] @ D[4:] + D[:4] @ xi[4:]) / D[4]
    if abs(nu) < 1e-12:
        raise SynthesisError("the prescribed velocity is a pure rotation or translation (zero pitch): the conic "
                             "through the two poses with this tangent degenerates; no Bennett linkage")
    C = np.zeros((3, 8))
    C[2, 0] = 1.0
    C[1] = xi
    C[1, 0] += mu
    C[0] = nu * D
    return C


def _triples(task_kinds, exact_items, n: int) -> np.ndarray:
    """Triples of pose items (k, 3): all when there are at most MAX_TRIPLES, else those among the exact
    poses first, then a deterministic sample (seeded generator)."""
    poses = [i for i, k in enumerate(task_kinds) if k != "point"]
    allt = list(itertools.combinations(poses, 3))
    if len(allt) <= MAX_TRIPLES:
        return np.array(allt, int).reshape(-1, 3)
    ex = [i for i in poses if i in exact_items]
    first = list(itertools.combinations(ex, 3))[: MAX_TRIPLES // 2]
    rng = np.random.default_rng(0)
    pick = rng.choice(len(allt), size=MAX_TRIPLES - len(first), replace=False)
    return np.array(first + [allt[i] for i in sorted(pick)], int).reshape(-1, 3)


def _seeds(Q, task, kinds, velocity_twists):
    """Seed motions (coef (S, 2, 8), reference (S, 8)): conics through triples and Hermite conics."""
    exact_items = set(np.nonzero(task.exact[:, :ERRORS].all(1))[0].tolist())
    tri = _triples(kinds, exact_items, len(Q))
    coefs, refs = [], []
    if len(tri):
        with np.errstate(all="ignore"):
            C = conic(relative_displacements_dq(Q[tri])).C  # (k, 3, 8)
        coefs.append(C[:, :2])
        refs.append(Q[tri[:, 0]])
    for a, tw in velocity_twists.items():
        for b in range(len(Q)):
            if b != a and kinds[b] != "point":
                try:
                    coefs.append(hermite_conic(Q[a], Q[b], tw)[None, :2])
                    refs.append(Q[a][None])
                except SynthesisError:
                    pass
    if not coefs:
        raise SynthesisError("no seed motion: a Bennett fit needs three poses, or two with a velocity")
    coef, ref = np.concatenate(coefs), np.concatenate(refs)
    ok = np.isfinite(coef).all((1, 2))
    return coef[ok], ref[ok]


def _project(coef, ref, task):
    """Each item's angle phi (S, N) on each seed motion: the nearest of GRID samples, by the weighted
    squared position and angle misses (exact components weighted EXACT_WEIGHT; angles 8 (1 - |p . q|))."""
    grid = (np.arange(GRID) + 0.5) * (np.pi / GRID)
    with np.errstate(all="ignore"):
        P = normalize_dq(_mul(homogeneous(coef, np.broadcast_to(grid, (len(coef), GRID))), ref[:, None]))
        x = dq_translation(P)  # (S, G, 3)
    w = task.weight[:, [0, 3]] + EXACT_WEIGHT * task.exact[:, [0, 3]]  # (N, 2): position, angle
    d2 = ((x[:, :, None, :] - task.X) ** 2).sum(-1) * w[:, 0] ** 2
    cos = np.abs(P[..., :4] @ task.Q[:, :4].T)  # |p . q|: (S, G, N)
    d2 = d2 + 8.0 * (1.0 - np.minimum(cos, 1.0)) * w[:, 1] ** 2
    return grid[np.argmin(np.nan_to_num(d2, nan=np.inf), axis=1)]


# ------------------------------------------------------------------ the fit
def fit_motion(ps: PoseSet):
    """The refined motions of a task (at least three items): (coef (K, 2, 8), reference (K, 8), phi (K, N),
    cost (K,), violation (K,), cond, summary) in the conditioned frame, best first; item 0 at phi = 0
    (t = inf), items 1, 2 at t = 0, 1."""
    T = np.asarray(ps.matrices, float)
    Tc, cond = condition(T)
    Q = pose_to_dq(Tc)
    task = task_arrays(Q, Tc[:, :3, 3], ps.tolerance, ps.velocity, float(cond.scale))
    twists = _twists(ps, Tc, float(cond.scale))
    coef, ref = _seeds(Q, task, item_kinds(ps), twists)
    phi = _project(coef, ref, task)
    gauge = _gauge_items(phi)
    with np.errstate(all="ignore"):
        M = gauge_matrix(np.take_along_axis(phi, gauge, 1)) @ _inv2(gauge_matrix(GAUGE_ANGLES))
        coef, ref, phi = regauge(coef, ref, phi, M)
    np.put_along_axis(phi, gauge, GAUGE_ANGLES[None], 1)
    ok = np.isfinite(coef).all((1, 2)) & np.isfinite(ref).all(1) & np.isfinite(phi).all(1)
    if not ok.any():
        raise SynthesisError("every seed motion is degenerate (the items fall on one point of it)")
    coef, ref, phi, gauge = coef[ok], ref[ok], phi[ok], gauge[ok]
    tried = int(ok.sum())
    layout = Layout(DEGREE, len(T), gauge)
    model = MotionModel(layout, task, ref)
    x0 = layout.join(coef, np.zeros((len(coef), 6)), phi)
    with np.errstate(all="ignore"):
        r, c = model.rows(x0)
    merit = np.nan_to_num((r * r).sum(-1) + EXACT_WEIGHT**2 * (c * c).sum(-1), nan=np.inf)
    keep = np.argsort(merit, kind="stable")[:KEEP]
    layout = Layout(DEGREE, len(T), gauge[keep])
    model = MotionModel(layout, task, ref[keep])
    with np.errstate(all="ignore"), one_blas_thread():
        res = levenberg_marquardt(model, x0[keep], layout.fixed, ITERATIONS)
    coef, x_ref, phi = layout.split(res.x)
    from synth.synthesis.fit import reference_pose

    refs = normalize_dq(reference_pose(ref[keep], x_ref))
    order = np.lexsort((res.cost, ~(res.violation <= FEASIBLE)))
    summary = FitSummary("fit", seeds=tried, refined=len(keep), iterations=res.iterations)
    return coef[order], refs[order], np.mod(phi[order], np.pi), res.cost[order], res.violation[order], cond, summary


def _twists(ps: PoseSet, Tc, scale: float) -> dict:
    """{item: twist (6,) [w, velocity of the body point at the origin]} (conditioned) of items with a full
    prescribed velocity."""
    out = {}
    if ps.velocity is None:
        return out
    for i, v in enumerate(np.asarray(ps.velocity, float)):
        if np.isnan(v).any():
            continue
        w, lin = v[:3], v[3:] / scale
        out[i] = np.concatenate([w, lin - np.cross(w, Tc[i, :3, 3])])
    return out


# ------------------------------------------------------------------ linkages
def linkage_of(coef, ref, phi, cond: Conditioning, ps: PoseSet, info: dict):
    """The Bennett linkage of a motion in the conditioned frame: C (coefficients (2, 8), monic), reference
    pose ``ref`` (8,) at t = inf (item 0, phi = 0) and the items' angles ``phi`` (N,) (t = cot phi)."""
    from synth.synthesis.bennett import factor_conic
    from synth.synthesis.conic import to_world

    C = np.concatenate([coef, np.eye(8)[:1]])
    H, K, Cw, residual = factor_conic(C, cond)
    with np.errstate(divide="ignore"):
        ts = np.cos(phi) / np.sin(phi)
    ts[0] = np.inf
    ts[phi == np.pi / 2] = 0.0  # (cos(pi/2) is not 0 in floating point)
    Tref = dq_to_pose(ref)
    Tref[:3, 3] = Tref[:3, 3] * cond.scale + cond.centre
    lk = two_branch_linkage("bennett", H, K, Cw, ps.matrices, ps.names, ts,
                            {**info, "factorization_residual": residual,
                             "conditioning": {"centre": np.asarray(cond.centre).tolist(), "scale": float(cond.scale)}})
    lk.tool_ref = Tref
    del to_world
    return lk


def check_fitted(linkage) -> None:
    """SynthesisError when the fitted linkage does not close (relative error above ACCEPT_TOL over
    VERIFY_SAMPLES parameters) or transmits badly (`synth.synthesis.conditioning.transmission_problem`)."""
    why = transmission_problem(linkage)
    if why:
        raise SynthesisError(why)
    checks = self_check(linkage, VERIFY_SAMPLES)
    size = linkage.extent()
    rel = max(checks["max_closure_translation_error"] / size, checks["max_closure_rotation_error"])
    if not rel <= ACCEPT_TOL:
        raise SynthesisError(f"the fitted linkage does not close to double precision (relative error {rel:.1e})")
    linkage.checks = checks


def is_task(ps: PoseSet) -> bool:
    """Whether a pose set needs `bennett_task` rather than the classic three-pose synthesis: tolerances,
    velocities, a listed order or a count other than three poses."""
    return (ps.tolerance is not None or ps.velocity is not None or ps.order is Order.LISTED or len(ps) != 3
            or ps.has_points)


def bennett_task(ps: PoseSet, top: int = 1, best_effort: bool = False) -> list:
    """Bennett linkages for a task (`synth.task.PoseSet`), best first (up to ``top``): exact for 3 poses
    or a Hermite pair, fitted for more (module docstring). Each has its items' misses recorded
    (`annotate`). SynthesisError when nothing meets the exact items and velocities, none follows the
    listed order, or (unless ``best_effort``) the best misses a tolerance (`tolerance_problem` names the
    items); InputError for a task that does not determine a Bennett motion."""
    kinds = item_kinds(ps)
    n_poses = sum(k != "point" for k in kinds)
    twists = ps.velocity is not None and np.any(~np.isnan(ps.velocity))
    if len(ps) == 3 and n_poses == 3 and not twists:
        from synth.synthesis.bennett import bennett_candidates

        out = bennett_candidates(ps.matrices, ps.names, top=top)
        summary = FitSummary("exact", visit=visiting_order([r.t for r in out[0].poses]))
        candidates = out
    elif len(ps) == 2 and n_poses == 2 and twists:
        candidates, summary = [_hermite(ps)], None
    elif len(ps) >= 3 and n_poses >= 3 or (n_poses >= 2 and twists and len(ps) >= 3):
        candidates, summary = _fitted(ps, top), None
    else:
        got = f"{n_poses} poses" + (f" and {len(ps) - n_poses} points" if len(ps) > n_poses else "")
        raise InputError(f"{ps.source}: a Bennett linkage needs 3 or more poses, or 2 poses with a velocity at "
                         f"one of them, got {got}")
    results = []
    for lk in candidates:
        s = summary or lk.info.pop("_summary")
        if s.method == "exact":
            from synth.synthesis.bennett import verify

            verify(lk)
        elif s.method == "hermite":
            check_fitted(lk)  # (fits are checked in `_fitted`)
        annotate(lk, ps, s)
        results.append(lk)
    return select(results, ps, top, best_effort, "Bennett")


def _hermite(ps: PoseSet):
    Tc, cond = condition(ps.matrices)
    tw = _twists(ps, Tc, float(cond.scale))
    if len(tw) != 1:
        raise InputError(f"{ps.source}: two poses need a velocity with both 'angular' and 'linear' at exactly one "
                         "of them (Hermite interpolation); give a third pose otherwise")
    (a, twist), = tw.items()
    Q = pose_to_dq(Tc)
    coef = hermite_conic(Q[a], Q[1 - a], twist)[None, :2]
    ref = Q[a][None]
    phi = np.array([[0.0, np.pi / 2]]) if a == 0 else np.array([[np.pi / 2, 0.0]])
    if a == 1:  # item 0 to t = inf, item 1 to t = 0
        M = np.array([[0.0, 1.0], [1.0, 0.0]])
        coef, ref, phi = regauge(coef, ref, phi, M[None])
    summary = FitSummary("hermite", visit=(0, 1))
    lk = linkage_of(coef[0], ref[0], np.array([0.0, np.pi / 2]), cond, ps, {})
    lk.info["_summary"] = summary
    return lk


def _fitted(ps: PoseSet, top: int) -> list:
    coef, ref, phi, cost, violation, cond, summary = fit_motion(ps)
    out, why, taken = [], None, []
    for k in range(len(coef)):
        if any(np.abs(coef[k] - coef[j]).max() <= 1e-6 * (1 + np.abs(coef[j]).max()) for j in taken):
            continue  # the same motion from another seed
        if not violation[k] <= FEASIBLE:
            why = why or (f"the exact poses and velocities cannot all be met by a Bennett motion (best constraint "
                          f"violation {violation[k]:.1e}, relative)")
            continue
        try:
            lk = linkage_of(coef[k], ref[k], phi[k], cond, ps, {})
            check_fitted(lk)
        except SynthesisError as e:
            why = why or str(e)
            continue
        ts = [r.t for r in lk.poses]
        lk.info["_summary"] = FitSummary("fit", summary.seeds, summary.refined, summary.iterations,
                                         visiting_order(ts))
        out.append(lk)
        taken.append(k)
        if len(out) >= top:
            break
    if not out:
        raise SynthesisError(f"{ps.source}: {why or 'no Bennett motion fits the task'}")
    return out
