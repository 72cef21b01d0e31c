"""Motion polynomials (synth.algebra.polynomial) against docs/algorithm1.md and the numbers of its example A."""
import numpy as np
import pytest

from synth.algebra.dq import dq_inv, dq_mul, plucker
from synth.algebra.geometry import rotation_about_line
from synth.algebra.factorize import classify
from synth.algebra.polynomial import (
    degree,
    divide_linear_right,
    divide_real_quadratic,
    divide_right,
    evaluate,
    is_motion_polynomial,
    linear,
    make_monic,
    norm_poly,
    norm_poly_full,
    pose_at,
    poly_conj,
    poly_mul,
    product_of_linear,
    relative_error,
    right_value,
    study_residual,
)


def dq(s=0, i=0, j=0, k=0, es=0, ei=0, ej=0, ek=0):
    return np.array([s, i, j, k, es, ei, ej, ek], float)


H1 = dq(i=1, ej=1)  # i + eps j
H2 = dq(s=1, j=2, ei=3, ek=1)  # 1 + 2j + eps(3i + k)
# C = (t - h1)(t - h2) = t^2 + [-1 - i - 2j - eps(3i + j + k)] t + [i + 2k - 5 eps]
C_A = np.array([dq(i=1, k=2, es=-5), dq(s=-1, i=-1, j=-2, ei=-3, ej=-1, ek=-1), dq(s=1)])


def random_revolute(rng, box=2.0):
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    c = rng.uniform(-box, box, size=3)
    a = rng.uniform(-box, box)
    b = rng.uniform(0.3, box)
    return np.concatenate([[a], -b * u, [0], b * np.cross(c, u)])


# ------------------------------------------------------------------ products, norm (section 3)
def test_example_A_product():
    C = product_of_linear(np.stack([H1, H2]))
    assert np.allclose(C, C_A, atol=1e-15)
    assert np.allclose(poly_mul(linear(H1), linear(H2)), C_A)
    assert degree(C) == 2


def test_example_A_norm():
    assert np.allclose(norm_poly(C_A), [5, -2, 6, -2, 1])
    full = norm_poly_full(C_A)
    assert np.allclose(full[:, 0], [5, -2, 6, -2, 1])
    assert np.allclose(full[:, 1:], 0)
    assert is_motion_polynomial(C_A)
    assert study_residual(C_A) < 1e-15
    # N(C) = (t^2 + 1)(t^2 - 2t + 5) = N(t - h1) N(t - h2)
    assert np.allclose(np.convolve(norm_poly(linear(H1)), norm_poly(linear(H2))), [5, -2, 6, -2, 1])


def test_product_order_matters():
    assert not np.allclose(product_of_linear(np.stack([H1, H2])), product_of_linear(np.stack([H2, H1])))


def test_conjugate_of_product():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 8))
    B = rng.normal(size=(2, 8))
    assert np.allclose(poly_conj(poly_mul(A, B)), poly_mul(poly_conj(B), poly_conj(A)))


def test_not_a_motion_polynomial():
    C = np.array([dq(k=1), dq(s=1)])  # t + k + eps ... fine; perturb the dual part to break Study
    assert is_motion_polynomial(C)
    bad = C_A.copy()
    bad[0, 4] += 1.0  # i + 2k - 4 eps: dual part of the norm no longer vanishes
    assert not is_motion_polynomial(bad)
    assert study_residual(bad) > 1e-3


def test_norm_of_linear_factor():
    """N(t - h) = (t - a)^2 + b^2 (section 5)."""
    assert np.allclose(norm_poly(linear(H2)), [5, -2, 1])


# ------------------------------------------------------------------ evaluation
def test_evaluate_and_infinity():
    for t in (0.0, 1.5, -2.0):
        assert np.allclose(evaluate(C_A, t), C_A[0] + t * C_A[1] + t * t * C_A[2])
    vals = evaluate(C_A, np.array([0.0, 1.0, np.inf, -np.inf]))
    assert vals.shape == (4, 8)
    assert np.allclose(vals[2], dq(s=1))
    assert np.allclose(vals[3], dq(s=1))
    assert np.allclose(pose_at(C_A, np.inf), np.eye(4))


