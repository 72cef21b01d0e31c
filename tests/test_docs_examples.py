"""Every worked number in docs/*.md, recomputed with the library (so the docs stay true).

Each test names the page and section it checks. Where a number can be checked independently of the
code under test (Study condition, pose reproduction, fixed points, closed-form curves), it is.
"""
from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest

from synth.algebra.algorithm1 import algorithm1, multiply_back, norm_roots, orders, quadratics
from synth.algebra.cofactor import exact_result, factorize_with_cofactor
from synth.algebra.dq import act_on_points, dq_inv, dq_mul, dq_to_pose, plucker, pose_to_dq, quat_to_matrix, study_form
from synth.algebra.exact import factorize_exact
from synth.algebra.factorize import factorize
from synth.algebra.geometry import rotation_about_line
from synth.algebra.flip import bennett_flip
from synth.algebra.polynomial import (divide_real_quadratic, evaluate, linear, norm_poly, poly_mul,
                                      product_of_linear, study_residual)
from synth.algebra.realfactor import mrpf_exact
from synth.errors import SynthesisError
from synth.synthesis.bennett import bennett, bennett_parameters_of
from synth.synthesis.conic import relative_displacements
from synth.synthesis.multiloop import ladder_factors, ladder_linkage, loop_sides

I, J, K, ONE = (np.eye(8)[i] for i in (1, 2, 3, 0))
EI, EJ, EK = (np.eye(8)[i] for i in (5, 6, 7))


def dq(*terms):
    """Sum of (coefficient, basis element) pairs as an (8,) float array."""
    return sum(c * e for c, e in terms)


def pose(p, q):
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(np.array(q, float))
    T[:3, 3] = p
    return T


def frac_rows(rows):
    return [[F(x) for x in r] for r in rows]


# ============================================================================ docs/conventions.md
def test_pose_to_dq_example():
    """conventions.md section 2: position (1, 2, 3), quaternion (1/2, 1/2, 1/2, 1/2)."""
    T = pose([1, 2, 3], [0.5, 0.5, 0.5, 0.5])
    h = pose_to_dq(T)
    assert np.allclose(h, [0.5, 0.5, 0.5, 0.5, 1.5, 0, -1, -0.5], atol=1e-15)
    assert np.allclose(dq_to_pose(h), T, atol=1e-15)
    # independent: the action formula moves the body origin to the position, and 1 - eps/2 v translates by v
    assert np.allclose(act_on_points(h, np.zeros(3)), [1, 2, 3], atol=1e-14)
    v = np.array([0.3, -1.0, 2.0])
    tv = np.concatenate([[1, 0, 0, 0, 0], -v / 2])
    assert np.allclose(act_on_points(tv, np.array([5.0, 6, 7])), [5.3, 5, 9], atol=1e-14)


def test_joint_example():
    """conventions.md section 4: h = 1 + 2j + eps(3i + k)."""
    h = dq((1, ONE), (2, J), (3, EI), (1, EK))
    u, m = plucker(h)
    assert np.allclose(u, [0, -1, 0]) and np.allclose(m, [1.5, 0, 0.5])
    assert np.allclose(np.cross(u, m), [-0.5, 0, 1.5])
    theta = 2 * np.arctan2(2.0, 3.0 - 1.0)
    assert theta == pytest.approx(np.pi / 2)
    # the displacement (t - h)(3) is the rotation by pi/2 about the line (u, m)
    C = linear(h)
    assert np.allclose(dq_to_pose(evaluate(C, 3.0)), rotation_about_line(u, m, np.pi / 2), atol=1e-14)


# ============================================================================ docs/algorithm1.md
C_A = np.array([[0, 1, 0, 2, -5, 0, 0, 0], [-1, -1, -2, 0, 0, -3, -1, -1], [1, 0, 0, 0, 0, 0, 0, 0]], float)
H1_A = dq((1, I), (1, EJ))
H2_A = dq((1, ONE), (2, J), (3, EI), (1, EK))


def test_algorithm1_example_polynomial():
    """algorithm1.md section 5: C = (t - h1)(t - h2), N(C) = (t^2 + 1)(t^2 - 2t + 5)."""
    assert np.allclose(product_of_linear(np.array([H1_A, H2_A])), C_A, atol=1e-15)
    assert np.allclose(norm_poly(C_A), [5, -2, 6, -2, 1], atol=1e-14)
    z = norm_roots(norm_poly(C_A))
    assert np.allclose(z, [1j, 1 + 2j], atol=1e-12)  # quadratic 0: t^2 + 1, quadratic 1: t^2 - 2t + 5
    assert np.allclose(quadratics(z), [[1, 0], [5, -2]], atol=1e-12)


