"""synth.algebra.factorize.factorize on the hard cases of the norm roots: separated roots (the direct
numbering by (Re z rounded, Im z)), ties of the real parts, nearly repeated and nearly real roots (the
clustering path). Invariants with tolerances: multiply-back, Study condition, norms of the factors."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.algorithm1 import multiply_back, study_violation
from synth.algebra.factorize import factorize
from synth.algebra.polynomial import product_of_linear
from synth.errors import MpsynthError


def revolute_factor(a, b, axis, point):
    """t - h for the rotation about the line through ``point`` along ``axis``; N(t - h) = (t - a)^2 + b^2."""
    u = np.asarray(axis, float)
    u = u / np.linalg.norm(u)
    return np.concatenate([[a], -b * u, [0.0], b * np.cross(np.asarray(point, float), u)])


axis_st = st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.2)
point_st = st.lists(st.floats(-3, 3), min_size=3, max_size=3)


def valid(res, C, tol):
    """Every factorization multiplies back to within tol, satisfies the Study condition, and its
    factors have the norms its order names."""
    H = np.array([f.factors for f in res.factorizations])
    assert np.all(multiply_back(C, H) <= tol), multiply_back(C, H)
    assert np.all(study_violation(H) <= 1e-8)
    for f in res.factorizations:
        assert f.residual <= tol
        for h, q in zip(f.factors, f.order):
            c0, c1 = res.quadratics[q]
            scale = max(1.0, abs(c0))
            assert abs(h @ h - h[4:] @ h[4:] - c0) <= 1e-6 * scale and abs(2 * h[0] + c1) <= 1e-6 * max(1.0, abs(c1))


@pytest.mark.parametrize("seed", range(20))
def test_separated_cubics_are_tight(seed):
    rng = np.random.default_rng(seed)
    hs = np.stack([revolute_factor(-1.5 + 1.5 * i + rng.uniform(-0.2, 0.2), rng.uniform(0.3, 2),
                                   rng.normal(size=3), rng.uniform(-2, 2, size=3)) for i in rng.permutation(3)])
    C = product_of_linear(hs)
    res = factorize(C)
    assert res.multiplicity == [1, 1, 1] and len(res.factorizations) == 6 and not res.failed_orders
    assert list(res.quadratics[:, 1]) == sorted(res.quadratics[:, 1], reverse=True)  # numbered by Re z = -c1/2
    valid(res, C, 5e-13)


@pytest.mark.parametrize("a1", [0.0, 1e-12, -1e-12, 3e-10])
@pytest.mark.parametrize("order", [(0, 1, 2), (2, 0, 1), (1, 2, 0)])
def test_tied_real_parts_are_numbered_by_the_imaginary_part(a1, order):
    """Norm roots a1 + i and 0 + 2i: sorted by real part the second comes first (for a1 > 0), but the
    numbering rounds the real part to 9 decimals, then sorts by the imaginary part."""
    rng = np.random.default_rng(7)
    hs = [revolute_factor(a1, 1.0, rng.normal(size=3), rng.normal(size=3)),
          revolute_factor(0.0, 2.0, rng.normal(size=3), rng.normal(size=3)),
          revolute_factor(1.0, 1.5, rng.normal(size=3), rng.normal(size=3))]
    C = product_of_linear(np.stack([hs[i] for i in order]))
    res = factorize(C)
    assert res.quadratics[0][0] == pytest.approx(1.0) and res.quadratics[1][0] == pytest.approx(4.0)
    assert [f.order for f in res.factorizations] == sorted(f.order for f in res.factorizations)
    valid(res, C, 5e-13)


@st.composite
def nearly_repeated(draw):
    """Products of 2..3 revolute factors where two norm roots lie within 1e-12..1e-6 (relative) of each
    other: the same quadratic up to a tiny change of a or b, different axes."""
    n = draw(st.integers(2, 3))
    a, b = draw(st.floats(-2, 2)), draw(st.floats(0.3, 2))
    delta = 10.0 ** draw(st.floats(-12, -6))
    which = draw(st.sampled_from(["a", "b"]))
    a2, b2 = (a + delta, b) if which == "a" else (a, b * (1 + delta))
    hs = [revolute_factor(a, b, draw(axis_st), draw(point_st)), revolute_factor(a2, b2, draw(axis_st), draw(point_st))]
    if n == 3:
        hs.append(revolute_factor(draw(st.floats(-2, 2)), draw(st.floats(0.3, 2)), draw(axis_st), draw(point_st)))
    order = draw(st.permutations(range(n)))
    return np.stack([hs[i] for i in order])


@st.composite
def nearly_real(draw):
    """Products of 1..3 revolute factors, one of them with a norm root of imaginary part 1e-12..1e-6
    (relative): (t - a)^2 + b^2 with tiny b."""
    n = draw(st.integers(1, 3))
    a = draw(st.floats(-2, 2))
    b = 10.0 ** draw(st.floats(-12, -6)) * max(1.0, abs(a))
    hs = [revolute_factor(a, b, draw(axis_st), draw(point_st))]
    hs += [revolute_factor(draw(st.floats(-2, 2)), draw(st.floats(0.3, 2)), draw(axis_st), draw(point_st))
           for _ in range(n - 1)]
    order = draw(st.permutations(range(n)))
    return np.stack([hs[i] for i in order])


def factorizations_or_refusal(hs):
    """factorize gives factorizations whose reported residual is their multiply-back error (nearly
    repeated roots of a primal part with a real factor are ill conditioned: the residual says how
    well), or a library error."""
    C = product_of_linear(hs)
    try:
        res = factorize(C)
    except MpsynthError:
        return None
    H = np.array([f.factors for f in res.factorizations])
    np.testing.assert_allclose([f.residual for f in res.factorizations], multiply_back(C, H), rtol=1e-6, atol=1e-15)
    return H, C


@settings(max_examples=60, deadline=None)
@given(nearly_repeated())
def test_nearly_repeated_norm_roots(hs):
    factorizations_or_refusal(hs)


@settings(max_examples=60, deadline=None)
@given(nearly_real())
def test_nearly_real_norm_roots(hs):
    factorizations_or_refusal(hs)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10**6), st.floats(-12, -8))
def test_primal_with_nearly_real_factor(seed, log_eps):
    """C = (t - h1)(t - h2)(t - h3) near a primal part with a real quadratic factor: h3 = h2~ (then
    (t - h2)(t - h2~) = N(t - h2) is real) shifted by a tiny real number (keeps the Study condition)."""
    rng = np.random.default_rng(seed)
    hs = np.stack([revolute_factor(rng.uniform(-2, 2), rng.uniform(0.3, 2), rng.normal(size=3), rng.normal(size=3))
                   for _ in range(3)])
    hs[2] = hs[1] * np.array([1, -1, -1, -1, 1, -1, -1, -1])
    hs[2, 0] += 10.0 ** log_eps
    factorizations_or_refusal(hs)
