"""One engine: factorize and synth.bennett agree with their own invariants and with the per-set path
(the same conic, `factorize` with refinement) within tolerances relative to the scale."""
from __future__ import annotations

import numpy as np
import pytest

from synth.algebra.algorithm1 import multiply_back, study_violation
from synth.algebra.factorize import factorize
from synth.algebra.polynomial import product_of_linear
from synth.synthesis import bennett as bennett_mod
from synth.synthesis import bennett_core

from conftest import random_poses


def rotation_factors(rng, n, scale=1.0):
    h = rng.normal(size=(n, 8)) * scale
    h[:, 4] = 0.0
    for i in range(n):
        v, w = h[i, 1:4], h[i, 5:8]
        h[i, 5:8] = w - v * (v @ w) / (v @ v)
    return h


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("seed", range(30))
def test_factorize_multiplies_back_and_satisfies_study(n, seed):
    rng = np.random.default_rng(seed)
    h = rotation_factors(rng, n, scale=10 ** rng.uniform(-1, 1))
    C = product_of_linear(h)
    res = factorize(C)
    assert len(res.factorizations) == np.prod(range(1, n + 1))  # n! for distinct norm quadratics
    H = np.array([f.factors for f in res.factorizations])
    assert np.all(multiply_back(C, H) <= 5e-12)
    assert np.all(study_violation(H) <= 1e-10)
    # each factor's norm is the quadratic its order names
    for f in res.factorizations:
        for h_i, q in zip(f.factors, f.order):
            c0, c1 = res.quadratics[q]
            assert h_i[0] == pytest.approx(-c1 / 2, abs=1e-9 * max(1, abs(c1)))
            assert h_i[0] ** 2 + h_i[1:4] @ h_i[1:4] == pytest.approx(c0, rel=1e-9, abs=1e-12)
    # the original factorization is among them
    assert min(np.max(np.abs(F - h)) for F in H) <= 1e-8 * max(1.0, np.abs(h).max())


def test_worked_example_a():
    """docs/algorithm1.md, example A: C = (t - h1)(t - h2), h1 = i + eps j, h2 = 1 + 2j + eps(3i + k)."""
    C = np.array([[0, 1, 0, 2, -5, 0, 0, 0], [-1, -1, -2, 0, 0, -3, -1, -1], [1, 0, 0, 0, 0, 0, 0, 0]], float)
    res = factorize(C)
    np.testing.assert_allclose(res.quadratics, [[1, 0], [5, -2]], atol=1e-14)
    f = {r.order: r.factors for r in res.factorizations}[(0, 1)]  # t^2 + 1 left, t^2 - 2t + 5 right
    np.testing.assert_allclose(f, [[0, 1, 0, 0, 0, 0, 1, 0], [1, 0, 2, 0, 0, 3, 0, 1]], atol=1e-14)


@pytest.mark.parametrize("seed", range(40))
def test_bennett_equals_the_per_set_path(seed):
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 100)
    if not bennett_core.solve(T[None], 8).good[0]:
        return
    fast = bennett_mod.bennett(T, check_samples=8)
    gen = bennett_mod._bennett_general(T, [p.name for p in fast.poses], 8)
    scale = max(1.0, float(np.abs(gen.motion).max()))
    np.testing.assert_allclose(fast.motion, gen.motion, atol=1e-12 * scale)
    for a, b in zip(fast.joints, gen.joints):
        np.testing.assert_allclose(a.direction, b.direction, atol=1e-10)
        np.testing.assert_allclose(a.moment, b.moment, atol=1e-10 * scale)
        assert abs(a.a - b.a) <= 1e-10 * max(1, abs(b.a)) and abs(a.b - b.b) <= 1e-10 * max(1, b.b)
    for ra, rb in zip(fast.poses, gen.poses):
        for k, v in ra.joint_angles.items():
            d = abs(v - rb.joint_angles[k]) % (2 * np.pi)
            assert min(d, 2 * np.pi - d) <= 1e-9
    assert fast.info.warnings == gen.info.warnings
    # the vectorized path bounds closure and motion over the whole motion (checks["bounded"]); the
    # per-set path samples them
    assert set(fast.info.to_dict()) == set(gen.info.to_dict()) and set(fast.checks) == set(gen.checks) | {"bounded"}
    # relative to the linkage's size, plus a rounding floor of 1000 ulps of the coordinates (poses ~100 m
    # from the origin with a spread of 1 mm are only known to ~1e-14 m; ~1% of seeds need the floor)
    floor = 1e3 * np.finfo(float).eps * np.abs(T[:, :3, 3]).max()
    # the pose and closure figures are certified bounds (`pose_bound`, `loop_bound`): within the acceptance
    # limit; the per-set path's sampled figures within a tenth of it
    assert gen.checks["max_pose_translation_error"] <= 1e-9 * gen.checks["length_scale"] + floor
    assert fast.checks["max_pose_translation_error"] <= 1e-8 * fast.checks["length_scale"] + floor
    assert fast.checks["max_closure_translation_error"] <= 1e-8 * fast.checks["length_scale"] + floor


def test_the_generic_path_is_taken_for_random_poses():
    rng = np.random.default_rng(5)
    T = np.array([random_poses(rng, 3) for _ in range(200)])
    assert bennett_core.solve(T, 4).good.mean() >= 0.97


@pytest.mark.parametrize("seed", range(10))
def test_batch_length_scale_equals_linkage_extent(seed):
    """The Bennett pipeline's length scale (from its ring of common normals) is `Linkage.extent`."""
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-2, 2), offset=rng.normal(size=3) * 10)
    L = bennett_mod.bennett(T, check_samples=4)
    assert L.checks["length_scale"] == pytest.approx(L.extent(), rel=1e-12)
    out = bennett_core.solve(T[None], 0)
    assert out.length_scale[0] == pytest.approx(L.extent(), rel=1e-12)


@pytest.mark.parametrize("seed", range(8))
def test_perturbed_copies_in_the_batch_equal_the_perturbed_poses(seed):
    """solve(perturb=) multiplies the conditioned poses by the small motions: the same factors as
    `perturbed_poses` factored on their own, and the same axis distance as `axis_distance`."""
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-2, 2), offset=rng.normal(size=3) * 10)
    out = bennett_core.solve(T[None], 0, perturb=bennett_mod._small_motion_matrices(1e-9, 0, 2))
    ref = bennett_core.factor_sets(bennett_mod.perturbed_poses(T))
    assert out.good[0] and out.extra["good"].all() and ref["good"].all()
    scale = max(1.0, float(np.abs(ref["factors"]).max()))
    np.testing.assert_allclose(out.extra["factors"], ref["factors"], atol=1e-11 * scale)
    U, M = out.lines[..., 0, :], out.lines[..., 1, :]
    far = bennett_core.axis_distance(U, M, out.centre)
    assert out.axis_distance[0] == pytest.approx(far[0], rel=1e-9, abs=1e-12 * scale)
    L = bennett_mod.bennett(T)
    assert bennett_mod.sensitivity(L, solved=out.extra) == pytest.approx(bennett_mod.sensitivity(L), rel=1e-3)
