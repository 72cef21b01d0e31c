"""Dual quaternions as arrays of shape (..., 8) = [p0, p1, p2, p3, q0, q1, q2, q3] meaning p + eps q.

Conventions (docs/conventions.md): Hamilton product (ij = k); a point x is moved by
``x -> (p x p~ + p q~ - q p~) / N(p)``; the pose with rotation R (unit quaternion r) and translation d
is ``r - (eps/2) d r``; ``h1 h2`` acts as "first h2, then h1" like ``T1 @ T2``. Every function
broadcasts over leading batch axes. Lengths are in whatever unit the caller uses.

The algebra (qmul, qconj, qinv, dq_mul, dq_conj, dq_inv, dq_norm, the multiplication matrices,
study_condition, study_form) is dtype-generic: float input gives float64 arrays, numpy object arrays
of ``fractions.Fraction`` stay exact (the structure constants are integers). Geometry (poses, lines)
is float only.
"""
from __future__ import annotations

import functools
from fractions import Fraction

import numpy as np

_CONJ = np.array([1, -1, -1, -1, 1, -1, -1, -1])
_CONJ_F = _CONJ.astype(float)
_FLOAT = np.dtype(np.float64)


# ----------------------------------------------------------------- element types
def as_array(x) -> np.ndarray:
    """``x`` as a float64 array, or unchanged when it is an object array (exact Fractions)."""
    a = np.asarray(x)
    return a if a.dtype is _FLOAT or a.dtype.kind == "O" else a.astype(float)


def exact_array(x) -> np.ndarray:
    """``x`` (numbers, nested sequences) as an object array of Fractions (floats by their exact
    binary value)."""
    a = np.asarray(x, dtype=object)
    return np.vectorize(Fraction, otypes=[object])(a) if a.size else a


def zeros(shape, dtype) -> np.ndarray:
    """Zeros of ``dtype`` (float, or object filled with Fraction(0))."""
    if dtype is not _FLOAT and np.dtype(dtype) == object:
        return np.full(shape, Fraction(0), dtype=object)
    return np.zeros(shape, dtype)


@functools.lru_cache(maxsize=16)
def row_offsets(rows: int, cols: int) -> np.ndarray:
    """Flat offsets (rows, 1) of the rows of a C-contiguous (rows, cols) array (read-only, cached):
    ``a.reshape(-1)[idx + offsets]`` gathers ``a[i, idx[i, j]]`` in one indexing operation."""
    out = (np.arange(rows) * cols)[:, None]
    out.flags.writeable = False
    return out


def result_dtype(*arrays):
    """object when any input is an object array, else float64."""
    return object if any(np.asarray(a).dtype == object for a in arrays) else np.float64


def dot(a, b) -> np.ndarray:
    """Dot products along the last axis, (..., k) x (..., k) -> (...), broadcast; float arrays by one
    call of ``numpy.vecdot`` (numpy >= 2; else einsum): summing a product over a short last axis with
    ``.sum(-1)`` is several times slower on large batches; object arrays (exact) by a sum. (One strategy
    for every size: a faster sum of columns on large batches rounds differently from vecdot, and the
    6R scan's batch-versus-single agreement amplifies that to ~1e-9.)"""
    if a.dtype is _FLOAT and b.dtype is _FLOAT or a.dtype.kind != "O" and b.dtype.kind != "O":
        return _VECDOT(a, b)
    return np.asarray(np.sum(a * b, axis=-1))


def _einsum_dot(a, b):
    return np.einsum("...i,...i->...", a, b)


_VECDOT = getattr(np, "vecdot", _einsum_dot)


# ----------------------------------------------------------------- quaternions
def _quat_tensor():
    """Structure constants T[i, j, k]: (a b)_k = sum_ij a_i b_j T[i, j, k] (Hamilton, ij = k)."""
    T = np.zeros((4, 4, 4))
    e = np.eye(4)
    for i in range(4):
        for j in range(4):
            T[i, j] = _qmul_reference(e[i], e[j])
    return T


def _qmul_reference(a, b):
    a0, av, b0, bv = a[0], a[1:], b[0], b[1:]
    return np.concatenate([[a0 * b0 - av @ bv], a0 * bv + b0 * av + np.cross(av, bv)])


def _dual_tensor(T):
    D = np.zeros((8, 8, 8))
    D[:4, :4, :4] = T
    D[:4, 4:, 4:] = T
    D[4:, :4, 4:] = T
    return D


_QT = _quat_tensor()


