"""The maximal real polynomial factor mrpf(P) of a motion polynomial's primal part
(docs/exceptional.md).

mrpf(P) = g = the monic gcd of the four real component polynomials p0..p3 of P. Algorithm 1 is
guaranteed to work when deg g = 0 (generic). C is **bounded** iff g has no real zero (a real zero of
N(P) = sum p_i^2 is a common zero of all p_i); unbounded motions need a prismatic joint.

- exact (`mrpf_exact`): Euclid's gcd over Q for rational coefficients (ints / Fractions);
  boundedness from a Sturm count of g's real zeros;
- numeric (`mrpf_numeric`): the generalized Sylvester matrix S (rows t^j p_i, j < n) has the row space
  {multiples of g of degree < 2n}, so deg g = 2n - rank S (singular values > tol * sigma_max); g is
  the row-space vector with zero coefficients above deg g; Gauss-Newton then polishes g on
  sum_i min_q |p_i - g q|^2.

Real polynomials are ascending coefficient sequences (numpy float arrays, or lists of Fractions).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from synth.algebra.factorize import norm_quadratics
from synth.algebra.realpoly import conv_matrix, real_gcd, real_root_count
from synth.algebra.text import poly_text
from synth.errors import InputError, SynthesisError

__all__ = ["RealFactor", "UnboundedMotionError", "mrpf", "mrpf_exact", "mrpf_numeric", "real_gcd_exact",
           "real_gcd_numeric", "require_bounded", "poly_text", "NUMERIC_TOL"]

NUMERIC_TOL = 1e-9


class UnboundedMotionError(SynthesisError, ValueError):
    """The primal part has a real zero: the motion is unbounded and needs a sliding (prismatic) joint."""


@dataclass
class RealFactor:
    """mrpf(P) of a motion polynomial."""

    g: np.ndarray  # monic, ascending (float)
    exact: list | None  # the same as Fractions when computed exactly
    bounded: bool
    quadratics: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (m, 2) [c0, c1] of g
    multiplicity: list = field(default_factory=list)
    real_roots: list = field(default_factory=list)  # real zeros of g (unbounded case)

    @property
    def degree(self) -> int:
        return len(self.g) - 1

    @property
    def generic(self) -> bool:
        return self.degree == 0

    def text(self) -> str:
        return poly_text(self.exact if self.exact is not None else self.g)


# ------------------------------------------------------------------ helpers
def _rows(C):
    """Coefficient rows of C as a list of 8-lists, and whether they are exact."""
    if isinstance(C, np.ndarray):
        return [list(map(float, r)) for r in np.asarray(C, float)], False
    rows = [list(r) for r in C]
    exact = all(isinstance(x, (int, Fraction)) and not isinstance(x, bool) for r in rows for x in r)
    if exact:
        return [[Fraction(x) for x in r] for r in rows], True
    return [[float(x) for x in r] for r in rows], False


# ------------------------------------------------------------------ exact
def mrpf_exact(C) -> tuple[list, bool]:
    """(g as ascending Fractions, monic; bounded) for a polynomial with rational coefficients
    (rows of 8 ints/Fractions; only the primal columns 0..3 are used)."""
    return real_gcd_exact(C, columns=range(4))


def real_gcd_exact(C, columns=None) -> tuple[list, bool]:
    """(monic gcd as ascending Fractions; True when it has no real zero) of the given columns of the
    rational coefficient rows C (default: all columns)."""
    rows, exact = _rows(C)
    if not exact:
        rows = [[Fraction(x) for x in r] for r in rows]
    cols = range(len(rows[0])) if columns is None else columns
    g = real_gcd([r[i] for r in rows] for i in cols)
    if not g:
        raise InputError("the polynomials are all zero (for a motion: its primal part is zero)")
    return g, len(g) == 1 or real_root_count(g) == 0


# ------------------------------------------------------------------ numeric
def _polish(P, g, iterations=6):
    """Gauss-Newton on sum_i |p_i - g q_i|^2 over the lower coefficients of the monic g and the q_i."""
    n = P.shape[0] - 1
    nc = P.shape[1]
    d = len(g) - 1
    if d == 0:
        return g
    m = n - d + 1  # coefficients of each q_i
    g = np.array(g, float)

    def quotients(g):
        G = conv_matrix(g, m)
        return np.linalg.lstsq(G, P, rcond=None)[0]  # (m, 4)

    Qs = quotients(g)
    res = P - conv_matrix(g, m) @ Qs
    for _ in range(iterations):
        G = conv_matrix(g, m)
        # unknowns: g_0..g_{d-1}, then Q (m x 4) column-major by component
        J = np.zeros(((n + 1) * nc, d + nc * m))
        for i in range(nc):
            rows = slice(i * (n + 1), (i + 1) * (n + 1))
            for l in range(d):
                col = np.zeros(n + 1)
                col[l:l + m] = Qs[:, i]
                J[rows, l] = col
            J[rows, d + i * m:d + (i + 1) * m] = G
        r = (P - G @ Qs).T.reshape(-1)
        step = np.linalg.lstsq(J, r, rcond=None)[0]
        g_new = g.copy()
        g_new[:d] += step[:d]
        Q_new = Qs + step[d:].reshape(nc, m).T
        res_new = P - conv_matrix(g_new, m) @ Q_new
        if np.linalg.norm(res_new) >= np.linalg.norm(res):
            break
        g, Qs, res = g_new, Q_new, res_new
    return g


def mrpf_numeric(C, tol: float = NUMERIC_TOL) -> np.ndarray:
    """Monic g = mrpf(P) (ascending floats) of a monic motion polynomial C (n+1, 8) in floating point,
    rank decisions relative to ``tol`` (see the module docstring)."""
    return real_gcd_numeric(np.asarray(C, float)[:, :4], tol)


def real_gcd_numeric(P, tol: float = NUMERIC_TOL) -> np.ndarray:
    """Monic gcd (ascending floats) of the columns of P (n+1, c), real polynomials of degree <= n with
    at least one of degree n, by the generalized Sylvester matrix (see the module docstring)."""
    P = np.asarray(P, float)
    n = P.shape[0] - 1
    c = P.shape[1]
    if n < 1:
        return np.ones(1)
    scale = np.max(np.abs(P))
    Ps = P / scale
    S = np.zeros((c * n, 2 * n))
    for i in range(c):
        for j in range(n):
            S[i * n + j, j:j + n + 1] = Ps[:, i]
    _, sv, Vt = np.linalg.svd(S)
    rank = int(np.sum(sv > tol * sv[0]))
    d = 2 * n - rank
    if d <= 0:
        return np.ones(1)
    V = Vt[:rank]  # row-space basis (rank, 2n)
    A = V[:, d + 1:]  # coefficients above degree d must vanish
    _, _, Wt = np.linalg.svd(A.T)
    c = Wt[-1]
    g = (c @ V)[: d + 1]
    g = g / g[-1]
    return _polish(P, g)


# ------------------------------------------------------------------ dispatch
def _quadratic_split(g):
    if len(g) <= 1:
        return np.zeros((0, 2)), []
    quads, mult, _roots = norm_quadratics(np.asarray(g, float))
    return quads, list(mult)


def mrpf(C, *, tol: float = NUMERIC_TOL, exact: bool | None = None) -> RealFactor:
    """mrpf(P) of C: exact when C holds only ints/Fractions (or ``exact=True``), numeric otherwise.
    Also splits g into real monic quadratics (with multiplicities) when it is bounded."""
    rows, is_ex = _rows(C)
    use_exact = is_ex if exact is None else exact
    if use_exact:
        g_ex, bounded = mrpf_exact(rows)
        g = np.array([float(x) for x in g_ex])
    else:
        g_ex = None
        g = mrpf_numeric(np.array(rows, float), tol)
        bounded = True
    real_roots = []
    if len(g) > 1:
        z = np.roots(g[::-1])
        scale = np.maximum(1.0, np.abs(z))
        real_roots = sorted(float(x.real) for x in z[np.abs(z.imag) <= 1e-7 * scale])
        if not use_exact:
            bounded = not real_roots
    quads, mult = _quadratic_split(g) if bounded else (np.zeros((0, 2)), [])
    return RealFactor(g=g, exact=g_ex, bounded=bool(bounded), quadratics=quads, multiplicity=mult,
                      real_roots=real_roots)


def require_bounded(rf: RealFactor) -> None:
    """Raise UnboundedMotionError for an unbounded motion (a real zero of mrpf(P))."""
    if not rf.bounded:
        roots = ", ".join(f"{x:.6g}" for x in rf.real_roots) or "?"
        raise UnboundedMotionError(
            f"unbounded motion: the primal part has the real factor {rf.text()} (real zero t = {roots}); "
            "it needs a sliding joint (prismatic), which mpsynth does not build")