def test_algorithm1_example_steps():
    """algorithm1.md section 5: remainders, r1^-1 and both factorizations."""
    _, r1, r0 = divide_real_quadratic(C_A, np.array([5.0, -2.0]))
    assert np.allclose(r1, [1, -1, -2, 0, 0, -3, -1, -1]) and np.allclose(r0, [-5, 1, 0, 2, -5, 0, 0, 0])
    assert np.allclose(-dq_mul(dq_inv(r1), r0), H2_A, atol=1e-14)
    _, r1, r0 = divide_real_quadratic(C_A, np.array([1.0, 0.0]))
    assert np.allclose(r1, [-1, -1, -2, 0, 0, -3, -1, -1]) and np.allclose(r0, [-1, 1, 0, 2, -5, 0, 0, 0])
    assert np.allclose(dq_inv(r1), [-1 / 6, 1 / 6, 1 / 3, 0, 5 / 18, 2 / 9, -7 / 18, 1 / 6], atol=1e-14)
    M = np.array([[1.0, 0.0], [5.0, -2.0]])
    H, ok = algorithm1(C_A, M[orders(2)])
    assert ok.all() and np.all(multiply_back(C_A, H) < 1e-14)
    assert np.allclose(H[0], [H1_A, H2_A], atol=1e-14)
    h2p = [0, -1 / 3, 2 / 3, 2 / 3, 0, 14 / 9, 14 / 9, -7 / 9]
    h1p = [1, 4 / 3, 4 / 3, -2 / 3, 0, 13 / 9, -5 / 9, 16 / 9]
    assert np.allclose(H[1], [h1p, h2p], atol=1e-14)
    u, _ = plucker(np.array(h2p))
    assert np.allclose(u, [1 / 3, -2 / 3, -2 / 3])


def test_algorithm1_example_numbering_and_exact():
    """algorithm1.md sections 4, 5, 8: factorization 1 = order (0, 1); the exact twin agrees."""
    res = factorize(C_A)
    assert np.allclose(res.quadratics, [[1, 0], [5, -2]], atol=1e-12)
    assert [f.order for f in res.factorizations] == [(0, 1), (1, 0)]
    ex = factorize_exact(frac_rows(C_A.astype(int).tolist()))
    h2p = (0, F(-1, 3), F(2, 3), F(2, 3), 0, F(14, 9), F(14, 9), F(-7, 9))
    h1p = (1, F(4, 3), F(4, 3), F(-2, 3), 0, F(13, 9), F(-5, 9), F(16, 9))
    got = [[tuple(F(x) for x in h) for h in f.factors] for f in ex.factorizations]
    assert got[0] == [tuple(F(int(x)) for x in H1_A), tuple(F(int(x)) for x in H2_A)]
    assert got[1] == [h1p, h2p]


def test_repeated_quadratic_single_factorization():
    """algorithm1.md section 4: (t - i - eps j)(t - j - eps k) has exactly one factorization."""
    C = product_of_linear(np.array([dq((1, I), (1, EJ)), dq((1, J), (1, EK))]))
    assert np.allclose(norm_poly(C), [1, 0, 2, 0, 1])
    res = factorize(C)
    assert len(res.factorizations) == 1
    assert multiply_back(C, res.factorizations[0].factors) < 1e-12