def structure_constants() -> np.ndarray:
    """The integer structure constants D (8, 8, 8) of the dual quaternions in this layout:
    (a b)_k = sum_ij a_i b_j D[i, j, k]; entries 0 or +-1 (Hamilton, ij = k; eps^2 = 0)."""
    return _dual_tensor(_QT).astype(int)

_QT_FLAT = _QT.reshape(4, 16)
_DT_FLAT = _dual_tensor(_QT).reshape(8, 64)
_DT_RIGHT = _dual_tensor(_QT).transpose(1, 0, 2).reshape(8, 64)
# the same structure constants as Python ints, for exact (object) arrays
_EXACT = {id(T): T.astype(int).astype(object) for T in (_QT_FLAT, _DT_FLAT, _DT_RIGHT)}


def _constants(T, a):
    """The structure-constant matrix T for the element type of ``a``."""
    return _EXACT[id(T)] if a.dtype == object else T


def _sparse(T):
    """The nonzero structure constants of T (n, n, n) grouped by output component: (i, j, sign < 0,
    start of each component's run)."""
    i, j, k = np.nonzero(T)
    order = np.argsort(k, kind="stable")
    i, j, k = i[order], j[order], k[order]
    return i, j, T[i, j, k] < 0, np.searchsorted(k, np.arange(T.shape[2]))


_Q_SPARSE = _sparse(_QT)
_DQ_SPARSE = _sparse(_dual_tensor(_QT))


def _product(a, b, flat, sparse):
    """The bilinear product (a b)_k = sum_ij a_i b_j T[i, j, k] of the algebra with structure constants
    T (``flat`` = T reshaped (n, n*n), ``sparse`` = `_sparse` (T)): floats by the dense left-multiplication
    matrix, object arrays (exact) with only the nonzero T[i, j, k] = +-1."""
    if type(a) is not np.ndarray or a.dtype is not _FLOAT:
        a = as_array(a)
    if type(b) is not np.ndarray or b.dtype is not _FLOAT:
        b = as_array(b)
    if a.dtype is not _FLOAT or b.dtype is not _FLOAT:  # (as_array: float64 or object)
        i, j, neg, starts = sparse
        terms = a[..., i] * b[..., j]
        terms[..., neg] = -terms[..., neg]
        return np.add.reduceat(terms, starts, axis=-1)
    n = a.shape[-1]
    return _VECMAT(b, _linear_matrices(a, flat, (n, n)))


def _linear_matrices(x, T, shape) -> np.ndarray:
    """The matrices ``x @ T`` (..., *shape) of rows x (..., k) and constants T (k, r c) (row vectors: a
    product linear in x is ``y @ result``); a stack of rows (x.ndim > 2) as one GEMM rather than one
    product per matrix."""
    if x.ndim > 2 and x.size > 64:
        return (x.reshape(-1, x.shape[-1]) @ T).reshape(x.shape[:-1] + shape)
    return (x @ T).reshape(x.shape[:-1] + shape)


def _matmul_vecmat(b, L):
    return np.matmul(b[..., None, :], L)[..., 0, :]


_VECMAT = getattr(np, "vecmat", _matmul_vecmat)  # b @ L for row vectors b (numpy >= 2.2)


def qmul(a, b):
    """Hamilton product of quaternions (..., 4)."""
    return _product(a, b, _QT_FLAT, _Q_SPARSE)


def qconj(a):
    a = as_array(a)
    return a * _CONJ[:4]


def qinv(a):
    a = as_array(a)
    return qconj(a) / np.sum(a * a, axis=-1, keepdims=True)


