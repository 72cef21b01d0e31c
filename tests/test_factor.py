"""Complete factorization (synth/factor.py, numeric; synth/exact.py, rational) against MATH.md
sections 4, 9, 10, 11 and the survey's examples, plus property tests."""
import math
from fractions import Fraction as Fr

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra import exact as X
from synth.algebra.dq import dq_inv, dq_mul, plucker
from synth.algebra.geometry import common_normal
from synth.errors import InputError, NotGenericError, SynthesisError
from synth.algebra.expr import parse_polynomial
from synth.algebra.factorize import check_motion_polynomial, classify, factorize, norm_quadratics
from synth.algebra.polynomial import linear, norm_poly, poly_mul, product_of_linear, relative_error


def dq(s=0, i=0, j=0, k=0, es=0, ei=0, ej=0, ek=0):
    return np.array([s, i, j, k, es, ei, ej, ek], float)


def fdq(s=0, i=0, j=0, k=0, es=0, ei=0, ej=0, ek=0):
    return tuple(Fr(x) for x in (s, i, j, k, es, ei, ej, ek))


def poly(text):
    return parse_polynomial(text)


def quad_of(h):
    """N(t - h) as (c0, c1)."""
    h = np.asarray(h, float)
    return (h[0] ** 2 + h[1:4] @ h[1:4], -2 * h[0])


def by_rightmost(result, c0c1, tol=1e-9):
    """The factorizations whose rightmost factor has norm quadratic c0c1."""
    return [f for f in result.factorizations if np.allclose(quad_of(f.factors[-1]), c0c1, atol=tol)]


# ====================================================================== 11 A
H1 = dq(i=1, ej=1)
H2 = dq(s=1, j=2, ei=3, ek=1)
C_A = np.array([dq(i=1, k=2, es=-5), dq(s=-1, i=-1, j=-2, ei=-3, ej=-1, ek=-1), dq(s=1)])
A_LEFT = dq(s=1, i=4 / 3, j=4 / 3, k=-2 / 3, ei=13 / 9, ej=-5 / 9, ek=16 / 9)
A_RIGHT = dq(i=-1 / 3, j=2 / 3, k=2 / 3, ei=14 / 9, ej=14 / 9, ek=-7 / 9)


def test_example_A_both_orders():
    r = factorize(C_A)
    assert r.generic
    assert sorted(map(tuple, np.round(r.quadratics, 12))) == [(1.0, 0.0), (5.0, -2.0)]
    assert r.multiplicity == [1, 1]
    assert len(r.factorizations) == 2
    assert np.allclose(r.norm, [5, -2, 6, -2, 1])
    (f1,) = by_rightmost(r, (5, -2))
    assert np.allclose(f1.factors, [H1, H2], atol=1e-14)
    (f2,) = by_rightmost(r, (1, 0))
    assert np.allclose(f2.factors, [A_LEFT, A_RIGHT], atol=1e-14)
    for f in r.factorizations:
        assert f.residual < 1e-14
        assert [c.kind for c in f.classified()] == ["revolute", "revolute"]
        # N(t - h_i) is the quadratic of the order
        for h, q in zip(f.factors, f.order):
            assert np.allclose(quad_of(h), r.quadratics[q])
        assert relative_error(product_of_linear(f.factors), C_A) < 1e-14


def test_example_A_from_expression():
    C = poly("(t - i - eps j)(t - 1 - 2j - eps(3i + k))")
    assert np.allclose(C, C_A)
    C2 = poly("t^2 + (-1 - i - 2j - eps(3i + j + k)) t + i + 2k - 5 eps")
    assert np.allclose(C2, C_A)


