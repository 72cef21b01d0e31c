"""The plain-float factorization fast path (synth.algebra.scalar.factorize_generic behind synth.algebra.factorize.factorize):
agreement with the general batched engine on random revolute products, the safe path for nearly
repeated / nearly real norm roots, and the unrolled kernels against the plain compositions they replace."""
from __future__ import annotations

import importlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra import scalar as S
from synth.algebra.polynomial import product_of_linear, relative_error

factor_mod = importlib.import_module("synth.algebra.factorize")


def revolute_factor(a, b, axis, point):
    """t - h for the rotation about the line through ``point`` along ``axis``; N(t - h) = (t - a)^2 + b^2."""
    u = np.asarray(axis, float)
    u = u / np.linalg.norm(u)
    return np.concatenate([[a], -b * u, [0.0], b * np.cross(np.asarray(point, float), u)])


def general(C):
    """factorize(C) with the fast path switched off."""
    fast = factor_mod._factorize_fast
    factor_mod._factorize_fast = lambda C, validate: None
    try:
        return factor_mod.factorize(C)
    finally:
        factor_mod._factorize_fast = fast


def same_result(a, b, atol):
    """Two FactorResults agree: the same numbering, flags and (up to atol) numbers."""
    assert a.multiplicity == b.multiplicity and a.generic == b.generic
    assert a.failed_orders == b.failed_orders and a.real_factor_roots == b.real_factor_roots
    assert [f.order for f in a.factorizations] == [f.order for f in b.factorizations]
    np.testing.assert_allclose(a.norm, b.norm, rtol=1e-13, atol=1e-13 * max(1.0, np.abs(b.norm).max()))
    np.testing.assert_allclose(a.quadratics, b.quadratics, rtol=1e-10, atol=1e-12)
    for fa, fb in zip(a.factorizations, b.factorizations):
        np.testing.assert_allclose(fa.factors, fb.factors, atol=atol)
        assert [c.kind for c in fa.classified()] == [c.kind for c in fb.classified()]


axis_st = st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.2)
point_st = st.lists(st.floats(-3, 3), min_size=3, max_size=3)


@st.composite
def revolute_products(draw, n):
    """n random revolute factors (no separation enforced) at a random scale."""
    scale = 10.0 ** draw(st.floats(-1, 1))
    hs = [revolute_factor(draw(st.floats(-2, 2)) * scale, draw(st.floats(0.05, 2)) * scale, draw(axis_st),
                          np.asarray(draw(point_st)) * scale) for _ in range(n)]
    return np.stack(hs)


def outcome(fn, C):
    """fn(C), or the type of the error it raised."""
    try:
        return fn(C)
    except Exception as e:  # noqa: BLE001 - any verdict of the general engine
        return type(e)


@pytest.mark.parametrize("n,examples", [(1, 40), (2, 60), (3, 80), (4, 10), (5, 5), (6, 3)])
def test_fast_path_agrees_with_general_engine(n, examples):
    @settings(max_examples=examples, deadline=None)
    @given(revolute_products(n))
    def run(hs):
        C = product_of_linear(hs)
        res, gen = outcome(factor_mod.factorize, C), outcome(general, C)
        fast = factor_mod._factorize_fast(C, True)
        if fast is None:  # declined (or degree > 3): factorize is the general engine, exactly
            if isinstance(gen, type):
                assert res is gen
            else:
                same_result(res, gen, atol=0.0)
            return
        # the fast path only accepts norm roots 1e-5 apart (relative): factors agree to ~eps / 1e-5
        same_result(res, gen, atol=1e-9 * max(1.0, float(np.abs(C).max())))
        H = np.stack([f.factors for f in res.factorizations])
        assert np.all(relative_error(product_of_linear(H), C) <= 1e-12)
        assert all(f.residual <= S.FAST_MAX_RESIDUAL for f in res.factorizations)
        assert len(res.factorizations) == len(S._PERMUTATIONS[n])

    run()


