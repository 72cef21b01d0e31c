"""The plain-float single-member path (synth.sixbar_member, issue 4) agrees with the batched general path of
`one_member_loops`: same validity, factorizations, residuals at rounding level and the same scores."""
from __future__ import annotations

import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import synth.sixbar  # noqa: F401  (the module; the package exports the function of the same name)
from synth import sixbar_member as sm
from synth.cubic import _newton_step, _product_residual, multiply_back
from synth.errors import SynthesisError
from synth.motion import product_of_linear
from synth.sixbar import PART_KEYS, one_member_loops, prepare, scan

SIX = sys.modules["synth.sixbar"]


def random_poses(rng):
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, :3] = Rotation.random(4, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(size=(4, 3))
    return T


def general(T, family, member, problem, score=True, monkeypatch=None):
    """one_member_loops by the batched path only."""
    monkeypatch.setattr(SIX, "_member_loops_fast", lambda *a: None)
    try:
        return one_member_loops(T, family, member, problem=problem, score=score)
    finally:
        monkeypatch.undo()


def compare(a, b, score_rtol):
    assert (a.valid == b.valid).all() and (a.ok == b.ok).all()
    assert a.pairs.tolist() == b.pairs.tolist() and a.orders.tolist() == b.orders.tolist()
    scale = max(1.0, np.abs(b.factorizations).max())
    assert np.allclose(a.factorizations, b.factorizations, rtol=0, atol=1e-10 * scale)
    assert np.array_equal(a.C, b.C)
    if b.score is not None:
        assert np.allclose(a.score, b.score, rtol=score_rtol, atol=0)
        for k in PART_KEYS:
            if k != "residual":
                assert np.allclose(a.parts[k], b.parts[k], rtol=score_rtol, atol=1e-14), k


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10**6), st.floats(-6, 6))
def test_fast_path_agrees_on_random_members(seed, member):
    T = random_poses(np.random.default_rng(seed))
    try:
        pr = prepare(T)
    except SynthesisError:
        return  # oval: no 6R
    for fam in pr.families:
        try:
            a = one_member_loops(T, fam.index, member, problem=pr)
        except SynthesisError:
            continue  # degenerate label
        with pytest.MonkeyPatch.context() as mp:
            b = general(T, fam.index, member, pr, monkeypatch=mp)
        # ill-conditioned members: the general path's own polish may stop at ~1e-13 (the fast one reaches
        # ~2e-16), which moves the joint geometry by ~1e-10 relative
        compare(a, b, score_rtol=1e-8)
        if SIX._member_loops_fast(fam, float(member), True) is not None:
            assert a.residual.max() <= 1e-14
            for p in range(6):
                assert np.abs(product_of_linear(a.factorizations[p]) - a.C).max() <= 1e-12 * max(1, np.abs(a.C).max())


@pytest.mark.parametrize("seed", range(6))
def test_fast_path_on_the_best_designs(seed):
    """The members the scan recommends take the fast path, with the general path's scores to ~1e-12."""
    rng = np.random.default_rng(100 + seed)
    while True:
        T = random_poses(rng)
        try:
            pr = prepare(T)
            break
        except SynthesisError:
            continue
    for cand in scan(pr)[:2]:
        fam = pr.family(cand.family)
        assert SIX._member_loops_fast(fam, cand.member, True) is not None
        a = one_member_loops(T, cand.family, cand.member, problem=pr)
        with pytest.MonkeyPatch.context() as mp:
            b = general(T, cand.family, cand.member, pr, monkeypatch=mp)
        compare(a, b, score_rtol=2e-11)
        assert a.score[cand.pair - 1] == pytest.approx(cand.score, rel=2e-11)
        u = one_member_loops(T, cand.family, cand.member, problem=pr, score=False)
        assert u.score is None and np.array_equal(u.factorizations, a.factorizations)
        assert np.array_equal(u.valid, a.valid)


def test_example_member_fast_and_exact():
    from tests.test_cubic import e_poses

    T = e_poses()
    pr = prepare(T)
    assert SIX._member_loops_fast(pr.family(2), 0.5, True) is not None
    ml = one_member_loops(T, 2, 0.5, problem=pr)
    assert ml.residual.max() < 1e-15
    assert multiply_back(ml.C[None], ml.factorizations[None]).max() < 2e-15


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10**6))
def test_closed_form_newton_step_matches_the_linear_system(seed):
    """`_vnewton` (two Sylvester equations) = the 16 x 16 Newton system of synth.cubic on perturbed
    factorizations of a random cubic."""
    rng = np.random.default_rng(seed)
    H = rng.normal(size=(3, 8))
    H[:, 4] = 0.0
    v, w = H[:, 1:4], H[:, 5:8]
    H[:, 5:8] = w - v * (np.sum(v * w, -1) / np.sum(v * v, -1))[:, None]
    C = np.zeros((4, 8))
    C[3, 0] = 1.0
    C[:3] = product_of_linear(H)[:3]
    Hp = H + 1e-7 * rng.normal(size=H.shape)
    r, X = _product_residual(C, Hp)
    ref = _newton_step(Hp, X, r)
    r2, X2 = sm._vresidual(C, Hp[None, 0], Hp[None, 1], Hp[None, 2])
    assert np.allclose(r2[:, 0], r, atol=1e-15)
    d = np.stack(sm._vnewton(Hp[None, 0], Hp[None, 1], Hp[None, 2], r2, X2), 1)[0]
    assert np.allclose(d, ref, rtol=1e-6, atol=1e-6 * np.abs(ref).max())


def test_not_generic_members_take_the_general_path():
    from tests.test_cubic import e_poses

    T = e_poses()
    pr = prepare(T)
    fam = pr.family(2)
    bad = fam.bad_members()
    for lam in (1e-9, bad["lambda2"] * (1 + 1e-9)):
        assert sm.factor_member([tuple(r) for r in fam.member(lam).tolist()]) is None
        a = one_member_loops(T, 2, lam, problem=pr)
        with pytest.MonkeyPatch.context() as mp:
            b = general(T, 2, lam, pr, monkeypatch=mp)
        assert np.array_equal(a.valid, b.valid) and np.array_equal(a.score, b.score)
