"""Bennett flip (docs/exceptional.md): (t - m)(t - h) = (t - k)(t - n).

With w = ~m - h (the remainder of (t-m)(t-h) by N(t-m) is w t + m(h - ~m)):

    n = w^-1 m w,     k = m + h - n,

so that N(t - n) = N(t - m) and N(t - k) = N(t - h). The flip exists iff primal(w) != 0; it fails
exactly when primal(h) = conj(primal(m)) (equal angle laws about opposite parallel directions: the
product is a translation). Coaxial (commuting) m, h give the trivial flip k = h, n = m.

Arithmetic is the dtype-generic `synth.algebra.dq` code: Fractions (or ints) in give exact Fractions
out; floats give numpy arrays.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from synth.algebra.dq import dq_conj, dq_inv, dq_mul, exact_array
from synth.algebra.polynomial import product_of_linear, relative_error
from synth.errors import SynthesisError

FLIP_TOL = 1e-10  # |primal(w)| <= tol * (|m| + |h|): no flip (floats)


class FlipError(SynthesisError):
    """The Bennett flip of (t - m)(t - h) does not exist (the product is a translation)."""


def is_exact(*values) -> bool:
    """True when every entry is an int or a Fraction (not bool, not float)."""
    for v in values:
        for x in v:
            if isinstance(x, bool) or not isinstance(x, (int, Fraction)):
                return False
    return True


def rotation_defect(h) -> float:
    """How far t - h is from a rotation: max(|dual scalar|, |v . w|) relative to |v| (inf when v = 0)."""
    h = [float(x) for x in h]
    v, w = np.array(h[1:4]), np.array(h[5:8])
    nv = float(np.linalg.norm(v))
    if nv == 0.0:
        return float("inf")
    return max(abs(h[4]), abs(float(v @ w)) / nv) / max(1.0, nv, float(np.linalg.norm(w)))


def is_rotation(h, tol: float = 1e-9) -> bool:
    """t - h is a rotation: nonzero vector part of the primal, zero dual scalar, v . w = 0. Exact
    input is tested exactly."""
    if is_exact(h):
        v, w = h[1:4], h[5:8]
        return any(x != 0 for x in v) and h[4] == 0 and sum(a * b for a, b in zip(v, w)) == 0
    return rotation_defect(h) <= tol


# ------------------------------------------------------------------ the flip
def bennett_flip(m, h, *, tol: float = FLIP_TOL):
    """(k, n) with (t - m)(t - h) = (t - k)(t - n), N(t - n) = N(t - m), N(t - k) = N(t - h).

    ``m``, ``h``: 8 numbers each. All ints/Fractions -> exact lists of Fractions; otherwise float numpy
    arrays. Raises FlipError when primal(~m - h) = 0 (exactly, or within ``tol`` for floats)."""
    exact = is_exact(m, h)
    M, H = (exact_array(m), exact_array(h)) if exact else (np.asarray(m, float), np.asarray(h, float))
    w = dq_conj(M) - H
    pw = np.sum(w[:4] * w[:4])
    if exact:
        bad = pw == 0
    else:
        scale = float(np.linalg.norm(M)) + float(np.linalg.norm(H))
        bad = not np.isfinite(pw) or np.sqrt(pw) <= tol * max(scale, 1e-300)
    if bad:
        raise FlipError("no Bennett flip: the primal part of h is the conjugate of that of m (equal angle "
                        "laws about opposite parallel axes), so (t - m)(t - h) is a translation")
    n = dq_mul(dq_mul(dq_inv(w), M), w)
    k = M + H - n
    if exact:
        return k.tolist(), n.tolist()
    return k, n


def parallelogram_flip(m, h, *, tol: float = FLIP_TOL):
    """The flip when primal(h) = conj(primal(m)) (the product is a circular translation): not unique but a
    2-parameter family k = m - eps s, n = h + eps s, s perpendicular to the common axis direction
    (docs/exceptional.md, "Families of factorizations"); the four axes m, h, n, k form a parallelogram.

    Returns (k, n, s) for the member whose axes are those of m and h moved by d turned by the angle phi
    (cos phi = 3/5, sin phi = 4/5) about the direction of vec m, d = (axis point of h) - (axis point of m):
    s = (4/5) c d - (3/5) vec(m) x d, c = |vec m| (a rational approximation for exact input). The
    parallelogram is a rhombus (ground and crank of length |d|). Raises FlipError when the two axes
    coincide (the product is the identity)."""
    exact = is_exact(m, h)
    M = [Fraction(x) for x in m] if exact else np.asarray(m, float)
    H = [Fraction(x) for x in h] if exact else np.asarray(h, float)
    v = M[1:4]
    vv = sum(x * x for x in v)
    # axis point of t - x (x = a + v + eps w): -(v x w) / |v|^2; the same formula holds for h (vector -v)
    def point(x):
        a, b = x[1:4], x[5:8]
        cr = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        return [-c / vv for c in cr]

    d = [p - q for p, q in zip(point(H), point(M))]
    size = sum(x * x for x in d)
    scale = float(sum(abs(float(x)) for x in list(M) + list(H)))
    if (size == 0) if exact else float(size) ** 0.5 <= tol * max(scale, 1e-300):
        raise FlipError("no Bennett flip: the two axes coincide with opposite directions and equal angle laws, "
                        "so (t - m)(t - h) is the identity")
    c = float(vv) ** 0.5
    if exact:
        c = Fraction(c).limit_denominator(10**6) if Fraction(c) ** 2 != vv else Fraction(c)
    # s = c (sin d - cos (v x d) / c'), c' = |v|: the axes move by d turned by phi about the direction of v,
    # cos phi = 3/5, sin phi = 4/5 (rational; a rhombus whose flat configurations, at phi and phi + pi of the
    # crank, fall between the whole-degree steps of a drive)
    vxd = [v[1] * d[2] - v[2] * d[1], v[2] * d[0] - v[0] * d[2], v[0] * d[1] - v[1] * d[0]]
    cos, sin = (Fraction(3, 5), Fraction(4, 5)) if exact else (0.6, 0.8)
    s = [sin * c * x - cos * y for x, y in zip(d, vxd)]
    K = list(M[:5]) + [M[5 + i] - s[i] for i in range(3)]
    N = list(H[:5]) + [H[5 + i] + s[i] for i in range(3)]
    if exact:
        return K, N, s
    return np.array(K, float), np.array(N, float), np.array(s, float)


def flip_residual(m, h, k, n) -> float:
    """max |(t-m)(t-h) - (t-k)(t-n)| over the coefficients, relative to max(1, |coefficients|)."""
    lhs = product_of_linear(np.array([m, h], float))
    rhs = product_of_linear(np.array([k, n], float))
    return float(relative_error(rhs, lhs))