@pytest.mark.parametrize("seed", range(20))
def test_fast_path_is_taken_and_tight_for_separated_cubics(seed):
    rng = np.random.default_rng(seed)
    hs = np.stack([revolute_factor(-1.5 + 1.5 * i + rng.uniform(-0.2, 0.2), rng.uniform(0.3, 2),
                                   rng.normal(size=3), rng.uniform(-2, 2, size=3)) for i in rng.permutation(3)])
    C = product_of_linear(hs)
    fast = factor_mod._factorize_fast(C, True)
    assert fast is not None
    same_result(fast, general(C), atol=1e-12 * max(1.0, float(np.abs(C).max())))
    for f in fast.factorizations:
        assert f.residual == pytest.approx(float(relative_error(product_of_linear(f.factors), C)), abs=2e-15)


@pytest.mark.parametrize("a1", [0.0, 1e-12, -1e-12, 3e-10])
@pytest.mark.parametrize("order", [(0, 1, 2), (2, 0, 1), (1, 2, 0)])
def test_fast_path_numbers_tied_real_parts_like_the_general_engine(a1, order):
    """Norm roots a1 + i and 0 + 2i: sorted by real part the second comes first (for a1 > 0), but the
    general engine numbers by the real part rounded to 9 decimals, then the imaginary part."""
    rng = np.random.default_rng(7)
    hs = [revolute_factor(a1, 1.0, rng.normal(size=3), rng.normal(size=3)),
          revolute_factor(0.0, 2.0, rng.normal(size=3), rng.normal(size=3)),
          revolute_factor(1.0, 1.5, rng.normal(size=3), rng.normal(size=3))]
    C = product_of_linear(np.stack([hs[i] for i in order]))
    fast = factor_mod._factorize_fast(C, True)
    assert fast is not None
    same_result(fast, general(C), atol=1e-12 * max(1.0, float(np.abs(C).max())))
    assert fast.quadratics[0][0] == pytest.approx(1.0) and fast.quadratics[1][0] == pytest.approx(4.0)


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


def takes_safe_path(hs):
    C = product_of_linear(hs)
    assert S.factorize_generic(C) is None
    assert factor_mod._factorize_fast(C, True) is None
    res, gen = outcome(factor_mod.factorize, C), outcome(general, C)
    if isinstance(gen, type):
        assert res is gen
    else:
        same_result(res, gen, atol=0.0)


@settings(max_examples=60, deadline=None)
@given(nearly_repeated())
def test_nearly_repeated_norm_roots_take_the_safe_path(hs):
    takes_safe_path(hs)


@settings(max_examples=60, deadline=None)
@given(nearly_real())
def test_nearly_real_norm_roots_take_the_safe_path(hs):
    takes_safe_path(hs)


@settings(max_examples=30, deadline=None)
@given(revolute_products(3), st.floats(-12, -8))
def test_primal_with_nearly_real_factor_takes_the_safe_path(hs, log_eps):
    """C = (t - h1)(t - h2)(t - h3) near a primal part with a real quadratic factor: h3 = h2~ (then
    (t - h2)(t - h2~) = N(t - h2) is real) shifted by a tiny real number (keeps the Study condition). The
    norm then has a nearly double root: the fast path declines."""
    hs = hs.copy()
    hs[2] = hs[1] * np.array([1, -1, -1, -1, 1, -1, -1, -1])
    hs[2, 0] += 10.0 ** log_eps
    takes_safe_path(hs)


# ----------------------------------------------------------------------------- kernels
def rand_dq(rng, scale):
    return tuple((rng.normal(size=8) * scale).tolist())


