"""Bennett 4R linkage through three poses (docs/conic.md, docs/algorithm1.md).

``bennett(poses)`` takes a (3, 4, 4) array of poses in metres and returns a fully computed `Linkage`:
branch h = (h1, h2), branch k = (k1, k2) with C = (t-h1)(t-h2) = (t-k1)(t-k2); pose 0 at t = inf (all
angles 0), pose 1 at t = 0, pose 2 at t = 1. h1 (and k2) carry the norm factor whose root a + ib has the
smaller real part. The synthesis is `synth.synthesis.bennett_core.solve` on a batch of one; a set it
cannot judge goes through the per-set path here (the same conic, `synth.algebra.factorize.factorize`
with its refinements), which gives every refusal its plain-language message. ``linkage.checks`` holds the
self-check at ``check_samples`` parameters; `verify` is the explicit verification (200
samples) the CLI runs before writing.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from synth.algebra.algorithm1 import index_pairs
from synth.algebra.dq import dq_right_matrix, factor_lines, pose_to_dq
from synth.algebra.geometry import cross, dh_parameters, pose_difference, ring_normals, rotation_about_axis
from synth.algebra.factorize import factorize
from synth.checks import BOUND_CHECK_SAMPLES, DEFAULT_CHECK_SAMPLES, VERIFY_SAMPLES, as_checks, self_check
from synth.errors import InputError, NotGenericError, SynthesisError
from synth.info import Factorization, LinkageInfo
from synth.infoparts import BennettParameters, DHRow, StudyForm
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett_core import (ACCEPT_TOL, EPS, FLOOR_ULPS, TS, acceptance_error, axis_distance,
                                          bennett_parameters, factor_sets, solve)
from synth.synthesis.conditioning import (TRANSMISSION_LIMIT, near_degenerate, near_relations, pose_spread,
                                          transmission_refusal, worst_pair)
from synth.synthesis.conic import (Conditioning, condition, conditioning, conic, relative_displacements,
                                   position_spread, to_world)
from synth.synthesis.planar import zero_pitch
from synth.synthesis.planar_bennett import accepted_error
from synth.synthesis.planar_bennett import candidates as planar_candidates

__all__ = ["bennett", "bennett_candidates", "per_set_candidates", "verify", "check_distinct", "check_transmission",
           "sensitivity",
           "perturbed_poses", "dh_table", "bennett_parameters_of", "EPS", "FLOOR_ULPS", "ACCEPT_TOL"]

COINCIDENT_TOL = 1e-9  # relative to the pose spread (translation) and radians (rotation)
ACCURATE = 1e-9  # a self-check error above this (relative) gets a warning
SENSITIVITY_EPS = 1e-9  # relative pose perturbation of the condition estimate (`sensitivity`)
SENSITIVE = 1e4  # condition estimate above which a valid result gets a warning
LOOP_NAMES = ["h1", "h2", "k2", "k1"]


def check_distinct(T, names, tol=COINCIDENT_TOL):
    """Refuse coincident poses (k, 4, 4) with a message naming them: translations within ``tol`` of
    the RMS spread of the positions and rotations within ``tol`` radians."""
    T = np.asarray(T, float)
    L = pose_spread(T)
    i, j = index_pairs(len(T))
    dt, dr = pose_difference(T[i], T[j])
    same = ((dt <= tol * L) & (dr <= tol)) | ((dt == 0) & (dr <= tol))
    for a, b in zip(i[same].tolist(), j[same].tolist()):
        raise SynthesisError(f"poses {a} ({names[a]!r}) and {b} ({names[b]!r}) coincide: "
                             "three distinct poses are needed")


def bennett(poses, names=None, *, check_samples: int = BOUND_CHECK_SAMPLES, member=None):
    """Synthesize the Bennett linkage whose coupler visits the three poses (shape (3, 4, 4), metres).

    ``check_samples``: number of parameters covering the real line at which the loop closure and the
    motion are also sampled (``linkage.checks``); they are bounded over the whole motion in any case
    (`synth.checks.loop_bound`; the per-set path samples at least DEFAULT_CHECK_SAMPLES instead), and
    the tool frame at every pose's reported joint angles is bounded likewise (`synth.checks.pose_bound`;
    the per-set path evaluates it). Planar or spherical poses
    (docs/planar.md) have a family of quadratic motions through them and give a planar or spherical
    four-bar (kind ``planar_4r`` / ``spherical_4r``): the best-scored member, or ``member`` =
    (lambda1, lambda2). Raises InputError (shape, NaN, a member for spatial poses)
    or SynthesisError (degenerate or non-real cases, with a plain-language reason). Tasks with
    tolerances, velocities or more poses: `synth.synthesis.tasks.fit` (``synth.fit``)."""
    return bennett_candidates(poses, names, check_samples=check_samples, member=member)[0]


def bennett_candidates(poses, names=None, *, check_samples: int = BOUND_CHECK_SAMPLES, member=None,
                       top: int = 1) -> list:
    """`bennett` as a list: the one Bennett linkage of spatial poses, or up to ``top`` members of the
    family of planar or spherical poses, best score first (`synth.synthesis.planar_bennett.candidates`).
    SynthesisError when one fails the transmission gate (`check_transmission`), as `verify` would."""
    T = np.asarray(poses, float)
    if T.shape != (3, 4, 4):
        raise InputError(f"a Bennett linkage needs exactly 3 poses (array of shape (3, 4, 4)), got {T.shape}")
    names = list(names) if names is not None else ["p0", "p1", "p2"]
    if member is None:
        # the perturbed sets of the condition estimate (`sensitivity`) are factored in the same batch
        # (the first half of the pipeline only); a set with NaN or inf is never good (the per-set path says so)
        out = solve(T[None], check_samples, perturb=_small_motion_matrices(SENSITIVITY_EPS, 0, 2))
        if out.good[0]:
            linkage = linkage_from_solution(out, 0, T, names, check_samples, perturbed=out.extra)
            if out.transmission[0] > TRANSMISSION_LIMIT:  # the gate of `verify` (the ratio at hand)
                check_transmission(linkage)
            return [linkage]
        linkages = per_set_candidates(T, names, check_samples=check_samples, top=top, perturbed=out.extra)
    else:
        linkages = per_set_candidates(T, names, check_samples=check_samples, member=member, top=top)
    for lk in linkages:  # the gate of `verify` and of every entry point: a notebook gets what the CLI gives
        check_transmission(lk)
    return linkages


def per_set_candidates(T, names, *, check_samples: int = BOUND_CHECK_SAMPLES, member=None, top: int = 1,
                       perturbed: dict | None = None) -> list:
    """`bennett_candidates` for a set (3, 4, 4) that `synth.synthesis.bennett_core.solve` did not judge
    good (or with a ``member``): the per-set path, which synthesizes it or refuses it with a message.
    `synth.synthesis.bennett_batch` calls it directly for such sets (solve has already run there), with
    ``perturbed``: `factor_sets` of `perturbed_poses` (T), factored in one batch for all such sets."""
    T = np.asarray(T, float)
    names = list(names)
    if not np.all(np.isfinite(T)):
        raise InputError("the poses contain NaN or infinity")
    check_distinct(T, names)
    zp = zero_pitch(T, names)
    if zp is not None:
        return planar_candidates(zp, member, top=top, check_samples=check_samples)
    if member is not None:
        raise InputError("--member picks a member of the family of motions through planar or spherical poses; "
                         "these poses are spatial, so the conic and the Bennett linkage through them are unique")
    return [_bennett_general(T, names, check_samples, perturbed)]


def verify(linkage, samples: int = VERIFY_SAMPLES) -> dict:
    """The explicit verification of a Bennett linkage before it is written: the self-check at
    ``samples`` parameters (stored as ``linkage.checks``) and the acceptance gates: SynthesisError when
    the linkage misses its poses or does not close (relative error above ACCEPT_TOL), or when two joints'
    speeds differ by more than `synth.synthesis.conditioning.TRANSMISSION_LIMIT` somewhere in the cycle
    (`check_transmission`); the info's ``relative_error`` and warnings are updated. Returns the checks."""
    check_transmission(linkage)
    checks = self_check(linkage, samples)
    T = np.array([p.matrix for p in linkage.poses], float)
    cond = conditioning(T)
    if linkage.kind in ("planar_4r", "spherical_4r"):  # a member of a family (docs/planar.md)
        linkage.checks = checks
        rel = accepted_error(linkage, T, cond)
        linkage.info = linkage.info.replace(relative_error=_accept(linkage, cond, rel))
        return checks
    U, M = _loop_lines(linkage)
    errors = {"pose_translation": checks["max_pose_translation_error"],
              "pose_rotation": checks["max_pose_rotation_error"],
              "closure_translation": checks["max_closure_translation_error"],
              "closure_rotation": checks["max_closure_rotation_error"]}
    far = axis_distance(U, M, cond.centre[None])
    rel = float(acceptance_error(T[None], np.array([cond.scale]), far, {k: np.array([v]) for k, v in errors.items()})[0])
    info = linkage.info
    rel = _accept(linkage, cond, max(rel, info.relative_error or 0.0))
    B = [x / float(cond.scale) for x in info.synthesis.study_form.values]
    warnings, kappa = _warnings(linkage, B, cond, rel, info.condition_estimate, float(far[0]))
    linkage.checks = checks
    linkage.info = info.replace(relative_error=rel, condition_estimate=kappa, warnings=warnings)
    return checks


