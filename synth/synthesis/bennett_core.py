"""The Bennett synthesis, vectorized over pose sets: poses (N, 3, 4, 4) in metres -> arrays.

`solve` runs the whole pipeline on a batch (docs/conic.md, docs/algorithm1.md): conditioning, relative
displacements, the conic C through the poses, the roots of its norm polynomial, Algorithm 1 for both
orders (branch h = (h1, h2), branch k = (k1, k2), C = (t-h1)(t-h2) = (t-k1)(t-k2)), the world frame,
Plücker lines and angle laws, the angles at the poses, the loop geometry (Bennett parameters, DH table)
and the self-checks: closure and motion bounded over the whole motion (`synth.checks.loop_bound`) and
the tool frame at the poses' angles bounded through the motion (`synth.checks.pose_bound`), plus samples
at ``check_samples`` parameters (`synth.checks.check_figures`). ``synth.bennett`` is
a batch of one, ``synth.bennett_batch`` a batch of many. Sets the generic pipeline cannot judge
(``good`` False: degenerate or nearly degenerate poses, nearly real or repeated norm roots, a translation
factor, a multiply-back error above MAX_RESIDUAL after Newton polishing, a self-check near the
acceptance limit) are left to the per-set path of `synth.synthesis.bennett`, which gives each refusal its message.

Conventions: joints ``h1, h2, k1, k2``; h1 and k2 carry the norm factor whose root a + ib has the smaller
real part; pose 0 at t = inf (all angles 0), pose 1 at t = 0, pose 2 at t = 1; lengths in metres,
angles in radians; lines (direction, moment = point x direction) at the first pose; angle laws
theta(t) = 2 atan2(b, t - a).
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np

from synth.algebra.algorithm1 import (algorithm1, is_translation, multiply_back, norm_roots, polish, quadratics,
                                      remainder_error, root_conditioning)
from synth.algebra.anglelaw import angle_law
from synth.algebra.polynomial import norm_poly
from synth.blas import one_blas_thread
from synth.checks import check_figures, loop_bound, pose_bound
from synth.algebra.dq import dot, factor_lines, pose_to_dq
from synth.algebra.geometry import DHParameters, cross, dh_parameters, extent, ring_normals
from synth.synthesis.conditioning import pair_ratio
from synth.synthesis.conic import TS, condition_map, conditioning, conic, relative_displacements_dq, world_map

JOINTS = ("h1", "h2", "k1", "k2")
BRANCHES = np.array([[0, 1], [2, 3]])  # h1 h2 | k1 k2, base to coupler
LOOP = np.array([0, 1, 3, 2])  # h1 -> h2 -> k2 -> k1 -> h1
STRUCTURE = ((("base", "link_h1"), ("link_h1", "coupler"), ("base", "link_k1"), ("link_k1", "coupler_k")),
             "coupler", (("coupler", "coupler_k"),))
ACCEPT_TOL = 1e-8  # largest relative self-check error accepted (see `acceptance_error`)
FLOOR_ULPS = 2**17  # rounding floor of the world-frame checks, in ulps of the pose coordinates
EPS = float(np.finfo(float).eps)
MIN_B = 1e-6  # |B_ij| (conditioned) at or below this: (nearly) degenerate conic -> per-set path
MIN_IMAG = 1e-5  # min Im z / (1 + |z|^2) at or below this: nearly real norm root -> per-set path
MIN_SEPARATION = 1e-5  # min |z1 - z2| / (1 + |z|^2) at or below this: nearly repeated root -> per-set path
ONE_THREAD_MIN = 256  # sets from which BLAS runs on one thread (`synth.blas`: threads only cost here)
CHUNK = 2048  # sets per chunk of `solve` (N = 10,000: chunks of 1,000-2,000 sets ~20% faster per set than one)
MAX_RESIDUAL = 5e-13  # multiply-back error above this after polishing: per-set path
POLISH_ABOVE = 3e-14  # multiply-back error above this: polished (the world-frame bounds of `loop_bound` grow with it)
_ORDERS = np.array([[0, 1], [1, 0]])  # branch h, branch k
_EYE4 = np.eye(4)
_FLOOR = FLOOR_ULPS * EPS / ACCEPT_TOL


@dataclasses.dataclass(slots=True)
class Solved:
    """`solve`'s arrays over N pose sets (see `synth.synthesis.bennett_batch.BennettBatch` for the
    fields' shapes and conventions). ``good`` (N,): the set was solved here and its self-check is well
    inside ACCEPT_TOL (rows of other sets hold garbage); ``finite`` (N,): the poses were finite;
    ``bennett`` and ``errors``: dicts of arrays (`bennett_parameters`, the self-check figures); ``dh``:
    `synth.algebra.geometry.DHParameters` of the loop h1 h2 k2 k1; ``axis_distance`` (N,): the axes' largest distance from the centroid (m);
    ``length_scale`` (N,): the linkage's extent (m); ``transmission`` (N,): the largest speed ratio of
    two joints (`synth.synthesis.conditioning`: h1 and k2, h2 and k1 share their norm roots, so the ratio
    of h1 and h2 is the largest); ``extra``: see `solve`'s ``perturb``."""

    good: np.ndarray
    finite: np.ndarray
    lines: np.ndarray
    laws: np.ndarray
    pose_angles: np.ndarray
    factors: np.ndarray
    motion: np.ndarray
    study_form: np.ndarray
    centre: np.ndarray
    scale: np.ndarray
    residual: np.ndarray
    bennett: dict
    dh: DHParameters
    errors: dict
    relative_error: np.ndarray
    axis_distance: np.ndarray
    length_scale: np.ndarray
    transmission: np.ndarray
    extra: dict | None = None


