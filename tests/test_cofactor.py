"""Theorem 2: C R = product of rotations (docs/exceptional.md, worked examples E2-E4)."""
from fractions import Fraction as F

import numpy as np
import pytest

from synth.algebra.certify import exact_check, exact_product, rationalize, rationalize_factors
from synth.algebra.cofactor import build_items, factorize_with_cofactor
from synth.algebra.dualsystem import qp_mul, solve_items
from synth.algebra.translation import circular_residual, ellipse_split, factor_circular
from synth.errors import NotGenericError
from synth.algebra.expr import parse_polynomial
from synth.algebra.factorize import factorize
from synth.algebra.flip import is_rotation
from synth.algebra.polynomial import poly_mul, product_of_linear, relative_error
from synth.algebra.realfactor import UnboundedMotionError

ELLIPTIC = "t^2 + 1 + eps*(i + 2*j*t)"


def _exact(text):
    return parse_polynomial(text, exact=True)


def _rational_result(text):
    C = _exact(text)
    res = factorize_with_cofactor(C)
    hs = rationalize_factors(res.factors)
    R = [rationalize(x) for x in res.R]
    return C, res, R, hs


# ------------------------------------------------------------------ section 3
def test_algorithm_1_fails_on_the_elliptic_translation():
    with pytest.raises(NotGenericError):
        factorize(parse_polynomial(ELLIPTIC))


@pytest.mark.parametrize("a,b", [(1, 2), (2, 1), (3, -1), (F(1, 2), 5)])
def test_elliptic_right_zero_is_off_the_sphere(a, b):
    """F = a i + b j t has the unique right zero y = -(a/b) k, |y| != 1 for a != b: no factorization."""
    y = qp_mul(np.array([[0, 0, float(b), 0]]), np.array([[0, float(a), 0, 0]]))[0] / float(b) ** 2
    assert np.allclose(y, [0, 0, 0, -float(a) / float(b)])
    assert abs(np.linalg.norm(y) - 1) > 0.1
    E = np.array([[float(a), 0, 0], [0, float(b), 0]])
    assert np.max(np.abs(circular_residual([1.0, 0.0], E))) > 1e-3  # not circular


# ------------------------------------------------------------------ E2
def test_e2_elliptic_translation_exact():
    C, res, R, hs = _rational_result(ELLIPTIC)
    assert R == [1, 0, 1] and res.deg_R == 2 and res.bound_met
    assert hs == [[0, 0, 0, 1, 0, 0, F(-3, 4), 0], [0, 0, 0, -1, 0, 0, F(-3, 4), 0],
                  [0, 0, 0, -1, 0, 0, F(-1, 4), 0], [0, 0, 0, 1, 0, 0, F(-1, 4), 0]]
    assert exact_check(C, R, hs)
    assert [r["kind"] for r in res.report] == ["ellipse"]
    assert res.residual < 1e-14


def test_e2_split_into_circles():
    F1, F2 = ellipse_split([1.0, 0.0], np.array([[1.0, 0, 0], [0, 2.0, 0]]))
    assert np.allclose(F1, [[1.5, 0, 0], [0, 1.5, 0]])  # F+ = (3/2)(i + j t)
    assert np.allclose(F2, [[-0.5, 0, 0], [0, 0.5, 0]])  # F- = (1/2)(-i + j t)


@pytest.mark.parametrize("seed", range(6))
def test_e2_closed_form_family(seed):
    """h1 = k - eps(f1 i + (c+ + g1) j), h2 = -k + eps(f1 i + g1 j), h3 = -k + eps(-f2 i + (c- - g2) j),
    h4 = k + eps(f2 i + g2 j) factor C (t^2 + 1) for all a, b, f1, g1, f2, g2 (exact)."""
    rng = np.random.default_rng(seed)
    a, b, f1, g1, f2, g2 = (F(int(x), int(y)) for x, y in zip(rng.integers(-9, 10, 6), rng.integers(1, 7, 6)))
    cp, cm = (a + b) / 2, (a - b) / 2
    hs = [[0, 0, 0, 1, 0, -f1, -(cp + g1), 0], [0, 0, 0, -1, 0, f1, g1, 0],
          [0, 0, 0, -1, 0, -f2, cm - g2, 0], [0, 0, 0, 1, 0, f2, g2, 0]]
    C = [[1, 0, 0, 0, 0, a, 0, 0], [0, 0, 0, 0, 0, 0, b, 0], [1, 0, 0, 0, 0, 0, 0, 0]]
    assert exact_check(C, [1, 0, 1], hs)