def test_example_A_exact_numbers():
    C = [[Fr(x) for x in row] for row in C_A.astype(int).tolist()]
    # the steps of 11 A in rational arithmetic
    _, r1, r0 = X.divide_real_quadratic(C, (Fr(1), Fr(0)))
    assert r1 == fdq(s=-1, i=-1, j=-2, ei=-3, ej=-1, ek=-1)
    assert r0 == fdq(s=-1, i=1, k=2, es=-5)
    r1inv = X.dq_inv(r1)
    assert r1inv == fdq(s=Fr(-1, 6), i=Fr(1, 6), j=Fr(1, 3), es=Fr(5, 18), ei=Fr(2, 9), ej=Fr(-7, 18), ek=Fr(1, 6))
    h = X.dq_neg(X.dq_mul(r1inv, r0))
    assert h == fdq(i=Fr(-1, 3), j=Fr(2, 3), k=Fr(2, 3), ei=Fr(14, 9), ej=Fr(14, 9), ek=Fr(-7, 9))
    _, r1, r0 = X.divide_real_quadratic(C, (Fr(5), Fr(-2)))
    assert r1 == fdq(s=1, i=-1, j=-2, ei=-3, ej=-1, ek=-1)
    assert r0 == fdq(s=-5, i=1, k=2, es=-5)

    r = X.factorize_exact(C)
    assert r.generic
    assert r.quadratics == [(1, 0), (5, -2)]
    assert r.norm == [5, -2, 6, -2, 1]
    facts = {f.order: f for f in r.factorizations}
    assert set(facts) == {(0, 1), (1, 0)}
    assert facts[(0, 1)].factors == [fdq(i=1, ej=1), fdq(s=1, j=2, ei=3, ek=1)]
    assert facts[(1, 0)].factors == [
        fdq(s=1, i=Fr(4, 3), j=Fr(4, 3), k=Fr(-2, 3), ei=Fr(13, 9), ej=Fr(-5, 9), ek=Fr(16, 9)),
        fdq(i=Fr(-1, 3), j=Fr(2, 3), k=Fr(2, 3), ei=Fr(14, 9), ej=Fr(14, 9), ek=Fr(-7, 9)),
    ]
    for f in r.factorizations:
        assert X.product_of_linear(f.factors) == [tuple(row) for row in C]
        assert f.kinds == ["revolute", "revolute"]


def test_exact_and_numeric_enumerate_the_same_orders():
    C = C_A
    rn = factorize(C)
    re_ = X.factorize_exact([[Fr(int(x)) for x in row] for row in C])
    assert [f.order for f in rn.factorizations] == [f.order for f in re_.factorizations]
    for fn, fe in zip(rn.factorizations, re_.factorizations):
        assert np.allclose(fn.factors, fe.floats(), atol=1e-14)


# ====================================================================== 9 / 11 C Bennett flip
M_FLIP = dq(k=2, ei=1)  # 2k + eps i
H_FLIP = dq(j=1, ek=1)  # j + eps k
K_NEW = dq(j=-3 / 5, k=4 / 5, ei=2 / 5, ej=12 / 25, ek=9 / 25)
M_NEW = dq(j=8 / 5, k=6 / 5, ei=3 / 5, ej=-12 / 25, ek=16 / 25)


def test_bennett_flip_numeric():
    C = product_of_linear(np.stack([M_FLIP, H_FLIP]))
    r = factorize(C)
    assert len(r.factorizations) == 2
    # N(t - m) = t^2 + 4 first (rightmost): (t - m)(t - h) = (t - k)(t - m')
    (flip,) = by_rightmost(r, quad_of(M_FLIP))
    k, m2 = flip.factors
    assert np.allclose(k, K_NEW, atol=1e-14)
    assert np.allclose(m2, M_NEW, atol=1e-14)
    assert np.allclose(quad_of(m2), quad_of(M_FLIP))
    assert np.allclose(quad_of(k), quad_of(H_FLIP))
    (orig,) = by_rightmost(r, quad_of(H_FLIP))
    assert np.allclose(orig.factors, [M_FLIP, H_FLIP], atol=1e-14)
    # the loop m - h - m' - k is a Bennett linkage: equal opposite distances and twists, and
    # sin(alpha)/a equal for both pairs
    lines = [plucker(x) for x in (M_FLIP, H_FLIP, m2, k)]
    cn = [common_normal(*lines[i], *lines[(i + 1) % 4]) for i in range(4)]
    da = [(float(c.distance), abs(float(c.twist))) for c in cn]
    assert da[0][0] == pytest.approx(da[2][0], abs=1e-12)
    assert da[1][0] == pytest.approx(da[3][0], abs=1e-12)
    s0 = [math.sin(a) for _, a in da]
    assert s0[0] == pytest.approx(s0[2], abs=1e-12)
    assert s0[1] == pytest.approx(s0[3], abs=1e-12)
    assert s0[0] / da[0][0] == pytest.approx(s0[1] / da[1][0], rel=1e-12)