def solve(T, check_samples: int, perturb=None, *, as_single: bool = False) -> Solved:
    """The Bennett pipeline on poses T (N, 3, 4, 4), metres; returns the arrays over N (`Solved`). Rows of sets that are not good hold garbage.
    Large batches run in chunks of CHUNK sets, whose temporaries stay in the CPU caches, with BLAS on
    one thread from ONE_THREAD_MIN sets on (`synth.blas`, docs/architecture.md "Threads"). ``perturb``
    (K, 3, 8, 8): the right-multiplication matrices (`synth.algebra.dq.dq_right_matrix`) of small motions,
    one per copy and pose, translations in units of the pose spread (the condition estimate's
    perturbations, `synth.synthesis.bennett.perturbed_poses`): every set with pose i moved to T_i M_ki is
    also factored, in the same batch (the first half of the pipeline only, `_factors`):
    ``out["extra"]`` = {``good`` (N K,) (the gates before the self-check), ``factors`` (N K, 4, 8)},
    set by set. ``as_single``: every set's arrays are the bits a batch of one gives (the norm roots from
    companion matrices at every batch size, `synth.algebra.algorithm1.norm_roots`; batch jobs print
    what the per-job path prints), a little slower."""
    T = np.asarray(T, float)
    roots = {"ferrari": False} if as_single else {}  # (`_solve`'s keyword)
    with np.errstate(all="ignore"):  # (for `_factors` and `_solve`: rows of bad sets hold garbage)
        if perturb is not None:
            fac = _factors(T, perturb)
            n = T.shape[0]
            out = _solve(T, check_samples, {k: v[:n] for k, v in fac.items()})
            out.extra = {"good": fac["good"][n:], "factors": fac["factors"][n:]}  # as `factor_sets`
            return out
        if T.shape[0] >= ONE_THREAD_MIN:
            with one_blas_thread():
                parts = [_solve(T[i : i + CHUNK], check_samples, **roots) for i in range(0, T.shape[0], CHUNK)]
            return parts[0] if len(parts) == 1 else _concatenate(parts)
        return _solve(T, check_samples, **roots)