def test_evaluation_is_a_homomorphism():
    """t is real and central: (AB)(t) = A(t) B(t)."""
    rng = np.random.default_rng(1)
    hs = np.stack([random_revolute(rng) for _ in range(3)])
    C = product_of_linear(hs)
    for t in (-1.3, 0.0, 0.7, 4.0):
        prod = evaluate(linear(hs[0]), t)
        for h in hs[1:]:
            prod = dq_mul(prod, evaluate(linear(h), t))
        assert np.allclose(evaluate(C, t), prod)


# ------------------------------------------------------------------ section 5 worked example
def test_example_revolute_joint():
    """h = 1 + 2j + eps(3i + k): u = (0,-1,0), m = (1.5,0,0.5), foot (-0.5,0,1.5), a = 1, b = 2, and at
    t = 3 the pose of t - h is the rotation by +pi/2 about (u, m)."""
    f = classify(H2)
    assert f.kind == "revolute"
    u, m = f.line
    assert np.allclose(u, [0, -1, 0])
    assert np.allclose(m, [1.5, 0, 0.5])
    assert np.allclose(np.cross(u, m), [-0.5, 0, 1.5])
    assert f.a == pytest.approx(1.0)
    assert f.b == pytest.approx(2.0)
    assert f.quadratic == pytest.approx((5.0, -2.0))
    assert f.angle(3.0) == pytest.approx(np.pi / 2)
    assert f.angle(np.inf) == 0.0
    T = pose_at(linear(H2), 3.0)
    assert np.allclose(T, rotation_about_line(u, m, np.pi / 2), atol=1e-15)
    # the foot point is fixed by the motion, a point off the axis is not
    foot = np.cross(u, m)
    assert np.allclose(T[:3, :3] @ foot + T[:3, 3], foot)


def test_angle_law_over_all_t():
    """theta(t) = 2 atan2(b, t - a) reproduces the pose of t - h for every t, and decreases from 2 pi to
    0 as t runs from -inf to +inf (one turn over the whole motion)."""
    rng = np.random.default_rng(2)
    h = random_revolute(rng)
    f = classify(h)
    u, m = f.line
    ts = np.array([-50.0, -3.0, -0.2, 0.0, 0.4, 1.0, 7.0, 1e3])
    for t in ts:
        assert np.allclose(pose_at(linear(h), t), rotation_about_line(u, m, f.angle(t)), atol=1e-12)
    th = f.angle(ts)
    assert np.all(np.diff(th) < 0)
    assert 0 < th.min() and th.max() < 2 * np.pi


def test_product_of_exponentials():
    """pose(t) of (t - h1)...(t - hn) = Rot(L1, theta1) ... Rot(Ln, thetan) (section 5)."""
    rng = np.random.default_rng(3)
    hs = np.stack([random_revolute(rng) for _ in range(4)])
    C = product_of_linear(hs)
    for t in (-2.0, 0.3, 5.0):
        T = np.eye(4)
        for h in hs:
            f = classify(h)
            T = T @ rotation_about_line(*f.line, f.angle(t))
        assert np.allclose(pose_at(C, t), T, atol=1e-12)


def test_translation_factor():
    """t - eps i is a translation by 2i/t; classified as such."""
    h = dq(ei=1)
    f = classify(h)
    assert f.kind == "translation"
    assert np.allclose(f.translation_direction, [2, 0, 0])
    for t in (0.5, -4.0):
        T = pose_at(linear(h), t)
        assert np.allclose(T[:3, :3], np.eye(3))
        assert np.allclose(T[:3, 3], [2 / t, 0, 0])


# ------------------------------------------------------------------ division (section 3, 11 A)
def test_example_A_division_by_second_quadratic():
    """M = t^2 - 2t + 5: r1 = 1 - i - 2j - eps(3i + j + k), r0 = -5 + i + 2k - 5 eps, h = h2, quotient t - h1."""
    Q, r1, r0 = divide_real_quadratic(C_A, [5.0, -2.0])
    assert np.allclose(r1, dq(s=1, i=-1, j=-2, ei=-3, ej=-1, ek=-1))
    assert np.allclose(r0, dq(s=-5, i=1, k=2, es=-5))
    assert np.allclose(Q, [dq(s=1)])
    h = -dq_mul(dq_inv(r1), r0)
    assert np.allclose(h, H2)
    D, rem = divide_linear_right(C_A, h)
    assert np.allclose(rem, 0, atol=1e-14)
    assert np.allclose(D, linear(H1))


