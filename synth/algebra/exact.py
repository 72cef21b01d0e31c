"""Exact (rational) factorization of motion polynomials: Algorithm 1 (docs/algorithm1.md) in
``fractions.Fraction`` arithmetic.

Applies to monic motion polynomials with rational coefficients whose norm polynomial N(C) splits over
Q into monic quadratics (irreducible ones, and squares (t - r)^2 of rational real roots, which always
come with even multiplicity because N(C) >= 0 on R). Then every step of Algorithm 1 stays in Q, and
the factorizations come out exactly. The quadratics are ordered, and the orders enumerated, exactly as
in the numeric engine (`synth.algebra.factorize`), so factorization number k means the same in both; factors are
classified the same way (revolute when the vector part of the primal part is nonzero, else a
translation), with exact zero tests instead of tolerances.

Dual quaternions here are tuples of 8 Fractions [p0..p3, q0..q3]; polynomials are lists of them,
index = power of t (ascending), like the numpy layout. sympy is imported lazily, only to factor N(C)
over QQ.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from numbers import Rational

from synth.algebra.scalar import qmul as q_mul  # generic over the element type: Fractions here
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


# ============================================================== dual quaternions
def _add4(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3])


def dq_mul(a, b):
    """(p1 + eps q1)(p2 + eps q2) = p1 p2 + eps (p1 q2 + q1 p2)."""
    p1, q1, p2, q2 = a[:4], a[4:], b[:4], b[4:]
    return q_mul(p1, p2) + _add4(q_mul(p1, q2), q_mul(q1, p2))


def dq_add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def dq_sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def dq_neg(a):
    return tuple(-x for x in a)


def dq_scale(a, s):
    return tuple(x * s for x in a)


def dq_conj(h):
    return (h[0], -h[1], -h[2], -h[3], h[4], -h[5], -h[6], -h[7])


def dq_inv(h):
    """h^-1 = h~ / N(h) with 1/(a + eps b) = 1/a - eps b/a^2 (the primal part must be nonzero)."""
    a = h[0] * h[0] + h[1] * h[1] + h[2] * h[2] + h[3] * h[3]
    if a == 0:
        raise ZeroDivisionError("dual quaternion with zero primal part is not invertible")
    b = 2 * (h[0] * h[4] + h[1] * h[5] + h[2] * h[6] + h[3] * h[7])
    c = dq_conj(h)
    return tuple(x / a for x in c[:4]) + tuple(c[4 + i] / a - c[i] * b / (a * a) for i in range(4))


def is_zero(h) -> bool:
    return all(x == 0 for x in h)


# ============================================================== polynomials
def poly_mul(A, B):
    out = [(ZERO,) * 8 for _ in range(len(A) + len(B) - 1)]
    for i, a in enumerate(A):
        for j, b in enumerate(B):
            out[i + j] = dq_add(out[i + j], dq_mul(a, b))
    return out


def linear(h):
    """t - h."""
    return [dq_neg(h), _ID]


def product_of_linear(hs):
    C = linear(hs[0])
    for h in hs[1:]:
        C = poly_mul(C, linear(h))
    return C


def norm_poly_full(C):
    return poly_mul(C, [dq_conj(c) for c in C])


def norm_poly(C) -> list[Fraction]:
    """The real norm polynomial N(C), ascending (the primal scalar part of C C~)."""
    return [row[0] for row in norm_poly_full(C)]


def divide_real_quadratic(C, M):
    """C = Q M + (r1 t + r0) for M = t^2 + M[1] t + M[0]; returns (Q, r1, r0)."""
    c0, c1 = M
    R = [list(row) for row in C]
    n = len(C) - 1
    Q = [(ZERO,) * 8 for _ in range(max(n - 1, 1))]
    for k in range(n, 1, -1):
        q = tuple(R[k])
        Q[k - 2] = q
        R[k - 1] = [x - c1 * y for x, y in zip(R[k - 1], q)]
        R[k - 2] = [x - c0 * y for x, y in zip(R[k - 2], q)]
    return Q, tuple(R[1]), tuple(R[0])


def divide_linear_right(C, h):
    """C = D (t - h) + C(h): returns (D, remainder)."""
    n = len(C) - 1
    D = [None] * n
    d = tuple(C[n])
    D[n - 1] = d
    for k in range(n - 1, 0, -1):
        d = dq_add(C[k], dq_mul(d, h))
        D[k - 1] = d
    return D, dq_add(C[0], dq_mul(d, h))


def evaluate(C, t):
    """C(t) for a rational t."""
    t = Fraction(t)
    out = C[-1]
    for c in reversed(C[:-1]):
        out = dq_add(dq_scale(out, t), c)
    return out


# ---------------------------------------------------------------- real polynomials (ascending)
def _rtrim(p):
    p = list(p)
    while p and p[-1] == 0:
        p.pop()
    return p


def real_divmod(a, b) -> tuple[list, list]:
    """(quotient, remainder) of real polynomials over Q (ascending; b nonzero), both trimmed."""
    a = _rtrim(a)
    b = _rtrim(b)
    q = [0] * max(len(a) - len(b) + 1, 0)
    while len(a) >= len(b) and a:
        f = a[-1] / b[-1]
        s = len(a) - len(b)
        q[s] = f
        for i, c in enumerate(b):
            a[s + i] -= f * c
        a = _rtrim(a)
    return _rtrim(q), a


def _rmod(a, b):
    return real_divmod(a, b)[1]


def real_gcd(polys) -> list[Fraction]:
    """Monic gcd over Q of real polynomials (ascending); [1] when coprime, [] when all are zero."""
    g: list[Fraction] = []
    for p in polys:
        p = _rtrim(p)
        while p:
            g, p = p, _rmod(g, p)
    if not g:
        return []
    return [c / g[-1] for c in g]


def real_root_count(p) -> int:
    """Number of distinct real zeros of a nonzero real polynomial over Q (ascending), by Sturm's theorem."""
    p = _rtrim(p)
    seq = [p, _rtrim([k * c for k, c in enumerate(p)][1:])]
    while seq[-1]:
        seq.append([-c for c in _rmod(seq[-2], seq[-1])])
    seq.pop()

    def changes(signs):
        signs = [s for s in signs if s]
        return sum(a != b for a, b in zip(signs, signs[1:]))

    at_plus = [(q[-1] > 0) - (q[-1] < 0) for q in seq]
    at_minus = [s if (len(q) - 1) % 2 == 0 else -s for s, q in zip(at_plus, seq)]
    return changes(at_minus) - changes(at_plus)


