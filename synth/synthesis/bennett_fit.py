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
and stored in its `PoseRecord` (``error``, ``tolerance``, ``exact``) and in ``info.fit``.
"""
from __future__ import annotations

import itertools

import numpy as np

from synth.algebra.dq import dq_to_pose, dq_translation, normalize_dq, pose_to_dq
from synth.blas import one_blas_thread
from synth.checks import VERIFY_SAMPLES
from synth.errors import InputError, SynthesisError
from synth.info import Factorization, LinkageInfo
from synth.infoparts import FitSummary
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.conic import Conditioning, condition, conic, relative_displacements_dq
from synth.synthesis.fit import (ERRORS, Layout, LMResult, MotionModel, levenberg_marquardt, rank_seeds, reference_pose,
                                 sample_combinations, task_arrays)
from synth.synthesis.fit_seeds import EXACT_WEIGHT, GRID, nearest, regauge, to_gauge, zoom
from synth.synthesis.pointfit import subset_motions
from synth.synthesis.fit_order import ListedOrder, directions, project_listed
from synth.synthesis.taskfit import annotate, check_fitted, first_built, item_kinds, item_tolerances, select, visiting_order
from synth.task import Order, PoseSet

__all__ = ["bennett_task", "is_task", "hermite_conic", "fit_motion", "linkage_of", "MAX_TRIPLES", "KEEP"]

POINTS_NEEDED = 5  # positions through which a quadratic motion has two free parameters (docs/points.md)
MAX_SUBSETS = 40  # seeds from 5-subsets of the positions of a point task
PARAMETER_SAMPLES = 24  # samples of the two free parameters per subset
MAX_TRIPLES = 60  # seeds from triples of poses: all when there are at most this many, else a sample
ROUNDS = 3  # batches of KEEP seeds refined at most, the next only when no refined seed meets the exact rows
KEEP = 4  # seeds refined by Levenberg-Marquardt
PRESCORED = 16  # seeds with the least summed misses at their grid projections, projected finely and ranked
PRESCORED_POINTS = 96  # the same for point tasks (samples of 5-point families: the pre-score ranks them less well)
ITERATIONS = 40  # Jacobians per refinement, at most
FINISH = 80  # further Jacobians on the best refined seed alone, at most
FEASIBLE = 1e-10  # largest constraint violation of an accepted fit (conditioned units)
DEGREE = 2


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
    ex = [i for i in poses if i in exact_items]
    first = itertools.islice(itertools.combinations(ex, 3), MAX_TRIPLES // 2)
    return np.array(sample_combinations(poses, 3, MAX_TRIPLES, first), int).reshape(-1, 3)


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
    if not len(tri) and len(Q) >= POINTS_NEEDED:  # a point task: no triples of poses
        c, r = subset_motions(dq_translation(Q), DEGREE, MAX_SUBSETS, PARAMETER_SAMPLES)
        coefs.append(c)
        refs.append(r)
    if not coefs:
        raise SynthesisError("no seed motion: a Bennett fit needs three poses, two with a velocity or six points")
    coef, ref = np.concatenate(coefs), np.concatenate(refs)
    ok = np.isfinite(coef).all((1, 2))
    if not ok.any():
        raise SynthesisError("no seed motion: every triple of poses is degenerate (coinciding poses, or poses related "
                             "by pure translations or by rotations about one axis); no Bennett motion fits them")
    return coef[ok], ref[ok]


# ------------------------------------------------------------------ the fit
def fit_motion(ps: PoseSet):
    """The refined motions of a task (at least three items): (coef (K, 2, 8), reference (K, 8), phi (K, N),
    cost (K,), violation (K,), cond, summary) in the conditioned frame, best first; item 0 at phi = 0
    (t = inf), items 1, 2 at t = 0, 1."""
    T = np.asarray(ps.matrices, float)
    Tc, cond = condition(T)
    Q = pose_to_dq(Tc)
    task = task_arrays(Q, Tc[:, :3, 3], item_tolerances(ps), ps.velocity, float(cond.scale))
    twists = _twists(ps, Tc, float(cond.scale))
    coef, ref = _seeds(Q, task, item_kinds(ps), twists)
    listed = ps.order is Order.LISTED
    if listed:  # each seed twice: the items placed in the listed order, either way round
        phi, rows, miss, h = project_listed(coef, ref, task)
        coef, ref, h = coef[rows], ref[rows], h / 2
    else:
        (phi, miss), h = nearest(coef, ref, task), np.pi / GRID
    tried = len(coef)
    keep = PRESCORED if sum(k != "point" for k in item_kinds(ps)) >= 3 else PRESCORED_POINTS
    best = rank_seeds(miss)[:keep]  # the cheap pre-score
    coef, ref = coef[best], ref[best]
    coef, ref, phi, gauge = to_gauge(coef, ref, zoom(coef, ref, task, phi[best], h))
    layout = Layout(DEGREE, len(T), gauge)
    sign = directions(phi)
    model = _model(layout, task, ref, sign if listed else None)
    x0 = layout.join(coef, np.zeros((len(coef), 6)), phi)
    with np.errstate(all="ignore"):
        r, c = model.rows(x0)
    merit = np.nan_to_num((r * r).sum(-1) + EXACT_WEIGHT**2 * (c * c).sum(-1), nan=np.inf)
    ranked = rank_seeds(merit, ~_in_order(phi)) if ps.order is Order.LISTED else rank_seeds(merit)
    positions_only = not (task.weight[:, 3:ERRORS].any() or task.exact[:, 3:].any())
    for start in range(0, min(len(ranked), ROUNDS * KEEP), KEEP):  # (listed order first, when asked for)
        keep = ranked[start:start + KEEP]  # the next seeds, when none of these meets the exact rows
        layout = Layout(DEGREE, len(T), gauge[keep])
        fixed = layout.fixed
        if positions_only:  # the tool's orientation at the reference is free: hold it
            fixed[:, 8 * DEGREE:8 * DEGREE + 3] = True
        with np.errstate(all="ignore"), one_blas_thread():
            res = levenberg_marquardt(_model(layout, task, ref[keep], sign[keep] if listed else None), x0[keep],
                                      fixed, ITERATIONS)
        if (res.violation <= FEASIBLE).any():
            break
    order = rank_seeds(res.cost, ~(res.violation <= FEASIBLE))
    b, more = order[:1], 0  # the finish: the best seed goes on alone (a curved valley can take many short steps)
    if res.iterations >= ITERATIONS:  # (not when every seed converged)
        with np.errstate(all="ignore"), one_blas_thread():
            fin = levenberg_marquardt(_model(Layout(DEGREE, len(T), gauge[keep][b]), task, ref[keep][b],
                                             sign[keep][b] if listed else None), res.x[b], fixed[b], FINISH)
        more = fin.iterations
        if fin.violation[0] <= max(res.violation[b[0]], FEASIBLE) and fin.cost[0] <= res.cost[b[0]]:
            res.x[b], res.cost[b], res.violation[b] = fin.x, fin.cost, fin.violation
    refined = start + len(keep)
    if ps.constraints is not None and ps.constraints.base is not None:  # the ground axes into the box (steer.py)
        from synth.synthesis.steer import into_base_box

        with np.errstate(all="ignore"), one_blas_thread():
            steered, seed = into_base_box(_model(layout, task, ref[keep], sign[keep] if listed else None), res, fixed,
                                          ps.constraints.base, cond)
        res = LMResult(np.concatenate([res.x, steered.x]), np.concatenate([res.cost, steered.cost]),
                       np.concatenate([res.violation, steered.violation]), res.iterations + steered.iterations)
        keep = np.concatenate([keep, keep[seed]])
        order = rank_seeds(res.cost, ~(res.violation <= FEASIBLE))
    coef, x_ref, phi = layout.split(res.x)
    refs = normalize_dq(reference_pose(ref[keep], x_ref))
    summary = FitSummary("fit", seeds=tried, refined=refined, iterations=res.iterations + more)
    return coef[order], refs[order], np.mod(phi[order], np.pi), res.cost[order], res.violation[order], cond, summary


def _model(layout, task, ref, sign):
    """The fit's model; with the seeds' directions ``sign`` (S,) (``order: listed``) its hinge rows too."""
    model = MotionModel(layout, task, ref)
    return model if sign is None else ListedOrder(model, sign, layout.items)


def _in_order(phi) -> np.ndarray:
    """(S,) whether each seed's item angles phi (S, N) (item 0 at 0) visit the items in the listed order."""
    d = np.diff(np.mod(phi[:, 1:], np.pi), axis=1)
    return np.all(d > 0, axis=1) | np.all(d < 0, axis=1)


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
def linkage_of(coef, ref, phi, cond: Conditioning, ps: PoseSet):
    """The Bennett linkage of a motion in the conditioned frame: C (coefficients (2, 8), monic), reference
    pose ``ref`` (8,) at t = inf (item 0, phi = 0) and the items' angles ``phi`` (N,) (t = cot phi)."""
    from synth.synthesis.bennett import LOOP_NAMES, bennett_parameters_of, dh_table, factor_conic

    C = np.concatenate([coef, np.eye(8)[:1]])
    H, K, Cw, residual = factor_conic(C, cond)
    with np.errstate(divide="ignore"):
        ts = np.cos(phi) / np.sin(phi)
    ts[0] = np.inf
    ts[phi == np.pi / 2] = 0.0  # (cos(pi/2) is not 0 in floating point)
    Tref = dq_to_pose(ref)
    Tref[:3, 3] = Tref[:3, 3] * cond.scale + cond.centre
    info = LinkageInfo(synthesis=Factorization(factorization_residual=residual, conditioning=Conditioning(
        np.asarray(cond.centre, float), float(cond.scale))))
    lk = two_branch_linkage("bennett", H, K, Cw, ps.matrices, ps.names, ts, info)
    lk.tool_ref = Tref
    lk.info = lk.info.replace(bennett=bennett_parameters_of(lk), dh=dh_table(lk, LOOP_NAMES))
    return lk


