"""Algorithm 1 (factorization of a monic motion polynomial into linear factors), batched.

Everything here works on a leading batch axis: ``C`` is ``(..., n+1, 8)`` (ascending powers of t,
monic: ``C[..., n, :] = 1``), dual quaternions are ``(..., 8)``. A single polynomial is a batch of one;
the enumeration of factorizations is a batch over orders; a 6R family scan is a batch over members and
orders. See docs/algorithm1.md for the theory and the worked numbers.

Algorithm 1. Let the norm polynomial ``N = C C~`` have the monic real quadratic factors
``M_1 .. M_n`` (one per conjugate pair of roots). For a chosen order (the quadratic of each factor, left
to right), from the right: write ``D mod M = r1 t + r0``; if ``r1`` is invertible, ``h = -r1^{-1} r0`` is
the unique right zero of ``D`` with ``N(t - h) = M``; divide ``D = D' (t - h)`` exactly and continue with
``D'``. Then ``C = (t - h_1) ... (t - h_n)``.
"""
from __future__ import annotations

import functools
import itertools

import numpy as np

from synth.algebra.dq import dot, dq_left_divide, dq_left_matrix, dq_right_matrix, row_offsets
from synth.algebra.polynomial import divide_linear_right, divide_real_quadratic, poly_mul, product_of_linear

GENERIC_TOL = 1e-9  # |primal(r1)| <= tol * max |primal(D_k)|: the remainder is not invertible
PRISMATIC_TOL = 1e-7  # |vec(primal h)| <= tol * (1 + |h0|): a translation factor, not a revolute one
FERRARI_MIN_BATCH = 32  # quartics from this batch size on start from Ferrari's formula (eigvals below)
_ONE = np.eye(8)[0]


def orders(n: int) -> np.ndarray:
    """All n! orders of n distinct quadratics, lexicographic, shape (n!, n)."""
    return np.array(list(itertools.permutations(range(n))), int).reshape(-1, n)


def distinct_orders(mult) -> list[tuple]:
    """The distinct orders (left to right) of quadratics 0, 1, ... repeated ``mult`` times, sorted
    lexicographically: the numbering of the factorizations in the float and the exact engine."""
    labels = np.repeat(np.arange(len(mult)), mult)
    return sorted(set(map(tuple, labels[orders(len(labels))].tolist())))