def test_nongeneric_examples():
    """algorithm1.md section 6 and exceptional.md section 1: real factors of the primal part."""
    C = poly_mul(linear(ONE), linear(J))
    C[1] -= EI + EK
    C[0] += 2 * EK
    assert np.allclose(norm_poly(C), poly_mul(np.array([[1, -2, 1]]).T * ONE, np.array([[1, 0, 1]]).T * ONE)[:, 0])
    g, bounded = mrpf_exact(frac_rows(C.astype(int).tolist()))
    assert g == [-1, 1] and not bounded  # g = t - 1
    M = np.array([[1.0, -2.0], [1.0, 0.0]])  # (t - 1)^2 and t^2 + 1
    H, ok = algorithm1(C, M[orders(2)])
    assert ok.all() and np.all(multiply_back(C, H) < 1e-14)
    assert np.allclose(H[0], [dq((1, ONE), (1, EI)), dq((1, J), (1, EK))], atol=1e-14)
    assert np.allclose(H[1], [dq((1, J), (1, EI), (2, EK)), dq((1, ONE), (-1, EK))], atol=1e-14)
    # the elliptic translation: every order stops at the genericity test
    E = np.zeros((3, 8))
    E[2, 0] = E[0, 0] = 1
    E[0, 5], E[1, 6] = 1.0, 2.0  # t^2 + 1 + eps(i + 2 j t)
    _, ok = algorithm1(E, np.array([[1.0, 0.0], [1.0, 0.0]]))
    assert not ok
    g, bounded = mrpf_exact(frac_rows(E.astype(int).tolist()))
    assert g == [1, 0, 1] and bounded


# ============================================================================ docs/conic.md
T_D = np.array([pose([0, 0, 0], [1, 0, 0, 0]), pose([1, 0, 0.5], [0.6, 0, 0, 0.8]),
                pose([0.25, 1, 0.2], [0.6, 0.8, 0, 0])])


def test_conic_example_exact_numbers():
    """conic.md section 4: B values, mu, C and N(C), from the formulas of section 2 (not conic.py)."""
    D = relative_displacements(T_D)
    assert np.allclose(D[1], [0.6, 0, 0, 0.8, 0.2, -0.3, 0.4, -0.15], atol=1e-15)
    B01, B02, B12 = D[1, 4] / 2, D[2, 4] / 2, float(study_form(D[1], D[2]))
    assert (B01, B02, B12) == pytest.approx((1 / 10, 1 / 20, 53 / 500), abs=1e-15)
    mu1, mu2 = -B02 / B12, B01 / B12
    assert (mu1, mu2) == pytest.approx((-25 / 53, 50 / 53), abs=1e-15)
    C = np.zeros((3, 8))
    C[2] = ONE
    C[1] = -ONE + mu1 * D[1] + mu2 * D[2]  # t(t - 1) + mu1 (t - 1) D1 + mu2 t D2
    C[0] = -mu1 * D[1]
    assert study_residual(C) < 1e-15
    c1 = [-38 / 53, 40 / 53, 0, -20 / 53, 0, 15 / 212, -29 / 53, 83 / 212]
    c0 = [15 / 53, 0, 0, 20 / 53, 5 / 53, -15 / 106, 10 / 53, -15 / 212]
    assert np.allclose(C[1], c1, atol=1e-15) and np.allclose(C[0], c0, atol=1e-15)
    assert np.allclose(norm_poly(C), [625 / 2809, -1940 / 2809, 5034 / 2809, -76 / 53, 1], atol=1e-14)
    z = norm_roots(norm_poly(C))
    assert np.allclose(z, [0.2128367441 + 0.3799257778j, 0.5041443880 + 0.9586920209j], atol=1e-10)
    # the curve hits the poses: C(0) ~ D1, C(1) ~ D2
    for t, Di in ((0.0, D[1]), (1.0, D[2])):
        v = evaluate(C, t)
        assert np.allclose(v / np.linalg.norm(v[:4]) * np.sign(v[0]), Di, atol=1e-14)


def test_bennett_example():
    """conic.md section 4: axes, angles and Bennett parameters of `bennett`."""
    lk = bennett(T_D)
    h1, k1 = lk.joint("h1"), lk.joint("k1")
    assert np.allclose(h1.direction, [-0.2327764841, -0.9407168724, -0.2467121287], atol=1e-10)
    assert np.allclose(h1.moment, [0.6227965221, -0.0290471829, -0.4768602594], atol=1e-10)
    assert np.allclose(k1.direction, [0.8794844950, -0.3728022990, -0.2958470363], atol=1e-10)
    assert np.allclose(k1.moment, [0.0335470508, 0.5490998426, -0.5922032374], atol=1e-10)
    assert (h1.a, h1.b) == pytest.approx((0.2128367441, 0.3799257778), abs=1e-10)
    ang = [p.joint_angles for p in lk.poses]
    assert all(abs(x) < 1e-15 for x in ang[0].values())
    for a, (x, y) in zip(ang[1:], ((4.1628830873, 4.1098453272), (0.8993459891, 2.1869341004))):
        assert (a["h1"], a["k2"], a["h2"], a["k1"]) == pytest.approx((x, x, y, y), abs=1e-9)
    par = bennett_parameters_of(lk).to_dict()
    assert par["a"] == pytest.approx(0.2956964860, abs=1e-10)
    assert par["alpha"] == pytest.approx(-2.0742295787, abs=1e-10)
    assert par["b"] == pytest.approx(0.3293871988, abs=1e-10)
    assert par["beta"] == pytest.approx(-1.3500405141, abs=1e-10)
    ratio = par["a"] / abs(np.sin(par["alpha"]))
    assert ratio == pytest.approx(0.3375795005, abs=1e-10)
    assert par["b"] / abs(np.sin(par["beta"])) == pytest.approx(ratio, rel=1e-12)
    # independent: the tool reaches each pose at the reported angles
    for p in lk.poses:
        assert np.allclose(lk.tool_pose(p.joint_angles), p.matrix, atol=1e-12)