def test_bennett_flip_exact():
    C = X.product_of_linear([fdq(k=2, ei=1), fdq(j=1, ek=1)])
    r = X.factorize_exact(C)
    assert r.quadratics == [(1, 0), (4, 0)]
    (flip,) = [f for f in r.factorizations if f.order[-1] == 1]  # N(t - m) = t^2 + 4 first
    assert flip.factors == [
        fdq(j=Fr(-3, 5), k=Fr(4, 5), ei=Fr(2, 5), ej=Fr(12, 25), ek=Fr(9, 25)),
        fdq(j=Fr(8, 5), k=Fr(6, 5), ei=Fr(3, 5), ej=Fr(-12, 25), ek=Fr(16, 25)),
    ]
    (orig,) = [f for f in r.factorizations if f.order[-1] == 0]
    assert orig.factors == [fdq(k=2, ei=1), fdq(j=1, ek=1)]


# ====================================================================== survey examples (section 10)
def test_survey_t_minus_i():
    r = factorize(poly("t - i"))
    assert r.generic
    (f,) = r.factorizations
    assert np.allclose(f.factors, [dq(i=1)])
    (c,) = f.classified()
    assert c.kind == "revolute"
    u, m = c.line
    assert np.allclose(u, [-1, 0, 0]) and np.allclose(m, 0)
    assert (c.a, c.b) == pytest.approx((0, 1))


def test_survey_t_minus_i_squared():
    """(t - i)^2: norm (t^2 + 1)^2, exactly one factorization (t - i)(t - i)."""
    r = factorize(poly("(t - i)^2"))
    assert r.multiplicity == [2]
    assert np.allclose(r.quadratics, [[1, 0]], atol=1e-14)
    (f,) = r.factorizations
    assert np.allclose(f.factors, [dq(i=1), dq(i=1)], atol=1e-12)
    re_ = X.factorize_exact(parse_polynomial("(t - i)^2", exact=True))
    (fe,) = re_.factorizations
    assert fe.factors == [fdq(i=1), fdq(i=1)]


def test_survey_translation():
    """t - eps i: a translation by 2i/t (a prismatic joint), not a rotation."""
    r = factorize(poly("t - eps i"))
    assert not r.generic  # the primal part t is real
    (f,) = r.factorizations
    (c,) = f.classified()
    assert c.kind == "translation"
    assert np.allclose(c.translation_direction, [2, 0, 0])
    re_ = X.factorize_exact(parse_polynomial("t - eps i", exact=True))
    assert re_.factorizations[0].kinds == ["translation"]


EXC = "(t - 1)*(t - j) - eps*((i + k)*t - 2*k)"


def test_survey_exceptional_polynomial():
    """N(C) = (t - 1)^2 (t^2 + 1); exactly (t - 1 - eps i)(t - j - eps k) and
    (t - j - eps(i + 2k))(t - 1 + eps k), with translation factors t - 1 -+ ..."""
    C = poly(EXC)
    assert np.allclose(norm_poly(C), np.convolve([1, -2, 1], [1, 0, 1]))
    r = factorize(C)
    assert not r.generic
    assert len(r.factorizations) == 2
    (f1,) = by_rightmost(r, (1, 0))
    assert np.allclose(f1.factors, [dq(s=1, ei=1), dq(j=1, ek=1)], atol=1e-12)
    assert [c.kind for c in f1.classified()] == ["translation", "revolute"]
    (f2,) = by_rightmost(r, (1, -2))
    assert np.allclose(f2.factors, [dq(j=1, ei=1, ek=2), dq(s=1, ek=-1)], atol=1e-12)
    assert [c.kind for c in f2.classified()] == ["revolute", "translation"]
    for f in r.factorizations:
        assert f.residual < 1e-12


