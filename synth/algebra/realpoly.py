"""Real polynomials (ascending coefficient sequences): the helpers every module of synth.algebra shares.

Two kinds of input, the same conventions (index = power of t):

- exact: sequences of Fractions/ints (`trim`, `real_divmod`, `real_gcd`, `real_root_count`): Euclid
  and Sturm over Q, used by the exact factorization and the maximal real factor
  (docs/exceptional.md);
- float: numpy arrays (`real_mul`, `real_pow`, `quad`, `quadratic_roots`, `divide_real`, `mod_real`),
  also applied column-wise to (n+1, c) arrays of real polynomials (e.g. the components of a
  quaternion polynomial).

`synth.algebra.text.poly_text` prints either kind.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np


# ------------------------------------------------------------------ exact (over Q)
def trim(p) -> list:
    """The coefficients without trailing (highest-power) zeros, as a new list."""
    p = list(p)
    while p and p[-1] == 0:
        p.pop()
    return p


def real_divmod(a, b) -> tuple[list, list]:
    """(quotient, remainder) of real polynomials over Q (ascending; b nonzero), both trimmed."""
    a = trim(a)
    b = trim(b)
    q = [0] * max(len(a) - len(b) + 1, 0)
    while len(a) >= len(b) and a:
        f = a[-1] / b[-1]
        s = len(a) - len(b)
        q[s] = f
        for i, c in enumerate(b):
            a[s + i] -= f * c
        a = trim(a)
    return trim(q), a


def real_gcd(polys) -> list[Fraction]:
    """Monic gcd over Q of real polynomials (ascending); [1] when coprime, [] when all are zero."""
    g: list[Fraction] = []
    for p in polys:
        p = trim(p)
        while p:
            g, p = p, real_divmod(g, p)[1]
    if not g:
        return []
    return [c / g[-1] for c in g]


def real_root_count(p) -> int:
    """Number of distinct real zeros of a nonzero real polynomial over Q (ascending), by Sturm's theorem."""
    p = trim(p)
    seq = [p, trim([k * c for k, c in enumerate(p)][1:])]
    while seq[-1]:
        seq.append([-c for c in real_divmod(seq[-2], seq[-1])[1]])
    seq.pop()

    def changes(signs):
        signs = [s for s in signs if s]
        return sum(a != b for a, b in zip(signs, signs[1:]))

    at_plus = [(q[-1] > 0) - (q[-1] < 0) for q in seq]
    at_minus = [s if (len(q) - 1) % 2 == 0 else -s for s, q in zip(at_plus, seq)]
    return changes(at_minus) - changes(at_plus)


# ------------------------------------------------------------------ float
def real_mul(a, b) -> np.ndarray:
    """Product of two real polynomials (ascending floats)."""
    return np.convolve(np.asarray(a, float), np.asarray(b, float))


def real_pow(a, k: int) -> np.ndarray:
    """a^k (ascending floats); 1 for k = 0."""
    out = np.ones(1)
    for _ in range(k):
        out = real_mul(out, a)
    return out


def quad(M) -> np.ndarray:
    """Ascending coefficients [c0, c1, 1] of the monic quadratic M = [c0, c1] (t^2 + c1 t + c0)."""
    return np.array([M[0], M[1], 1.0])


def quadratic_roots(M) -> tuple[float, float]:
    """(alpha, beta) with t^2 + c1 t + c0 = (t - alpha)^2 + beta^2 for M = [c0, c1] (beta >= 0; 0 when
    the roots are real)."""
    c0, c1 = float(M[0]), float(M[1])
    alpha = -c1 / 2
    return alpha, float(np.sqrt(max(c0 - alpha * alpha, 0.0)))


def divide_real(P, g) -> np.ndarray:
    """Quotient P / g of the real polynomials in the columns of P (n+1, c) by the real monic g, by
    least squares (exact when g divides every column)."""
    P = np.asarray(P, float)
    return np.linalg.lstsq(conv_matrix(g, P.shape[0] - len(g) + 1), P, rcond=None)[0]


def mod_real(E, M) -> np.ndarray:
    """Remainder of the columns of E (n, c) modulo the monic real polynomial M (ascending)."""
    E = np.array(E, float)
    d = len(M) - 1
    for k in range(E.shape[0] - 1, d - 1, -1):
        c = E[k].copy()
        E[k - d:k + 1] -= np.outer(M, c)
    return E[:d]


def conv_matrix(a, n_cols) -> np.ndarray:
    """Matrix A with A @ x = coefficients of a * x (x of length n_cols)."""
    a = np.asarray(a, float)
    A = np.zeros((len(a) + n_cols - 1, n_cols))
    for j in range(n_cols):
        A[j:j + len(a), j] = a
    return A


def compose_affine(C, sigma, tau) -> np.ndarray:
    """C(sigma s + tau) / sigma^n as polynomials in s, for the columns of C (n+1, c) (monic stays monic)."""
    C = np.asarray(C, float)
    n = C.shape[0] - 1
    out = np.zeros((1, C.shape[1]))
    out[0] = C[n]
    for k in range(n - 1, -1, -1):
        # out = out * (sigma s + tau) + C[k]
        new = np.zeros((out.shape[0] + 1, C.shape[1]))
        new[1:] += sigma * out
        new[:-1] += tau * out
        new[0] += C[k]
        out = new
    return out / sigma**n