def _concatenate(parts: list):
    """`Solved`, dicts (nested) or other dataclasses (`DHParameters`) of arrays over sets, joined along the
    set axis."""
    if isinstance(parts[0], Solved):
        return Solved(*(_concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(Solved)
                        if f.name != "extra"))
    if isinstance(parts[0], dict):
        return {k: _concatenate([p[k] for p in parts]) for k in parts[0]}
    if dataclasses.is_dataclass(parts[0]):
        return type(parts[0])(**{f.name: _concatenate([getattr(p, f.name) for p in parts])
                                 for f in dataclasses.fields(parts[0])})
    return np.concatenate(parts, axis=0)


def factor_sets(T) -> dict:
    """The two factorizations only, for pose sets T (M, 3, 4, 4): ``good`` (M,) (the gates that need no
    self-check) and ``factors`` (M, 4, 8) of h1 h2 k1 k2 in the world frame."""
    with np.errstate(all="ignore"):
        fac = _factors(np.asarray(T, float))
    return {"good": fac["good"], "factors": fac["factors"]}


def _factors(T, perturb=None, ferrari: bool | None = None) -> dict:
    """The first half of the pipeline, arrays over the sets of T (N, 3, 4, 4): conic, norm roots,
    Algorithm 1 for both orders (polished where needed), the factors and C in the world frame, and
    ``good``: the gates that need no self-check. ``perturb`` (K, 3, 8, 8): as `solve`; the perturbed copies
    follow the N sets (set by set) in the arrays over sets, except ``Tf``, ``Q``, ``centre`` and ``scale``
    (the N sets only); ``ferrari``: as `synth.algebra.algorithm1.norm_roots`;
    ``conditioned``: the factors in the conditioned frame. Call under ``np.errstate(all="ignore")``."""
    finite = np.isfinite(T).all(axis=(1, 2, 3))
    Tf = T if np.count_nonzero(finite) == finite.size else np.where(finite[:, None, None, None], T, _EYE4)
    cond = conditioning(Tf)
    Q = pose_to_dq(Tf)  # world frame (checks)
    # the conditioned poses (conic): translated by -centre, lengths divided by the scale (from Q, not from
    # the positions: the conic then passes through the poses as the checks see them)
    Qc = np.matmul(Q, condition_map(cond.scale, cond.centre))
    if perturb is not None:
        # T_i M moved to the conditioned frame is Tc_i M' with M's translation divided by the spread, i.e.
        # in spread units: the copies are products of conditioned poses and the given motions, with the
        # set's conditioning (the same world-frame factors up to rounding: the conic is unique)
        Qc = np.concatenate([Qc, np.matmul(Qc[:, None, :, None, :], perturb).reshape(-1, 3, 8)])
        rows = _copy_rows(T.shape[0], perturb.shape[0])
        finite = finite.take(rows)
    N = Qc.shape[0]
    con = conic(relative_displacements_dq(Qc))
    C, B = con.C, con.B  # (N, 3, 8), (N, 3)
    z = norm_roots(norm_poly(C), ferrari=ferrari)  # (N, 2), Re z[0] <= Re z[1]
    im, sep = root_conditioning(z)
    H, ok, R = algorithm1(C[:, None], quadratics(z)[:, _ORDERS], remainders=True)  # (N, 2 branches, 2, 8)
    residual = remainder_error(C[:, None], H, R).max(axis=1)  # the multiply-back error, up to rounding
    # Algorithm 1 loses digits when roots are close or nearly real: Newton on the product equations
    # (`polish`) restores them here rather than sending the set to the per-set path
    ok = ok.all(axis=1) & finite
    redo = ((residual > POLISH_ABOVE) & ok).nonzero()[0]
    if redo.size:
        H[redo] = polish(C[redo, None], H[redo])[0]
        residual[redo] = multiply_back(C[redo, None], H[redo]).max(axis=1)
    good = (ok & (np.abs(B).min(axis=1) > MIN_B) & (im > MIN_IMAG) & (sep > MIN_SEPARATION)
            & (residual <= MAX_RESIDUAL) & ~is_translation(H).any(axis=(1, 2)))
    conditioned = H.reshape(N, 4, 8)
    W = world_map(cond.scale, cond.centre)  # (`to_world`), one per set of T, then per row
    world = np.matmul(np.concatenate([conditioned, C], axis=1), W if perturb is None else W.take(rows, axis=0))
    return dict(finite=finite, Tf=Tf, Q=Q, centre=cond.centre, scale=cond.scale, B=B, residual=residual,
                good=good, factors=world[:, :4], motion=world[:, 4:], conditioned=conditioned)