def test_survey_exceptional_polynomial_exact():
    r = X.factorize_exact(parse_polynomial(EXC, exact=True))
    assert not r.generic
    assert r.real_factor == [-1, 1]  # t - 1
    got = {tuple(f.kinds): f.factors for f in r.factorizations}
    assert got[("translation", "revolute")] == [fdq(s=1, ei=1), fdq(j=1, ek=1)]
    assert got[("revolute", "translation")] == [fdq(j=1, ei=1, ek=2), fdq(s=1, ek=-1)]


@pytest.mark.parametrize("a,b", [(1, 2), (3, -1), (0, 1), (1, 1), (2, 2)])
def test_survey_elliptic_translation_not_generic(a, b):
    """t^2 + 1 + eps(a i + b j t): Algorithm 1 stops for every a, b (no factorization for a != b,
    infinitely many for a = b; neither is found). Reported as not generic."""
    text = f"t^2 + 1 + eps({a} i + {b} j t)"
    with pytest.raises(NotGenericError, match=r"not generic.*\(t\^2 \+ 1\)"):
        factorize(poly(text))
    with pytest.raises(NotGenericError, match=r"\(t\^2 \+ 1\)"):
        X.factorize_exact(parse_polynomial(text, exact=True))


def test_elliptic_translation_a_equals_b_has_factorizations():
    """Equation (5): for a = b, h1 = k - eps(f i + (a + g) j), h2 = -k + eps(f i + g j) factor C
    (the engine does not find them; this documents why the error says 'not generic')."""
    a, f, g = 2.0, 0.7, -1.3
    h1 = dq(k=1, ei=-f, ej=-(a + g))
    h2 = dq(k=-1, ei=f, ej=g)
    assert np.allclose(product_of_linear(np.stack([h1, h2])), poly(f"t^2 + 1 + eps({a} i + {a} j t)"))


# ====================================================================== repeated quadratics
def test_repeated_quadratic_gives_one_factorization():
    """(t - i - eps j)(t - j - eps k), norm (t^2 + 1)^2: exactly one factorization (MATH.md 4)."""
    C = poly("(t - i - eps j)(t - j - eps k)")
    assert np.allclose(norm_poly(C), [1, 0, 2, 0, 1])
    r = factorize(C)
    assert r.multiplicity == [2]
    (f,) = r.factorizations
    assert np.allclose(f.factors, [dq(i=1, ej=1), dq(j=1, ek=1)], atol=1e-12)
    assert f.residual < 1e-14
    (fe,) = X.factorize_exact(parse_polynomial("(t - i - eps j)(t - j - eps k)", exact=True)).factorizations
    assert fe.factors == [fdq(i=1, ej=1), fdq(j=1, ek=1)]


@pytest.mark.parametrize("text,mult,count", [
    ("(t - i)^3", [3], 1),
    ("(t - i - eps j)(t - j - eps k)(t - k)", [3], 1),
    ("(t - i - eps j)(t - j - eps k)(t - k)(t - i)", [4], 1),
    ("(t - 2 - 3i)^2 (t - j)", [1, 2], 3),
    ("(t - 2 - 3i - eps j)(t - j)(t - 2 - 3k)", [1, 2], 3),
])
def test_higher_multiplicities(text, mult, count):
    r = factorize(poly(text))
    assert sorted(r.multiplicity) == sorted(mult)
    assert len(r.factorizations) == count
    for f in r.factorizations:
        assert f.residual < 1e-13
    # the merged quadratics are accurate (the cluster mean is polished on a derivative of N)
    tq = [quad_of(h) for h in r.factorizations[0].factors]
    for q in r.quadratics:
        assert min(np.abs(np.array(q) - np.array(t)).sum() for t in tq) < 1e-12


