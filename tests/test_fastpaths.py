"""The plain-float fast paths (synth/scalar.py) agree with the general numpy engine up to rounding."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from synth.algebra.polynomial import product_of_linear, relative_error

from conftest import random_poses

factor_mod = importlib.import_module("synth.algebra.factorize")
bennett_mod = importlib.import_module("synth.synthesis.bennett")


def rotation_factors(rng, n, scale=1.0):
    h = rng.normal(size=(n, 8)) * scale
    h[:, 4] = 0.0
    for i in range(n):
        v, w = h[i, 1:4], h[i, 5:8]
        h[i, 5:8] = w - v * (v @ w) / (v @ v)
    return h


def general_factorize(C, monkeypatch):
    with monkeypatch.context() as m:
        m.setattr(factor_mod, "_factorize_fast", lambda C, validate: None)
        return factor_mod.factorize(C)


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("seed", range(30))
def test_factorize_fast_equals_general(n, seed, monkeypatch):
    rng = np.random.default_rng(seed)
    C = product_of_linear(rotation_factors(rng, n, scale=10 ** rng.uniform(-1, 1)))
    fast = factor_mod._factorize_fast(np.asarray(C, float), True)
    gen = general_factorize(C, monkeypatch)
    if fast is None:  # not clearly generic: the general engine decides (rare for random factors)
        return
    assert factor_mod.factorize(C) is not gen
    np.testing.assert_allclose(fast.quadratics, gen.quadratics, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(fast.norm, gen.norm, rtol=1e-13, atol=1e-13)
    assert fast.multiplicity == gen.multiplicity and fast.generic == gen.generic
    assert [f.order for f in fast.factorizations] == [f.order for f in gen.factorizations]
    scale = max(1.0, float(np.abs(C).max()))
    for a, b in zip(fast.factorizations, gen.factorizations):
        np.testing.assert_allclose(a.factors, b.factors, atol=1e-11 * scale)
        assert a.residual <= 5e-13 and relative_error(product_of_linear(a.factors), C) <= 5e-13


def test_factorize_fast_path_is_taken_for_generic_cubics():
    rng = np.random.default_rng(5)
    taken = sum(factor_mod._factorize_fast(product_of_linear(rotation_factors(rng, 3)), True) is not None
                for _ in range(50))
    assert taken >= 45


def test_worked_example_a_takes_the_fast_path():
    """MATH.md 11 A: C = (t - h1)(t - h2), h1 = i + eps j, h2 = 1 + 2j + eps(3i + k)."""
    C = np.array([[0, 1, 0, 2, -5, 0, 0, 0], [-1, -1, -2, 0, 0, -3, -1, -1], [1, 0, 0, 0, 0, 0, 0, 0]], float)
    res = factor_mod._factorize_fast(C, True)
    assert res is not None
    np.testing.assert_allclose(res.quadratics, [[1, 0], [5, -2]], atol=1e-14)
    f = {r.order: r.factors for r in res.factorizations}[(0, 1)]  # t^2 + 1 left, t^2 - 2t + 5 right
    np.testing.assert_allclose(f, [[0, 1, 0, 0, 0, 0, 1, 0], [1, 0, 2, 0, 0, 3, 0, 1]], atol=1e-14)


def test_factorize_fast_path_declines_what_it_cannot_judge():
    # repeated quadratic: (t - i - eps j)(t - j - eps k), norm (t^2 + 1)^2
    C = product_of_linear(np.array([[0, 1, 0, 0, 0, 0, 1, 0], [0, 0, 1, 0, 0, 0, 0, 1]], float))
    assert factor_mod._factorize_fast(C, True) is None
    assert factor_mod._factorize_fast(C[:, :7], True) is None  # wrong shape
    bad = C.copy()
    bad[0, 4] += 1  # Study condition violated
    assert factor_mod._factorize_fast(bad, True) is None


@pytest.mark.parametrize("seed", range(40))
def test_bennett_fast_equals_general(seed):
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 100)
    if bennett_mod.bennett_core(T) is None:
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
    assert fast.info["warnings"] == gen.info["warnings"]
    assert set(fast.info) == set(gen.info) and set(fast.checks) == set(gen.checks)


def test_thresholds_agree_with_the_general_engine():
    from synth.algebra import scalar
    from synth.synthesis import bennett_batch as batch

    assert scalar.FAST_MAX_RESIDUAL == factor_mod.REFINE_TRIGGER
    assert batch.ACCEPT_TOL == bennett_mod.ACCEPT_TOL


@pytest.mark.parametrize("seed", range(10))
def test_checks_extent_equals_linkage_extent(seed):
    from synth.checks import extent

    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-2, 2), offset=rng.normal(size=3) * 10)
    L = bennett_mod.bennett(T, check_samples=4)
    assert extent(L) == pytest.approx(L.extent(), rel=1e-12)
    assert L.checks["length_scale"] == pytest.approx(L.extent(), rel=1e-12)
    # a joint no link pairs, and parallel axes
    L.links = {"base": ["h1"], "coupler": ["h2", "k2"], "coupler_k": []}
    assert extent(L) == pytest.approx(L.extent(), rel=1e-12)
    L.joints[3].direction = L.joints[1].direction.copy()
    L.joints[3].moment = L.joints[1].moment + np.cross([0.1, 0.2, 0.3], L.joints[1].direction)
    assert extent(L) == pytest.approx(L.extent(), rel=1e-12)


def test_checks_extent_equals_linkage_extent_sixbar():
    import synth
    from synth.checks import extent

    rng = np.random.default_rng(3)
    L = synth.sixbar(random_poses(rng, 4))
    assert extent(L) == pytest.approx(L.extent(), rel=1e-12)
