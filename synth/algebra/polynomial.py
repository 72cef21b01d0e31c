"""Motion polynomials: arrays (..., n+1, 8), row k = dual quaternion coefficient of t^k (ascending).

``t`` is real and central. A motion polynomial C = P + eps Q has a real norm polynomial C C~ and an
invertible (here: unit, monic) leading coefficient; C(t) is then a pose for every real t with
N(C)(t) != 0, and C(inf) = 1 for monic C (docs/algorithm1.md). All functions broadcast over leading
batch axes; real polynomials are arrays (..., m+1) in ascending powers.

The algebra (products, norms, divisions, evaluation) is dtype-generic like `synth.algebra.dq`: float
arrays in, float64 out; object arrays of Fractions in, exact Fractions out (the exact Algorithm 1 of
`synth.algebra.exact` runs on these same routines).
"""
from __future__ import annotations

import functools
from fractions import Fraction

import numpy as np

from synth.algebra.dq import as_array, dot, dq_conj, dq_inv, dq_mul, dq_to_pose, result_dtype, zeros


def degree(C) -> int:
    return np.asarray(C).shape[-2] - 1


def poly_mul(A, B, mul=dq_mul):
    """Product A B of polynomials with (dual) quaternion coefficients (order matters): ``mul`` is the
    coefficient product, `dq_mul` (rows of 8) by default, `synth.algebra.dq.qmul` for quaternion rows of 4."""
    A = as_array(A)
    B = as_array(B)
    na, nb = A.shape[-2], B.shape[-2]
    batch = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    out = zeros(batch + (na + nb - 1, A.shape[-1]), result_dtype(A, B))
    for i in range(na):
        out[..., i : i + nb, :] += mul(A[..., i : i + 1, :], B)
    return out


def poly_conj(C):
    """Conjugate every coefficient."""
    return dq_conj(C)


def linear(h):
    """The monic linear polynomial t - h, shape (..., 2, 8)."""
    h = as_array(h)
    one = zeros(h.shape, h.dtype)
    one[..., 0] = Fraction(1) if h.dtype == object else 1.0
    return np.stack([-h, one], axis=-2)


def product_of_linear(hs):
    """(t - h_1)(t - h_2)...(t - h_n) for hs of shape (..., n, 8): (..., n+1, 8), monic. Built factor by
    factor, C (t - h) = t C - C h, with C's i+1 coefficients kept in the top rows n-i..n so that
    multiplying by t needs no shift: one coefficient product per step for all of C's coefficients (the
    leading one is 1, and 1 h = h exactly)."""
    hs = as_array(hs)
    n = hs.shape[-2]
    C = zeros(hs.shape[:-2] + (n + 1, 8), hs.dtype)
    C[..., n, 0] = Fraction(1) if hs.dtype == object else 1.0
    np.negative(hs[..., 0, :], out=C[..., n - 1, :])
    for i in range(1, n):  # C has degree i, in rows n-i..n
        C[..., n - i - 1 : n, :] -= dq_mul(C[..., n - i :, :], hs[..., i : i + 1, :])
    return C


def norm_poly_full(C):
    """C C~ as a dual-quaternion polynomial (..., 2n+1, 8); entries 1..7 vanish for a motion polynomial."""
    return poly_mul(C, poly_conj(C))


def norm_poly(C):
    """The real norm polynomial N(C) = |P(t)|^2, shape (..., 2n+1), ascending. (Its dual part, 2 P.Q,
    is the Study condition; see `study_residual`.)"""
    P = as_array(C)[..., :4]
    n1 = P.shape[-2]
    G = dot(P[..., :, None, :], P[..., None, :, :])  # G[i, j] = p_i . p_j (one call; `dot` rounds alike at every batch size)
    out = zeros(P.shape[:-2] + (2 * n1 - 1,), P.dtype)
    for i in range(n1):  # N_k = sum of G[i, j] over i + j = k
        out[..., i : i + n1] += G[..., i, :]
    return out


def study_residual(C):
    """Largest |entry 1..7| of C C~ relative to its largest coefficient: 0 for a motion polynomial."""
    F = norm_poly_full(C)
    scale = np.max(np.abs(F), axis=(-2, -1))
    return np.max(np.abs(F[..., 1:]), axis=(-2, -1)) / np.where(scale > 0, scale, 1.0)


def is_motion_polynomial(C, tol=1e-10) -> bool:
    C = np.asarray(C, float)
    lead = C[..., -1, :4]
    return bool(np.all(np.linalg.norm(lead, axis=-1) > 0) and np.all(study_residual(C) <= tol))