def test_equal_norms_different_axes():
    rng = np.random.default_rng(11)
    u1, u2 = rng.normal(size=(2, 3))
    u1 /= np.linalg.norm(u1)
    u2 /= np.linalg.norm(u2)
    a, b = 0.4, 1.3
    h1 = np.concatenate([[a], -b * u1, [0], b * np.cross(rng.normal(size=3), u1)])
    h2 = np.concatenate([[a], -b * u2, [0], b * np.cross(rng.normal(size=3), u2)])
    r = factorize(product_of_linear(np.stack([h1, h2])))
    (f,) = r.factorizations
    assert np.allclose(f.factors, [h1, h2], atol=1e-10)


# ====================================================================== 11 D and 11 E
D_C1 = [Fr(-38, 53), Fr(40, 53), 0, Fr(-20, 53), 0, Fr(15, 212), Fr(-29, 53), Fr(83, 212)]
D_C0 = [Fr(15, 53), 0, 0, Fr(20, 53), Fr(5, 53), Fr(-15, 106), Fr(10, 53), Fr(-15, 212)]
D_H1 = [0.2128367441, 0.08843778676, 0.3574025895, 0.09373229741, 0, 0.2366164531, -0.01103577354, -0.181171505]
D_H2 = [0.504144388, -0.8431547679, -0.3574025895, 0.2836261932, 0, -0.3073711701, 0.5582055849, -0.210337929]
D_K1 = [0.504144388, -0.8431547679, 0.3574025895, 0.2836261932, 0, 0.03216128991, 0.5264176378, -0.5677405185]
D_K2 = [0.2128367441, 0.08843778676, -0.3574025895, 0.09373229741, 0, -0.1029160069, 0.02075217352, 0.1762310845]


def test_example_D_bennett_factors():
    C = np.array([[float(x) for x in D_C0], [float(x) for x in D_C1], dq(s=1)])
    N = norm_poly(C)
    assert np.allclose(N, [625 / 2809, -1940 / 2809, 5034 / 2809, -76 / 53, 1], atol=1e-15)
    r = factorize(C)
    assert len(r.factorizations) == 2
    (fh,) = by_rightmost(r, quad_of(D_H2), tol=1e-8)
    (fk,) = by_rightmost(r, quad_of(D_K2), tol=1e-8)
    assert np.allclose(fh.factors, [D_H1, D_H2], atol=2e-10)
    assert np.allclose(fk.factors, [D_K1, D_K2], atol=2e-10)
    h1, h2 = (classify(h) for h in fh.factors)
    k1, k2 = (classify(h) for h in fk.factors)
    assert np.allclose(h1.line[0], [-0.2327764841, -0.9407168724, -0.2467121287], atol=1e-9)
    assert np.allclose(h1.line[1], [0.6227965221, -0.02904718285, -0.4768602594], atol=1e-9)
    assert np.allclose(k1.line[0], [0.879484495, -0.372802299, -0.2958470363], atol=1e-9)
    assert np.allclose(k1.line[1], [0.03354705078, 0.5490998426, -0.5922032374], atol=1e-9)
    assert (h1.a, h1.b) == pytest.approx((0.2128367441, 0.3799257778), abs=1e-9)
    assert (h2.a, h2.b) == pytest.approx((0.504144388, 0.9586920209), abs=1e-9)
    for t, th1, th2 in ((0.0, 4.1628830873, 4.1098453272), (1.0, 0.8993459891, 2.1869341004)):
        assert h1.angle(t) == pytest.approx(th1, abs=1e-9)
        assert k2.angle(t) == pytest.approx(th1, abs=1e-9)
        assert h2.angle(t) == pytest.approx(th2, abs=1e-9)
        assert k1.angle(t) == pytest.approx(th2, abs=1e-9)
    # exact mode: the norm has irrational roots and does not split over Q
    with pytest.raises(SynthesisError, match="does not factor over the rationals.*drop --exact"):
        X.factorize_exact([D_C0, D_C1, [1, 0, 0, 0, 0, 0, 0, 0]])


