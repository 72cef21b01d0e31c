"""synth.algebra.geometry: worked numbers and properties of the line and rigid-body functions."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.dq import pose_to_dq
from synth.algebra.geometry import (INTERSECT_TOL, MIN_EXTENT, PARALLEL_TOL, common_normal, cross, dh_parameters,
                                    dq_pose_difference, extent, invert_pose, joint_sites, line_point, pose_difference,
                                    ring_normals, rotation_about_axis, rotation_about_line, rotation_angle, skew,
                                    spread)

from conftest import random_poses


def line(point, direction):
    """(u, m) of the line through ``point`` along ``direction``."""
    u = np.asarray(direction, float) / np.linalg.norm(direction)
    return u, np.cross(point, u)


# ----------------------------------------------------------------- worked numbers
def test_skew_perpendicular_lines():
    """z axis and the line through (3, 0, 4) along y: the normal runs along x at height 4."""
    cn = common_normal(*line([0, 0, 0], [0, 0, 1]), *line([3, 0, 4], [0, 1, 0]))
    assert np.allclose(cn.feet, [[0, 0, 4], [3, 0, 4]], atol=1e-15)
    assert cn.distance == pytest.approx(3.0)
    assert np.allclose(cn.normal, [1, 0, 0])
    assert cn.twist == pytest.approx(-math.pi / 2)  # R_x(-pi/2) takes z to y
    assert cn.line_angle == pytest.approx(math.pi / 2)
    assert not cn.parallel and not cn.some_parallel


def test_intersecting_lines():
    cn = common_normal(*line([0, 0, 0], [0, 0, 1]), *line([5, 0, 0], [1, 0, 0]))
    assert cn.distance == pytest.approx(0.0, abs=1e-15)
    assert np.allclose(cn.feet, 0.0, atol=1e-15)
    assert np.allclose(cn.normal, [0, 1, 0])  # u1 x u2 / |u1 x u2|
    assert cn.twist == pytest.approx(math.pi / 2)


def test_parallel_lines_meet_at_the_midpoint_rule():
    """Parallel lines: the normal through the midpoint of the points nearest the origin."""
    cn = common_normal(*line([0, 0, 7], [0, 0, 1]), *line([0, 2, -3], [0, 0, -1]))
    assert cn.parallel and cn.some_parallel
    assert np.allclose(cn.feet, [[0, 0, 0], [0, 2, 0]], atol=1e-15)
    assert cn.distance == pytest.approx(2.0)
    assert abs(cn.twist) == pytest.approx(math.pi)  # antiparallel directions
    assert cn.line_angle == pytest.approx(0.0, abs=1e-15)


def test_nearly_parallel_below_the_threshold_counts_as_parallel():
    tilt = 0.5 * PARALLEL_TOL
    cn = common_normal(*line([0, 0, 0], [0, 0, 1]), *line([1, 0, 0], [0, tilt, 1]))
    assert cn.parallel
    assert cn.distance == pytest.approx(1.0, rel=1e-9)
    tilt = 10 * PARALLEL_TOL  # above: the exact common normal, far along the axes
    cn = common_normal(*line([0, 0, 0], [0, 0, 1]), *line([1, 0, 0], [0, tilt, 1]))
    assert not cn.parallel
    assert cn.distance == pytest.approx(1.0, rel=1e-6)


def test_coinciding_lines():
    cn = common_normal(*line([1, 1, 0], [1, 0, 0]), *line([4, 1, 0], [1, 0, 0]))
    assert cn.distance == pytest.approx(0.0, abs=INTERSECT_TOL)
    assert np.allclose(cn.normal, 0.0) and cn.twist == 0.0


def test_dh_of_a_known_ring():
    """Alternating z and x axes: 0 (z through 0), 1 (x at z = 2), 2 (z through (0, 3, 0)), 3 (x at (0, 3, 5)).
    Feet on axis 0: (0, 0, 2) towards 1, (0, 0, 5) from 3, so d_0 = -3; on axis 2: (0, 3, 2) from 1,
    (0, 3, 5) towards 3, so d_2 = 3."""
    U = np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 0, 1.0], [1.0, 0, 0]])
    P = np.array([[0, 0, 0.0], [0, 0, 2.0], [0, 3.0, 0], [0, 3.0, 5.0]])
    dh = dh_parameters(U, np.cross(P, U))
    assert np.allclose(dh.a, [0.0, 3.0, 0.0, 3.0], atol=1e-12)
    assert np.allclose(dh.alpha, [math.pi / 2, -math.pi / 2, math.pi / 2, math.pi / 2])
    assert np.allclose(dh.d, [-3.0, 0.0, 3.0, 0.0], atol=1e-12)
    assert np.allclose(np.cos(dh.theta), [-1.0, 1.0, 1.0, -1.0], atol=1e-12)
    table = dh.table(["a", "b", "c", "d"])
    assert [r["next"] for r in table] == ["b", "c", "d", "a"] and table[1]["a"] == pytest.approx(3.0)


def test_rotations_worked():
    R = rotation_about_axis([0, 0, 1], math.pi / 2)
    assert np.allclose(R @ [1, 0, 0], [0, 1, 0])
    assert rotation_angle(R) == pytest.approx(math.pi / 2)
    T = rotation_about_line([0, 0, 1], np.cross([1, 0, 0], [0, 0, 1]), math.pi)  # about the z line through (1, 0, 0)
    assert np.allclose(T @ [0, 0, 5, 1], [2, 0, 5, 1])
    dt, dr = pose_difference(np.eye(4), T)
    assert dt == pytest.approx(2.0) and dr == pytest.approx(math.pi)
    assert np.allclose(skew([1, 2, 3]) @ [4, 5, 6], np.cross([1, 2, 3], [4, 5, 6]))


def test_spread_and_extent_worked():
    c, rms = spread([[0, 0, 0], [2, 0, 0]])
    assert np.allclose(c, [1, 0, 0]) and rms == pytest.approx(1.0)
    assert extent(np.zeros((3, 3))) == MIN_EXTENT
    assert np.allclose(extent(np.array([[[0, 0, 0], [0, 4, 0.0]], [[1, 1, 1], [1, 1, 1.0]]])), [2.0, MIN_EXTENT])


def test_joint_sites_mean_of_feet_else_nearest_point():
    U = np.array([[0, 0, 1.0], [0, 1.0, 0], [1.0, 0, 0]])
    P = np.array([[0, 0, 0.0], [3, 0, 4], [0, 0, 9]])
    sites = joint_sites(U, np.cross(P, U), [(0, 1)], centre=[5, 5, 9])
    assert np.allclose(sites, [[0, 0, 4], [3, 0, 4], [5, 0, 9]])


def test_common_normal_of_nearly_parallel_lines_far_from_their_feet():
    """Lines 6e-8 rad apart whose feet lie 7e7 out: the feet's difference cancels to ~1e-5 rad off the
    true normal; the normal is u1 x u2 / |u1 x u2|, signed from foot 1 to foot 2 (a hypothesis example)."""
    u1 = np.array([2.0**-9, 0, 1]) / np.linalg.norm([2.0**-9, 0, 1])
    u2 = np.array([2.0**-9, 2.0**-24, 1]) / np.linalg.norm([2.0**-9, 2.0**-24, 1])
    p2 = np.array([0, 4.25, 1.0])
    cn = common_normal(u1, np.zeros(3), u2, np.cross(p2, u2))
    assert np.abs(cn.feet).max() > 7e7
    assert abs(cn.normal @ u1) < 1e-12 and abs(cn.normal @ u2) < 1e-12
    assert cn.normal @ (cn.feet[1] - cn.feet[0]) > 0
    c = np.cross(u1, u2)
    assert cn.distance == pytest.approx(abs(p2 @ c) / np.linalg.norm(c), rel=1e-6)
    assert cn.twist == pytest.approx(np.arcsin(np.linalg.norm(c)), rel=1e-6)


# ----------------------------------------------------------------- properties
unit = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: 0.1 < np.linalg.norm(v)).map(
    lambda v: np.array(v) / np.linalg.norm(v))
point = st.tuples(*[st.floats(-10, 10)] * 3).map(np.array)


@settings(max_examples=200, deadline=None)
@given(unit, point, unit, point)
def test_feet_on_their_lines_normal_perpendicular_distance_symmetric(u1, p1, u2, p2):
    m1, m2 = np.cross(p1, u1), np.cross(p2, u2)
    cn = common_normal(u1, m1, u2, m2)
    f1, f2 = cn.feet
    scale = 1 + np.abs(p1).max() + np.abs(p2).max()
    tol = 1e-9 * scale / max(np.linalg.norm(np.cross(u1, u2)), 1e-3)
    assert np.allclose(np.cross(f1, u1), m1, atol=tol) and np.allclose(np.cross(f2, u2), m2, atol=tol)
    if cn.distance > 1e-6 * scale:
        assert abs(cn.normal @ u1) < 1e-6 and abs(cn.normal @ u2) < 1e-6
        assert np.allclose(f2 - f1, cn.distance * cn.normal, atol=tol)
    back = common_normal(u2, m2, u1, m1)
    assert back.distance == pytest.approx(cn.distance, rel=1e-9, abs=tol)
    assert abs(back.twist) == pytest.approx(abs(cn.twist), abs=1e-9)
    if not cn.parallel:  # the distance of skew lines: |(p2 - p1) . (u1 x u2)| / |u1 x u2|
        c = np.cross(u1, u2)
        assert cn.distance == pytest.approx(abs((p2 - p1) @ c) / np.linalg.norm(c), rel=1e-6, abs=tol)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.floats(0.1, 2), st.floats(0.2, 2.9), st.floats(-2, 2), st.floats(-3, 3),
                          st.booleans()), min_size=4, max_size=7))
def test_dh_round_trip(params):
    """Axes built from DH parameters (Rot_z(theta) Trans_z(d) Trans_x(a) Rot_x(alpha)) give them back at
    the joints whose neighbours both come from the chain (the ring's closing pair is whatever it is)."""
    F = np.eye(4)
    U, P = [], []
    for a, alpha, d, theta, neg in params:
        alpha = -alpha if neg else alpha
        U.append(F[:3, 2].copy())
        P.append(F[:3, 3].copy())
        Rz = rotation_about_axis([0, 0, 1], theta)
        Rx = rotation_about_axis([1, 0, 0], alpha)
        A = np.eye(4)
        A[:3, :3] = Rz @ Rx
        A[:3, 3] = Rz @ [a, 0, d]
        F = F @ A
    U, P = np.array(U), np.array(P)
    dh = dh_parameters(U, np.cross(P, U))
    J = len(params)
    for i in range(J - 1):
        a, alpha, d, theta, neg = params[i]
        assert dh.a[i] == pytest.approx(a, abs=1e-9)
        assert dh.alpha[i] == pytest.approx(-alpha if neg else alpha, abs=1e-9)
        if i > 0:
            assert dh.d[i] == pytest.approx(d, abs=1e-9)
            assert math.remainder(dh.theta[i] - theta, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_batched_equals_one_by_one(seed):
    rng = np.random.default_rng(seed)
    U = rng.normal(size=(5, 4, 3))
    U /= np.linalg.norm(U, axis=-1, keepdims=True)
    U[0, 1] = U[0, 0]  # a parallel pair in the batch
    M = np.cross(rng.normal(size=(5, 4, 3)), U)
    ring = ring_normals(U, M)
    for g in range(5):
        for i in range(4):
            k = (i + 1) % 4
            one = common_normal(U[g, i], M[g, i], U[g, k], M[g, k])
            assert np.allclose(one.feet, ring.feet[g, i], atol=1e-12)
            assert one.distance == pytest.approx(ring.distance[g, i], abs=1e-12)
            assert one.twist == pytest.approx(ring.twist[g, i], abs=1e-12)
    assert ring.parallel[0, 0] and ring.some_parallel


@settings(max_examples=100, deadline=None)
@given(unit, st.floats(-math.pi, math.pi), point)
def test_rotation_properties(u, theta, p):
    R = rotation_about_axis(u, theta)
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-14) and np.linalg.det(R) == pytest.approx(1.0)
    assert np.allclose(R @ u, u, atol=1e-14)
    assert rotation_angle(R) == pytest.approx(abs(theta), abs=1e-12)
    T = rotation_about_line(u, np.cross(p, u), theta)
    assert np.allclose(T[:3, :3], R) and np.allclose(T @ np.append(p, 1), np.append(p, 1), atol=1e-12)
    assert np.allclose(invert_pose(T) @ T, np.eye(4), atol=1e-12)


def test_pose_differences_agree():
    rng = np.random.default_rng(5)
    A, B = random_poses(rng, 8), random_poses(rng, 8)
    dt, dr = pose_difference(A, B)
    qt, qr = dq_pose_difference(pose_to_dq(A), pose_to_dq(B))
    assert np.allclose(dt, qt, atol=1e-12) and np.allclose(dr, qr, atol=1e-9)
    st_, sr = dq_pose_difference(np.stack([pose_to_dq(A), pose_to_dq(B)]))
    assert np.array_equal(st_, qt) and np.array_equal(sr, qr)


@pytest.mark.parametrize("n", [4, 2000])  # the small path and the componentwise one (> 3000 numbers)
def test_cross_matches_numpy(n):
    rng = np.random.default_rng(n)
    a, b = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    assert np.allclose(cross(a, b), np.cross(a, b), atol=1e-15)
    assert np.allclose(line_point(a, b), np.cross(a, b), atol=1e-15)
