"""Motion polynomials whose tool point visits prescribed points, and the scan over their free
parameters (docs/points.md).

Frames: the scan works in the *conditioned* frame of the points (origin at their centroid, lengths
divided by their RMS spread L, `synth.synthesis.conic.condition`); `point_motion` itself works in the
frame whose origin is the point visited at t = infinity.

The interpolation (`point_motion`): a monic motion polynomial C = P + eps Q of degree n (P monic, Q of
degree < n) moves the tool origin to x at parameter t exactly when Q(t) + x P(t) / 2 = 0 (x a pure
quaternion; docs/conventions.md, section 2). With the first point at t = infinity moved to the origin
(C(inf) = 1) and 2n further points x_i at distinct parameters t_i these are 8n linear equations in the
8n unknown coefficients; their solution satisfies the Study condition identically, because the dual
part 2 P.Q of the norm has degree < 2n and vanishes at the 2n parameters t_i. One batched linear solve
gives a member for every choice of parameters: n = 2 (five points) a Bennett motion, n = 3 (seven
points) a 6R motion.

Free parameters: an affine change of t keeps C monic, so t_1 = -1 and t_2n = 1 are fixed and the 2n - 2
interior parameters (-1 < t_2 < ... < t_{2n-1} < 1) are free (2 for Bennett, 4 for 6R). Points missing
from the task (fewer than 2n + 1 given) are free too. `scan` samples both (seeded), factors every member
with the one batched Algorithm 1 and scores each loop with the 6R engineering score
(`synth.synthesis.sixbar_loops`), the parameter separation taking the place of t3's.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.dq import dq_inv, dq_mul, qmul, translation_dq
from synth.algebra.polynomial import norm_poly
from synth.synthesis.conic import Conditioning, to_world
from synth.synthesis.cubic import PAIRS, PERMS, chordal_separation
from synth.synthesis.fit import sample_combinations
from synth.synthesis.sixbar_loops import edge_normals, factor_members, geometry_parts, member_geometry, score_loops

__all__ = ["point_motion", "subset_motions", "rereference", "parameter_samples", "scan", "PointScan",
           "BENNETT_ORDERS",
           "BENNETT_PAIRS", "SAMPLES"]

SAMPLES = {2: 136, 3: 400}  # parameter samples of the default scan, by degree
BENNETT_ORDERS = np.array([[0, 1], [1, 0]])  # the two factorizations of a quadratic (norm factors by Re root)
BENNETT_PAIRS = np.array([[0, 1]])  # the one loop: branch h = order 0, branch k = order 1
_QUAT_BASIS = np.eye(4)


def point_motion(X, t, degree: int):
    """Monic motion polynomials C (B, n+1, 8) of degree n = ``degree`` with C(inf) = 1 that move the
    origin to the points X (B, 2n, 3) at the parameters t (B, 2n) (finite, distinct). One batched
    linear solve of the 8n x 8n system of docs/points.md. Rows whose system is singular (or not finite)
    come back as NaN. Lengths in the units of X."""
    X = np.asarray(X, float)
    t = np.asarray(t, float)
    n = int(degree)
    B, k = t.shape
    if k != 2 * n or X.shape != (B, k, 3):
        raise ValueError(f"point_motion needs (B, {2 * n}, 3) points and (B, {2 * n}) parameters")
    x = np.concatenate([np.zeros((B, k, 1)), X], -1)  # pure quaternions
    Lx = np.swapaxes(qmul(x[..., None, :], _QUAT_BASIS), -1, -2)  # (B, k, 4, 4): Lx @ p = x p
    V = t[..., None] ** np.arange(n)  # (B, k, n)
    A = np.zeros((B, k, 4, 2, n, 4))
    A[:, :, :, 0] = 0.5 * V[:, :, None, :, None] * Lx[:, :, :, None, :]  # columns of P's coefficients
    A[:, :, :, 1] = V[:, :, None, :, None] * np.eye(4)[None, None, :, None, :]  # columns of Q's
    A = A.reshape(B, 4 * k, 8 * n)
    rhs = (-0.5 * t[..., None] ** n * x).reshape(B, 4 * k)
    good = np.isfinite(A).all((-2, -1)) & np.isfinite(rhs).all(-1)
    A[~good], rhs[~good] = np.eye(8 * n), 0.0
    with np.errstate(all="ignore"):
        try:
            u = np.linalg.solve(A, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:  # a singular row: solve row by row, NaN where singular
            u = np.full((B, 8 * n), np.nan)
            for b in range(B):
                try:
                    u[b] = np.linalg.solve(A[b], rhs[b])
                except np.linalg.LinAlgError:
                    good[b] = False
    u = u.reshape(B, 2, n, 4)
    C = np.zeros((B, n + 1, 8))
    C[:, :n, :4], C[:, :n, 4:] = u[:, 0], u[:, 1]
    C[:, n, 0] = 1.0
    C[~good] = np.nan
    return C


def subset_motions(X, degree: int, max_subsets: int, samples: int):
    """Seed motions of a fit of the positions X (N, 3) (N > 2n; conditioned): for each (2n+1)-subset (all,
    or a sample of ``max_subsets`` from a generator seeded with 0) the motions of degree n moving the
    subset's first position through the others at ``samples`` choices of the free parameters
    (`parameter_samples`, `point_motion`), conjugated to the frame. Returns (coef (S, n, 8) of the monic
    motions, reference poses (S, 8): the translations to the subsets' first positions)."""
    n = int(degree)
    sub = np.array(sample_combinations(range(len(X)), 2 * n + 1, max_subsets), int)  # (k, 2n + 1)
    t = parameter_samples(samples, 2 * n - 2)  # (m, 2n)
    k, m = len(sub), len(t)
    rel = X[sub[:, 1:]] - X[sub[:, :1]]  # (k, 2n, 3)
    with np.errstate(all="ignore"):
        C = point_motion(np.repeat(rel, m, axis=0), np.tile(t, (k, 1)), n)  # (k m, n+1, 8)
    first = np.repeat(X[sub[:, 0]], m, axis=0)
    move, back = translation_dq(first)[:, None], translation_dq(-first)[:, None]
    return dq_mul(dq_mul(move, C[:, :n]), back), move[:, 0]


def rereference(H, t0: float):
    """Move the reference configuration of the factorized motion C = (t - h_1)...(t - h_n) (factors H
    (..., n, 8)) to the parameter t0 (docs/points.md, section 3): the new parameter s with
    t = t0 - 1/s (increasing with t, s = inf at t = t0, s = 0 at t = inf) and the monic motion
    D(s) = s^n C(t0 - 1/s) C(t0)^-1 = (s - f_1)...(s - f_n) of the displacements relative to C(t0), with
    f_i = P (t0 - h_i)^-1 P^-1, P = (t0 - h_1)...(t0 - h_{i-1}). Returns the factors f (..., n, 8)."""
    H = np.asarray(H, float)
    a = -H
    a[..., 0] += t0  # t0 - h_i
    P = np.zeros(H.shape[:-2] + (8,))
    P[..., 0] = 1.0
    out = np.empty_like(H)
    for i in range(H.shape[-2]):
        out[..., i, :] = dq_mul(dq_mul(P, dq_inv(a[..., i, :])), dq_inv(P))
        P = dq_mul(P, a[..., i, :])
    return out


def parameter_samples(count: int, free: int, seed: int = 0) -> np.ndarray:
    """Parameters (count, free + 2): -1, the sorted interior ones, 1. Row 0 is evenly spaced; the other
    rows are seeded random (uniform order statistics)."""
    rng = np.random.default_rng(seed)
    inner = np.sort(rng.uniform(-1.0, 1.0, size=(count, free)), axis=-1)
    inner[0] = np.linspace(-1.0, 1.0, free + 2)[1:-1]
    return np.concatenate([-np.ones((count, 1)), inner, np.ones((count, 1))], -1)


@dataclass
class PointScan:
    """Members of a point scan (conditioned frame) and the scores of their loops."""

    degree: int
    t: np.ndarray  # (S, 2n) parameters of points 1..2n (point 0 at t = inf)
    Y: np.ndarray  # (S, 2n + 1, 3) the points of each member (given, then the chosen missing ones)
    C: np.ndarray  # (S, n+1, 8) monic motions (conditioned frame)
    roots: np.ndarray  # (S, n) norm roots
    H: np.ndarray  # (S, orders, n, 8) factors by order (Bennett: BENNETT_ORDERS; 6R: PERMS)
    pairs: np.ndarray  # (P, 2) loops: order of branch h, order of branch k
    orders: np.ndarray  # (orders, n) quadratic indices of each order
    parts: dict  # score parts, each (S, P)
    valid: np.ndarray  # (S, P)
    score: np.ndarray  # (S, P), 0 where invalid


def scan(Y, degree: int, *, samples: int | None = None, seed: int = 0) -> PointScan:
    """Score every loop of ``samples`` members through the conditioned points Y (k, 3) (k <= 2n + 1,
    point 0 visited at t = inf): free parameters from `parameter_samples`, the 2n + 1 - k missing points
    seeded standard normal (one unit = the points' spread, about their centroid) and appended after the
    given ones."""
    Y = np.asarray(Y, float)
    n = int(degree)
    S = int(samples or SAMPLES[n])
    k = Y.shape[0]
    t = parameter_samples(S, 2 * n - 2, seed)
    rng = np.random.default_rng(seed + 1)
    extra = rng.standard_normal((S, 2 * n + 1 - k, 3))
    YY = np.concatenate([np.broadcast_to(Y, (S, k, 3)), extra], 1)
    X = YY[:, 1:] - YY[:, :1]
    with np.errstate(all="ignore"):
        CX = point_motion(X, t, n)
        finite = np.isfinite(CX).all((-2, -1)) & (np.abs(CX).max((-2, -1), initial=0) < 1e12)
        CX[~finite] = np.eye(8)[0]
        C = to_world(CX, Conditioning(centre=YY[:, 0], scale=np.ones(S)))
    if n == 3:
        mf = factor_members(C)
        roots, H, ok, res = mf.roots, mf.H, mf.ok, mf.residual
        geo = member_geometry(mf)
        pairs, orders = PAIRS, PERMS
    else:
        roots, H, ok, res = _factor_quadratics(C)
        geo = _bennett_geometry(H)
        pairs, orders = BENNETT_PAIRS, BENNETT_ORDERS
    with np.errstate(all="ignore"):
        im, sep = a1.root_conditioning(roots)
        tsep = chordal_separation(t)
        parts, valid, score = score_loops(im, sep, ("parameter_separation", tsep), geo, res, ok, finite, pairs)
    return PointScan(degree=n, t=t, Y=YY, C=C, roots=roots, H=H, pairs=pairs, orders=orders, parts=parts,
                     valid=valid, score=score)


def _factor_quadratics(C):
    """Both factorizations of monic quadratics C (S, 3, 8) by the batched Algorithm 1: norm roots (S, 2),
    factors (S, 2, 2, 8) by BENNETT_ORDERS, ok (S, 2) (no translation factor), residual (S, 2)."""
    with np.errstate(all="ignore"):
        z = a1.norm_roots(norm_poly(C))
        H, ok = a1.algorithm1(C[:, None], a1.quadratics(z)[:, BENNETT_ORDERS])
        res = np.maximum(a1.multiply_back(C[:, None], H), a1.study_violation(H))
        ok &= ~a1.is_translation(H).any(-1) & np.isfinite(res)
    return z, np.where(ok[..., None, None], H, np.nan), ok, np.where(ok, res, np.inf)


def _bennett_geometry(H):
    """min_offset, min_twist and extent (each (S, 1)) of the Bennett loop h1 h2 k2 k1 of factors
    H (S, 2, 2, 8) (BENNETT_ORDERS), as `synth.synthesis.sixbar_loops.member_geometry`."""
    with np.errstate(all="ignore"):
        return geometry_parts(edge_normals(H.reshape(-1, 4, 8), _BENNETT_RING), _BENNETT_LOOP)


_BENNETT_RING = np.array([[0, 1], [1, 3], [3, 2], [2, 0]])  # h1 h2, h2 k2, k2 k1, k1 h1 of H (S, 4, 8)
_BENNETT_LOOP = np.arange(4)[None]