def is_task(ps: PoseSet) -> bool:
    """Whether a pose set needs `bennett_task` rather than the classic three-pose synthesis: tolerances,
    velocities, a listed order or a count other than three poses."""
    if ps.tolerance is not None or ps.velocity is not None or ps.order is Order.LISTED:
        return True
    return len(ps) > POINTS_NEEDED if ps.has_points else len(ps) != 3


def bennett_task(ps: PoseSet, top: int = 1, best_effort: bool = False) -> list:
    """`_bennett_task` with every refusal naming the task's source first."""
    try:
        return _bennett_task(ps, top, best_effort)
    except SynthesisError as e:
        if str(e).startswith(f"{ps.source}: "):
            raise
        raise SynthesisError(f"{ps.source}: {e}") from e


def _bennett_task(ps: PoseSet, top: int, best_effort: bool) -> list:
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
    elif n_poses < len(ps) and len(ps) <= POINTS_NEEDED:  # a point task (docs/points.md): exact as before
        from synth.synthesis.points import oriented_item, point_candidates

        oriented, rot = oriented_item(ps.matrices, ps.kinds, ps.names)
        candidates = point_candidates(ps.positions, ps.names, degree=DEGREE, top=top, tool_rotation=rot,
                                      oriented=oriented, check_samples=VERIFY_SAMPLES)
        summary = FitSummary("exact", visit=visiting_order([r.t for r in candidates[0].poses]))
    elif (len(ps) >= 3 and n_poses >= 3) or (n_poses >= 2 and twists and len(ps) >= 3) or len(ps) > POINTS_NEEDED:
        _refuse_zero_pitch(ps, n_poses)
        candidates, summary = _fitted(ps, top), None
    else:
        got = f"{n_poses} poses" + (f" and {len(ps) - n_poses} points" if len(ps) > n_poses else "")
        raise InputError(f"{ps.source}: a Bennett linkage needs 3 or more poses, 2 poses with a velocity at one "
                         f"of them, or 3 or more points, got {got}")
    results = []
    for lk in candidates:
        s = summary or lk.info.fit_summary
        if s.method == "exact" and not ps.has_points:
            from synth.synthesis.bennett import verify

            verify(lk)
        elif s.method == "hermite":
            check_fitted(lk)  # (fits are checked in `_fitted`)
        annotate(lk, ps, s)
        results.append(lk)
    return select(results, ps, top, best_effort, "Bennett")