def quat_to_matrix(r):
    """Rotation matrix (..., 3, 3) of a (not necessarily unit) quaternion (..., 4)."""
    r = np.asarray(r, float)
    r = r / np.linalg.norm(r, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(r, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def _shepperd_map():
    """The affine map R (9,) -> K (16,) with K = 4 q q^T for the unit quaternion q of R: K = R @ A + c."""
    A = np.zeros((3, 3, 4, 4))
    sign = {(0, 0): (1, 1, -1, -1), (1, 1): (1, -1, 1, -1), (2, 2): (1, -1, -1, 1)}
    for (i, _), s in sign.items():
        A[i, i] += np.diag(s)
    for (i, j), (a, b), sg in (((2, 1), (0, 1), 1), ((1, 2), (0, 1), -1), ((0, 2), (0, 2), 1), ((2, 0), (0, 2), -1),
                               ((1, 0), (0, 3), 1), ((0, 1), (0, 3), -1), ((0, 1), (1, 2), 1), ((1, 0), (1, 2), 1),
                               ((0, 2), (1, 3), 1), ((2, 0), (1, 3), 1), ((1, 2), (2, 3), 1), ((2, 1), (2, 3), 1)):
        A[i, j, a, b] += sg
        A[i, j, b, a] += sg
    return 4.0 * A.reshape(9, 16), 4.0 * np.eye(4).reshape(16)  # (times 4: see `matrix_to_quat`)


_SHEPPERD_A, _SHEPPERD_C = _shepperd_map()


def matrix_to_quat(R):
    """Unit quaternion (..., 4), w >= 0, of rotation matrices (..., 3, 3). Numerically stable for all
    angles (Shepperd's method): K = 4 q q^T is affine in R; the row of K with the largest diagonal
    entry K_kk = 4 q_k^2 is 4 q_k q, divided by s = 2 sqrt(K_kk) = 4 |q_k| (and q_k = s / 4). Computed
    as 4 K (exact: a power of two), whose row divided by sqrt(4 K_kk) = s is 4 q with 4 q_k = s, then
    normalized: the same bits as from K, two operations fewer."""
    R = np.asarray(R, float)
    batch = R.shape[:-2]
    K = R.reshape(-1, 9) @ _SHEPPERD_A
    K += _SHEPPERD_C  # (M, 16): 4 K
    row = K[:, ::5].argmax(axis=1)
    row += row_offsets(K.shape[0], 4)[:, 0]  # row 4i + k of K as (4M, 4) = the flat index of q_k in q (M, 4)
    q = K.reshape(-1, 4).take(row, axis=0)  # 16 q_k q
    s = np.sqrt(q.reshape(-1).take(row))  # sqrt(4 K_kk) = 4 |q_k| (q[i, k] = 4 K_kk)
    np.negative(s, out=s, where=q[:, 0] < 0)  # the sign giving w >= 0 (q_0 = 4 K_k0 / s)
    q /= s[:, None]  # 4 q
    q.reshape(-1)[row] = s
    q /= np.sqrt(dot(q, q))[:, None]
    return q.reshape(batch + (4,))


# ----------------------------------------------------------------- dual quaternions
def dq_left_matrix(a):
    """The 8x8 matrix L with (a b) = b @ L (row-vector convention), shape (..., 8, 8)."""
    a = as_array(a)
    return (a @ _constants(_DT_FLAT, a)).reshape(a.shape[:-1] + (8, 8))


def dq_right_matrix(a):
    """The 8x8 matrix R with (b a) = b @ R (row-vector convention), shape (..., 8, 8)."""
    a = as_array(a)
    return (a @ _constants(_DT_RIGHT, a)).reshape(a.shape[:-1] + (8, 8))


def dq_mul(a, b):
    """Dual quaternion product (..., 8) x (..., 8): (p1 + eps q1)(p2 + eps q2)."""
    return _product(a, b, _DT_FLAT, _DQ_SPARSE)


def dq_conj(h):
    """Quaternion conjugate of both parts: p~ + eps q~."""
    return as_array(h) * _CONJ


def dq_norm(h):
    """Dual-number norm h h~ = |p|^2 + eps 2 p.q, returned as (..., 2) = [primal, dual]."""
    h = as_array(h)
    p, q = h[..., :4], h[..., 4:]
    out = zeros(h.shape[:-1] + (2,), h.dtype)
    out[..., 0] = dot(p, p)
    out[..., 1] = 2 * dot(p, q)
    return out


def study_condition(h):
    """The Study form p . q (zero exactly on the Study quadric)."""
    h = as_array(h)
    return dot(h[..., :4], h[..., 4:])


def study_form(g, h):
    """Symmetric bilinear form B(g, h) = (p_g . q_h + p_h . q_g) / 2."""
    g = as_array(g)
    h = as_array(h)
    return dot(g, h.take(_SWAP, axis=-1)) / 2  # one dot with h's halves swapped (q_h + eps p_h)


_SWAP = np.array([4, 5, 6, 7, 0, 1, 2, 3])  # p + eps q -> q + eps p


def dq_inv(h):
    """Inverse (p must be nonzero): h~ / N(h) with 1/(a + eps b) = 1/a - eps b/a^2."""
    h = as_array(h)
    return _over_norm(h * (_CONJ_F if h.dtype is _FLOAT else _CONJ), h)


def _over_norm(x, a):
    """x (..., 8) divided, in place, by the dual number a a~ = |p|^2 + eps 2 p.q of a (..., 8) (p != 0):
    1/(u + eps w) = 1/u - eps w/u^2. Returns x."""
    p = a[..., :4]
    n = dot(p, p)[..., None]
    x /= n
    s = dot(p, a[..., 4:])[..., None]
    s /= n
    s += s  # 2 p.q / |p|^2
    x[..., 4:] -= x[..., :4] * s
    return x


def pose_to_dq(T):
    """4x4 pose(s) (..., 4, 4) to unit dual quaternion(s) (..., 8) with p0 >= 0: r - (eps/2) d r."""
    T = np.asarray(T, float)
    return translated(matrix_to_quat(T[..., :3, :3]), T[..., :3, 3])


def translated(h, v):
    """``translation_dq(v) h`` (the motion h, then the translation by v), (..., 8) and (..., 3), broadcast:
    p + eps (q - (v/2) p), one quaternion product (the dual-quaternion product with the translation's
    zeros left out, -1/2 folded into its structure constants). h may be a quaternion p (..., 4) (a
    rotation, q = 0)."""
    h = np.asarray(h, float)
    v = np.asarray(v, float)
    p = h[..., :4]
    vp = _VECMAT(p, _linear_matrices(v, _HALF_VECTOR, (4, 4)))  # -(v/2) p
    out = np.empty(vp.shape[:-1] + (8,))
    out[..., :4] = p
    if h.shape[-1] == 8:
        np.add(h[..., 4:], vp, out=out[..., 4:])
    else:
        out[..., 4:] = vp
    return out


_HALF_VECTOR = -0.5 * _QT_FLAT[1:]  # (3, 16): -(v/2) p = p @ (v @ this) (4, 4) (exact: a power of two)


def dq_translation(h, pp=None):
    """Translations (..., 3) of the poses of dual quaternions h (..., 8) (Study condition assumed, p != 0,
    any scale): d = 2 vec(p q~) / |p|^2 (`translation_split`). ``pp``: |p|^2 (...,), when the caller has it."""
    h = np.asarray(h, float)
    return np.stack(translation_split(np.moveaxis(h, -1, 0), pp), axis=-1)


_DT_CONJ_LEFT = _dual_tensor(_QT) * _CONJ[:, None, None]  # (a~ b)_k = sum_ij a_i b_j this[i, j, k]
_DT_CONJ_FLAT = _DT_CONJ_LEFT.reshape(8, 64)
_DQ_CONJ_SPARSE = _sparse(_DT_CONJ_LEFT)


def dq_left_divide(a, b):
    """a^-1 b for dual quaternions (..., 8), broadcast, a invertible (primal part p != 0): the product
    a~ b (the conjugate folded into the structure constants) divided by the dual number
    a a~ = |p|^2 + eps 2 p.q, with 1/(x + eps y) = 1/x - eps y/x^2 (no inverse formed). dtype-generic
    like `dq_mul`."""
    a = as_array(a)
    return _over_norm(_product(a, b, _DT_CONJ_FLAT, _DQ_CONJ_SPARSE), a)


def dq_to_pose(h):
    """Dual quaternion(s) (..., 8) with p != 0 (Study condition assumed) to 4x4 pose(s)."""
    h = np.asarray(h, float)
    p, q = h[..., :4], h[..., 4:]
    n = dot(p, p)[..., None]
    d = 2 * qmul(p, qconj(q))[..., 1:] / n
    T = np.zeros(h.shape[:-1] + (4, 4))
    T[..., :3, :3] = quat_to_matrix(p)
    T[..., :3, 3] = d
    T[..., 3, 3] = 1.0
    return T


def act_on_points(h, x):
    """Image of points x (..., 3) under the displacement h (..., 8)."""
    T = dq_to_pose(h)
    return np.einsum("...ij,...j->...i", T[..., :3, :3], x) + T[..., :3, 3]


def translation_dq(v):
    """Translation by v: 1 - (eps/2) v."""
    v = np.asarray(v, float)
    out = np.zeros(v.shape[:-1] + (8,))
    out[..., 0] = 1.0
    out[..., 5:] = -0.5 * v
    return out


def normalize_dq(h):
    """Scale to |p| = 1 and p0 >= 0 (the same pose)."""
    h = np.asarray(h, float)
    n = np.sqrt(dot(h[..., :4], h[..., :4]))[..., None]
    np.negative(n, out=n, where=h[..., :1] < 0)
    return h / n


# ----------------------------------------------------------------- split layout
# A "split" dual quaternion is a sequence of its 8 components, each an array (shapes broadcast) or None for
# a component known to be zero: plain arithmetic per component for large batches (the self-checks: jobs x
# samples), no small matrix products. The structure constants are `dq_mul`'s.
def _split_terms(T) -> tuple:
    """Per output component k of the structure constants T (n, n, m) (entries 0, +-1): the terms (i, j,
    negative) of its nonzero T[i, j, k], positive ones first."""
    return tuple(tuple(sorted(((int(i), int(j), bool(T[i, j, k] < 0)) for i, j in zip(*np.nonzero(T[:, :, k]))),
                              key=lambda term: term[2])) for k in range(T.shape[2]))


_DQ_TERMS = _split_terms(_dual_tensor(_QT))
_VEC_TERMS = _split_terms((_QT * _CONJ_F[:4, None])[:, :, 1:])  # vec(p q~)_k = sum_ij p_i q_j T[i, j, k]


def bilinear_split(a, b, terms) -> list:
    """The bilinear product of split a and b with the structure constants ``terms`` (`_split_terms`):
    components sum_ij +-a_i b_j in the order of the terms, None where every term has a zero factor."""
    shape = np.broadcast_shapes(*(np.shape(x) for x in (*a, *b) if x is not None))
    out, tmp = [], None
    for k_terms in terms:
        acc = None
        for i, j, neg in k_terms:
            if a[i] is None or b[j] is None:
                continue
            if acc is None:
                acc = np.multiply(a[i], b[j], out=np.empty(shape))
                if neg:
                    np.negative(acc, out=acc)
                continue
            tmp = np.multiply(a[i], b[j], out=tmp if tmp is not None else np.empty(shape))
            (np.subtract if neg else np.add)(acc, tmp, out=acc)
        out.append(acc)
    return out


def dq_mul_split(a, b) -> list:
    """`dq_mul` of split dual quaternions a, b (8 components each, broadcast; None: zero): a list of 8."""
    return bilinear_split(a, b, _DQ_TERMS)


def product_support(a, b) -> frozenset:
    """The components of a product of dual quaternions that can be nonzero when only the components ``a``
    of the left and ``b`` of the right factor are (sets of indices 0-7)."""
    return frozenset(k for k, terms in enumerate(_DQ_TERMS) if any(i in a and j in b for i, j, _ in terms))


def translation_split(h, pp=None) -> list:
    """The translation (3 components) of the pose of split dual quaternions h (Study condition assumed,
    p != 0, any scale): d = 2 vec(p q~) / |p|^2, as `dq_translation`. ``pp``: |p|^2 when the caller has it."""
    if pp is None:
        pp = square_sum(h[:4])
    scale = 2.0 / pp
    return [x * scale if x is not None else np.zeros(np.shape(scale)) for x in bilinear_split(h[:4], h[4:], _VEC_TERMS)]


def square_sum(x) -> np.ndarray:
    """sum_k x_k^2 of the components x (arrays, or None: zero), in order."""
    acc = None
    for c in x:
        if c is not None:
            if acc is None:
                acc = np.multiply(c, c)
            elif isinstance(acc, np.ndarray) and acc.ndim and acc.shape == np.shape(c):
                acc += c * c
            else:
                acc = acc + c * c
    return acc if acc is not None else np.zeros(())


# ----------------------------------------------------------------- lines
def plucker(h):
    """Plücker line (direction u, moment m) of a rotation h = a + v + eps w (v != 0):
    u = -v/|v|, m = w/|v| (`factor_lines`). Returns arrays (..., 3), (..., 3)."""
    lines = factor_lines(h)[0]
    return lines[..., 0, :], lines[..., 1, :]


def factor_lines(F) -> tuple[np.ndarray, np.ndarray]:
    """Lines (..., 2, 3) (direction u, moment m) and angle laws (..., 2) (a, b) of the joints t - h of
    the revolute factors F (..., 8), h = a + v + eps (q0 + w): b = |v|, u = -v / b, m = w / b."""
    F = np.asarray(F, float)
    laws = np.empty(F.shape[:-1] + (2,))
    laws[..., 0] = F[..., 0]
    vw = F.reshape(F.shape[:-1] + (2, 4))[..., 1:]
    np.sqrt(dot(vw[..., 0, :], vw[..., 0, :]), out=laws[..., 1])
    return vw / (_LINE_SIGNS * laws[..., 1, None, None]), laws


_LINE_SIGNS = np.array([[-1.0], [1.0]])  # u = -v / b, m = w / b