def norm_roots(N, newton: int = 2, ferrari: bool | None = None) -> np.ndarray:
    """One root of each conjugate pair of a real monic polynomial N (..., 2n+1) (ascending) without
    real roots: shape (..., n), Im z >= 0, sorted by Re z + 1e-12 Im z. Quartics (n = 2, the Bennett
    case) in batches of FERRARI_MIN_BATCH or more start from Ferrari's closed form, everything else (and
    quartics where Newton does not settle) from companion-matrix eigenvalues (batched
    ``numpy.linalg.eigvals``); then ``newton`` Newton steps on N. Real or repeated roots are not
    detected here (see `root_conditioning`). ``ferrari`` False: companion-matrix starts at every batch size,
    so each row's roots are the bits a batch of one gives (True: Ferrari's at every size)."""
    N = np.asarray(N, float)
    batch, m = N.shape[:-1], N.shape[-1] - 1
    flat = N.reshape(-1, m + 1)
    with np.errstate(all="ignore"):  # (for `_eig_upper` and `_newton` too)
        if m == 4 and (flat.shape[0] >= FERRARI_MIN_BATCH if ferrari is None else ferrari):
            z, step = _newton(flat, _ferrari_upper(flat), max(newton, 1) + 1)
            redo = ~(np.abs(step) <= 1e-10 * np.maximum(1.0, np.abs(z))).all(axis=-1) & np.isfinite(flat).all(axis=-1)
            if redo.any():
                z[redo] = _newton(flat[redo], _eig_upper(flat[redo]), newton)[0]
        else:
            z = _newton(flat, _eig_upper(flat), newton)[0]
    np.abs(z.imag, out=z.imag)  # (z is a fresh array) reflected into Im z >= 0
    key = z.imag * _TIE
    key += z.real
    order = key.argsort(axis=-1, kind="stable")
    z = z.reshape(-1)[order + row_offsets(*z.shape)]
    return z.reshape(batch + (m // 2,))


_TIE = np.array(1e-12)  # sort key Re z + 1e-12 Im z: equal real parts (up to rounding) ordered by Im z


def _eig_upper(flat):
    """The m/2 eigenvalues of the companion matrices of flat (B, m+1), reflected into Im z >= 0, one of
    each conjugate pair, sorted by (Re z, Im z) (NaN for a polynomial with a non-finite or zero leading
    coefficient). LAPACK returns the eigenvalues of a real matrix with each complex pair exactly
    conjugate, so after the reflection a pair is two equal values, adjacent after sorting, and every
    other sorted value takes each pair once (and, with real eigenvalues, m/2 - pairs of them). Called
    under ``numpy.errstate(all="ignore")`` (`norm_roots`)."""
    B, m = flat.shape[0], flat.shape[-1] - 1
    comp = np.zeros((B, m, m))
    comp[:, 1:, :-1] = identity(m - 1)  # the subdiagonal
    np.divide(flat[:, :m], -flat[:, m:], out=comp[:, :, -1])
    try:
        z = np.linalg.eigvals(comp)
    except np.linalg.LinAlgError:
        bad = ~np.isfinite(comp[:, :, -1]).all(axis=-1)
        if not bad.any():
            raise
        comp[bad, :, -1] = 0.0
        z = np.array(np.linalg.eigvals(comp), complex)
        z[bad] = np.nan
    z = np.asarray(z, complex)  # (eigvals gives a real array when every eigenvalue is real)
    np.abs(z.imag, out=z.imag)
    z.sort(axis=-1)  # (z is a fresh array)
    return z[:, ::2]


@functools.lru_cache(maxsize=None)
def identity(n: int) -> np.ndarray:
    """The identity matrix of size n (read-only, cached: small kernels build it on every call)."""
    e = np.eye(n)
    e.flags.writeable = False
    return e


def _newton(flat, z, steps):
    """``steps`` Newton steps on the real polynomials flat (B, m+1) at the complex points z (B, r),
    value and derivative by Horner's scheme (elementwise on (B, r): no per-polynomial matrix products;
    the coefficients are copied once to complex arrays of z's shape, so no step casts or broadcasts).
    Where the steps end non-finite (a vanishing derivative), z keeps its start and the step is inf.
    Returns (z, the last step). Called under ``numpy.errstate(all="ignore")`` (`norm_roots`)."""
    m = flat.shape[-1] - 1
    cols = np.empty((m + 1,) + z.shape, complex)  # cols[k] (B, r): the coefficient of t^k
    cols[...] = flat.T[:, :, None]
    z0 = z = np.array(z, complex)  # (contiguous)
    if steps < 1:
        return z, np.zeros(z.shape, complex)
    for _ in range(steps):
        val, der = cols[m] * z, cols[m]
        val += cols[m - 1]
        for k in range(m - 2, -1, -1):
            der = der * z
            der += val
            val *= z
            val += cols[k]
        step = val / der
        z = z - step
    fin = np.isfinite(z)
    if not fin.all():
        z = np.where(fin, z, z0)
        step = np.where(fin, step, np.inf)
    return z, step


def _ferrari_upper(flat):
    """Ferrari's closed form for the quartics flat (B, 5) (monic, ascending): the two roots with the
    largest imaginary parts, (B, 2). Depressed quartic y^4 + p y^2 + q y + r (t = y - n3/4), the
    largest real root m of the resolvent cubic, then two real quadratics; of each quadratic's two roots
    (a conjugate pair, or +-y for a biquadratic) the one with the larger imaginary part."""
    n0, n1, n2, n3 = (flat[:, k] / flat[:, 4] for k in range(4))
    s = n3 / 4.0
    ss = s * s
    p = n2 - 6.0 * ss
    q = n1 - s * (2.0 * n2 - 8.0 * ss)
    r = n0 - s * (n1 - s * (n2 - 3.0 * ss))
    mres = _largest_cubic_root(p, p * p / 4.0 - r, -q * q / 8.0)
    pos = mres > 0
    w = np.sqrt(np.where(pos, 2.0 * mres, 1.0))
    sgn = np.array([1.0, -1.0])
    half = 0.5 * sgn * w[:, None]  # -B/2 for the two quadratics y^2 + B y + Cq, B = -sgn w
    Cq = (p / 2.0 + mres)[:, None] + sgn * (q / (2.0 * w))[:, None]
    Z = half + np.sqrt((half * half - Cq).astype(complex))  # (B, 2): the root of each with Im >= 0
    # q = 0 (m = 0): a biquadratic, y^2 = -p/2 +- sqrt(p^2/4 - r), roots +-y
    bi = np.flatnonzero(~pos)
    if bi.size:
        pb = p[bi, None]
        y = np.sqrt(-pb / 2.0 + np.sqrt((pb * pb / 4.0 - r[bi, None]).astype(complex)) * sgn)
        Z[bi] = np.where(y.imag < 0, -y, y)
    return Z - s[:, None]


def _largest_cubic_root(b, c, d):
    """Largest real root of x^3 + b x^2 + c x + d (arrays): trigonometric form or Cardano, then Newton."""
    bb = b * b
    p = c - bb / 3.0
    q = 2.0 * bb * b / 27.0 - b * c / 3.0 + d
    p3 = p / 3.0
    disc = (q / 2.0) ** 2 + p3 * p3 * p3
    three = disc < 0
    r = np.sqrt(np.where(three, -p3, 0.0))
    arg = np.clip(-q / np.where(three, 2.0 * r * r * r, 1.0), -1.0, 1.0)
    sq = np.sqrt(np.where(three, 0.0, disc))
    x = np.where(three, 2.0 * r * np.cos(np.arccos(arg) / 3.0), np.cbrt(-q / 2.0 + sq) + np.cbrt(-q / 2.0 - sq)) - b / 3.0
    for _ in range(2):
        f = ((x + b) * x + c) * x + d
        df = (3.0 * x + 2.0 * b) * x + c
        x = x - np.where(df != 0, f / np.where(df != 0, df, 1.0), 0.0)
    return x


def root_conditioning(z) -> tuple[np.ndarray, np.ndarray]:
    """Distance of roots z (..., n) (Im z >= 0) from degeneracy, both in [0, 1):
    ``min Im z / (1 + |z|^2)`` (a real root: a real factor of the primal part, or a joint whose angle
    jumps) and ``min |z - z'| / (1 + max(|z|, |z'|)^2)`` (a repeated root: equal norm factors)."""
    z = np.asarray(z)
    w = np.square(np.abs(z))
    w += 1.0
    im = (np.abs(z.imag) / w).min(axis=-1)
    n = z.shape[-1]
    if n < 2:
        return im, np.ones(im.shape)
    ij = _pair_columns(n)  # i then j of every pair i < j
    p = ij.shape[0] // 2
    zz, ww = z.take(ij, axis=-1), w.take(ij, axis=-1)
    sep = (np.abs(zz[..., :p] - zz[..., p:]) / np.maximum(ww[..., :p], ww[..., p:])).min(axis=-1)
    return im, sep


@functools.lru_cache(maxsize=None)
def _pair_columns(n: int) -> np.ndarray:
    """The `index_pairs` of n items as one index array: every i, then every j (read-only, cached)."""
    out = np.concatenate(index_pairs(n))
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=None)
def index_pairs(n: int) -> tuple:
    """Index pairs i < j of n items (``numpy.triu_indices(n, 1)``; read-only, cached)."""
    out = np.triu_indices(n, 1)
    for a in out:
        a.flags.writeable = False
    return out


def quadratics(z) -> np.ndarray:
    """Monic real quadratics (..., n, 2) = [c0, c1] (t^2 + c1 t + c0) with the roots z, z-bar."""
    z = np.asarray(z)
    out = np.empty(z.shape + (2,))
    np.square(np.abs(z), out=out[..., 0])
    np.multiply(z.real, -2.0, out=out[..., 1])
    return out


def algorithm1(C, M, *, remainders: bool = False):
    """Algorithm 1 on monic motion polynomials C (..., n+1, 8) for the norm quadratics M (..., n, 2)
    of the factors, left to right (broadcast against C's batch). Returns the factors H (..., n, 8)
    (``C = (t - H[0]) ... (t - H[n-1])`` when all goes well) and ``ok`` (...,): every remainder had an
    invertible leading coefficient (GENERIC_TOL relative to C's primal part). Failed items hold
    finite garbage, not NaN. With ``remainders`` also R (..., n-1, 8), the remainders of the exact
    right divisions: dividing by t - H[p] (p >= 1) leaves R[p-1], and
    ``C - (t - H[0]) ... (t - H[n-1]) = sum_p R[p-1] (t - H[p+1]) ... (t - H[n-1])`` (`remainder_error`)."""
    C = np.asarray(C, float)
    M = np.asarray(M, float)
    n = C.shape[-2] - 1
    prim = dot(C[..., :4], C[..., :4]).max(axis=-1)  # (|primal| of the largest coefficient)^2
    prim *= GENERIC_TOL**2
    monic = bool((C[..., n, :] == _ONE).all())  # then so is every quotient D
    D, ok, hs, rs = C, None, [], []  # D: the quotient so far (broadcast against M by the first division)
    for pos in range(n - 1, 0, -1):
        _, r1, r0 = divide_real_quadratic(D, M[..., pos, :], quotient=False)
        good = dot(r1[..., :4], r1[..., :4]) > prim
        ok = good if ok is None else ok & good
        if not good.all():
            r1 = np.where(good[..., None], r1, _ONE)
        h = dq_left_divide(r1, r0)
        np.negative(h, out=h)
        hs.append(h)
        D, rem = divide_linear_right(D, h, monic=monic)
        rs.append(rem)
    # the last remainder D = D1 t + D0 is linear with the leading coefficient of C: h_1 = -D1^{-1} D0
    # (the remainder of D mod M_1, whatever M_1); D1 = 1 exactly when C is monic
    h = D[..., 0, :] if monic else dq_left_divide(D[..., 1, :], D[..., 0, :])
    batch = np.broadcast_shapes(h.shape[:-1], M.shape[:-2]) if n == 1 else hs[0].shape[:-1]
    H = np.empty(batch + (n, 8))
    np.negative(h, out=H[..., 0, :])
    for pos, h in zip(range(n - 1, 0, -1), hs):
        H[..., pos, :] = h
    R = np.empty(batch + (max(n - 1, 0), 8))
    for pos, rem in zip(range(n - 1, 0, -1), rs):
        R[..., pos - 1, :] = rem
    if ok is None:
        ok = np.ones(batch, bool)
    return (H, ok, R) if remainders else (H, ok)


def remainder_error(C, H, R) -> np.ndarray:
    """Relative multiply-back error of the factorizations H (..., n, 8) of C (..., n+1, 8) from the
    remainders R of `algorithm1` (``remainders=True``): max |C - (t - h_1)...(t - h_n)| / max(1, max |C|)
    without forming the product (for n = 3, one quaternion product instead of five); inf where not
    finite. Equals `multiply_back` up to rounding."""
    n = H.shape[-2]
    with np.errstate(all="ignore"):
        E = np.zeros(H.shape[:-2] + (1, 8)) if n < 2 else None  # (t^0..t^{n-2}) (broadcast against C below)
        for p in range(1, n):  # (the last remainder is multiplied by the empty product 1)
            term = (poly_mul(R[..., p - 1 : p, :], product_of_linear(H[..., p + 1 :, :]))
                    if p + 1 < n else R[..., p - 1 : p, :])
            if E is None:  # p = 1: all n - 1 coefficients (a fresh product for n > 2, never written for n = 2)
                E = term
            else:
                E[..., : n - p, :] += term
        scale = np.maximum(np.abs(C).max(axis=(-2, -1)), 1.0)
        r = np.abs(E).max(axis=(-2, -1)) / scale
    return np.where(np.isfinite(r), r, np.inf)


def multiply_back(C, H) -> np.ndarray:
    """Relative multiply-back error of the factorizations H (..., n, 8) of C (..., n+1, 8):
    max |(t - h_1)...(t - h_n) - C| / max(1, max |C|), inf where not finite."""
    with np.errstate(all="ignore"):
        E = product_of_linear(H) - C
        scale = np.maximum(1.0, np.abs(C).max(axis=(-2, -1)))
        r = np.abs(E).max(axis=(-2, -1)) / scale
    return np.where(np.isfinite(r), r, np.inf)


def study_violation(H) -> np.ndarray:
    """Largest Study-condition violation of the linear factors t - h, h (..., n, 8): the dual scalar
    part and v.w of each h must vanish (relative to max(1, |h|)). Shape (...)."""
    with np.errstate(all="ignore"):
        s = np.maximum(1.0, np.abs(H).max(axis=-1))
        v = (np.abs(H[..., 4]) + np.abs(np.sum(H[..., 1:4] * H[..., 5:8], -1)) / s) / s
        return np.max(v, axis=-1)


def is_translation(H) -> np.ndarray:
    """Which factors t - h (..., 8) are translations (no rotation part): |vec(primal h)| small."""
    return ~(np.sqrt(dot(H[..., 1:4], H[..., 1:4])) > PRISMATIC_TOL * (1 + np.abs(H[..., 0])))


def polish(C, H, iterations: int = 3, step_tol: float = 1e-10):
    """Newton's method on the product equations (t - h_1)...(t - h_n) = C (coefficients of t^0 .. t^{n-1},
    8n equations in the 8n unknowns) for factorizations H (..., n, 8) of C (..., n+1, 8), broadcast.
    A factorization with distinct norm quadratics is locally unique, so the Jacobian is regular and one
    or two steps bring the multiply-back error to rounding level; nearly real or nearly equal norm roots
    otherwise cost Algorithm 1 digits, and a badly conditioned start (residual ~1e-7) may need a third
    step (a 6R family member measured: 8.7e-8 -> 1.6e-12 after two steps, 8.9e-14 after three). A step is kept only where it lowers the residual; iteration stops
    after a step of at most ``step_tol`` (relative). Returns (polished H, largest absolute coefficient
    error of each product)."""
    C = np.asarray(C, float)
    n = C.shape[-2] - 1
    H = np.array(np.broadcast_to(H, np.broadcast_shapes(C.shape[:-2], np.shape(H)[:-2]) + (n, 8)), float)
    r = (product_of_linear(H) - C)[..., :n, :]
    rm = np.abs(r).max(axis=(-2, -1))
    tiny = 2e-16 * np.maximum(1.0, np.abs(C).max(axis=(-2, -1)))
    active = rm > tiny  # each product steps as it would alone: a batch gives every row its own result
    with np.errstate(all="ignore"):
        for _ in range(iterations):
            if not active.any():
                break
            D = _newton_step(_jacobian(H), -r.reshape(r.shape[:-2] + (8 * n, 1))).reshape(H.shape)
            Hn = H + np.where(np.isfinite(D), D, 0)
            rn = (product_of_linear(Hn) - C)[..., :n, :]
            rmn = np.abs(rn).max(axis=(-2, -1))
            better = (rmn < rm) & active
            H = np.where(better[..., None, None], Hn, H)
            r = np.where(better[..., None, None], rn, r)
            rm = np.where(better, rmn, rm)
            big = np.abs(D).max(axis=(-2, -1)) > step_tol * np.maximum(1.0, np.abs(H).max(axis=(-2, -1)))
            active = better & big
    return H, rm


def _newton_step(J, rhs):
    """The Newton steps J^-1 rhs (..., m, 1) of Jacobians J (..., m, m); NaN where J is singular (so that
    one singular product never stops the others)."""
    try:
        return np.linalg.solve(J, rhs)
    except np.linalg.LinAlgError:
        out = np.full(np.broadcast_shapes(J.shape[:-1], rhs.shape[:-2] + (J.shape[-1],)) + (1,), np.nan)
        J, rhs = np.broadcast_to(J, out.shape[:-1] + J.shape[-1:]), np.broadcast_to(rhs, out.shape)
        for idx in np.ndindex(out.shape[:-2]):
            try:
                out[idx] = np.linalg.solve(J[idx], rhs[idx])
            except np.linalg.LinAlgError:
                pass
        return out


def _jacobian(H):
    """Jacobian (..., 8n, 8n) of the coefficients t^0..t^{n-1} of (t - h_1)...(t - h_n) with respect to
    h_1..h_n (column-vector convention: a x = L(a) x, x a = R(a) x). The derivative in h_i is
    -A_i(t) dh_i B_i(t) with A_i = prod_{j<i} (t - h_j), B_i = prod_{j>i} (t - h_j)."""
    n = H.shape[-2]
    batch = H.shape[:-2]
    J = np.zeros(batch + (n, 8, n, 8))  # (coefficient k, component, factor i, component)
    for i in range(n):
        LA = np.swapaxes(dq_left_matrix(_prod(H[..., :i, :])), -1, -2)  # (..., i+1, 8, 8), column convention
        RB = np.swapaxes(dq_right_matrix(_prod(H[..., i + 1 :, :])), -1, -2)  # (..., n-i, 8, 8)
        P = LA[..., :, None, :, :] @ RB[..., None, :, :, :]  # (..., i+1, n-i, 8, 8): every LA[a] RB[b]
        for a in range(i + 1):
            for b in range(min(n - a, n - i)):  # coefficient k = a + b < n
                J[..., a + b, :, i, :] -= P[..., a, b, :, :]
    return J.reshape(batch + (8 * n, 8 * n))


def _prod(hs):
    """(t - h_1)...(t - h_m) for hs (..., m, 8), ascending coefficients (..., m+1, 8); 1 when m = 0."""
    if hs.shape[-2]:
        return product_of_linear(hs)
    out = np.zeros(hs.shape[:-2] + (1, 8))
    out[..., 0, 0] = 1.0
    return out
