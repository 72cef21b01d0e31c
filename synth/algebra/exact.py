"""Exact (rational) factorization of motion polynomials: Algorithm 1 (docs/algorithm1.md) in
``fractions.Fraction`` arithmetic.

Applies to monic motion polynomials with rational coefficients whose norm polynomial N(C) splits over
Q into monic quadratics (irreducible ones, and squares (t - r)^2 of rational real roots, which always
come with even multiplicity because N(C) >= 0 on R). Then every step of Algorithm 1 stays in Q, and
the factorizations come out exactly. The quadratics are ordered, and the orders enumerated, exactly as
in the numeric engine (`synth.algebra.factorize`), so factorization number k means the same in both;
factors are classified the same way (revolute when the vector part of the primal part is nonzero,
else a translation), with exact zero tests instead of tolerances.

Only the rational norm factorization and the exact zero tests are particular to this module: the
arithmetic is the dtype-generic `synth.algebra.dq` / `synth.algebra.polynomial` code on numpy object
arrays of Fractions, batched over the orders. Results are given as tuples of 8 Fractions [p0..p3,
q0..q3]; polynomials as lists of them, index = power of t (ascending). sympy is imported lazily, only
to factor N(C) over QQ.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from numbers import Rational

import numpy as np

from synth.algebra import dq as dqa
from synth.algebra import polynomial as poly
from synth.algebra.algorithm1 import distinct_orders
from synth.algebra.dq import exact_array
from synth.algebra.realpoly import real_divmod, real_gcd, real_root_count
from synth.algebra.text import poly_text
from synth.errors import InputError, NoFactorizationError, NotGenericError, SynthesisError

__all__ = [
    "to_fraction",
    "as_exact_polynomial",
    "check_exact_motion_polynomial",
    "factorize_exact",
    "ExactFactorization",
    "ExactFactorResult",
    "dq_mul",
    "dq_conj",
    "dq_inv",
    "poly_mul",
    "product_of_linear",
    "norm_poly",
    "real_divmod",
    "real_gcd",
    "real_root_count",
]

ZERO = Fraction(0)
ONE = Fraction(1)
_ID = (ONE,) + (ZERO,) * 7

NOT_RATIONAL_MESSAGE = ("the norm polynomial does not factor over the rationals; exact factorization "
                        "unavailable, drop --exact")


# ============================================================== numbers
def to_fraction(x, what: str = "coefficient") -> Fraction:
    """An exact rational from an int, Fraction, float (its shortest decimal representation, so 0.1 is
    1/10) or a string such as "3/4", "-2", "0.25", "1e-3". Raises InputError otherwise."""
    if isinstance(x, bool):
        raise InputError(f"{what}: expected a number, got {str(x).lower()}")
    if isinstance(x, Fraction):
        return x
    if isinstance(x, int):
        return Fraction(x)
    if isinstance(x, Rational):
        return Fraction(x.numerator, x.denominator)
    if isinstance(x, float):
        if not math.isfinite(x):
            raise InputError(f"{what}: {x} is not a finite number")
        return Fraction(repr(x))
    if isinstance(x, str):
        s = x.strip()
        if len(s) > 400:
            raise InputError(f"{what}: number text is too long ({len(s)} characters)")
        try:
            return Fraction(s)
        except (ValueError, ZeroDivisionError):
            shown = s if len(s) <= 40 else s[:40] + "..."
            raise InputError(f"{what}: {shown!r} is not a number (use e.g. 3, -0.25, \"3/4\")") from None
    raise InputError(f"{what}: expected a number, got {type(x).__name__}")


def as_exact_polynomial(rows) -> list[tuple[Fraction, ...]]:
    """Rows of 8 numbers (anything `to_fraction` accepts) as a list of 8-tuples of Fractions."""
    out = []
    for k, row in enumerate(rows):
        if not isinstance(row, (list, tuple)) or len(row) != 8:
            n = len(row) if isinstance(row, (list, tuple)) else type(row).__name__
            raise InputError(f"row {k} (coefficient of t^{k}) must hold 8 numbers, got {n}")
        out.append(tuple(to_fraction(x, f"row {k} (coefficient of t^{k})") for x in row))
    return out


# ============================================================== the algebra, exactly
# The dual-quaternion and polynomial routines of synth.algebra.dq / synth.algebra.polynomial applied to
# object arrays of Fractions; these adapters take rows of numbers and give tuples (polynomials: lists of
# tuples), the data layout of this module.
def _plain(x):
    """Exact arrays as tuples: (8,) -> tuple, (n+1, 8) -> list of tuples; tuples of arrays elementwise."""
    if isinstance(x, tuple):
        return tuple(_plain(v) for v in x)
    x = np.asarray(x, dtype=object)
    return tuple(x.tolist()) if x.ndim == 1 else [tuple(r) for r in x.tolist()]


def _exactly(func, convert=_plain):
    """``func`` applied to exact arrays of its arguments, the result converted back."""
    def exact_func(*args):
        return convert(func(*(exact_array(a) for a in args)))

    exact_func.__name__ = func.__name__
    exact_func.__doc__ = f"`{func.__module__}.{func.__name__}` in Fractions (tuples in, tuples out)."
    return exact_func


dq_mul = _exactly(dqa.dq_mul)
dq_conj = _exactly(dqa.dq_conj)
dq_inv = _exactly(dqa.dq_inv)  # ZeroDivisionError when the primal part is zero
poly_mul = _exactly(poly.poly_mul)
product_of_linear = _exactly(poly.product_of_linear)
divide_real_quadratic = _exactly(poly.divide_real_quadratic)  # C = Q M + (r1 t + r0): (Q, r1, r0)
norm_poly = _exactly(poly.norm_poly, list)  # N(C), ascending


def dq_neg(a):
    return tuple(-x for x in a)


# ============================================================== validation
def check_exact_motion_polynomial(C) -> None:
    """Monic (leading row exactly 1), degree >= 1, norm exactly real; InputError otherwise."""
    if len(C) < 2:
        raise InputError("a motion polynomial needs degree >= 1")
    if tuple(C[-1]) != _ID:
        raise InputError("the polynomial is not monic (leading coefficient must be 1)")
    F = poly.norm_poly_full(exact_array(C))
    if np.any(F[:, 1:] != 0):
        raise InputError("not a motion polynomial: its norm is not real (Study condition violated)")


# ============================================================== norm factors over Q
def _frac(r) -> Fraction:
    """sympy Rational -> Fraction."""
    return Fraction(int(r.p), int(r.q))


def rational_norm_quadratics(N):
    """Monic quadratic factors of the real polynomial N over Q, ordered like the numeric engine:
    irreducible quadratics (complex roots) by (Re z, Im z) of their root with Im z > 0, then squares
    (t - r)^2 of rational real roots by r. Returns (quadratics [(c0, c1)], multiplicities, real-pair
    flags). Raises SynthesisError when N does not split into rational quadratics."""
    import sympy  # lazily: only exact mode needs it

    t = sympy.Symbol("t")
    poly = sympy.Poly([sympy.Rational(c.numerator, c.denominator) for c in reversed(N)], t, domain="QQ")
    _, factors = poly.factor_list()
    complex_q, real_q = [], []
    for f, e in factors:
        coeffs = [_frac(c) for c in f.all_coeffs()]  # descending
        lead = coeffs[0]
        coeffs = [c / lead for c in coeffs]
        if len(coeffs) == 2:  # t + c0: a rational real root r = -c0
            if e % 2:
                raise SynthesisError("the norm polynomial has a real root of odd multiplicity "
                                     "(not a motion polynomial)")
            r = -coeffs[1]
            real_q.append(((r * r, -2 * r), e // 2, r))
        elif len(coeffs) == 3:
            c1, c0 = coeffs[1], coeffs[2]
            disc = c1 * c1 - 4 * c0
            if disc >= 0:  # irreducible over Q with two irrational real roots
                raise SynthesisError(NOT_RATIONAL_MESSAGE)
            complex_q.append(((c0, c1), e, (-c1 / 2, c0 - c1 * c1 / 4)))
        else:
            raise SynthesisError(NOT_RATIONAL_MESSAGE)
    complex_q.sort(key=lambda x: x[2])
    real_q.sort(key=lambda x: x[2])
    quads = [q for q, _, _ in complex_q] + [q for q, _, _ in real_q]
    mult = [m for _, m, _ in complex_q] + [m for _, m, _ in real_q]
    is_real = [False] * len(complex_q) + [True] * len(real_q)
    return quads, mult, is_real


# ============================================================== Algorithm 1
@dataclass
class ExactFactorization:
    factors: list  # n tuples of 8 Fractions: C = (t - factors[0]) ... (t - factors[n-1])
    order: tuple  # index into ExactFactorResult.quadratics of N(t - h_i), left to right
    kinds: list  # "revolute" / "translation" per factor
    residual: float = 0.0  # exact: every division remainder was exactly zero

    def floats(self):
        import numpy as np

        return np.array([[float(x) for x in h] for h in self.factors], float)


@dataclass
class ExactFactorResult:
    C: list
    norm: list  # N(C), ascending Fractions
    quadratics: list  # distinct monic quadratics (c0, c1)
    multiplicity: list
    factorizations: list
    generic: bool
    real_factor: list = field(default_factory=list)  # monic gcd of the primal components (ascending)
    failed_orders: list = field(default_factory=list)
    exact: bool = True


def classify_exact(h) -> str:
    return "revolute" if any(x != 0 for x in h[1:4]) else "translation"


def algorithm1_exact(C, quads, orders):
    """Algorithm 1 for the given orders (tuples of indices into the rational norm quadratics ``quads``
    (m, 2), left to right) of the exact C (n+1, 8). Orders that end alike share their right-hand steps:
    level L works on the distinct suffixes of length L as one batch. Returns (H (P, n, 8) exact, ok (P,)):
    ok where every remainder had a nonzero primal leading coefficient (an exact test), and then
    C = (t - H[p, 0])...(t - H[p, n-1]) exactly (asserted)."""
    n = C.shape[-2] - 1
    one = exact_array(_ID)
    index = {(): 0}  # suffix -> row in the current level's batch
    D, ok_prev = C[None], np.ones(1, bool)
    h_of, ok_of = {}, {}
    for L in range(1, n + 1):
        suffixes = sorted({tuple(o[n - L:]) for o in orders})
        D = D[[index[s[1:]] for s in suffixes]]
        ok = ok_prev[[index[s[1:]] for s in suffixes]]
        _, r1, r0 = poly.divide_real_quadratic(D, quads[[s[0] for s in suffixes]], quotient=False)
        good = np.any(r1[:, :4] != 0, axis=-1)
        ok &= good
        h = -dqa.dq_mul(dqa.dq_inv(np.where(good[:, None], r1, one)), r0)
        D, rem = poly.divide_linear_right(D, h)
        if np.any(rem[ok] != 0):  # pragma: no cover - impossible in exact arithmetic
            raise AssertionError("exact division by t - h left a remainder")
        index = {s: k for k, s in enumerate(suffixes)}
        h_of.update(zip(suffixes, h))
        ok_of.update(zip(suffixes, ok))
        ok_prev = ok
    if np.any(D[ok_prev] != one):  # pragma: no cover - impossible
        raise AssertionError("exact Algorithm 1 did not end with the constant 1")
    H = np.array([[h_of[tuple(o[pos:])] for pos in range(n)] for o in orders], dtype=object).reshape(-1, n, 8)
    return H, np.array([ok_of[tuple(o)] for o in orders], bool)


def factorize_exact(C, *, validate: bool = True) -> ExactFactorResult:
    """All factorizations of a monic rational motion polynomial C (rows of 8 numbers, constant term
    first) from Algorithm 1 in exact arithmetic. Orders whose remainder has a zero primal leading
    coefficient are skipped (``failed_orders``); when none succeeds, raises NotGenericError (primal part
    with a real factor) or NoFactorizationError. Raises SynthesisError when N(C) does not split into
    rational quadratics, InputError for invalid input."""
    C = as_exact_polynomial(C)
    if validate:
        check_exact_motion_polynomial(C)
    N = norm_poly(C)
    quads, mult, _ = rational_norm_quadratics(N)
    n = len(C) - 1
    if sum(mult) != n:  # cannot happen for a valid motion polynomial
        raise SynthesisError("the norm polynomial has the wrong degree")
    primal = [[row[d] for row in C] for d in range(4)]
    g = real_gcd(primal)
    generic = len(g) <= 1
    orders = distinct_orders(mult)
    H, ok = algorithm1_exact(exact_array(C), exact_array(quads), orders)
    facts = [ExactFactorization(factors=_plain(h), order=order, kinds=[classify_exact(x) for x in h])
             for order, h, good in zip(orders, H, ok) if good]
    failed = [order for order, good in zip(orders, ok) if not good]
    result = ExactFactorResult(C=C, norm=N, quadratics=quads, multiplicity=mult, factorizations=facts,
                               generic=generic, real_factor=g if not generic else [], failed_orders=failed)
    if not facts:
        if not generic:
            raise NotGenericError(
                f"not generic: the primal part has the real factor ({poly_text(g)}); Algorithm 1 "
                "finds no factorization into linear factors (try --cofactor)")
        raise NoFactorizationError("no factorization into linear factors was found")
    return result
