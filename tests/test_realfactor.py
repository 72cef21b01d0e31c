"""mrpf(P): exact (Euclid over Q) and numeric detection (docs/exceptional.md, example E1)."""
from fractions import Fraction as F

import numpy as np
import pytest

from synth.algebra.expr import parse_polynomial
from synth.algebra.polynomial import poly_mul, product_of_linear
from synth.algebra.realfactor import (UnboundedMotionError, mrpf, mrpf_exact, mrpf_numeric, real_gcd_numeric,
                              require_bounded)

ELLIPTIC = "t^2 + 1 + eps*(i + 2*j*t)"
SURVEY_UNBOUNDED = "(t-1)*(t-j) - eps*((i+k)*t - 2*k)"


def test_e1_elliptic_translation_exact():
    g, bounded = mrpf_exact(parse_polynomial(ELLIPTIC, exact=True))
    assert g == [1, 0, 1] and bounded
    rf = mrpf(parse_polynomial(ELLIPTIC, exact=True))
    assert rf.exact == [F(1), F(0), F(1)] and rf.degree == 2 and not rf.generic
    assert rf.quadratics.tolist() == [[1.0, 0.0]] and rf.multiplicity == [1]
    require_bounded(rf)


def test_e1_survey_unbounded_exact():
    rf = mrpf(parse_polynomial(SURVEY_UNBOUNDED, exact=True))
    assert rf.exact == [F(-1), F(1)] and not rf.bounded
    with pytest.raises(UnboundedMotionError, match="sliding joint") as e:
        require_bounded(rf)
    assert isinstance(e.value, ValueError) and e.value.exit_code == 1


def test_e1_numeric():
    rf = mrpf(parse_polynomial(ELLIPTIC))
    assert np.allclose(rf.g, [1, 0, 1], atol=1e-12) and rf.bounded
    rf = mrpf(parse_polynomial(SURVEY_UNBOUNDED))
    assert np.allclose(rf.g, [-1, 1], atol=1e-10) and not rf.bounded
    assert rf.real_roots == pytest.approx([1.0])


def test_generic_has_trivial_mrpf():
    C = parse_polynomial("(t - i - eps*j)*(t - 1 - 2*j - eps*(3*i + k))", exact=True)
    assert mrpf_exact(C) == ([F(1)], True)
    assert mrpf_numeric(np.array(C, float)).tolist() == [1.0]


def _noisy_case():
    # P = (t^2 + 1)(t^2 + 2t + 3)(t - i - 2j) with some dual part
    return parse_polynomial("(t^2+1)*(t^2+2*t+3)*(t-i-2*j) + eps*(i*t+j)")


def test_numeric_finds_g_with_noise():
    C = _noisy_case()
    expected = np.array([3, 2, 4, 2, 1.0])  # (t^2 + 1)(t^2 + 2t + 3)
    assert np.allclose(mrpf_numeric(C), expected, atol=1e-12)
    rng = np.random.default_rng(1)
    noisy = C + 1e-13 * rng.normal(size=C.shape)
    assert np.allclose(mrpf_numeric(noisy), expected, atol=1e-9)


def test_numeric_perturbation_gives_generic():
    rng = np.random.default_rng(2)
    C = _noisy_case() + 1e-3 * rng.normal(size=(6, 8))
    assert mrpf_numeric(C).tolist() == [1.0]


def test_repeated_quadratic_factor():
    # (t^2 + 1)^2 (t - j + 2k) in the primal part
    C = parse_polynomial("(t^2+1)^2*(t - j + 2*k) + eps*(t^2*i + k)", exact=True)
    g, bounded = mrpf_exact(C)
    assert g == [1, 0, 2, 0, 1] and bounded
    assert np.allclose(mrpf_numeric(np.array(C, float)), [1, 0, 2, 0, 1], atol=1e-8)
    rf = mrpf(np.array(C, float))
    assert rf.multiplicity == [2] and np.allclose(rf.quadratics, [[1, 0]], atol=1e-6)


def test_random_products_numeric_vs_exact():
    """Random rational rotations times real quadratics: numeric and exact g agree."""
    rng = np.random.default_rng(3)
    for _ in range(10):
        u = rng.integers(-3, 4, size=3)
        if not u.any():
            u[0] = 1
        G = product_of_linear(np.array([[rng.integers(-2, 3), *u, 0, 0, 0, 0]], float))
        a, b = rng.integers(-3, 4), rng.integers(1, 4)
        M = np.zeros((3, 8))
        M[:, 0] = [a * a + b * b, -2 * a, 1]
        C = poly_mul(M, G)
        exact = [[F(int(round(x))) for x in row] for row in C]
        g_ex, _ = mrpf_exact(exact)
        assert np.allclose(mrpf_numeric(C), [float(x) for x in g_ex], atol=1e-9)


def test_real_gcd_of_all_components():
    # (t^2 + 4) * (t - i + eps j): every component divisible by t^2 + 4
    C = parse_polynomial("(t^2 + 4)*(t - i + eps*j)")
    assert np.allclose(real_gcd_numeric(C), [4, 0, 1], atol=1e-12)


def _sympy_gcd_and_bounded(cols):
    import sympy
    t = sympy.Symbol("t")
    g = None
    for c in cols:
        if any(c):
            p = sympy.Poly(list(reversed([sympy.Rational(x.numerator, x.denominator) for x in c])), t, domain="QQ")
            g = p if g is None else sympy.gcd(g, p)
    g = g.monic()
    return [F(int(c.p), int(c.q)) for c in reversed(g.all_coeffs())], g.degree() == 0 or g.count_roots() == 0


@pytest.mark.parametrize("seed", range(40))
def test_real_gcd_exact_agrees_with_sympy(seed):
    """Euclid + Sturm over Fractions give sympy's gcd over QQ and its real-root verdict (common factors with
    and without real zeros, repeated ones, coprime columns, a zero column)."""
    from synth.algebra.realfactor import real_gcd_exact
    rng = np.random.default_rng(seed)

    def rnd(deg):
        return [F(int(rng.integers(-5, 6)), int(rng.integers(1, 4))) for _ in range(deg)] + [F(int(rng.integers(1, 4)))]

    common = [F(1)]
    for _ in range(int(rng.integers(0, 3))):
        f = [F(int(rng.integers(-3, 4))), F(int(rng.integers(-3, 4)), 2), F(1)]  # real zeros or not
        common = [sum(common[i] * f[k - i] for i in range(len(common)) if 0 <= k - i < len(f))
                  for k in range(len(common) + 2)]
    cols = []
    for c in range(4):
        q = rnd(int(rng.integers(0, 3)))
        cols.append([sum(common[i] * q[k - i] for i in range(len(common)) if 0 <= k - i < len(q))
                     for k in range(len(common) + len(q) - 1)])
    if seed % 7 == 0:
        cols[1] = [F(0)] * len(cols[1])
    n = max(map(len, cols))
    rows = [[c[k] if k < len(c) else F(0) for c in cols] for k in range(n)]
    assert real_gcd_exact(rows) == _sympy_gcd_and_bounded([[r[i] for r in rows] for i in range(4)])


@pytest.mark.parametrize("g,count", [([F(1)], 0), ([F(1), F(0), F(1)], 0), ([F(-1), F(0), F(1)], 2),
                                     ([F(1), F(-2), F(1)], 1), ([F(0), F(0), F(0), F(1)], 1),
                                     ([F(-6), F(11), F(-6), F(1)], 3), ([F(2), F(0), F(-3), F(0), F(1)], 4)])
def test_real_root_count(g, count):
    from synth.algebra.realpoly import real_root_count
    assert real_root_count(g) == count