@functools.lru_cache(maxsize=16)
def _copy_rows(N: int, K: int) -> np.ndarray:
    """The set of each row of N sets followed by K copies of each, (N (1 + K),) (read-only, cached)."""
    out = np.concatenate([np.arange(N), np.repeat(np.arange(N), K)])
    out.flags.writeable = False
    return out


def _solve(T, check_samples: int, fac=None, ferrari: bool | None = None) -> dict:
    fac = _factors(T, ferrari=ferrari) if fac is None else fac
    N = T.shape[0]
    factors, motion, Q, centre, scale = fac["factors"], fac["motion"], fac["Q"], fac["centre"], fac["scale"]
    # (N, 4, 2, 3), (N, 4, 2): the joints of the linkage, the ones `synth.checks.loop_bound` certifies
    lines, laws = factor_lines(factors)
    a, b = laws[..., 0], laws[..., 1]
    U, M = lines[..., 0, :], lines[..., 1, :]
    pose_angles = angle_law(a[:, None, :], b[:, None, :], TS[:, None])  # (N, 3, 4); 0 at t = inf
    loop = lines.take(LOOP, axis=1)
    geo = ring_normals(loop[..., 0, :], loop[..., 1, :])
    # the linkage's length scale (`synth.linkage.Linkage.extent`) of the tool positions (pose 0 twice: the
    # reference) and the joint sites, the means of the feet of the common normals on either side (each
    # link carries two joints of the loop), less their centroid: one linear map of the positions and feet
    pts = np.concatenate([fac["Tf"][:, :, :3, 3], geo.feet.reshape(N, 8, 3)], axis=1)
    length_scale = extent(np.matmul(_SITES, pts), centred=True)
    # certified: closure and motion over the whole motion, the poses at their angles through the motion
    bound = loop_bound(U, M, a, b, BRANCHES, motion)
    errors = pose_bound(motion, TS[1:], Q[:, 1:3], Q[:, 0], bound)  # (pose 0: t = inf)
    errors["closure_translation"], errors["closure_rotation"], errors["motion"] = (
        bound["closure_translation"], bound["closure_rotation"], bound["motion"])
    if check_samples > 0:
        sampled = check_figures(STRUCTURE, U, M, a, b, pose_angles, Q[:, :3], Q[:, 0], motion, check_samples)
        errors = {k: np.maximum(v, sampled[k]) for k, v in errors.items()}
    # `axis_distance` from the conditioned factors a + v + eps (q0 + w_c): |m - c x u| = L |w_c| / |v|
    # (`synth.synthesis.conic.to_world`), without the world frame's cancellation
    wc = fac["conditioned"][..., 5:]
    far = dot(wc, wc)
    far /= b * b
    far = np.sqrt(far.max(axis=1))
    far *= scale
    rel = acceptance_error(fac["Tf"], scale, far, errors)
    good = fac["good"] & (rel <= 0.1 * ACCEPT_TOL)
    if geo.some_parallel:
        good &= ~geo.parallel.any(axis=1)
    return Solved(good=good, finite=fac["finite"], lines=lines, laws=laws, pose_angles=pose_angles, factors=factors,
                  motion=motion, study_form=fac["B"] * scale[:, None], centre=centre, scale=scale,
                  residual=fac["residual"], bennett=bennett_parameters(geo),
                  dh=dh_parameters(loop[..., 0, :], normals=geo),
                  errors=errors, relative_error=rel, axis_distance=far, length_scale=length_scale,
                  transmission=pair_ratio(a[:, 0] - a[:, 1], b[:, 0], b[:, 1]))  # (b = |v| >= 0)