def check_transmission(linkage) -> None:
    """SynthesisError when two joints' speeds differ by more than TRANSMISSION_LIMIT somewhere in the
    cycle (`synth.synthesis.conditioning.transmission_problem`), naming the pair of poses nearly related
    by a pure translation or rotation, or nearly coinciding, when there is one (`transmission_refusal`)."""
    rho, fast, slow = worst_pair(linkage)
    if not rho <= TRANSMISSION_LIMIT:
        T = np.array([p.matrix for p in linkage.poses], float)
        raise SynthesisError(transmission_refusal(T, [p.name for p in linkage.poses], rho, fast, slow))


def linkage_from_solution(out, i: int, T, names, check_samples: int, perturbed: dict | None = None):
    """The `Linkage` of set i of a `synth.synthesis.bennett_core.solve` result (checks and info from
    its arrays). ``perturbed``: ``good`` and ``factors`` of `perturbed_poses` (T) (`factor_sets`), when
    at hand (`sensitivity` computes them otherwise)."""
    F = out.factors[i]
    scale = float(out.scale[i])
    cond = Conditioning(centre=out.centre[i], scale=scale)
    info = LinkageInfo(synthesis=Factorization(factorization_residual=float(out.residual[i]),
                                               study_form=StudyForm.of(out.study_form[i].tolist()),
                                               conditioning=Conditioning(np.array(out.centre[i], float), scale)))
    linkage = two_branch_linkage("bennett", F[:2], F[2:], out.motion[i], T, names, TS, info,
                                 angles=out.pose_angles[i], lines=(out.lines[i], out.laws[i]))
    figures = {k: float(v[i]) for k, v in out.errors.items()}
    linkage.checks = as_checks(figures, check_samples, float(out.length_scale[i]), bounded=True)
    linkage.info = _complete_info(linkage, info, out.study_form[i] / scale, cond, out.bennett, out.dh,
                                  float(out.relative_error[i]), float(out.axis_distance[i]), perturbed, row=i,
                                  frame=(out.centre[i], scale, out.lines[i]))
    return linkage