@pytest.mark.parametrize("poses, words", [
    ([pose([0, 0, 0], [1, 0, 0, 0]), pose([1, 0, 0], [1, 0, 0, 0]), pose([0, 1, 0], [1, 0, 0, 0])],
     "pure translations"),
    ([pose([0, 0, 0], [1, 0, 0, 0]), pose([1, 0, 0.5], [0.6, 0, 0, 0.8]), pose([1, 0, 0.5], [0.6, 0, 0, 0.8])],
     "coincide"),
])
def test_bennett_degenerate_messages(poses, words):
    """conic.md section 5: pure translations and coincident poses are refused with their message (planar
    pose sets have a family of four-bars, docs/planar.md)."""
    with pytest.raises(SynthesisError, match=words):
        bennett(np.array(poses))


# ============================================================================ docs/cubic.md
T_E = np.concatenate([T_D, [pose([-1, 0.5, 0], [0.2, 0.4, 0.4, 0.8])]])


def test_cubic_example():
    """cubic.md section 7: signature, t3 of both families, the member lambda1 = 0.5 of family 2."""
    from synth.synthesis.cubic import families, quadric

    D = relative_displacements(T_E)
    q = quadric(D)
    assert q.signature == (2, 2)
    fams, _ = families(q)
    assert [f.index for f in fams] == [1, 2]
    assert [f.t3 for f in fams] == pytest.approx([0.8414306314, -0.7848268578], abs=1e-10)
    fam = fams[1]
    C = fam.member(0.5)
    c1 = [-0.6676567652, 0.3246889073, 0.8343860133, 1.7784385804, -0.2448920031, -0.2019373573,
          -0.6417448627, 0.3886057611]
    c2 = [-1.5016952533, -1.4838249321, -0.8343860133, -2.1784385804, 0, 0.4606063597, 0.9923344744,
          -0.8062385716]
    assert np.allclose(C[0], [0.3, 0, 0, 0.4, 0.1, -0.15, 0.2, -0.075], atol=1e-12)
    assert np.allclose(C[1], c1, atol=1e-9) and np.allclose(C[2], c2, atol=1e-9) and np.allclose(C[3], ONE)
    N = [0.25, 1.0221568052, 1.7664642298, -7.4991674723, 8.5633062001, -3.0033905067, 1]
    assert np.allclose(norm_poly(C), N, atol=1e-9)
    # independent checks of the stated member: a motion polynomial through the four poses
    assert study_residual(C) < 1e-13
    for t, Di in ((0.0, D[1]), (1.0, D[2]), (fam.t3, D[3])):
        v = evaluate(C, t)
        assert np.allclose(v / np.linalg.norm(v[:4]) * np.sign(v[0]), Di, atol=1e-12)
    z = norm_roots(norm_poly(C))
    assert np.allclose(z, [-0.1658995584 + 0.1584960916j, 0.7454471107 + 0.4737237177j,
                           0.9221477010 + 2.2884851324j], atol=1e-9)
    H, ok = algorithm1(C, quadratics(z)[orders(3)])
    assert ok.all() and np.all(multiply_back(C, H) < 1e-13)
    bad = fam.bad_members()
    assert bad["lambda2"] == pytest.approx(0.4399665691, abs=1e-9)
    assert bad["lambda3"] == pytest.approx(0.3702013480, abs=1e-9)