def test_outer_pair_is_the_composition_bitwise():
    rng = np.random.default_rng(1)
    for _ in range(2000):
        s = 10.0 ** rng.uniform(-3, 3)
        a, b = rand_dq(rng, s), rand_dq(rng, s)
        h, k = S._outer_pair(a, b)
        assert h == S._dq_neg(S.dq_mul(a, b))
        assert k == S.dq_conj(S._dq_neg(S.dq_mul(S.dq_conj(a), S.dq_conj(b))))


def test_cubic_order_is_the_multiply_back_bitwise():
    rng = np.random.default_rng(2)
    for _ in range(2000):
        s = 10.0 ** rng.uniform(-3, 3)
        h1, h3 = rand_dq(rng, s), rand_dq(rng, s)
        c = [rand_dq(rng, s ** (3 - k)) for k in range(3)]
        h2, err = S._cubic_order(h1, h3, *c)
        assert h2 == tuple([-(x + y + z) for x, y, z in zip(c[2], h1, h3)])
        assert err == S._multiply_back_error([h1, h2, h3], c + [S._ONE])
    h2, err = S._cubic_order((np.inf,) + h1[1:], h3, *c)
    assert err == np.inf


@pytest.mark.parametrize("n", [1, 2, 3])
def test_multiply_back_error_matches_product_of_linear(n):
    """The scalar multiply-back (signs folded in) is the numpy product's error up to rounding."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        H = [rand_dq(rng, 1.0) for _ in range(n)]
        C = product_of_linear(np.array(H)) + rng.normal(size=(n + 1, 8)) * 1e-9
        C[-1] = S._ONE
        rows = [tuple(r) for r in C.tolist()]
        ref = float(np.max(np.abs(product_of_linear(np.array(H)) - C)))
        assert S._multiply_back_error(H, rows) == pytest.approx(ref, rel=1e-6, abs=1e-15)


def test_remainder_mod_quadratic_matches_numpy():
    from synth.algebra.polynomial import divide_real_quadratic

    rng = np.random.default_rng(4)
    for n in (2, 3, 4):
        C = rng.normal(size=(n + 1, 8))
        for monic in (False, True):
            if monic:
                C[-1] = S._ONE
            r1, r0 = S.remainder_mod_quadratic([tuple(r) for r in C.tolist()], 1.7, -0.4)
            _, e1, e0 = divide_real_quadratic(C, np.array([1.7, -0.4]))
            np.testing.assert_allclose(r1, e1, rtol=0, atol=1e-14)
            np.testing.assert_allclose(r0, e0, rtol=0, atol=1e-14)


def test_companion_eigenvalues_fallback(monkeypatch):
    """The LAPACK kernel and numpy.linalg.eigvals give the same roots; the fast path works with either."""
    rng = np.random.default_rng(5)
    hs = np.stack([revolute_factor(i - 1.0, 1.0, rng.normal(size=3), rng.normal(size=3)) for i in range(3)])
    C = product_of_linear(hs)
    N = S._poly_norm_and_study([tuple(r) for r in C.tolist()])[0]
    a = S._companion_eigenvalues(N)
    monkeypatch.setattr(S, "_EIGVALS", np.linalg.eigvals)
    assert S._companion_eigenvalues(N) == a
    assert factor_mod._factorize_fast(C, True) is not None
    monkeypatch.setattr(S, "_EIGVALS", None)
    assert S._companion_eigenvalues(N) == a  # chosen again on first use


def test_eigenvalue_failure_declines(monkeypatch):
    """An eigenvalue computation that gives NaN (LAPACK without convergence) is a decline, not an answer."""
    rng = np.random.default_rng(6)
    hs = np.stack([revolute_factor(i - 1.0, 1.0, rng.normal(size=3), rng.normal(size=3)) for i in range(3)])
    C = product_of_linear(hs)
    monkeypatch.setattr(S, "_EIGVALS", lambda a: np.full(len(a), complex("nan+nanj")))
    assert factor_mod._factorize_fast(C, True) is None
    assert len(factor_mod.factorize(C).factorizations) == 6  # the general engine
