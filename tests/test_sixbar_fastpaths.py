"""The cheaper numerics of the 6R member path (issue 4) agree with their plain definitions: the 16 x 16
Newton polish, the Gram-matrix norm polynomial with Horner-Newton roots, Cramer's rule for a member's
coefficients and the lambdas read off C(t_i)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from synth.synthesis.cubic import (_T, factor_members, families, multiply_back, norm_roots, polish, quadric)
from synth.algebra.dq import dq_mul
from synth.errors import SynthesisError
from synth.synthesis.conic import condition, relative_displacements
from synth.algebra.polynomial import evaluate, norm_poly, product_of_linear
from synth.synthesis.sixbar import member_lambdas


def rotation_factors(rng, n=3):
    """n random rotation factors h (dual scalar 0, v.w = 0)."""
    h = rng.normal(size=(n, 8))
    h[:, 4] = 0.0
    v, w = h[:, 1:4], h[:, 5:8]
    h[:, 5:8] = w - v * (np.sum(v * w, -1) / np.sum(v * v, -1))[:, None]
    return h


def newton24(C, H, steps=2):
    """Reference: Newton on all 24 product equations (row-vector convention, a x = x L(a), x a = x R(a))."""
    L = lambda a: np.einsum("i,ijk->jk", a, _T)  # noqa: E731
    R = lambda a: np.einsum("i,jik->jk", a, _T)  # noqa: E731
    H = H.copy()
    for _ in range(steps):
        h1, h2, h3 = H
        X = dq_mul(h1, h2)
        r = np.concatenate([-dq_mul(X, h3) - C[0], X + dq_mul(h1 + h2, h3) - C[1], -(h1 + h2 + h3) - C[2]])
        I8 = np.eye(8)
        J = np.block([[-R(dq_mul(h2, h3)), R(h2) + R(h3), -I8],
                      [-L(h1) @ R(h3), L(h1) + R(h3), -I8],
                      [-L(X), L(h1) + L(h2), -I8]])
        H = H + np.linalg.solve(J.T, -r).reshape(3, 8)
    return H


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1e-12, 1e-5))
def test_polish_matches_full_newton_and_the_exact_factors(seed, eps):
    rng = np.random.default_rng(seed)
    H0 = rotation_factors(rng)
    C = product_of_linear(H0)
    H = H0 + eps * rng.normal(size=H0.shape)
    P, rm = polish(C, H, return_residual=True)
    ref = newton24(C, H)
    scale = 1 + np.abs(H0).max()
    assert np.abs(P - ref).max() <= 1e-11 * scale ** 3
    assert np.abs(P - H0).max() <= 1e-11 * scale ** 3
    assert multiply_back(C[None], P[None, None])[0, 0] <= 1e-14 * scale ** 2
    assert rm == pytest.approx(np.abs(product_of_linear(P)[:3] - C[:3]).max(), abs=1e-15 * scale ** 3)


def test_polish_broadcasts_and_keeps_exact_factors():
    rng = np.random.default_rng(3)
    H0 = rotation_factors(rng)
    C = product_of_linear(H0)
    HK = np.stack([H0 + 1e-9, H0 - 1e-9])
    P = polish(C, HK)
    assert P.shape == (2, 3, 8)
    assert np.abs(P - H0).max() < 1e-13
    assert np.array_equal(polish(C, H0, iterations=0), H0)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_norm_roots_are_the_roots_of_the_norm_polynomial(seed):
    rng = np.random.default_rng(seed)
    C = np.stack([product_of_linear(rotation_factors(rng)) for _ in range(4)])
    z = norm_roots(C)
    for Cg, zg in zip(C, z):
        N = norm_poly(Cg)
        ref = np.roots(N[::-1])
        ref = ref[ref.imag > 0]
        assert len(ref) == 3 and np.all(zg.imag >= 0)
        for r in ref:
            assert np.min(np.abs(zg - r)) <= 1e-9 * (1 + abs(r) ** 2)
        assert np.all(np.diff(zg.real) >= 0)
    assert np.array_equal(norm_roots(C[0]), z[0])  # unbatched


def _member_and_family(seed):
    rng = np.random.default_rng(seed)
    while True:
        T = np.tile(np.eye(4), (4, 1, 1))
        T[:, :3, :3] = Rotation.random(4, random_state=rng).as_matrix()
        T[:, :3, 3] = rng.normal(size=(4, 3))
        try:
            fams, _ = families(quadric(relative_displacements(condition(T)[0])))
        except SynthesisError:
            continue
        if fams:
            return fams[0], rng


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-5, 5))
def test_member_and_lambdas_match_their_definitions(seed, lam1):
    fam, _ = _member_and_family(seed)
    C = fam.member(lam1)
    a, b = np.linalg.solve(np.array([fam.lead, fam.weights[:, 1]]), [1.0, lam1])
    ref = a * fam.basis[0] + b * fam.basis[1]
    ref[3] = np.eye(8)[0]
    assert np.allclose(C, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
    lam = member_lambdas(fam, C)
    vals = evaluate(C, fam.ts[1:])
    lam_ref = np.sum(vals[:, :4] * fam.D[1:, :4], -1)
    assert np.allclose(lam, lam_ref, rtol=1e-12, atol=1e-12 * (1 + np.abs(lam_ref).max()))
    assert lam[0] == pytest.approx(lam1, rel=1e-10, abs=1e-10)


def test_factor_members_single_member_refined_is_rounding_level():
    fam, _ = _member_and_family(11)
    mf = factor_members(fam.member(0.37)[None])
    assert np.all(mf.residual[mf.ok] < 1e-14)


def test_norm_roots_batch_shapes():
    rng = np.random.default_rng(5)
    C = np.stack([product_of_linear(rotation_factors(rng)) for _ in range(6)]).reshape(2, 3, 4, 8)
    z = norm_roots(C)
    assert z.shape == (2, 3, 3)
    assert np.array_equal(z.reshape(6, 3), norm_roots(C.reshape(6, 4, 8)))
    assert norm_roots(C[0, 0]).shape == (3,)