def _refuse_zero_pitch(ps: PoseSet, n_poses: int) -> None:
    """SynthesisError for more than three poses (no points) in one planar or spherical subgroup
    (`synth.synthesis.planar.zero_pitch`): the Bennett motions through their triples degenerate to planar
    or spherical four-bar motions, which the spatial fit has no seeds for; planar tasks go to `mpsynth
    fourbar`."""
    if n_poses != len(ps) or n_poses <= 3:
        return
    from synth.synthesis.conic import relative_displacements
    from synth.synthesis.planar import ZERO_PITCH_TOL, study_forms, zero_pitch

    if np.max(np.abs(study_forms(relative_displacements(condition(ps.matrices)[0])))) > ZERO_PITCH_TOL:
        return  # spatial
    kind = None
    for tri in itertools.islice(itertools.combinations(range(n_poses), 3), 20):  # a triple that classifies them
        try:
            kind = zero_pitch(ps.matrices[list(tri)], [ps.names[i] for i in tri]).kind
            break
        except SynthesisError:  # (a degenerate triple: translations only, one axis)
            continue
    if kind is None:
        return  # (the fit's own refusal names the degeneracy)
    if kind == "planar":
        raise SynthesisError(f"the {n_poses} poses are planar (every rotation about one normal, every tool origin "
                             "in one plane perpendicular to it): a Bennett linkage through them degenerates to a "
                             "planar four-bar, which `mpsynth fourbar` synthesizes (exactly for 3 to 5 poses, by "
                             "least squares within the tolerances for more)")
    raise SynthesisError(f"the {n_poses} poses are spherical (every one a rotation about one common point): a "
                         "Bennett linkage through them degenerates to a spherical four-bar, which is not fitted to "
                         "more than three poses; give three poses (`mpsynth bennett` gives the family of "
                         "spherical four-bars through them)")


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
    lk = linkage_of(coef[0], ref[0], np.array([0.0, np.pi / 2]), cond, ps)
    lk.info = lk.info.replace(fit_summary=FitSummary("hermite", visit=(0, 1)))
    return lk


def _fitted(ps: PoseSet, top: int) -> list:
    coef, ref, phi, cost, violation, cond, summary = fit_motion(ps)

    def skip(k, taken):
        if any(np.abs(coef[k] - coef[j]).max() <= 1e-6 * (1 + np.abs(coef[j]).max()) for j in taken):
            return ""  # the same motion from another seed
        if not violation[k] <= FEASIBLE:
            return (f"the exact poses and velocities cannot all be met by a Bennett motion (best constraint "
                    f"violation {violation[k]:.1e}, relative)")
        return None

    def build(k):
        lk = linkage_of(coef[k], ref[k], phi[k], cond, ps)
        lk.info = lk.info.replace(fit_summary=FitSummary("fit", summary.seeds, summary.refined, summary.iterations,
                                                         visiting_order([r.t for r in lk.poses])))
        return lk

    out, why = first_built(range(len(coef)), build, top, skip)
    if not out:
        raise SynthesisError(f"{ps.source}: {why or 'no Bennett motion fits the task'}")
    return out
