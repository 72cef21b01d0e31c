"""Dual quaternion algebra and poses (synth.algebra.dq) against docs/conventions.md."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.dq import (
    act_on_points,
    dq_conj,
    dq_inv,
    dq_left_divide,
    dq_left_matrix,
    dq_mul,
    dq_norm,
    dq_to_pose,
    dq_translation,
    exact_array,
    matrix_to_quat,
    normalize_dq,
    plucker,
    pose_to_dq,
    qconj,
    qinv,
    qmul,
    quat_to_matrix,
    study_condition,
    study_form,
    translation_dq,
)
from synth.algebra.geometry import rotation_about_line

ONE = np.eye(8)[0]
Q1, QI, QJ, QK = np.eye(4)

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
dq_strategy = st.lists(finite, min_size=8, max_size=8).map(np.array)
vec3 = st.lists(st.floats(-100, 100, allow_nan=False), min_size=3, max_size=3).map(np.array)


def unit_vector(x):
    x = np.asarray(x, float)
    n = np.linalg.norm(x)
    return x / n if n > 1e-3 else np.array([0.0, 0.0, 1.0])


def axis_angle_R(u, theta):
    u = unit_vector(u)
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K


def pose(R, d):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = d
    return T


def dq_tol(a, b):
    return 1e-12 * max(1.0, np.abs(a).max(), np.abs(b).max())


# ------------------------------------------------------------------ quaternions (section 1)
def test_hamilton_units():
    assert np.allclose(qmul(QI, QJ), QK)
    assert np.allclose(qmul(QJ, QI), -QK)
    assert np.allclose(qmul(QJ, QK), QI)
    assert np.allclose(qmul(QK, QI), QJ)
    for u in (QI, QJ, QK):
        assert np.allclose(qmul(u, u), -Q1)
    assert np.allclose(qmul(qmul(QI, QJ), QK), -Q1)  # ijk = -1


def test_quaternion_product_formula():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 4))
    a0, av, b0, bv = a[0], a[1:], b[0], b[1:]
    expect = np.concatenate([[a0 * b0 - av @ bv], a0 * bv + b0 * av + np.cross(av, bv)])
    assert np.allclose(qmul(a, b), expect)
    assert np.allclose(qmul(a, qinv(a)), Q1)
    assert np.allclose(qconj(a), [a[0], -a[1], -a[2], -a[3]])


def test_dual_unit_squares_to_zero():
    eps = np.eye(8)[4]
    assert np.allclose(dq_mul(eps, eps), 0)
    # eps commutes with everything
    h = np.arange(1.0, 9.0)
    assert np.allclose(dq_mul(eps, h), dq_mul(h, eps))


def test_dual_quaternion_product_definition():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(2, 8))
    p1, q1, p2, q2 = a[:4], a[4:], b[:4], b[4:]
    expect = np.concatenate([qmul(p1, p2), qmul(p1, q2) + qmul(q1, p2)])
    assert np.allclose(dq_mul(a, b), expect)
    assert np.allclose(b @ dq_left_matrix(a), expect)


def test_batched_product_broadcasts():
    rng = np.random.default_rng(2)
    A = rng.normal(size=(5, 8))
    B = rng.normal(size=(5, 8))
    out = dq_mul(A, B)
    assert out.shape == (5, 8)
    for k in range(5):
        assert np.allclose(out[k], dq_mul(A[k], B[k]))
    assert dq_mul(A[:, None, :], B[None, :, :]).shape == (5, 5, 8)


@settings(max_examples=60, deadline=None)
@given(dq_strategy, dq_strategy, dq_strategy)
def test_associativity(a, b, c):
    left = dq_mul(dq_mul(a, b), c)
    right = dq_mul(a, dq_mul(b, c))
    assert np.allclose(left, right, rtol=0, atol=1e-12 * max(1.0, np.abs(left).max()))


@settings(max_examples=60, deadline=None)
@given(dq_strategy, dq_strategy)
def test_conjugate_reverses_products(a, b):
    lhs = dq_conj(dq_mul(a, b))
    rhs = dq_mul(dq_conj(b), dq_conj(a))
    assert np.allclose(lhs, rhs, rtol=0, atol=dq_tol(lhs, rhs))


@settings(max_examples=60, deadline=None)
@given(dq_strategy, dq_strategy)
def test_norm_is_multiplicative(a, b):
    # N(h) = h h~ as an 8-vector is the dual number N(h)[0] + eps N(h)[1]
    nab = dq_norm(dq_mul(a, b))
    na, nb = dq_norm(a), dq_norm(b)
    expect = np.array([na[0] * nb[0], na[0] * nb[1] + na[1] * nb[0]])
    assert np.allclose(nab, expect, rtol=0, atol=1e-12 * max(1.0, np.abs(expect).max()))
    full = dq_mul(a, dq_conj(a))
    assert np.allclose(full[[0, 4]], na, rtol=0, atol=dq_tol(full, na))
    assert np.allclose(full[[1, 2, 3, 5, 6, 7]], 0, atol=dq_tol(full, na))


@settings(max_examples=60, deadline=None)
@given(dq_strategy)
def test_inverse(h):
    if np.linalg.norm(h[:4]) < 1e-2:
        return
    inv = dq_inv(h)
    assert np.allclose(dq_mul(h, inv), ONE, atol=1e-9)
    assert np.allclose(dq_mul(inv, h), ONE, atol=1e-9)


def test_norm_formula():
    h = np.array([1.0, 2, 3, 4, 5, 6, 7, 8])
    p, q = h[:4], h[4:]
    assert np.allclose(dq_norm(h), [p @ p, 2 * p @ q])
    assert study_condition(h) == pytest.approx(p @ q)
    g = np.array([0.5, -1, 0, 2, 1, 1, -3, 0])
    assert study_form(g, h) == pytest.approx(0.5 * (g[:4] @ h[4:] + h[:4] @ g[4:]))
    assert study_form(h, h) == pytest.approx(study_condition(h))


# ------------------------------------------------------------------ poses (section 2)
def test_pose_example_B():
    """docs/conventions.md, example B: position (1, 2, 3), quaternion (1/2, 1/2, 1/2, 1/2)."""
    T = pose(quat_to_matrix([0.5, 0.5, 0.5, 0.5]), [1, 2, 3])
    h = pose_to_dq(T)
    assert np.allclose(h, [0.5, 0.5, 0.5, 0.5, 1.5, 0, -1, -0.5], atol=1e-15)
    assert np.allclose(dq_to_pose(h), T, atol=1e-15)
    assert abs(study_condition(h)) < 1e-15


def test_action_formula_and_pose_agree():
    """x -> (p x p~ + p q~ - q p~) / N(p) equals R x + d of dq_to_pose, also for non-unit h."""
    rng = np.random.default_rng(3)
    T = pose(axis_angle_R(rng.normal(size=3), 2.0), rng.normal(size=3))
    h = 2.5 * pose_to_dq(T)
    x = rng.normal(size=3)
    p, q = h[:4], h[4:]
    xq = np.concatenate([[0], x])
    img = (qmul(qmul(p, xq), qconj(p)) + qmul(p, qconj(q)) - qmul(q, qconj(p))) / (p @ p)
    assert abs(img[0]) < 1e-12
    assert np.allclose(img[1:], T[:3, :3] @ x + T[:3, 3])
    assert np.allclose(act_on_points(h, x), img[1:])
    assert np.allclose(act_on_points(-h, x), img[1:])  # h and -h are the same pose


def test_translation_sign_convention():
    v = np.array([1.0, -2.0, 0.5])
    h = translation_dq(v)
    assert np.allclose(h, [1, 0, 0, 0, 0, -0.5, 1.0, -0.25])  # dual part -v/2
    x = np.array([3.0, 4.0, 5.0])
    assert np.allclose(act_on_points(h, x), x + v)
    assert np.allclose(dq_to_pose(h), pose(np.eye(3), v))


def test_survey_translation_t_minus_eps_i():
    """t - eps i moves every point by 2i/t (docs/conventions.md)."""
    for t in (0.5, 2.0, -3.0):
        h = np.array([t, 0, 0, 0, 0, -1, 0, 0])
        x = np.array([0.3, -1.0, 2.0])
        assert np.allclose(act_on_points(h, x), x + np.array([2 / t, 0, 0]))


def test_composition_matches_matrix_product():
    rng = np.random.default_rng(4)
    T1 = pose(axis_angle_R(rng.normal(size=3), 0.7), rng.normal(size=3))
    T2 = pose(axis_angle_R(rng.normal(size=3), -2.2), rng.normal(size=3))
    h = dq_mul(pose_to_dq(T1), pose_to_dq(T2))
    assert np.allclose(dq_to_pose(h), T1 @ T2)
    # rotate, then translate: (1 - eps d/2) r
    r = pose_to_dq(pose(T1[:3, :3], np.zeros(3)))
    assert np.allclose(dq_mul(translation_dq(T1[:3, 3]), r), pose_to_dq(T1))


@settings(max_examples=80, deadline=None)
@given(vec3, vec3, st.floats(-np.pi, np.pi), st.sampled_from([0.0, 1e-9, 1e-5, 1e-3]), st.booleans())
def test_pose_round_trip(axis, d, theta, near_pi, use_near_pi):
    """Random poses, including rotations within 1e-9..1e-3 rad of 180 degrees."""
    if use_near_pi:
        theta = np.pi - near_pi
    R = axis_angle_R(axis, theta)
    T = pose(R, d)
    h = pose_to_dq(T)
    assert h[0] >= 0
    assert abs(np.linalg.norm(h[:4]) - 1) < 1e-14
    assert abs(study_condition(h)) < 1e-12 * max(1.0, np.abs(d).max())
    T2 = dq_to_pose(h)
    assert np.allclose(T2[:3, :3], R, rtol=0, atol=1e-14)
    assert np.allclose(T2[:3, 3], d, rtol=0, atol=1e-13 * max(1.0, np.abs(d).max()))
    assert np.allclose(pose_to_dq(T2), h, rtol=0, atol=1e-13 * max(1.0, np.abs(d).max()))


def test_round_trip_exact_half_turns():
    for u in (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]), unit_vector([1, -1, 2])):
        R = axis_angle_R(u, np.pi)
        q = matrix_to_quat(R)
        assert abs(q[0]) < 1e-15
        assert np.allclose(np.abs(q[1:]), np.abs(u))
        assert np.allclose(quat_to_matrix(q), R, atol=1e-15)


def test_batched_pose_conversion():
    rng = np.random.default_rng(5)
    Ts = np.stack([pose(axis_angle_R(rng.normal(size=3), a), rng.normal(size=3)) for a in (0.1, 1.5, 3.1)])
    H = pose_to_dq(Ts)
    assert H.shape == (3, 8)
    assert np.allclose(dq_to_pose(H), Ts)


def test_normalize_dq():
    h = np.array([-2.0, 0, 0, 0, 0, 1, 0, 0])
    n = normalize_dq(h)
    assert np.allclose(n, [1, 0, 0, 0, 0, -0.5, 0, 0])
    assert np.allclose(dq_to_pose(n), dq_to_pose(h))


# ------------------------------------------------------------------ lines (section 5)
def test_plucker_of_example_h():
    """h = 1 + 2j + eps(3i + k): u = (0, -1, 0), m = (1.5, 0, 0.5), foot point (-0.5, 0, 1.5)."""
    h = np.array([1.0, 0, 2, 0, 0, 3, 0, 1])
    u, m = plucker(h)
    assert np.allclose(u, [0, -1, 0])
    assert np.allclose(m, [1.5, 0, 0.5])
    assert np.allclose(np.cross(u, m), [-0.5, 0, 1.5])
    assert abs(u @ m) < 1e-15


def test_rotation_about_line():
    u = np.array([0.0, 0.0, 1.0])
    c = np.array([1.0, 0.0, 0.0])
    m = np.cross(c, u)
    T = rotation_about_line(u, m, np.pi / 2)
    assert np.allclose(T[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    # points on the axis are fixed, the origin goes round the axis
    assert np.allclose(T[:3, :3] @ c + T[:3, 3], c)
    assert np.allclose(T[:3, 3], [1, -1, 0])
    Ts = rotation_about_line(u, m, np.array([0.0, np.pi, 2 * np.pi]))
    assert Ts.shape == (3, 4, 4)
    assert np.allclose(Ts[0], np.eye(4))
    assert np.allclose(Ts[2], np.eye(4))


def test_left_divide_is_the_inverse_times():
    """a^-1 b without forming the inverse: exact on Fractions, to rounding on floats; a (a^-1 b) = b."""
    rng = np.random.default_rng(4)
    a, b = rng.normal(size=(2, 6, 8))
    x = dq_left_divide(a, b)
    assert np.allclose(x, dq_mul(dq_inv(a), b), rtol=0, atol=1e-12 * np.abs(x).max())
    assert np.allclose(dq_mul(a, x), b, atol=1e-12)
    ea, eb = exact_array(a[:2]), exact_array(b[:2])
    assert np.all(dq_left_divide(ea, eb) == dq_mul(dq_inv(ea), eb))


def test_dq_translation_matches_the_pose():
    """2 vec(p q~) / |p|^2 at any scale of h, as dq_to_pose's translation."""
    rng = np.random.default_rng(5)
    T = dq_to_pose(normalize_dq(rng.normal(size=(7, 8)) * np.r_[1.0, 1, 1, 1, 0, 0, 0, 0]))
    T[:, :3, 3] = rng.normal(size=(7, 3))
    h = pose_to_dq(T) * rng.uniform(0.5, 3.0, size=(7, 1))
    assert np.allclose(dq_translation(h), T[:, :3, 3], atol=1e-14)
    assert np.allclose(dq_translation(h[None, :3].repeat(30, axis=0)), T[:3, :3, 3], atol=1e-14)  # (the GEMM path)
