"""synth.algebra.algorithm1: the one batched Algorithm 1 (invariants with tolerances)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra import algorithm1 as A
from synth.algebra.dq import dq_left_matrix, dq_mul, dq_right_matrix
from synth.algebra.polynomial import norm_poly, product_of_linear


def rotations(rng, shape):
    """Random revolute factors h = p + eps w with v.w = 0 and zero dual scalar part (shape + (8,))."""
    p = rng.normal(size=shape + (4,))
    w = np.cross(p[..., 1:], rng.normal(size=shape + (3,)))
    h = np.zeros(shape + (8,))
    h[..., :4], h[..., 5:] = p, w
    return h


def test_left_and_right_matrices():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 7, 8))
    np.testing.assert_allclose(np.einsum("bi,bij->bj", b, dq_left_matrix(a)), dq_mul(a, b), atol=1e-14)
    np.testing.assert_allclose(np.einsum("bi,bij->bj", b, dq_right_matrix(a)), dq_mul(b, a), atol=1e-14)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_every_order_multiplies_back(n):
    rng = np.random.default_rng(n)
    C = product_of_linear(rotations(rng, (100, n)))
    z = A.norm_roots(norm_poly(C))
    assert z.shape == (100, n) and np.all(z.imag > 0)
    H, ok = A.algorithm1(C[:, None], A.quadratics(z)[:, A.orders(n)])
    assert H.shape == (100, len(A.orders(n)), n, 8) and ok.all()
    assert np.median(A.multiply_back(C[:, None], H)) < 1e-14
    Hp, _ = A.polish(C[:, None], H)
    assert np.max(A.multiply_back(C[:, None], Hp)) < 1e-14
    assert np.max(A.study_violation(Hp)) < 1e-11


def test_the_original_factors_are_found():
    rng = np.random.default_rng(5)
    H0 = rotations(rng, (3,))
    C = product_of_linear(H0)
    N = norm_poly(C)
    Q = A.quadratics(A.norm_roots(N))
    # the order whose quadratics are those of H0, left to right
    q0 = np.stack([np.sum(H0[:, :4] ** 2, -1), -2 * H0[:, 0]], -1)
    order = [int(np.argmin(np.abs(Q - q).sum(-1))) for q in q0]
    H, ok = A.algorithm1(C, Q[order])
    assert ok
    np.testing.assert_allclose(H, H0, atol=1e-10)


def test_batch_agrees_with_single_calls():
    rng = np.random.default_rng(9)
    C = product_of_linear(rotations(rng, (20, 3)))
    Q = A.quadratics(A.norm_roots(norm_poly(C)))
    H, _ = A.algorithm1(C[:, None], Q[:, A.orders(3)])
    for i in range(20):
        Hi, _ = A.algorithm1(C[i], Q[i][A.orders(3)])
        np.testing.assert_allclose(Hi, H[i], rtol=1e-12, atol=1e-12)


def test_non_invertible_remainder_is_flagged():
    # C = (t^2 + 1)(t - h): the primal part has the real factor t^2 + 1, so C mod (t^2 + 1) = 0 and no
    # linear factor with norm t^2 + 1 can be split off on the right
    h = rotations(np.random.default_rng(3), (1,))[0]
    C = np.zeros((4, 8))
    lin = product_of_linear(h[None])  # (2, 8): [-h, 1]
    C[0] += lin[0]
    C[1] += lin[1]
    C[2] += lin[0]
    C[3] += lin[1]  # (t^2 + 1)(t - h)
    m_h = [np.sum(h[:4] ** 2), -2 * h[0]]
    _, ok = A.algorithm1(C, np.array([m_h, [1.0, 0.0], [1.0, 0.0]]))
    assert not ok
    H, ok = A.algorithm1(C, np.array([[1.0, 0.0], [1.0, 0.0], m_h]))
    assert not ok  # h splits off first; what is left is t^2 + 1, whose remainders vanish


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10**6), n=st.integers(1, 3), scale=st.sampled_from([1e-3, 1.0, 1e3]))
def test_property_factorizations_multiply_back(seed, n, scale):
    rng = np.random.default_rng(seed)
    H0 = rotations(rng, (n,))
    H0[:, 4:] *= scale
    C = product_of_linear(H0)
    Q = A.quadratics(A.norm_roots(norm_poly(C)))
    _, sep = A.root_conditioning(A.norm_roots(norm_poly(C)))
    H, ok = A.algorithm1(C, Q[A.orders(n)])
    Hp, _ = A.polish(C, H)
    if sep > 1e-3:
        assert ok.all()
        assert np.max(A.multiply_back(C, Hp)) < 1e-12