def test_example_E_cubic():
    C = np.array([
        [0.3, 0, 0, 0.4, 0.1, -0.15, 0.2, -0.075],
        [-0.6676567652, 0.3246889073, 0.8343860133, 1.77843858, -0.2448920031, -0.2019373573,
         -0.6417448627, 0.3886057611],
        [-1.501695253, -1.483824932, -0.8343860133, -2.17843858, 0, 0.4606063597, 0.9923344744,
         -0.8062385716],
        dq(s=1),
    ])
    N = norm_poly(C)
    assert np.allclose(N, [0.25, 1.022156805, 1.76646423, -7.499167472, 8.5633062, -3.003390507, 1], atol=1e-8)
    r = factorize(C)
    assert len(r.factorizations) == 6
    ab = sorted((-c1 / 2, math.sqrt(c0 - c1 * c1 / 4)) for c0, c1 in r.quadratics)
    expect = [(-0.1658995584, 0.1584960916), (0.7454471107, 0.4737237177), (0.922147701, 2.288485132)]
    assert np.allclose(ab, expect, atol=1e-8)
    for f in r.factorizations:
        assert f.residual < 1e-9  # the coefficients are given to 10 digits only
        assert all(c.kind == "revolute" for c in f.classified())


# ====================================================================== validation
def test_invalid_input():
    with pytest.raises(InputError, match="not monic"):
        factorize(poly("2t - i"))
    with pytest.raises(InputError, match="not a motion polynomial"):
        factorize(poly("(t - i)(t - j) + eps k"))
    with pytest.raises(InputError, match="NaN"):
        factorize(np.array([dq(i=np.nan), dq(s=1)]))
    with pytest.raises(InputError, match="8 numbers"):
        check_motion_polynomial(np.zeros((2, 7)))
    with pytest.raises(InputError, match="degree"):
        factorize(np.array([dq(s=1)]))
    with pytest.raises(InputError, match="not monic"):
        X.factorize_exact(parse_polynomial("2t - i", exact=True))
    with pytest.raises(InputError, match="not a motion polynomial"):
        X.factorize_exact(parse_polynomial("(t - i)(t - j) + eps k", exact=True))
    with pytest.raises(InputError, match="8 numbers"):
        X.factorize_exact([[0] * 7, [1] + [0] * 7])
    with pytest.raises(InputError, match="not a number"):
        X.factorize_exact([["x"] * 8, [1] + [0] * 7])


def test_exact_number_parsing():
    assert X.to_fraction("3/4") == Fr(3, 4)
    assert X.to_fraction(" -2 ") == -2
    assert X.to_fraction("1e-3") == Fr(1, 1000)
    assert X.to_fraction(0.1) == Fr(1, 10)
    assert X.to_fraction(7) == 7
    for bad in (float("nan"), float("inf"), True, None, "1/0", "abc", [1]):
        with pytest.raises(InputError):
            X.to_fraction(bad)


def test_exact_odd_real_root_multiplicity_and_real_quadratic():
    # a polynomial factored over Q whose norm has an irreducible quadratic with real roots:
    # N = (t^2 - 2)^2 ... is not reachable from a valid motion polynomial with the sign pattern of
    # a norm; test the norm-splitting helper directly
    with pytest.raises(SynthesisError, match="rationals"):
        X.rational_norm_quadratics([Fr(4), 0, Fr(-4), 0, Fr(1)])  # (t^2 - 2)^2
    with pytest.raises(SynthesisError, match="rationals"):
        X.rational_norm_quadratics([Fr(2), 0, 0, 0, Fr(1)])  # t^4 + 2, irreducible over Q
    q, m, real = X.rational_norm_quadratics([Fr(1), Fr(-2), Fr(1)])  # (t - 1)^2
    assert q == [(1, -2)] and m == [1] and real == [True]


