"""Bennett flip (docs/exceptional.md, section 4): (t - m)(t - h) = (t - k)(t - n).

With w = ~m - h (the remainder of (t-m)(t-h) by N(t-m) is w t + m(h - ~m)):

    n = w^-1 m w,     k = m + h - n,

so that N(t - n) = N(t - m) and N(t - k) = N(t - h). The flip exists iff primal(w) != 0; it fails
exactly when primal(h) = conj(primal(m)) (equal angle laws about opposite parallel directions: the
product is a translation). Coaxial (commuting) m, h give the trivial flip k = h, n = m.

Arithmetic is generic: Fractions (or ints) in give exact Fractions out; floats give numpy arrays.
The small helpers below (``dq_mul_any``, ...) work on any sequence of 8 numbers.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from synth.errors import SynthesisError

FLIP_TOL = 1e-10  # |primal(w)| <= tol * (|m| + |h|): no flip (floats)


class FlipError(SynthesisError):
    """The Bennett flip of (t - m)(t - h) does not exist (the product is a translation)."""


# ------------------------------------------------------------------ generic dual quaternions
def q_mul_any(a, b):
    """Hamilton product of two 4-sequences of any number type (ij = k)."""
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return [a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0]


def dq_mul_any(a, b):
    """(p1 + eps q1)(p2 + eps q2) = p1 p2 + eps (p1 q2 + q1 p2), any number type."""
    p = q_mul_any(a[:4], b[:4])
    q1 = q_mul_any(a[:4], b[4:])
    q2 = q_mul_any(a[4:], b[:4])
    return p + [x + y for x, y in zip(q1, q2)]


def dq_conj_any(a):
    return [a[0], -a[1], -a[2], -a[3], a[4], -a[5], -a[6], -a[7]]


def dq_inv_any(a):
    """Inverse of a dual quaternion with nonzero primal part: ~a / N(a), 1/(x + eps y) = 1/x - eps y/x^2."""
    c = dq_conj_any(a)
    x = sum(v * v for v in a[:4])
    y = 2 * sum(u * v for u, v in zip(a[:4], a[4:]))
    return [v / x for v in c[:4]] + [c[4 + i] / x - c[i] * y / (x * x) for i in range(4)]


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
    if exact:
        M = [Fraction(x) for x in m]
        H = [Fraction(x) for x in h]
    else:
        M = [float(x) for x in m]
        H = [float(x) for x in h]
    w = [a - b for a, b in zip(dq_conj_any(M), H)]
    pw = sum(x * x for x in w[:4])
    if exact:
        bad = pw == 0
    else:
        scale = float(np.linalg.norm(M)) + float(np.linalg.norm(H))
        bad = not np.isfinite(pw) or np.sqrt(pw) <= tol * max(scale, 1e-300)
    if bad:
        raise FlipError("no Bennett flip: the primal part of h is the conjugate of that of m (equal angle "
                        "laws about opposite parallel axes), so (t - m)(t - h) is a translation")
    n = dq_mul_any(dq_mul_any(dq_inv_any(w), M), w)
    k = [a + b - c for a, b, c in zip(M, H, n)]
    if exact:
        return k, n
    return np.array(k, float), np.array(n, float)


def flip_residual(m, h, k, n) -> float:
    """max |(t-m)(t-h) - (t-k)(t-n)| over the coefficients, relative to max(1, |coefficients|)."""
    m, h, k, n = ([float(x) for x in v] for v in (m, h, k, n))
    lhs1 = [-(a + b) for a, b in zip(m, h)]
    rhs1 = [-(a + b) for a, b in zip(k, n)]
    lhs0 = dq_mul_any(m, h)
    rhs0 = dq_mul_any(k, n)
    err = max(abs(a - b) for a, b in zip(lhs1 + lhs0, rhs1 + rhs0))
    return err / max(1.0, max(abs(x) for x in lhs1 + lhs0))
