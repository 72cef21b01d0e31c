"""Spatial 6R linkages fitted to over-determined tasks (docs/sixbar_fit.md): five or more poses, each exact
or within a tolerance, optionally with the direction of the tool's velocity.

Pipeline (conditioned frame): seeds from exact sub-solutions (`synth.synthesis.cubic_fit`: quadruples with
pose 0, the best-fitting members of both cubic families through each) -> the degree-generic batched fit of
`synth.synthesis.fit` with n = 3 (coefficients of the monic cubic, Study condition, exact poses and
velocities as equality constraints; STAGE1 iterations on all seeds, then STAGE2 on the KEEP_FITS best) ->
every factorization of each distinct feasible cubic and its 9 loops scored like the exact 6R scan
(`synth.synthesis.sixbar_loops.score_loops`, the separation of the pose parameters in place of t3's) ->
candidates (fit, loop pair), best cost first and then score, built into linkages
(`synth.synthesis.assemble.two_branch_linkage`, factors polished) and checked (closure, transmission:
`synth.synthesis.taskfit.check_fitted`).

Conventions as for Bennett fits (`synth.synthesis.bennett_fit.linkage_of`): pose 0 is at t = inf (all joint
angles 0); the records hold the target poses and the joint angles at the fitted parameters; ``tool_ref``
is the tool pose reached at t = inf; the misses are measured on the linkage (`synth.synthesis.taskfit.annotate`).
"""
from __future__ import annotations

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.dq import dq_to_pose, normalize_dq, pose_to_dq
from synth.blas import one_blas_thread
from synth.errors import SynthesisError
from synth.info import LinkageInfo, Orders, SixbarCandidate
from synth.infoparts import FitSummary, ScoreParts
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett_fit import FEASIBLE
from synth.synthesis.conic import Conditioning, condition, to_world
from synth.synthesis.cubic import PAIRS, PERMS, chordal_separation
from synth.synthesis.cubic_fit import point_seeds, seeds
from synth.synthesis.fit_order import ListedOrder, directions
from synth.synthesis.fit import (ERRORS, Layout, LMResult, MotionModel, cost_classes, levenberg_marquardt, rank_seeds,
                                 reference_pose, task_arrays)
from synth.synthesis.sixbar import LOOP, loop_dh
from synth.synthesis.sixbar_loops import factor_members, member_geometry, root_pairs, score_loops, score_warnings
from synth.synthesis.taskfit import first_built, item_kinds, item_tolerances, visiting_order, visits_in_order
from synth.task import Order, PoseSet

__all__ = ["CubicFits", "fit_cubics", "fit_candidates", "STAGE1", "STAGE2", "KEEP_FITS"]

DEGREE = 3
STAGE1 = 8  # Jacobians on every seed
KEEP_FITS = 6  # best seeds refined further
STAGE2 = 60  # Jacobians on those, at most
DISTINCT = 1e-6  # relative coefficient distance below which two fits are one motion
MAX_BUILT = 12  # candidates built before giving up
LOOPS_PER_FIT = 3  # loop pairs of one fitted motion tried, at most


class CubicFits:
    """Refined cubic motions of a task, best first (feasible, then cost): coef (K, 3, 8), reference poses
    ref (K, 8) at t = inf, angles phi (K, N) (t = cot phi, phi_0 = 0), cost (K,), violation (K,), the
    conditioning and a `FitSummary` (seeds, refined, iterations)."""

    def __init__(self, coef, ref, phi, cost, violation, cond, summary):
        self.coef, self.ref, self.phi, self.cost, self.violation = coef, ref, phi, cost, violation
        self.cond, self.summary = cond, summary

    def ts(self, k: int) -> np.ndarray:
        """Pose parameters t (N,) of fit k: t = cot phi, t_0 = inf."""
        return _cot(self.phi[k])


def _cot(phi) -> np.ndarray:
    """t = cot phi (N,) of the poses' angles, t_0 = inf (pose 0 at phi = 0)."""
    phi = np.mod(phi, np.pi)
    with np.errstate(divide="ignore"):
        ts = np.cos(phi) / np.sin(phi)
    ts[0] = np.inf
    ts[phi == np.pi / 2] = 0.0
    return ts


def _model(task, ref, layout, sign=None):
    """(the fit's model, the columns held): with ``sign`` the listed order's hinge rows too."""
    fixed = layout.fixed
    if not (task.weight[:, 3:ERRORS].any() or task.exact[:, 3:].any()):  # positions only: hold the tool's
        fixed[:, 8 * DEGREE:8 * DEGREE + 3] = True  # orientation at the reference (points do not see it)
    model = MotionModel(layout, task, ref)
    if sign is not None:
        model = ListedOrder(model, sign, layout.items)
    return model, fixed