# ====================================================================== properties
def revolute_factor(a, b, axis, point):
    u = np.asarray(axis, float)
    u = u / np.linalg.norm(u)
    return np.concatenate([[a], -b * u, [0], b * np.cross(np.asarray(point, float), u)])


axis_st = st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.2)
point_st = st.lists(st.floats(-2, 2), min_size=3, max_size=3)


@st.composite
def revolute_products(draw, n):
    """n revolute factors whose norm roots a + ib are pairwise separated (a spread out on a grid with
    jitter, b in [0.3, 2]), multiplied in a random order."""
    slots = draw(st.permutations(list(range(n))))
    fs = []
    for s in slots:
        a = -1.5 + 0.6 * s + draw(st.floats(-0.2, 0.2))
        b = draw(st.floats(0.3, 2.0))
        fs.append(revolute_factor(a, b, draw(axis_st), draw(point_st)))
    return np.stack(fs)


def check_all_factorizations(hs):
    n = len(hs)
    C = product_of_linear(hs)
    r = factorize(C)
    assert r.generic
    assert len(r.factorizations) == math.factorial(n)
    assert len({f.order for f in r.factorizations}) == math.factorial(n)
    H = np.stack([f.factors for f in r.factorizations])
    res = relative_error(product_of_linear(H), C)  # batched multiply-back, independent of the engine's
    assert np.all(res <= 1e-12)
    for f in r.factorizations:
        assert f.residual <= 1e-12
        assert all(c.kind == "revolute" for c in f.classified())
    quads = np.array(r.quadratics)[np.array([f.order for f in r.factorizations])]  # (P, n, 2)
    a = H[..., 0]
    assert np.allclose(np.stack([a * a + np.sum(H[..., 1:4] ** 2, -1), -2 * a], -1), quads, rtol=1e-9, atol=1e-9)
    assert np.any(np.all(np.abs(H - hs).reshape(len(H), -1) <= 1e-9, axis=1))  # the input factorization
    # different orders give different factorizations (all quadratics distinct)
    assert len({tuple(np.round(x.ravel(), 6)) for x in H}) == len(H)


@pytest.mark.parametrize("n,examples", [(1, 30), (2, 30), (3, 25), (4, 15), (5, 8), (6, 4)])
def test_products_of_random_revolute_factors(n, examples):
    @settings(max_examples=examples, deadline=None, derandomize=False)
    @given(revolute_products(n))
    def run(hs):
        check_all_factorizations(hs)

    run()


def test_random_cubics_seeded():
    """Plain random factors (no separation enforced): all 6 factorizations multiply back to 1e-12."""
    rng = np.random.default_rng(20240601)
    for _ in range(40):
        hs = np.stack([revolute_factor(rng.uniform(-2, 2), rng.uniform(0.3, 2), rng.normal(size=3),
                                       rng.uniform(-2, 2, size=3)) for _ in range(3)])
        r = factorize(product_of_linear(hs))
        assert len(r.factorizations) == 6
        assert max(f.residual for f in r.factorizations) <= 1e-12


def rational_revolute(a, v, c):
    """t - h with rational a, v and axis point c: h = a + v + eps (v x c) (v . w = 0)."""
    a, v, c = Fr(a), [Fr(x) for x in v], [Fr(x) for x in c]
    w = (v[1] * c[2] - v[2] * c[1], v[2] * c[0] - v[0] * c[2], v[0] * c[1] - v[1] * c[0])
    return (a, *v, Fr(0), *w)


@settings(max_examples=10, deadline=None)
@given(st.lists(st.tuples(st.integers(-3, 3), st.lists(st.integers(-3, 3), min_size=3, max_size=3)
                          .filter(any), st.lists(st.integers(-4, 4), min_size=3, max_size=3)),
                min_size=2, max_size=3))