def _bennett_general(T, names, check_samples, perturbed=None):
    """The per-set path: the same conic, `factorize` with root merging and refinement, every refusal
    message; the self-check by `synth.checks.self_check`. ``perturbed``: as `linkage_from_solution`."""
    H, K, C, con, cond, info = _general_factors(T, names)
    linkage = two_branch_linkage("bennett", H, K, C, T, names, con.ts, info)
    linkage.checks = self_check(linkage, max(check_samples, DEFAULT_CHECK_SAMPLES))
    U, M = _loop_lines(linkage)
    c = linkage.checks
    errors = {"pose_translation": c["max_pose_translation_error"], "pose_rotation": c["max_pose_rotation_error"],
              "closure_translation": c["max_closure_translation_error"],
              "closure_rotation": c["max_closure_rotation_error"]}
    far = axis_distance(U, M, cond.centre[None])
    rel = float(acceptance_error(T[None], np.array([cond.scale]), far, {k: np.array([v]) for k, v in errors.items()})[0])
    geo = ring_normals(U, M)
    linkage.info = _complete_info(linkage, info, con.B, cond, bennett_parameters(geo), dh_parameters(U, normals=geo),
                                  rel, float(far[0]), perturbed)
    return linkage


def _loop_lines(linkage, loop=LOOP_NAMES):
    """Lines (1, J, 3), (1, J, 3) of the joints ``loop`` in loop order."""
    lines = np.array([(j.direction, j.moment) for j in map(linkage.joint, loop)], float)
    return lines[None, :, 0], lines[None, :, 1]