def evaluate(C, t):
    """C(t) for real t (scalar or array of shape S), giving (..., *S, 8). t = +-inf gives the leading
    coefficient (the identity for monic C). One matrix product of the powers t^k (*S, n+1) with the
    coefficients."""
    C = np.asarray(C, float)
    t = np.asarray(t, float)
    inf = np.isinf(t)
    some_inf = inf.any()
    V = np.power((np.where(inf, 0.0, t) if some_inf else t)[..., None], exponents(C.shape[-2] - 1))  # (*S, n+1)
    if some_inf:
        V[inf] = exponents(C.shape[-2] - 1) == C.shape[-2] - 1  # t^n / t^n at infinity: the leading coefficient
    if t.ndim > 1:  # S[:-1] are batch axes of the product: C's batch in front of them
        C = C.reshape(C.shape[:-2] + (1,) * (t.ndim - 1) + C.shape[-2:])
    return np.matmul(V, C)


@functools.lru_cache(maxsize=16)
def exponents(n: int) -> np.ndarray:
    """The exponents 0 .. n as floats (read-only, cached): ``t[..., None] ** exponents(n)`` are the powers of t."""
    out = np.arange(n + 1.0)
    out.flags.writeable = False
    return out


def pose_at(C, t):
    """4x4 pose(s) of the motion C at parameter(s) t (including +-inf)."""
    return dq_to_pose(evaluate(C, t))


def right_value(C, h):
    """Right value C(h) = sum c_k h^k (coefficients on the left): t - h right-divides C iff it is 0."""
    C = as_array(C)
    h = as_array(h)
    out = C[..., -1, :] * np.ones(h.shape, int)
    for k in range(C.shape[-2] - 2, -1, -1):
        out = dq_mul(out, h) + C[..., k, :]
    return out


def divide_real_quadratic(C, M, *, quotient: bool = True):
    """C = Q M + (r1 t + r0) for a real monic quadratic M = t^2 + M[1] t + M[0] (M shape (..., 2) =
    [c0, c1]), broadcast. Returns Q (..., n-1, 8) (None when not ``quotient``: the remainder only), r1,
    r0 (..., 8). Real M divides left and right alike."""
    C = as_array(C)
    M = as_array(M)
    n = C.shape[-2] - 1
    c0 = M[..., 0:1]
    c1 = M[..., 1:2]
    rows = [C[..., k, :] for k in range(n + 1)]  # the running remainder, coefficient by coefficient
    Q = None
    for k in range(n, 1, -1):
        q = rows[k]
        rows[k - 1] = rows[k - 1] - c1 * q
        rows[k - 2] = rows[k - 2] - c0 * q
        if not quotient:
            continue
        if Q is None:  # (rows[k - 2] has the broadcast batch of C and M)
            Q = np.empty(rows[k - 2].shape[:-1] + (n - 1, 8), rows[k - 2].dtype)  # (every row written)
        Q[..., k - 2, :] = q
    if n < 2:  # degree 1: C is its own remainder
        Q = zeros(C.shape[:-2] + (1, 8), result_dtype(C, M)) if quotient else None
        return Q, rows[1].copy(), rows[0].copy()
    return Q, rows[1], rows[0]


def divide_linear_right(C, h, *, monic: bool = False):
    """C = D (t - h) + C(h): returns D (..., n, 8) and the remainder C(h) (..., 8), broadcast. ``monic``:
    the caller knows C's leading coefficient is exactly 1, whose product with h is h (one product fewer)."""
    C = as_array(C)
    h = as_array(h)
    n = C.shape[-2] - 1
    ds = [C[..., n, :]]  # the coefficients of D, from the top
    dh = h if monic else dq_mul(ds[0], h)
    for k in range(n - 1, 0, -1):
        ds.append(C[..., k, :] + dh)
        dh = dq_mul(ds[-1], h)
    rem = C[..., 0, :] + dh  # (the broadcast batch of C and h)
    D = np.empty(rem.shape[:-1] + (n, 8), rem.dtype)  # (every row written)
    for k, d in enumerate(reversed(ds)):
        D[..., k, :] = d
    return D, rem


def divide_right(C, D):
    """Right division C = Q D + R by D with invertible leading coefficient (docs/algorithm1.md)."""
    R = as_array(C).copy()
    D = as_array(D)
    n, m = R.shape[-2] - 1, D.shape[-2] - 1
    if n < m:
        return zeros(R.shape[:-2] + (1, 8), R.dtype), R
    lead_inv = dq_inv(D[..., m, :])
    Q = zeros(R.shape[:-2] + (n - m + 1, 8), result_dtype(R, D))
    for k in range(n, m - 1, -1):
        q = dq_mul(R[..., k, :], lead_inv)
        Q[..., k - m, :] = q
        R[..., k - m : k + 1, :] -= dq_mul(q[..., None, :], D)
    return Q, R[..., :m, :] if m > 0 else R[..., :1, :] * 0


def make_monic(C):
    """Divide (on the left) by the leading coefficient, which must be invertible."""
    C = as_array(C)
    return dq_mul(dq_inv(C[..., -1:, :]), C)


def relative_error(A, B):
    """max |A - B| / max(1, max |B|) over the last two axes."""
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    return np.max(np.abs(A - B), axis=(-2, -1)) / np.maximum(1.0, np.max(np.abs(B), axis=(-2, -1)))