def real_poly_text(p) -> str:
    """Readable text of a monic real polynomial, descending powers: 't^2 + 1'."""
    terms = []
    for k in range(len(p) - 1, -1, -1):
        c = p[k]
        if c == 0:
            continue
        mono = "" if k == 0 else ("t" if k == 1 else f"t^{k}")
        mag = abs(c)
        body = (str(mag) if (mag != 1 or not mono) else "") + ((" " if mag != 1 else "") + mono if mono else "")
        body = body.strip()
        sign = "-" if c < 0 else "+"
        terms.append((sign, body))
    if not terms:
        return "0"
    first = ("-" if terms[0][0] == "-" else "") + terms[0][1]
    return " ".join([first] + [f"{s} {b}" for s, b in terms[1:]])


# ============================================================== validation
def check_exact_motion_polynomial(C) -> None:
    """Monic (leading row exactly 1), degree >= 1, norm exactly real; InputError otherwise."""
    if len(C) < 2:
        raise InputError("a motion polynomial needs degree >= 1")
    if tuple(C[-1]) != _ID:
        raise InputError("the polynomial is not monic (leading coefficient must be 1)")
    F = norm_poly_full(C)
    if any(x != 0 for row in F for x in row[1:]):
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


def factorize_exact(C, *, validate: bool = True) -> ExactFactorResult:
    """All factorizations of a monic rational motion polynomial C (rows of 8 numbers, constant term
    first) from Algorithm 1 in exact arithmetic. Orders whose remainder has a zero primal leading
    coefficient are skipped (``failed_orders``); when none succeeds, raises NotGenericError (primal part
    with a real factor) or NoFactorizationError. Raises SynthesisError when N(C) does not split into
    rational quadratics, InputError for invalid input."""
    from synth.algebra.factorize import _distinct_orders

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
    orders = _distinct_orders(mult)

    cache: dict[tuple, tuple | None] = {(): (C, ())}

    def run(suffix):
        """(D, hs) after processing the quadratics of suffix (rightmost last), or None on failure."""
        if suffix in cache:
            return cache[suffix]
        prev = run(suffix[1:])
        out = None
        if prev is not None:
            D, hs = prev
            _, r1, r0 = divide_real_quadratic(D, quads[suffix[0]])
            if any(x != 0 for x in r1[:4]):
                h = dq_neg(dq_mul(dq_inv(r1), r0))
                Dn, rem = divide_linear_right(D, h)
                if not is_zero(rem):  # pragma: no cover - impossible in exact arithmetic
                    raise AssertionError("exact division by t - h left a remainder")
                out = (Dn, (h,) + hs)
        cache[suffix] = out
        return out

    facts, failed = [], []
    for order in orders:
        r = run(tuple(order))
        if r is None:
            failed.append(tuple(order))
            continue
        D, hs = r
        if len(D) != 1 or tuple(D[0]) != _ID:  # pragma: no cover - impossible
            raise AssertionError("exact Algorithm 1 did not end with the constant 1")
        facts.append(ExactFactorization(factors=list(hs), order=tuple(order),
                                        kinds=[classify_exact(h) for h in hs]))
    result = ExactFactorResult(C=C, norm=N, quadratics=quads, multiplicity=mult, factorizations=facts,
                               generic=generic, real_factor=g if not generic else [], failed_orders=failed)
    if not facts:
        if not generic:
            raise NotGenericError(
                f"not generic: the primal part has the real factor ({real_poly_text(g)}); Algorithm 1 "
                "finds no factorization into linear factors (try --cofactor)")
        raise NoFactorizationError("no factorization into linear factors was found")
    return result