def _complete_info(linkage, info: LinkageInfo, B, cond, bp, dh, rel, far, perturbed=None, row: int = 0,
                   frame=None) -> LinkageInfo:
    """``info`` plus the Bennett parameters ``bp`` and DH table ``dh`` (dicts of arrays over sets, of
    which set ``row`` is this linkage's), relative self-check error and warnings; raises SynthesisError
    when the self-check error ``rel`` exceeds ACCEPT_TOL (`_accept`). ``perturbed``, ``frame``: as
    `sensitivity`'s ``solved`` and ``frame``."""
    rel = _accept(linkage, cond, rel)
    warnings, kappa = _warnings(linkage, np.asarray(B, float).tolist(), cond, rel, info.condition_estimate, far,
                                perturbed, frame)
    return info.replace(bennett=BennettParameters.of_row(bp, row), dh=DHRow.table(dh.table(LOOP_NAMES, row)),
                        relative_error=rel, condition_estimate=kappa, warnings=warnings)


def bennett_parameters_of(linkage) -> BennettParameters:
    """The Bennett parameters (a, alpha, b, beta, mismatches, Bennett condition residual) of a Bennett
    linkage's loop h1-h2-k2-k1."""
    return BennettParameters.of_row(bennett_parameters(ring_normals(*_loop_lines(linkage))))


def dh_table(linkage, loop: list[str]) -> tuple[DHRow, ...]:
    """Denavit-Hartenberg parameters around a closed loop of joints at the reference configuration:
    for joint i, ``a``/``alpha`` to the next joint (signed twist about the common normal), ``d`` the
    offset along axis i between the incoming and outgoing common normals, ``theta`` the angle between
    them about axis i."""
    return DHRow.table(dh_parameters(*_loop_lines(linkage, loop)).table(loop, 0))


def _accept(linkage, cond, rel) -> float:
    """Refuse a linkage whose own self-check fails (relative error ``rel`` above ACCEPT_TOL, see
    `synth.synthesis.bennett_core.acceptance_error`): near degenerate poses can defeat double precision
    (the conic's coefficients or the factorization lose most digits), and a linkage that misses its
    poses must never be reported as a result. Errors between ACCURATE and ACCEPT_TOL are accepted with a
    warning (`_warnings`). Returns rel."""
    if not rel <= ACCEPT_TOL:  # (also catches NaN)
        T = np.array([p.matrix for p in linkage.poses])
        names = [p.name for p in linkage.poses]
        raise SynthesisError(
            f"the poses are too close to a degenerate configuration{near_degenerate(T, names, float(cond.scale))}: the "
            f"linkage computed in double precision misses them by {rel:.1e} (relative; at most {ACCEPT_TOL:g} "
            "is accepted), so no reliable linkage can be given; move the poses further apart")
    return rel


def perturbed_poses(T, eps: float = SENSITIVITY_EPS, trials: int = 2, seed: int = 0) -> np.ndarray:
    """The poses (3, 4, 4) moved by ``trials`` deterministic random perturbations of relative size
    ``eps`` (each pose: a rotation of eps radians and a translation of eps pose spreads, in its own
    frame), shape (trials, 3, 4, 4). (`bennett_candidates` has `synth.synthesis.bennett_core.solve`
    apply the same motions to the conditioned poses' dual quaternions, `_small_motion_matrices`.)"""
    T = np.asarray(T, float)
    M = _small_motions(eps, seed, trials).copy()  # (trials, 3, 4, 4), translations of unit length
    M[..., :3, 3] *= pose_spread(T)
    return T @ M