def test_cubic_pair_table():
    """cubic.md section 5: the 9 loop pairs and their numbering."""
    from synth.synthesis.cubic import PAIRS, PERMS

    table = ["012 120", "012 201", "012 210", "021 102", "021 120", "021 210", "102 201", "102 210", "120 201"]
    got = [" ".join("".join(str(x) for x in PERMS[i]) for i in p) for p in PAIRS]
    assert got == table


def test_sixbar_default_choice():
    """cubic.md section 7: the default scan's choice for the example poses."""
    import synth

    lk = synth.sixbar(T_E)
    assert (lk.info.synthesis.family, lk.info.synthesis.pair) == (2, 9)
    assert lk.info.synthesis.member == pytest.approx(0.3893714696, abs=1e-8)
    assert lk.info.synthesis.score == pytest.approx(1.2586, abs=1e-4)
    assert lk.info.synthesis.orders.to_dict() == {"h": [1, 2, 0], "k": [2, 0, 1]}
    for p in lk.poses:
        assert np.allclose(lk.tool_pose(p.joint_angles), p.matrix, atol=1e-12)


# ============================================================================ docs/exceptional.md
def q(s):
    return F(s)


def test_flip_examples():
    """exceptional.md section 7 (Flip): exact values."""
    k, n = bennett_flip([1, 2, 0, 0, 0, 0, 3, 0], [0, 0, 0, 1, 0, 1, 1, 0])
    assert k == [0, q("2/3"), q("-2/3"), q("-1/3"), 0, q("14/9"), q("10/9"), q("8/9")]
    assert n == [1, q("4/3"), q("2/3"), q("4/3"), 0, q("-5/9"), q("26/9"), q("-8/9")]
    k, n = bennett_flip([0, 0, 0, 2, 0, 1, 0, 0], [0, 0, 1, 0, 0, 0, 0, 1])
    assert k == [0, 0, q("-3/5"), q("4/5"), 0, q("2/5"), q("12/25"), q("9/25")]
    assert n == [0, 0, q("8/5"), q("6/5"), 0, q("3/5"), q("-12/25"), q("16/25")]


C_ELL = np.array([[1, 0, 0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 0, 2, 0], [1, 0, 0, 0, 0, 0, 0, 0]], float)
E2 = [[0, 0, 0, 1, 0, 0, q("-3/4"), 0], [0, 0, 0, -1, 0, 0, q("-3/4"), 0],
      [0, 0, 0, -1, 0, 0, q("-1/4"), 0], [0, 0, 0, 1, 0, 0, q("-1/4"), 0]]
M0 = [2, 0, 0, q("3/2"), 0, q("3/2"), 0, 0]


def _feet(hs):
    return [np.cross(*plucker(np.array([float(x) for x in h])))[:2] for h in hs]


def test_ellipse_cofactor_example():
    """exceptional.md section 7 (Ellipse): R = t^2 + 1, the four exact factors and their axes."""
    for t in np.linspace(-5, 5, 11):  # independent: the origin runs on (x + 1)^2 + (y/2)^2 = 1
        x, y, z = act_on_points(evaluate(C_ELL, t), np.zeros(3))
        assert (x + 1) ** 2 + (y / 2) ** 2 == pytest.approx(1, abs=1e-14) and z == 0
    res = factorize_with_cofactor(C_ELL)
    assert np.allclose(res.R, [1, 0, 1]) and res.residual < 1e-12
    R, hs = exact_result(C_ELL, res)
    assert hs == E2
    assert np.allclose(_feet(hs), [[-0.75, 0], [0.75, 0], [0.25, 0], [-0.25, 0]], atol=1e-15)


def test_circle_example():
    """exceptional.md section 7 (Circle): R = 1, minimum-norm factors."""
    C = np.array([[1, 0, 0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 0, 1, 0], [1, 0, 0, 0, 0, 0, 0, 0]], float)
    res = factorize_with_cofactor(C)
    assert np.allclose(res.R, [1])
    assert np.allclose(res.factors, [[0, 0, 0, 1, 0, 0, -0.5, 0], [0, 0, 0, -1, 0, 0, -0.5, 0]], atol=1e-12)