def axis_distance(U, M, c) -> np.ndarray:
    """Largest distance of the axes (U, M) (N, J, 3) from the points c (N, 3): |m - c x u|."""
    m = M - cross(c[:, None, :], U)
    return np.sqrt(dot(m, m).max(axis=-1))


def acceptance_error(T, spread, far, errors) -> np.ndarray:
    """The acceptance figure (N,): the largest self-check error, translations relative to the pose
    spread (closure: to the axes' largest distance ``far`` from the centroid, `axis_distance`), plus a
    floor of FLOOR_ULPS ulps of the coordinates' magnitude (a pose 1e6 m from the origin is only known
    to ~1e-10 m)."""
    floor = np.abs(T[:, :, :3, 3]).max(axis=(1, 2), initial=0.0)
    floor *= _FLOOR
    return np.maximum(np.maximum(errors["pose_translation"] / (spread + floor), errors["pose_rotation"]),
                      np.maximum(errors["closure_translation"] / (np.maximum(spread, far) + floor),
                                 errors["closure_rotation"]))


def bennett_parameters(geo) -> dict:
    """Link lengths and twists of the loop h1-h2-k2-k1 (its `synth.algebra.geometry.ring_normals`), each (N,): a,
    alpha (links h1h2 and k2k1), b, beta (coupler h2k2 and base k1h1), the mismatches of opposite links,
    a/sin(alpha), b/sin(beta) and the Bennett condition residual |a/sin(alpha)| - |b/sin(beta)| (relative;
    NaN when a twist vanishes)."""
    dist, twist = geo.distance, geo.twist  # (N, 4): a, b, a', b' and alpha, beta, alpha', beta'
    dt = np.abs(geo.distance_twist)  # (2, N, 4): distances and |twists|
    first = dt[..., :2]  # a, b and |alpha|, |beta|
    with np.errstate(all="ignore"):
        s = np.sin(first[1])  # |sin(twist)| (|twist| <= pi)
        r = np.divide(dist[:, :2], s, out=np.full(s.shape, np.inf), where=s > 1e-15)  # a / sin(alpha), b / sin(beta)
        r0, r1 = r[:, 0], r[:, 1]
        res = np.abs(r0 - r1) / np.maximum(np.maximum(r0, r1), 1e-300)  # NaN when either is inf
        mismatch = np.abs(first - dt[..., 2:])
        mismatch = np.maximum(mismatch[..., 0], mismatch[..., 1])  # (2, N): lengths, twists
        mismatch[0] /= np.maximum(np.maximum(first[0, :, 0], first[0, :, 1]), 1e-300)
    return {"a": dist[:, 0], "alpha": twist[:, 0], "b": dist[:, 1], "beta": twist[:, 1],
            "opposite_length_mismatch": mismatch[0], "opposite_twist_mismatch": mismatch[1],
            "a_over_sin_alpha": r0, "b_over_sin_beta": r1, "bennett_condition_residual": res}



def _sites_map(J: int, P: int) -> np.ndarray:
    """The linear map (P + J + 1, P + 2 J) from the tool positions of P poses and the feet (`ring_normals`:
    pair i's foot on joint i, then on joint i+1) around a loop of J joints to the points of the length
    scale less their centroid: the positions, the joint sites (the mean of the feet on either side of
    each joint) and pose 0 again (the tool reference)."""
    S = np.zeros((P + J + 1, P + 2 * J))
    S[:P, :P] = np.eye(P)
    S[P + J, 0] = 1.0
    for i in range(J):
        S[P + i, P + 2 * i] = S[P + i, P + 2 * ((i - 1) % J) + 1] = 0.5
    out = S - S.mean(axis=0)
    out.flags.writeable = False
    return out


_SITES = _sites_map(4, 3)  # the Bennett loop's length-scale map (`_solve`)