def sensitivity(linkage, eps: float = SENSITIVITY_EPS, trials: int = 2, seed: int = 0, solved=None,
                frame=None) -> float:
    """Condition estimate of the synthesis: the largest change of the joint axes (unit directions,
    and moments about the poses' centroid divided by the pose spread) per unit relative change of
    the poses, over the ``trials`` perturbations of `perturbed_poses`. Infinite when a perturbed input
    has no Bennett linkage. Deterministic (fixed seed). ``solved``: ``good`` and ``factors`` of the
    perturbed sets (`synth.synthesis.bennett_core.factor_sets`; computed here when None). ``frame``:
    (centroid (3,), spread > 0, lines (4, 2, 3) of h1 h2 k1 k2) of the linkage's poses and joints, when
    at hand (`synth.synthesis.bennett_core.solve`'s centre, scale and lines)."""
    if frame is None:
        c, spread = position_spread(np.array([p.matrix for p in linkage.poses]))
        spread = max(float(spread), 1e-300)
        J = {j.name: j for j in linkage.joints}
        ref = np.array([(J[n].direction, J[n].moment) for n in ("h1", "h2", "k1", "k2")], float)  # (4, 2, 3)
    else:
        c, spread, ref = frame
    if solved is not None and np.count_nonzero(solved["good"]) == trials:
        F = solved["factors"]
    else:
        T = np.array([p.matrix for p in linkage.poses])
        Tp = perturbed_poses(T, eps, trials, seed)
        out = solved if solved is not None else factor_sets(Tp)
        F = []
        for k in range(trials):
            if out["good"][k]:
                F.append(out["factors"][k])
            else:
                try:
                    H, K, *_ = _general_factors(Tp[k], [p.name for p in linkage.poses])
                except SynthesisError:
                    return float("inf")
                F.append(np.concatenate([H, K]))
        F = np.array(F)
    # the perturbed lines (trials, 4, 2, 3)
    lines = factor_lines(F)[0]
    # their changes in both labellings (branches may swap), moments about c / spread (linear in the lines)
    D = lines.take(_LABELLINGS, axis=1) - ref  # (trials, 2, 4, 2, 3)
    D[..., 1, :] -= cross(c, D[..., 0, :])
    D[..., 1, :] /= spread
    d = np.abs(D).reshape(trials, 2, 24).max(axis=2).min(axis=1)
    return float(d.max()) / eps


_LABELLINGS = np.array([[0, 1, 2, 3], [2, 3, 0, 1]])  # h1 h2 k1 k2, and the branches swapped