def test_exact_matches_numeric_on_rational_products(specs):
    hs = [rational_revolute(Fr(a, 2), [Fr(x, 3) for x in v], [Fr(x, 2) for x in c]) for a, v, c in specs]
    C = X.product_of_linear(hs)
    Cf = np.array([[float(x) for x in row] for row in C])
    try:
        re_ = X.factorize_exact(C)
    except NotGenericError:  # e.g. (t - h)(t - conj h) = N(t - h) is real: both engines refuse
        with pytest.raises(NotGenericError):
            factorize(Cf)
        return
    rn = factorize(Cf)
    assert re_.generic == rn.generic
    assert sorted(re_.multiplicity) == sorted(rn.multiplicity)
    assert len(re_.factorizations) == len(rn.factorizations)
    # the same factorizations (the numbering is checked in test_exact_and_numeric_number_alike)
    numeric = [fn.factors for fn in rn.factorizations]
    for fe in re_.factorizations:
        assert X.product_of_linear(fe.factors) == [tuple(r) for r in C]
        match = [k for k, H in enumerate(numeric) if np.allclose(fe.floats(), H, atol=1e-7)]
        assert match
        assert fe.kinds == [c.kind for c in rn.factorizations[match[0]].classified()]


@pytest.mark.parametrize("text", [
    "(t - 1/3 k)(t - 2/3 k)(t - k)",  # equal real parts 0: Im decides
    "(t - 1/2 - 1/3 i)(t - 1/2 - j - eps k)(t - 1/2 - 2/3 k)",
    "(t - 1/3 k)(t - k - eps i)",
    "(t - 1 - j)(t - 1 - 2i - eps k)",
    "(t - i - eps j)(t - 1 - 2j - eps(3i + k))",
])
def test_exact_and_numeric_number_alike(text):
    """Factorization k means the same in both modes: quadratics sorted by (Re z, Im z), with equal
    real parts tied exactly (not decided by rounding noise), orders enumerated alike."""
    rn = factorize(poly(text))
    re_ = X.factorize_exact(parse_polynomial(text, exact=True))
    assert np.allclose(rn.quadratics, np.array(re_.quadratics, float), atol=1e-12)
    assert [f.order for f in rn.factorizations] == [f.order for f in re_.factorizations]
    for fn, fe in zip(rn.factorizations, re_.factorizations):
        assert np.allclose(fn.factors, fe.floats(), atol=1e-12)


def test_exact_degree_four_all_orders():
    hs = [rational_revolute(0, [1, 0, 0], [0, 1, 0]), rational_revolute(1, [0, 2, 0], [1, 0, 1]),
          rational_revolute(-1, [0, 0, 3], [2, -1, 0]), rational_revolute(2, [1, 1, 1], [0, 0, 1])]
    C = X.product_of_linear(hs)
    r = X.factorize_exact(C)
    assert len(r.factorizations) == 24
    assert len({tuple(map(tuple, f.factors)) for f in r.factorizations}) == 24
    for f in r.factorizations:
        assert X.product_of_linear(f.factors) == C
    assert any(f.factors == hs for f in r.factorizations)


def test_norm_quadratics_real_root_pairs():
    # (t - 1)^2 (t - 3)^2 (t^2 + 1): the real roots pair into (t - 1)^2 and (t - 3)^2
    N = np.convolve(np.convolve([1, -2, 1], [9, -6, 1]), [1, 0, 1])
    q, m, roots = norm_quadratics(N)
    assert np.allclose(sorted(map(tuple, q), key=lambda x: x[1]), [(9, -6), (1, -2), (1, 0)], atol=1e-6)
    assert m == [1, 1, 1]


def test_products_of_linear_agree():
    assert np.allclose(poly_mul(linear(H1), linear(H2)), product_of_linear(np.stack([H1, H2])))
    assert np.allclose(dq_mul(dq_inv(H2), H2), dq(s=1))