def test_quaternion_cofactor_example():
    """exceptional.md section 7 (Quaternion co-factor): C H = (t - h1)(t - h2)(t - h3), the axis of h3."""
    CH = poly_mul(C_ELL, linear(K))
    res = factorize_with_cofactor(CH)
    assert np.allclose(res.R, [1])
    _, hs = exact_result(CH, res)
    assert hs == [[0, 0, 0, -1, 0, 0, q("-1/4"), 0], [0, 0, 0, 1, 0, 0, q("-1/4"), 0],
                  [0, 0, 0, 1, 0, 0, q("-3/2"), 0]]
    pair = product_of_linear(np.array([[float(x) for x in h] for h in hs[:2]]))
    assert np.allclose(pair, [[1, 0, 0, 0, 0, -0.5, 0, 0], [0, 0, 0, 0, 0, 0, 0.5, 0], ONE])
    # independent: h3's axis is the vertical line through (-3/2, 0), i.e. (-(a+b)/2, 0) -- not (+(a+b)/2, 0)
    # as MATH-EXCEPTIONAL.md section 9 (E4) states. Points of the axis are fixed by the rotation.
    h3 = np.array([0, 0, 0, 1, 0, 0, -1.5, 0])
    assert np.allclose(_feet([h3]), [[-1.5, 0]])
    g = evaluate(linear(h3), 0.7)
    assert np.allclose(act_on_points(g, np.array([-1.5, 0, 0.3])), [-1.5, 0, 0.3], atol=1e-14)
    assert not np.allclose(act_on_points(g, np.array([1.5, 0, 0.3])), [1.5, 0, 0.3], atol=1e-3)
    # the origin (on the axis of H = t - k) draws the ellipse under C H
    for t in np.linspace(-4, 4, 9):
        x, y, _ = act_on_points(evaluate(CH, t), np.zeros(3))
        assert (x + 1) ** 2 + (y / 2) ** 2 == pytest.approx(1, abs=1e-13)


def test_elliptic_translation_ladder():
    """exceptional.md section 7 (Elliptic-translation linkage): exact flips, counts, loop sides."""
    ks, ms = ladder_factors(E2, M0)
    assert ks == [[0, 0, 0, 1, 0, q("48/41"), q("-129/164"), 0],
                  [0, 0, 0, -1, 0, q("660/697"), q("-513/2788"), 0],
                  [0, 0, 0, -1, 0, q("288/289"), q("-715/1156"), 0],
                  [0, 0, 0, 1, 0, q("-8340/11849"), q("22957/47396"), 0]]
    assert [m[5:7] for m in ms[1:]] == [[q("27/82"), q("3/82")], [q("-21/34"), q("-9/17")],
                                        [q("-933/578"), q("-93/578")], [q("-1269/1394"), q("-624/697")]]
    assert all(m[:5] + m[7:] == [2, 0, 0, q("3/2"), 0, 0] for m in ms)
    assert np.allclose(_feet([M0]), [[0, -1]])
    lk = ladder_linkage([[float(x) for x in h] for h in E2], np.array([float(x) for x in M0]))
    assert len(lk.joints) == 13
    sides = loop_sides(lk)
    want = [[1.25, 0.8049], [0.7581, 1.1773], [0.7301, 1.1339], [1.0855, 0.6990]]
    for s, w in zip(sides, want):
        assert np.allclose(s, w + w, atol=1e-4)


def test_ellipse_drawing_ladder():
    """exceptional.md section 7 (Ellipse-drawing linkage): exact flips and axis points."""
    hs = [[0, 0, 0, -1, 0, 0, q("-1/4"), 0], [0, 0, 0, 1, 0, 0, q("-1/4"), 0], [0, 0, 0, 1, 0, 0, q("-3/2"), 0]]
    ks, ms = ladder_factors(hs, M0)
    assert ks == [[0, 0, 0, -1, 0, 0, q("5/4"), 0], [0, 0, 0, 1, 0, q("12/41"), q("-227/164"), 0],
                  [0, 0, 0, 1, 0, q("2226/1681"), q("-3537/3362"), 0]]
    assert [m[5:7] for m in ms[1:]] == [[q("3/2"), q("-3/2")], [q("99/82"), q("-15/41")],
                                        [q("-393/3362"), q("-1368/1681")]]
    assert np.allclose(_feet([ks[0], ms[1]]), [[-1.25, 0], [-1, -1]])
    lk = ladder_linkage([[float(x) for x in h] for h in hs], np.array([float(x) for x in M0]))
    assert len(lk.joints) == 10
    for s, w in zip(loop_sides(lk), [[1.0308, 1.6008], [1.25, 0.8049], [1.4918, 0.9606]]):
        assert np.allclose(s, w + w, atol=1e-4)
