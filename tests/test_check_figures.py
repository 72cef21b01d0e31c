"""The one self-check (`synth.checks.check_figures`, issue 36): the same figures for a linkage alone and in
a batch, bit for bit; at the samples the factor expansion agrees with forward kinematics of the joint
angles (`synth.linkage.Linkage.displacements`) to rounding; a real defect shows."""
from __future__ import annotations

import numpy as np
import pytest

import synth
from synth.algebra.dq import pose_to_dq
from synth.algebra.geometry import pose_difference
from synth.checks import VERIFY_SAMPLES, check_figures, linkage_figures, sample_parameters
from synth.synthesis.bennett_core import STRUCTURE, solve

from conftest import random_poses


def _arrays(T):
    out = solve(T, 0, as_single=True)
    U, M = out.lines[..., 0, :], out.lines[..., 1, :]
    Q = pose_to_dq(T)
    return out, (STRUCTURE, U, M, out.laws[..., 0], out.laws[..., 1], out.pose_angles, Q, Q[:, 0], out.motion)


def test_a_linkage_has_the_same_figures_alone_and_in_a_batch():
    rng = np.random.default_rng(5)
    T = np.array([random_poses(rng, 3, scale=10 ** rng.uniform(-2, 1)) for _ in range(60)])
    _, args = _arrays(T)
    many = check_figures(*args, VERIFY_SAMPLES)
    for n in range(len(T)):
        one = check_figures(*(x if isinstance(x, tuple) else x[n : n + 1] for x in args), VERIFY_SAMPLES)
        for k, v in many.items():
            assert v[n] == one[k][0] or np.isnan(v[n]) and np.isnan(one[k][0]), (n, k)


@pytest.mark.parametrize("seed", range(4))
def test_sampled_figures_agree_with_forward_kinematics(seed):
    """Closure by composing unit joint displacements at the angle laws' angles, and the motion as the
    tool link against C(t) evaluated by `synth.algebra.polynomial.evaluate`: the check's figures are
    the same rounding-level numbers (both below 1e-13 relative to the linkage's size)."""
    rng = np.random.default_rng(seed)
    L = synth.bennett(random_poses(rng, 3, scale=0.3))
    fig = linkage_figures(L, 50)
    t = sample_parameters(L, 50)
    D = L.displacements(L.angles_at(t))
    (x, y), = L.closures
    ct, cr = pose_difference(D[x], D[y])
    size = L.extent()
    assert fig["closure_translation"] < 1e-13 * size and float(ct.max()) < 1e-13 * size
    assert fig["closure_rotation"] < 1e-13 and float(cr.max()) < 1e-13
    assert fig["motion"] < 1e-13 * (1 + size)
    assert fig["pose_translation"] < 1e-13 * size and fig["pose_rotation"] < 1e-13


def test_a_moved_axis_shows_in_closure_and_motion():
    rng = np.random.default_rng(8)
    T = np.array([random_poses(rng, 3, scale=0.2) for _ in range(20)])
    out, args = _arrays(T)
    U, M = args[1], args[2].copy()
    M[:, 1] += 1e-6 * np.cross(U[:, 1], [0.0, 0.0, 1.0])  # axis h2 shifted by up to 1e-6 m
    fig = check_figures(args[0], U, M, *args[3:], VERIFY_SAMPLES)
    assert np.all(fig["closure_translation"] + fig["closure_rotation"] > 1e-8)
    assert np.all(fig["motion"] > 1e-8)
    assert np.all(fig["pose_translation"] + fig["pose_rotation"] > 1e-8)
