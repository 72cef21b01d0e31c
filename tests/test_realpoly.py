"""Real polynomials (synth.algebra.realpoly): Euclid and Sturm over Q, the float helpers, the text."""
from fractions import Fraction as Fr

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.realpoly import (compose_affine, conv_matrix, divide_real, mod_real, quad, quadratic_roots,
                                    real_divmod, real_gcd, real_mul, real_pow, real_root_count, trim)
from synth.algebra.text import poly_text

fractions = st.builds(Fr, st.integers(-6, 6), st.integers(1, 4))
polys = st.lists(fractions, min_size=1, max_size=5).filter(lambda p: p[-1] != 0)


def mul(a, b):
    out = [Fr(0)] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return out


def add(a, b):
    n = max(len(a), len(b))
    return trim([(a[k] if k < len(a) else 0) + (b[k] if k < len(b) else 0) for k in range(n)])


@settings(max_examples=40, deadline=None)
@given(polys, polys)
def test_divmod_identity_exactly(a, b):
    q, r = real_divmod(a, b)
    assert add(mul(q, b) if q else [], r) == trim(a)
    assert len(r) < len(trim(b))


@settings(max_examples=30, deadline=None)
@given(polys, polys, polys)
def test_gcd_of_products_contains_the_common_factor(g, a, b):
    d = real_gcd([mul(g, a), mul(g, b)])
    assert d[-1] == 1
    assert real_divmod(mul(g, a), d)[1] == [] and real_divmod(mul(g, b), d)[1] == []
    assert real_divmod(d, [c / g[-1] for c in g])[1] == []  # g | gcd


def test_gcd_and_sturm_worked_numbers():
    assert real_gcd([[1, 0, 1], [0, 1]]) == [1]  # t^2 + 1, t: coprime
    assert real_gcd([[-1, 0, 1], [2, -3, 1]]) == [-1, 1]  # (t-1)(t+1), (t-1)(t-2) -> t - 1
    assert real_gcd([[0], []]) == []
    assert real_root_count([1, 0, 1]) == 0
    assert real_root_count([-2, 0, 1]) == 2  # t^2 - 2
    assert real_root_count([1, -2, 1]) == 1  # (t - 1)^2: one distinct zero
    assert real_root_count([0, -1, 0, 1]) == 3  # t^3 - t


def test_float_helpers():
    assert np.allclose(real_mul([1, 1], [-1, 1]), [-1, 0, 1])
    assert np.allclose(real_pow([1, 0, 1], 2), [1, 0, 2, 0, 1])
    assert np.allclose(quad([5, -2]), [5, -2, 1])
    assert quadratic_roots([5, -2]) == pytest.approx((1.0, 2.0))  # (t - 1)^2 + 4
    a, x = np.array([1.0, 2, 3]), np.array([4.0, -1])
    assert np.allclose(conv_matrix(a, 2) @ x, np.convolve(a, x))
    P = np.stack([real_mul([1, 0, 1], [2, 1]), real_mul([1, 0, 1], [0, 3])], axis=1)
    assert np.allclose(divide_real(P, [1, 0, 1]), [[2, 0], [1, 3]])
    assert np.allclose(mod_real(P + np.array([[1.0, 2], [0, 0], [0, 0], [0, 0]]), [1, 0, 1]), [[1, 2], [0, 0]])


def test_compose_affine_round_trip():
    C = np.array([[2.0, 1], [-3, 0], [1, 1]])  # columns: t^2 - 3t + 2, t^2 + 1
    s = compose_affine(C, 2.0, 0.5)
    back = compose_affine(s, 0.5, -0.25)  # t = 2 s + 1/2  <=>  s = t/2 - 1/4
    assert np.allclose(back, C, rtol=1e-12, atol=1e-12)
    assert np.allclose(s[-1], 1.0)  # monic stays monic


def test_poly_text():
    assert poly_text([Fr(1), 0, Fr(1)]) == "t^2 + 1"
    assert poly_text([Fr(-2), Fr(3, 4)]) == "3/4*t - 2"
    assert poly_text([5.0, -2.0, 1.0]) == "t^2 - 2 t + 5"
    assert poly_text([0.0]) == "0"