def test_example_A_division_by_first_quadratic():
    """M = t^2 + 1: r1 = -1 - i - 2j - eps(3i + j + k), r0 = -1 + i + 2k - 5 eps and r1^-1 as in 11 A."""
    _, r1, r0 = divide_real_quadratic(C_A, [1.0, 0.0])
    assert np.allclose(r1, dq(s=-1, i=-1, j=-2, ei=-3, ej=-1, ek=-1))
    assert np.allclose(r0, dq(s=-1, i=1, k=2, es=-5))
    r1inv = dq_inv(r1)
    assert np.allclose(r1inv, dq(s=-1 / 6, i=1 / 6, j=1 / 3, es=5 / 18, ei=2 / 9, ej=-7 / 18, ek=1 / 6))
    h = -dq_mul(r1inv, r0)
    assert np.allclose(h, dq(i=-1 / 3, j=2 / 3, k=2 / 3, ei=14 / 9, ej=14 / 9, ek=-7 / 9))
    D, rem = divide_linear_right(C_A, h)
    assert np.allclose(rem, 0, atol=1e-14)
    left = dq(s=1, i=4 / 3, j=4 / 3, k=-2 / 3, ei=13 / 9, ej=-5 / 9, ek=16 / 9)
    assert np.allclose(D, linear(left))


def test_remainder_theorem():
    """The remainder of C by t - h is the right value C(h); general right division agrees."""
    rng = np.random.default_rng(4)
    C = rng.normal(size=(4, 8))
    C[-1] = dq(s=1)
    h = rng.normal(size=8)
    D, rem = divide_linear_right(C, h)
    assert np.allclose(rem, right_value(C, h))
    assert np.allclose(poly_mul(D, linear(h)) + np.concatenate([[rem], np.zeros((3, 8))]), C)
    Q, R = divide_right(C, linear(h))
    assert np.allclose(Q, D)
    assert np.allclose(R[0], rem)


def test_divide_right_general():
    rng = np.random.default_rng(5)
    C = rng.normal(size=(5, 8))
    Dv = rng.normal(size=(3, 8))
    Q, R = divide_right(C, Dv)
    assert Q.shape == (3, 8) and R.shape == (2, 8)
    back = poly_mul(Q, Dv)
    back[:2] += R
    assert np.allclose(back, C)


def test_real_quadratic_division_reconstructs():
    rng = np.random.default_rng(6)
    C = rng.normal(size=(5, 8))
    M = np.array([2.0, -0.5])
    Q, r1, r0 = divide_real_quadratic(C, M)
    Mpoly = np.zeros((3, 8))
    Mpoly[:, 0] = [M[0], M[1], 1.0]
    back = poly_mul(Q, Mpoly)
    back[0] += r0
    back[1] += r1
    assert np.allclose(back, C)


def test_batched_divisions():
    rng = np.random.default_rng(7)
    Cs = np.stack([product_of_linear(np.stack([random_revolute(rng) for _ in range(3)])) for _ in range(4)])
    Ms = np.array([[1.0, 0.0], [2.0, 1.0], [5.0, -2.0], [0.5, 0.1]])
    Q, r1, r0 = divide_real_quadratic(Cs, Ms)
    for b in range(4):
        q1, a1, a0 = divide_real_quadratic(Cs[b], Ms[b])
        assert np.allclose(Q[b], q1) and np.allclose(r1[b], a1) and np.allclose(r0[b], a0)
    hs = rng.normal(size=(4, 8))
    D, rem = divide_linear_right(Cs, hs)
    for b in range(4):
        d1, e1 = divide_linear_right(Cs[b], hs[b])
        assert np.allclose(D[b], d1) and np.allclose(rem[b], e1)


def test_make_monic_and_relative_error():
    C = C_A.copy()
    lead = dq(s=2, k=1, ei=0.5)
    scaled = dq_mul(lead, C)
    assert np.allclose(make_monic(scaled), C)
    assert relative_error(C, C) == 0
    assert relative_error(C + 1e-3, C) == pytest.approx(1e-3 / 5)


def test_plucker_of_rotation_factor_moment():
    u, m = plucker(H1)
    assert np.allclose(u, [-1, 0, 0])
    assert np.allclose(m, [0, 1, 0])
