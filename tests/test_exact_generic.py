"""One engine, two number types: the dual-quaternion and polynomial routines of synth.algebra.dq /
synth.algebra.polynomial on object arrays of Fractions (exact) and on floats, and the exact Algorithm 1
(docs/algorithm1.md) and Bennett flip (docs/exceptional.md) built on them.

Invariants: exact results satisfy their identities exactly (==, in Fractions); float results agree
with the exact ones within 1e-12 relative; batches agree with single calls."""
from fractions import Fraction as Fr

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from synth.algebra import exact as X
from synth.algebra.certify import exact_check, exact_product
from synth.algebra.dq import (dq_conj, dq_inv, dq_left_matrix, dq_mul, dq_norm, exact_array, qinv, qmul,
                              structure_constants, study_condition)
from synth.algebra.factorize import factorize
from synth.algebra.flip import bennett_flip, flip_residual
from synth.algebra.polynomial import (divide_linear_right, divide_real_quadratic, divide_right, make_monic,
                                      norm_poly, norm_poly_full, poly_mul, product_of_linear, relative_error,
                                      right_value)

REL = 1e-12

fractions = st.builds(Fr, st.integers(-9, 9), st.integers(1, 5))
dqs = st.lists(fractions, min_size=8, max_size=8)


def rel_diff(a, b) -> float:
    """max |a - b| / max(1, max |b|) in floats."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(1.0, float(np.max(np.abs(b)))))


def rational_rotation(a, v, c):
    """h = a + v + eps (v x c): t - h is a rotation about the line through c with direction v."""
    v, c = np.array(v, dtype=object), np.array(c, dtype=object)
    w = np.array([v[1] * c[2] - v[2] * c[1], v[2] * c[0] - v[0] * c[2], v[0] * c[1] - v[1] * c[0]], dtype=object)
    return exact_array([a, *v, 0, *w])


rotations = st.builds(rational_rotation, fractions,
                      st.lists(fractions, min_size=3, max_size=3).filter(any),
                      st.lists(fractions, min_size=3, max_size=3))


# ------------------------------------------------------------------ the element types
def test_exact_arrays_stay_fractions():
    a = exact_array([1, Fr(1, 2), 0, 0, 0, 3, 0, Fr(-2, 3)])
    for out in (dq_mul(a, a), dq_conj(a), dq_inv(a), qmul(a[:4], a[4:]), dq_norm(a), study_condition(a)):
        assert np.asarray(out).dtype == object
        assert all(isinstance(x, Fr) for x in np.ravel(out))
    C = product_of_linear(np.stack([a, a]))
    assert C.dtype == object and all(isinstance(x, Fr) for x in C.ravel())


def test_structure_constants_worked_values():
    """ij = k, ji = -k, i^2 = -1, i eps = eps i (index 5), eps^2 = 0."""
    D = structure_constants()
    assert D[1, 2, 3] == 1 and D[2, 1, 3] == -1 and D[1, 1, 0] == -1
    assert D[1, 4, 5] == 1 and D[4, 1, 5] == 1 and not D[4:, 4:].any()
    assert set(np.unique(D)) == {-1, 0, 1}


@settings(max_examples=30, deadline=None)
@given(dqs, dqs, dqs)
def test_dq_product_exact_identities_and_float_agreement(a, b, c):
    A, B, Cq = exact_array(a), exact_array(b), exact_array(c)
    assert np.all(dq_mul(dq_mul(A, B), Cq) == dq_mul(A, dq_mul(B, Cq)))  # associative, exactly
    assert np.all(dq_conj(dq_mul(A, B)) == dq_mul(dq_conj(B), dq_conj(A)))
    assert np.all(dq_mul(A, B) == B @ dq_left_matrix(A))
    assert rel_diff(dq_mul(np.array(a, float), np.array(b, float)), dq_mul(A, B)) <= REL
    assert rel_diff(qmul(np.array(a[:4], float), np.array(b[:4], float)), qmul(A[:4], B[:4])) <= REL
    if any(a[:4]):
        one = exact_array([1, 0, 0, 0, 0, 0, 0, 0])
        assert np.all(dq_mul(A, dq_inv(A)) == one) and np.all(dq_mul(dq_inv(A), A) == one)
        assert np.all(qmul(A[:4], qinv(A[:4])) == one[:4])


def test_batch_matches_single_exact():
    rng = np.random.default_rng(3)
    A = exact_array(rng.integers(-5, 6, (4, 8))) / 3
    B = exact_array(rng.integers(-5, 6, (4, 8))) / 2
    batch = dq_mul(A, B)
    for k in range(4):
        assert np.all(batch[k] == dq_mul(A[k], B[k]))


def test_mixed_exact_and_float_give_floats_close_to_exact():
    a = exact_array([1, 2, 0, 0, 0, 0, 3, 0])
    b = np.array([0.5, 0, 0, 1, 0, 1, 1, 0])
    assert rel_diff(dq_mul(a, b), dq_mul(a, exact_array(b))) <= REL


# ------------------------------------------------------------------ polynomials
@settings(max_examples=20, deadline=None)
@given(st.lists(rotations, min_size=1, max_size=3), rotations)
def test_polynomial_routines_exact(hs, g):
    H = np.stack(hs)
    C = product_of_linear(H)
    assert np.all(C[-1] == exact_array([1, 0, 0, 0, 0, 0, 0, 0]))
    assert not np.any(norm_poly_full(C)[:, 1:])  # motion polynomial: C C~ is real, exactly
    assert list(norm_poly(C)) == [row[0] for row in norm_poly_full(C)]
    D, rem = divide_linear_right(C, H[-1])  # t - h_n right-divides C
    assert not np.any(rem) and not np.any(right_value(C, H[-1]))
    assert np.all(poly_mul(D, product_of_linear(H[-1:])) == C)
    Q, R = divide_right(poly_mul(C, product_of_linear(g[None])), product_of_linear(g[None]))
    assert np.all(Q == C) and not np.any(R)
    N = norm_poly(product_of_linear(H[-1:]))
    _, r1, r0 = divide_real_quadratic(C, N[:2])
    if np.any(r1[:4]):  # Algorithm 1's step: the unique right zero with norm N(t - h_n) is h_n
        assert np.all(-dq_mul(dq_inv(r1), r0) == H[-1])
    assert np.all(make_monic(2 * C) == C)
    Cf = product_of_linear(H.astype(float))
    assert float(relative_error(Cf, C.astype(float))) <= REL


# ------------------------------------------------------------------ the exact Algorithm 1
EXAMPLES = [
    "(t - i - eps j)(t - 1 - 2j - eps(3i + k))",
    "(t - 1/3 k)(t - k - eps i)",
    "(t - 1/2 - 1/3 i)(t - 1/2 - j - eps k)(t - 1/2 - 2/3 k)",
    "(t - 2k - eps i)(t - j - eps k)",
]


@pytest.mark.parametrize("text", EXAMPLES)
def test_exact_factorizations_multiply_back_exactly_and_match_floats(text):
    from synth.algebra.expr import parse_polynomial

    C = parse_polynomial(text, exact=True)
    re_ = X.factorize_exact(C)
    rn = factorize(np.array(C, float))
    assert [f.order for f in re_.factorizations] == [f.order for f in rn.factorizations]
    for fe, fn in zip(re_.factorizations, rn.factorizations):
        assert np.all(product_of_linear(exact_array(fe.factors)) == exact_array(C))
        assert rel_diff(fn.factors, fe.floats()) <= REL


@settings(max_examples=15, deadline=None)
@given(st.lists(rotations, min_size=2, max_size=3))
def test_exact_algorithm1_on_random_rational_products(hs):
    C = product_of_linear(np.stack(hs))
    quads = [(h[0] ** 2 + sum(x * x for x in h[1:4]), -2 * h[0]) for h in hs]
    assume(len(set(quads)) == len(quads))  # distinct norm factors: n! factorizations
    # well separated roots, so that the float engine is accurate to ~1e-13 (the test compares at 1e-12)
    z = [complex(-float(c1) / 2, np.sqrt(float(c0) - float(c1) ** 2 / 4)) for c0, c1 in quads]
    assume(min(abs(p - q) for k, p in enumerate(z) for q in z[k + 1:]) > 0.3)
    try:
        re_ = X.factorize_exact(C.tolist())
    except Exception as e:  # noqa: BLE001 - a real factor (e.g. h_2 = conj h_1) or norm not over Q
        assume(not str(e))
    for fe in re_.factorizations:
        assert np.all(product_of_linear(exact_array(fe.factors)) == C)
    rn = factorize(C.astype(float))
    assert len(rn.factorizations) == len(re_.factorizations)
    for fe, fn in zip(re_.factorizations, rn.factorizations):
        assert fe.order == fn.order
        assert rel_diff(fn.factors, fe.floats()) <= 1e-10


def test_exact_adapters_keep_the_tuple_layout():
    m, h = (0, 0, 0, 2, 0, 1, 0, 0), (0, 0, 1, 0, 0, 0, 0, 1)
    C = X.product_of_linear([m, h])
    assert isinstance(C, list) and all(isinstance(r, tuple) and len(r) == 8 for r in C)
    assert X.dq_mul(m, h) == tuple(dq_mul(exact_array(m), exact_array(h)))
    assert X.norm_poly(C) == [4, 0, 5, 0, 1]
    with pytest.raises(ZeroDivisionError):
        X.dq_inv((0, 0, 0, 0, 1, 0, 0, 0))


# ------------------------------------------------------------------ certification and the flip
def test_certify_exact_product_and_check():
    hs = [rational_rotation(1, [1, 0, 0], [0, 1, 0]), rational_rotation(Fr(1, 2), [0, 0, 2], [1, 0, 0])]
    P = exact_product(hs)
    assert P == product_of_linear(np.stack(hs)).tolist()
    assert exact_product([]) == [[1, 0, 0, 0, 0, 0, 0, 0]]
    assert exact_check(P, [1], hs)
    assert exact_check(P, [1, 0, 1], hs) is False


@settings(max_examples=30, deadline=None)
@given(rotations, rotations)
def test_flip_exact_identity_and_float_agreement(m, h):
    try:
        k, n = bennett_flip(list(m), list(h))
    except Exception:  # noqa: BLE001 - FlipError: primal(h) = conj(primal(m)), a translation
        assume(False)
    lhs = product_of_linear(np.stack([m, h]))
    assert np.all(product_of_linear(exact_array([k, n])) == lhs)
    assert np.all(dq_norm(exact_array(n)) == dq_norm(m)) and np.all(dq_norm(exact_array(k)) == dq_norm(h))
    assert n[0] == m[0] and k[0] == h[0]  # N(t - n) = N(t - m), N(t - k) = N(t - h)
    mf, hf = m.astype(float), h.astype(float)
    kf, nf = bennett_flip(mf, hf)
    assert flip_residual(mf, hf, kf, nf) <= 1e-12
    assert rel_diff(kf, np.array(k, float)) <= 1e-10 and rel_diff(nf, np.array(n, float)) <= 1e-10