def _refine(task, ref, x0, gauge, iterations, sign=None):
    """Levenberg-Marquardt on seeds x0; with the seeds' directions ``sign`` (``order: listed``) the hinge rows
    of the order too (`synth.synthesis.fit_order.ListedOrder`)."""
    layout = Layout(DEGREE, task.Q.shape[0], gauge)
    model, fixed = _model(task, ref, layout, sign)
    with np.errstate(all="ignore"):
        return layout, levenberg_marquardt(model, x0, fixed, iterations)


def fit_cubics(ps: PoseSet) -> CubicFits:
    """Fitted cubic motions of a task (module docstring). SynthesisError when no quadruple of the poses
    gives a seed (every one degenerate or oval)."""
    T = np.asarray(ps.matrices, float)
    Tc, cond = condition(T)
    Q = pose_to_dq(Tc)
    task = task_arrays(Q, Tc[:, :3, 3], item_tolerances(ps), ps.velocity, float(cond.scale))
    points = sum(k != "point" for k in item_kinds(ps)) < 4  # no quadruple of poses: 7-subsets of the positions
    coef, ref, phi, gauge, quads = point_seeds(Tc[:, :3, 3], task) if points else seeds(Q, task)
    if not len(coef):
        raise SynthesisError(f"{ps.source}: no quadruple of the poses with pose 0 spans a real family of cubic "
                             "motions (each is degenerate or oval): no 6R motion to start a fit from")
    with one_blas_thread():
        layout = Layout(DEGREE, len(T), gauge)
        x0 = layout.join(coef, np.zeros((len(coef), 6)), phi)
        sign = directions(phi) if ps.order is Order.LISTED else None  # steer toward the listed order
        _, first = _refine(task, ref, x0, gauge, STAGE1, sign)
        merit = np.nan_to_num(first.cost + 1e6 * first.violation, nan=np.inf)
        if ps.order is Order.LISTED:  # the seeds that visit the poses in the listed order first
            keep = rank_seeds(merit, ~np.array([visits_in_order(_cot(p)) for p in layout.split(first.x)[2]]))
        else:
            keep = rank_seeds(merit)
        keep = keep[:KEEP_FITS]
        layout, res = _refine(task, ref[keep], first.x[keep], gauge[keep], STAGE2, None if sign is None else sign[keep])
        if ps.constraints is not None and ps.constraints.base is not None:  # a loop's ground axes into the box
            from synth.synthesis.steer import into_base_box

            model, fixed = _model(task, ref[keep], layout, None if sign is None else sign[keep])
            with np.errstate(all="ignore"):
                steered, seed = into_base_box(model, res, fixed, ps.constraints.base, cond, PERMS, PAIRS)
            res = LMResult(np.concatenate([res.x, steered.x]), np.concatenate([res.cost, steered.cost]),
                           np.concatenate([res.violation, steered.violation]), res.iterations + steered.iterations)
            keep = np.concatenate([keep, keep[seed]])
            layout = Layout(DEGREE, len(T), gauge[keep])
    c, x_ref, ph = layout.split(res.x)
    refs = normalize_dq(reference_pose(ref[keep], x_ref))
    order = rank_seeds(res.cost, ~(res.violation <= FEASIBLE))
    summary = FitSummary("fit", seeds=len(coef), refined=len(set(keep.tolist())),
                         iterations=first.iterations + res.iterations)
    return CubicFits(c[order], refs[order], np.mod(ph[order], np.pi), res.cost[order], res.violation[order], cond,
                     summary)


def _distinct(fits: CubicFits, listed: bool) -> list[int]:
    """Indices of the feasible fits, one per motion (with ``listed``: only those visiting the poses in the
    listed order, `synth.synthesis.taskfit.visits_in_order`)."""
    taken = []
    for k in range(len(fits.coef)):
        if not fits.violation[k] <= FEASIBLE or not np.isfinite(fits.coef[k]).all():
            continue
        if listed and not visits_in_order(fits.ts(k)):
            continue
        if any(np.abs(fits.coef[k] - fits.coef[j]).max() <= DISTINCT * (1 + np.abs(fits.coef[j]).max()) for j in taken):
            continue
        taken.append(k)
    return taken


def _scored(fits: CubicFits, idx):
    """Factor and score the loops of the fits ``idx`` in one batch: (MemberFactors, parts, valid, score)."""
    C = np.concatenate([fits.coef[idx], np.broadcast_to(np.eye(8)[0], (len(idx), 1, 8))], 1)
    tsep = chordal_separation(np.array([fits.ts(k)[1:] for k in idx], float))
    with np.errstate(all="ignore"):
        mf = factor_members(C, polish=True)
        im, sep = a1.root_conditioning(mf.roots)
        parts, valid, score = score_loops(im, sep, ("parameter_separation", tsep), member_geometry(mf), mf.residual,
                                          mf.ok, np.isfinite(C).all((-2, -1)), PAIRS)
    return mf, parts, valid, score


