"""The certified closure, motion and pose bounds (synth.checks.loop_bound, pose_bound, docs/conventions.md
section 9): they bound the errors at every parameter, including dense samples, and the forward kinematics
at the poses' angles, and they grow with a real defect."""
from __future__ import annotations

import numpy as np
import pytest

from synth.algebra.dq import pose_to_dq
from synth.checks import check_figures, loop_bound, pose_bound
from synth.synthesis.bennett_core import BRANCHES, STRUCTURE, TS, solve

from conftest import random_poses


def _sets(seed, n):
    rng = np.random.default_rng(seed)
    return np.array([random_poses(rng, 3, scale=10 ** rng.uniform(-2, 2), offset=rng.normal(size=3) * 10)
                     for _ in range(n)])


def _arrays(out):
    U, M = out.lines[:, :, 0], out.lines[:, :, 1]
    return U, M, out.laws[..., 0], out.laws[..., 1]


@pytest.mark.parametrize("seed", [0, 1])
def test_bounds_are_above_the_errors_at_dense_samples_and_the_poses(seed):
    T = _sets(seed, 200)
    out = solve(T, 0)
    U, M, a, b = _arrays(out)
    Q = pose_to_dq(T)
    sampled = check_figures(STRUCTURE, U, M, a, b, out.pose_angles, Q, Q[:, 0], out.motion, 500)
    bound = loop_bound(U, M, a, b, BRANCHES, out.motion)
    # the poses' figures: forward kinematics at the reported angles (pose 0 included) against the bound
    bound.update(pose_bound(out.motion, TS[1:], Q[:, 1:], Q[:, 0], bound))
    for key in ("closure_translation", "closure_rotation", "motion", "pose_translation", "pose_rotation"):
        assert np.all(bound[key] >= sampled[key]), key
    # and stays at the rounding level for these well-conditioned sets
    size = out.scale + np.abs(T[:, :, :3, 3]).max(axis=(1, 2))
    assert np.median(bound["closure_translation"] / size) < 1e-12
    assert np.median(bound["pose_translation"] / size) < 1e-12


def test_bound_detects_a_moved_axis_and_a_wrong_angle_law():
    T = _sets(3, 50)
    out = solve(T, 0)
    U, M, a, b = _arrays(out)
    Q = pose_to_dq(T)
    for what in ("moment", "law"):
        M2, a2 = M.copy(), a.copy()
        if what == "moment":
            M2[:, 3] += 1e-6 * out.scale[:, None] * np.cross(U[:, 3], [0.0, 0.0, 1.0])  # axis k2 shifted
        else:
            a2[:, 2] += 1e-6  # joint k1 runs a little ahead
        bound = loop_bound(U, M2, a2, b, BRANCHES, out.motion)
        sampled = check_figures(STRUCTURE, U, M2, a2, b, out.pose_angles, Q, Q[:, 0], out.motion, 200)
        assert np.all(bound["closure_translation"] + bound["closure_rotation"]
                      >= sampled["closure_translation"] + sampled["closure_rotation"])
        assert np.all(sampled["closure_translation"] + sampled["closure_rotation"] > 1e-9)  # a real defect


def test_repeated_roots_give_no_bound():
    T = _sets(4, 5)
    out = solve(T, 0)
    U, M, a, b = _arrays(out)
    a[:, 1], b[:, 1] = a[:, 0], b[:, 0]  # h1 and h2 with the same law: the partial fractions do not exist
    bound = loop_bound(U, M, a, b, BRANCHES, out.motion)
    assert np.all(np.isinf(bound["closure_translation"]))


def test_pose_bound_detects_a_moved_pose_and_a_wrong_motion():
    T = _sets(5, 50)
    out = solve(T, 0)
    U, M, a, b = _arrays(out)
    bound = loop_bound(U, M, a, b, BRANCHES, out.motion)
    moved = T.copy()
    moved[:, 2, :3, 3] += 1e-6 * out.scale[:, None]  # pose 2 shifted: the linkage misses it
    Qm = pose_to_dq(moved)
    got = pose_bound(out.motion, TS[1:], Qm[:, 1:], Qm[:, 0], bound)
    assert np.all(got["pose_translation"] >= 1e-6 * out.scale * np.sqrt(3) * (1 - 1e-9))
    wrong = out.motion.copy()
    wrong[:, 0, 1] += 1e-6  # C no longer the tool link's motion: the motion bound grows, and with it the pose bound
    bad = loop_bound(U, M, a, b, BRANCHES, wrong)
    Q = pose_to_dq(T)
    assert np.all(pose_bound(wrong, TS[1:], Q[:, 1:], Q[:, 0], bad)["pose_rotation"] > 1e-7)