# ------------------------------------------------------------------ E3 (circle, equation (5))
def test_e3_circular_translation_min_norm_member():
    C, res, R, hs = _rational_result("t^2 + 1 + eps*(i + j*t)")
    assert R == [1] and res.deg_R == 0
    assert hs == [[0, 0, 0, 1, 0, 0, F(-1, 2), 0], [0, 0, 0, -1, 0, 0, F(-1, 2), 0]]
    assert exact_check(C, R, hs)
    fam = res.family
    assert fam is not None
    D = np.array(fam["directions"])
    # the directions span {(d h1, d h2) = (-(f, g, 0), (f, g, 0))}
    assert np.allclose(D[:, 2], 0) and abs(np.linalg.det(D[:, :2])) == pytest.approx(1.0)


@pytest.mark.parametrize("seed", range(5))
def test_equation_5_all_members(seed):
    """eq. (5): h1 = k - eps(f i + (a + g) j), h2 = -k + eps(f i + g j) for every f, g (exact), and the
    family returned by factor_circular is the same set."""
    rng = np.random.default_rng(seed)
    a, f, g = (F(int(x), int(y)) for x, y in zip(rng.integers(-9, 10, 3), rng.integers(1, 7, 3)))
    if a == 0:
        a = F(1)
    C = [[1, 0, 0, 0, 0, a, 0, 0], [0, 0, 0, 0, 0, 0, a, 0], [1, 0, 0, 0, 0, 0, 0, 0]]
    assert exact_check(C, [1], [[0, 0, 0, 1, 0, -f, -(a + g), 0], [0, 0, 0, -1, 0, f, g, 0]])
    (h1, h2), fam = factor_circular([1.0, 0.0], np.array([[float(a), 0, 0], [0, float(a), 0]]))
    e1, e2 = (np.array(v) for v in fam["directions"])
    s = float(f) * e1 + float(g) * e2
    H1, H2 = h1.copy(), h2.copy()
    H1[5:8] -= s
    H2[5:8] += s
    assert relative_error(product_of_linear(np.array([H1, H2])), np.array(C, float)) < 1e-14


# ------------------------------------------------------------------ E4 (quaternion co-factor H = t - k)
def test_e4_quaternion_cofactor_exact():
    C, res, R, hs = _rational_result(f"({ELLIPTIC})*(t - k)")
    assert R == [1] and res.deg_R == 0
    assert hs == [[0, 0, 0, -1, 0, 0, F(-1, 4), 0], [0, 0, 0, 1, 0, 0, F(-1, 4), 0],
                  [0, 0, 0, 1, 0, 0, F(-3, 2), 0]]
    assert exact_check(C, R, hs)
    assert res.template == ["T1", "r1"]
    # (t - h1)(t - h2) = M + eps c-(i - j t), c- = (a - b)/2 = -1/2
    assert exact_product(hs[:2]) == [[1, 0, 0, 0, 0, F(-1, 2), 0, 0], [0, 0, 0, 0, 0, 0, F(1, 2), 0],
                                     [1, 0, 0, 0, 0, 0, 0, 0]]


def test_e4_template_kernel_is_two_dimensional():
    C = parse_polynomial(f"({ELLIPTIC})*(t - k)")
    items = build_items([np.array([0, 0, 0, 1.0])], [(np.array([1.0, 0.0]), 1)], (0,))
    z0, K, res = solve_items(items, C[:3, 4:], 3)
    assert res < 1e-14 and K.shape[1] == 2
    # the kernel moves h3 = k + eps(s1 i + s2 j) freely
    assert np.linalg.matrix_rank(K[6:8]) == 2


@pytest.mark.parametrize("a,b", [(1, 2), (3, 1), (2, -1), (1, F(-1, 2))])
def test_e4_unique_circular_member(a, b):
    """Circularity forces h3 = k - eps (a + b)/2 j for every a, b (here: the found member)."""
    C = [[1, 0, 0, 0, 0, a, 0, 0], [0, 0, 0, 0, 0, 0, b, 0], [1, 0, 0, 0, 0, 0, 0, 0]]
    CH = [[F(x) for x in row] for row in np.array(poly_mul(np.array(C, float), np.array(
        [[0, 0, 0, -1, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0, 0, 0]], float)))]
    res = factorize_with_cofactor(CH)
    assert res.deg_R == 0
    h3 = res.factors[2]
    assert np.allclose(h3, [0, 0, 0, 1, 0, 0, -float(a + b) / 2, 0], atol=1e-12)


def test_doc_e7_axis_of_h3_is_at_minus_a_plus_b_over_2():
    """docs/exceptional.md (E4/E7) says h3 = k - eps((a+b)/2) j is 'a rotation about the vertical line
    through ((a+b)/2, 0)'. With section 1's conventions (u = -v/|v|, m = w/|v|, point u x m) the line
    passes through (-(a+b)/2, 0): the sign in the text is wrong (the E6 table uses the right sign:
    h1 = k - 3/4 eps j at (-0.75, 0))."""
    from synth.algebra.dq import plucker

    u, m = plucker(np.array([0, 0, 0, 1, 0, 0, -1.5, 0]))
    assert np.allclose(np.cross(u, m), [-1.5, 0, 0])