def fit_candidates(ps: PoseSet, top: int = 1) -> list:
    """Built and checked 6R linkages of the fitted motions (best cost first, then the engineering score of
    the loop; with ``order: listed`` only motions visiting the poses in that order), at most ``top``, each
    with ``info.fit_summary`` (its `FitSummary`) for `synth.synthesis.taskfit.annotate`. SynthesisError
    with the reason when none."""
    fits = fit_cubics(ps)
    idx = _distinct(fits, ps.order is Order.LISTED)
    if not idx and _distinct(fits, False):
        k = _distinct(fits, False)[0]
        raise SynthesisError(f"{ps.source}: order: listed, but none of the fitted 6R motions visits the poses in "
                             f"the listed order (the best visits {', '.join(ps.names[i] for i in visiting_order(fits.ts(k)))})")
    if not idx:
        raise SynthesisError(f"{ps.source}: the exact poses and velocities cannot all be met by a cubic 6R motion "
                             f"(best constraint violation {np.nanmin(fits.violation):.1e}, conditioned units)")
    mf, parts, valid, score = _scored(fits, idx)
    miss = np.zeros(valid.shape, bool)
    if ps.constraints is not None and ps.constraints.base is not None:  # loops with ground axes in the box first
        from synth.synthesis.steer import conditioned_box, ground_box_distance

        miss = ground_box_distance(mf.H, PAIRS, conditioned_box(ps.constraints.base, fits.cond)) > 1e-9
    tie = cost_classes(fits.cost)  # (fits whose costs differ in rounding only: by their rank, `rank_seeds`)
    rank = sorted((bool(miss[j, p]), tie[k], -score[j, p], j, p) for j, k in enumerate(idx)
                  for p in _best_loops(score[j], valid[j], miss[j]))
    if not rank:
        raise SynthesisError(f"{ps.source}: every fitted cubic motion has a nearly real or repeated norm factor or a "
                             "translation factor: no 6R linkage of it")
    out, why = first_built([(j, int(p)) for *_, j, p in rank[:MAX_BUILT]],
                           lambda jp: _linkage(fits, idx[jp[0]], mf, jp[0], jp[1], parts, score, ps), top)
    if not out:
        raise SynthesisError(f"{ps.source}: {why}")
    return out


def _best_loops(score, valid, miss) -> np.ndarray:
    """The LOOPS_PER_FIT valid loop pairs of best score of one fit (their closure and transmission fail
    mostly together, so a fit that fails them gives way to the next); those not ``miss``-ing the task's
    base box first."""
    ok = np.nonzero(valid)[0]
    return ok[np.lexsort((-score[ok], miss[ok]))[:LOOPS_PER_FIT]]


def _linkage(fits: CubicFits, k, mf, j, p, parts, score, ps: PoseSet):
    """The 6R linkage of loop pair p (0..8) of fit k (row j of the scored batch), world frame."""
    C = np.concatenate([fits.coef[k], np.eye(8)[:1]])
    oh, ok_ = PAIRS[p]
    HK, _ = a1.polish(C, np.stack([mf.H[j, oh], mf.H[j, ok_]]))
    res = float(np.max(np.maximum(a1.multiply_back(C, HK), a1.study_violation(HK))))
    cond = fits.cond
    W = to_world(np.concatenate([HK[0], HK[1], C]), cond)
    ts = fits.ts(k)
    pp = {key: float(v[j, p]) for key, v in parts.items()}
    record = SixbarCandidate(
        task="fit", pair=p + 1, score=float(score[j, p]), score_parts=ScoreParts.of(pp),
        orders=Orders(h=tuple(PERMS[oh].tolist()), k=tuple(PERMS[ok_].tolist())), norm_roots=root_pairs(mf.roots[j]),
        factorization_residual=res, parameters=tuple(None if np.isinf(t) else float(t) for t in ts),
        conditioning=Conditioning(np.asarray(cond.centre, float), float(cond.scale)))
    lk = two_branch_linkage("6r", W[:3], W[3:6], W[6:], ps.matrices, ps.names, ts, LinkageInfo(synthesis=record))
    ref = dq_to_pose(fits.ref[k])
    ref[:3, 3] = ref[:3, 3] * cond.scale + cond.centre
    lk.tool_ref = ref
    s = fits.summary
    lk.info = lk.info.replace(dh=loop_dh(lk, LOOP), warnings=score_warnings(pp, "motion"),
                              fit_summary=FitSummary("fit", s.seeds, s.refined, s.iterations, visiting_order(ts)))
    return lk