@lru_cache(maxsize=8)
def _small_motions(eps: float, seed: int, trials: int) -> tuple:
    """`perturbed_poses`' motions, one per trial and pose (in that order): a rotation of ``eps`` radians
    about a random axis and a unit translation in a random direction (normal draws of a Generator
    seeded with ``seed``: w, v per pose), shape (trials, 3, 4, 4). Cached (read-only): they depend on the
    arguments only."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(3 * trials):
        w = rng.normal(size=3)
        v = rng.normal(size=3)
        M = np.eye(4)
        M[:3, :3] = rotation_about_axis(w / np.linalg.norm(w), eps)
        M[:3, 3] = v * (eps / np.linalg.norm(v))
        out.append(M)
    out = np.array(out).reshape(trials, 3, 4, 4)
    out.flags.writeable = False
    return out


@lru_cache(maxsize=8)
def _small_motion_matrices(eps: float, seed: int, trials: int) -> np.ndarray:
    """The right-multiplication matrices (trials, 3, 8, 8) of `_small_motions` as unit dual quaternions,
    translations in pose spreads (`synth.synthesis.bennett_core.solve`'s ``perturb``; cached, read-only)."""
    out = dq_right_matrix(pose_to_dq(_small_motions(eps, seed, trials)))
    out.flags.writeable = False
    return out


def _general_factors(T, names):
    check_distinct(T, names)
    Tc, cond = condition(T)
    D = relative_displacements(Tc)
    try:
        con = conic(D)
    except SynthesisError as e:
        close = [text for kind, text in near_relations(T, names, float(cond.scale)) if kind == 0]
        if close:  # the Study form of nearly equal poses vanishes quadratically: say what really happens
            raise SynthesisError(f"{close[0]}: the conic through them is numerically degenerate (poses "
                                 "1e-3 apart, relative, are needed); give three clearly distinct poses") from e
        raise
    H, K, C, residual = factor_conic(con.C, cond)
    # the Study form is translation invariant and scales with length: report it in metres
    info = LinkageInfo(synthesis=Factorization(factorization_residual=residual,
                                               study_form=StudyForm.of(v * cond.scale for v in con.B),
                                               conditioning=Conditioning(cond.centre, float(cond.scale))))
    return H, K, C, con, cond, info


def factor_conic(C, cond: Conditioning):
    """Branches h = (h1, h2) and k = (k1, k2) (world frame, (2, 8) each) of a monic quadratic motion
    polynomial C (3, 8) in the conditioned frame ``cond`` (`synth.algebra.factorize.factorize`; h1 carries
    the norm root with the smaller real part), C in the world frame and the factorization residual.
    SynthesisError when C has a real factor, a repeated norm factor or a translation factor."""
    try:
        res = factorize(C, validate=False)
    except NotGenericError as e:
        raise SynthesisError(
            "the conic through the poses is degenerate (its motion has a real factor, e.g. a "
            f"circular translation): no Bennett linkage of revolute joints ({e})") from None
    if len(res.factorizations) < 2:
        raise SynthesisError("the conic through the poses has only one factorization (a repeated norm "
                             "factor): the two branches coincide and do not form a movable loop")
    a_roots = -0.5 * res.quadratics[:, 1]
    first = int(np.argmin(a_roots))
    by_order = {f.order: f for f in res.factorizations}
    fh, fk = by_order[(first, 1 - first)], by_order[(1 - first, first)]
    for f in (fh, fk):
        if any(x.kind == "translation" for x in f.classified()):
            raise SynthesisError(
                "the relative screws of the poses have parallel axes: one factor of the motion is a "
                "translation, so the linkage would need a prismatic joint (not supported)")
    return to_world(fh.factors, cond), to_world(fk.factors, cond), to_world(C, cond), max(fh.residual, fk.residual)


def _warnings(linkage, B, cond, rel, kappa, far, perturbed=None, frame=None) -> tuple[tuple[str, ...], float | None]:
    """Warnings for a valid result: axes far from the poses, and sensitivity to the poses. The condition
    estimate (`sensitivity`, two extra syntheses) runs only when a cheap indicator suggests trouble:
    axes more than 3 pose spreads away, a Study form value |B| < 1e-2 (nearly zero pitch), or norm
    roots that are close or nearly real. ``perturbed``, ``frame``: as `sensitivity`'s ``solved`` and
    ``frame``. ``rel``: the relative self-check error; ``kappa``: the condition estimate when known (else
    None). Returns the warnings and the condition estimate (None when it did not run)."""
    out = []
    if rel > ACCURATE:
        out.append(f"the linkage reproduces the poses less accurately than usual (relative error between "
                   f"{ACCURATE:g} and {ACCEPT_TOL:g}): the poses are close to a degenerate configuration")
    # distance of each axis from the poses' centroid: |moment about the centroid| = |m - c x u|
    far = far / cond.scale
    if far > 1e3:
        out.append(f"joint axes lie {far:.3g} pose spreads away from the poses: the poses are nearly "
                   "related by pure translations, the linkage is valid but impractically large")
    # the two norm roots a + ib are those of h1 and h2 (k2 and k1 repeat them)
    h1, h2 = linkage.joint("h1"), linkage.joint("h2")
    a1, b1, a2, b2 = h1.a, h1.b, h2.a, h2.b
    roots_close = math.hypot(a1 - a2, b1 - b2) < 1e-2 * max(1.0, abs(a1), abs(b1), abs(a2), abs(b2))
    nearly_real = min(b1, b2) < 1e-2 * max(1.0, abs(a1), abs(a2))
    if far > 3 or min(map(abs, B)) < 1e-2 or roots_close or nearly_real:
        if kappa is None:
            kappa = sensitivity(linkage, solved=perturbed, frame=frame)
        if kappa > SENSITIVE:
            # orders of magnitude only: the text must not depend on rounding (batch and single paths agree)
            mag = math.floor(math.log10(kappa)) if math.isfinite(kappa) else None
            shown = "infinite (a tiny change makes it degenerate)" if mag is None else f"about 1e{mag}"
            moved = "1" if mag is None or mag >= 9 else f"1e{mag - 9}"
            out.append(f"the result is valid but sensitive to the poses: changing them by 1e-9 (relative) "
                       f"moves the joint axes by up to about {moved} (condition estimate {shown}); small errors "
                       "in the poses give a different linkage")
    return tuple(out), kappa