# ------------------------------------------------------------------ detection, errors
def test_unbounded_is_refused():
    with pytest.raises(UnboundedMotionError, match="sliding joint"):
        factorize_with_cofactor(_exact("(t-1)*(t-j) - eps*((i+k)*t - 2*k)"))


def test_generic_input_gives_r_1():
    C = parse_polynomial("(t - i - eps*j)*(t - 1 - 2*j - eps*(3*i + k))")
    res = factorize_with_cofactor(C)
    assert res.generic and res.deg_R == 0 and res.residual < 1e-13 and len(res.factors) == 2


def test_real_content_is_written_as_coaxial_pair():
    C = parse_polynomial(f"({ELLIPTIC})*(t^2 + 4)")
    res = factorize_with_cofactor(C)
    assert len(res.real_content) == 1 and res.residual < 1e-12
    assert res.deg_R == 2


# ------------------------------------------------------------------ random property test
def _rrot(rng, ab=None):
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    a, b = ab if ab is not None else (rng.normal(), rng.uniform(0.3, 2))
    d = rng.normal(size=3)
    d -= (d @ n) * n
    h = np.zeros(8)
    h[0], h[1:4], h[5:8] = a, b * n, d
    return h


def _rtrans(rng, k=1, planar=False):
    a, b = rng.normal(), rng.uniform(0.3, 2)
    M = np.array([a * a + b * b, -2 * a, 1.0])
    B = np.ones(1)
    for _ in range(k):
        B = np.convolve(B, M)
    E = rng.normal(size=(2 * k, 3))
    if planar:
        E[:, 2] = 0
    T = np.zeros((2 * k + 1, 8))
    T[:, 0] = B
    T[:2 * k, 5:8] = E
    return T, (a, b)


def _random_case(rng, kind):
    G = lambda m=2: product_of_linear(np.array([_rrot(rng) for _ in range(m)]))  # noqa: E731
    if kind == "GT":
        return poly_mul(G(), _rtrans(rng)[0])
    if kind == "TG":
        return poly_mul(_rtrans(rng)[0], G())
    if kind == "GTG":
        return poly_mul(poly_mul(G(1), _rtrans(rng)[0]), G(1))
    if kind == "shared":  # a rotation shares its norm with the translation
        T, ab = _rtrans(rng)
        Gs = product_of_linear(np.array([_rrot(rng, ab), _rrot(rng)]))
        return poly_mul(Gs, T) if rng.random() < 0.5 else poly_mul(T, Gs)
    if kind == "TT":
        return poly_mul(poly_mul(_rtrans(rng)[0], G(1)), _rtrans(rng)[0])
    if kind == "TGT":  # shared norm between two translations
        T1, ab = _rtrans(rng)
        return poly_mul(poly_mul(T1, product_of_linear(_rrot(rng, ab)[None])), _rtrans(rng)[0])
    if kind == "k2planar":
        return poly_mul(_rtrans(rng, 2, planar=True)[0], G(1))
    if kind == "k2":
        return poly_mul(G(1), _rtrans(rng, 2)[0])
    raise ValueError(kind)


def _check_random(kind, seed):
    rng = np.random.default_rng(1000 * seed + sum(map(ord, kind)))
    C = _random_case(rng, kind)
    res = factorize_with_cofactor(C)
    deg_g = len(res.g) - 1
    assert deg_g >= 2, "the construction is non-generic"
    assert res.deg_R <= deg_g and res.bound_met
    assert res.residual < 1e-10
    assert len(res.factors) == C.shape[0] - 1 + res.deg_R
    assert all(is_rotation(h, 1e-9) for h in res.factors)
    # multiply back independently: prod (t - h) = C R
    R8 = np.zeros((len(res.R), 8))
    R8[:, 0] = res.R
    assert relative_error(product_of_linear(res.factors), poly_mul(C, R8)) < 1e-10
    # the real co-factor has no real zero (the motion stays bounded)
    if len(res.R) > 1:
        assert np.min(np.abs(np.roots(res.R[::-1]).imag)) > 1e-6
    return res


@pytest.mark.parametrize("kind", ["GT", "TG", "GTG", "shared", "TT", "TGT", "k2planar"])
@pytest.mark.parametrize("seed", range(4))
def test_random_nongeneric_motions_factor(kind, seed):
    res = _check_random(kind, seed)
    if kind == "shared":
        assert res.deg_R == 0  # the kernel search makes the translation circular


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["GT", "TG", "GTG", "shared", "TT", "TGT", "k2planar", "k2"])
@pytest.mark.parametrize("seed", range(4, 16))
def test_random_nongeneric_motions_factor_sweep(kind, seed):
    _check_random(kind, seed)


def test_nonplanar_repeated_factor_one_case():
    _check_random("k2", 0)
