"""The design search's bounded evaluation (issue 36, third pass): a moved candidate's gap is evaluated only
where the move (the largest shift of an end of each capsule) may bring it below the target; elsewhere the
start's number is kept. Held here against the plain evaluation: the violation, and so the score the search
ranks by, is the plain one exactly; every number kept is within its stated staleness of the true gap; the
entries evaluated are `Scorer.at`'s numbers bit for bit. And the certificate's gaps that a turn about a
shared axis does not change, evaluated once, are the per-sample ones to rounding."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from synth.design.collision import _dist_at, certify, item_distances, pair_distances_at
from synth.design.coordinate import FULL, MARGIN, Scorer, _bounded, _full_bounded, mount_space, violation
from synth.design.search import Layout, certify_layout, initial_stacks, resolved_sizes, search_target
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett


@pytest.fixture(scope="module")
def setup():
    lk = bennett(load_poses(REPO / "fixtures" / "bennett_mm_deg.yaml").matrices)
    e = lk.extent()
    sizes = resolved_sizes(0.02 * e, 0.015 * e, 0.06 * e, 0.002 * e)
    search, exact = Layout(lk, merged=True, **sizes), Layout(lk, merged=False, **sizes)
    J = len(search.joints)

    def to_offsets(X):
        return search.end_offsets(search.mount_offsets(X[:, :J], X[:, J:2 * J], X[:, 2 * J:]))

    scorer = Scorer(search, 12 * J, 6 * J, FULL, to_offsets, settled=1e-3)
    target = search_target(sizes["clearance"], sizes["bar_radius"])
    return lk, search, exact, scorer, target, mount_space(J, search.gap_min, e), e


def moved(space, X, k, step):
    """The start(s) X moved by move ``k`` of ``space`` (as `coordinate.improve` moves them)."""
    C = X.copy()
    col = space.col[k]
    C[:, col] = np.maximum(space.lo[col], X[:, col] * space.mul[k] + space.add[k] * step)
    return C


def shifts(scorer, O, O0):
    """(n, P) how far each pair's gap can change between end offsets O0 and O (`improve`'s ``moved``)."""
    pairs = scorer.layout.cs.pairs
    s = np.abs(O - O0)
    return s[:, pairs[:, :2]].max(axis=2) + s[:, pairs[:, 2:]].max(axis=2)


def short(d, target):
    """Each entry's shortfall below the target: what `violation` sums (a sum's last bit can depend on the
    arrays' alignment in memory, numpy's SIMD reductions, so the entries are compared)."""
    return np.maximum(target - d, 0.0)


def test_items_are_the_numbers_of_at(setup):
    """`item_distances` (any design, pair and sample per item) gives `pair_distances_at`'s numbers."""
    lk, search, _, scorer, _, _, e = setup
    rng = np.random.default_rng(3)
    X = initial_stacks(rng, len(search.joints), 6, search.gap_min, e)
    O = scorer.offsets(X)
    P, K = scorer.Q.shape[2:]
    pidx, kidx = rng.integers(0, P, 300), rng.integers(0, K, 300)
    plain = pair_distances_at(search.cs, scorer.Q, scorer.U, O, pidx, kidx)  # (N, L)
    cand = rng.integers(0, len(X), 300)
    assert np.array_equal(item_distances(search.cs, scorer.Q, scorer.U, O, cand, pidx, kidx),
                          plain[cand, np.arange(300)])


def test_bounded_moves_score_as_the_plain_evaluation(setup):
    """A chain of random moves (every kind, steps from a quarter of the extent down to a hundredth): at each,
    the screen at chosen entries and the full evaluation, bounded, give the plain evaluation's violation
    exactly; numbers kept are at most their staleness above the true gaps; fresh ones are the true ones."""
    _, search, _, scorer, target, space, e = setup
    rng = np.random.default_rng(11)
    level = target * (1 + MARGIN)
    X = initial_stacks(rng, len(search.joints), 3, search.gap_min, e)[:3]
    gaps, offs, stale = scorer.full(X), scorer.to_offsets(X), np.zeros((3, len(search.cs.pairs)))
    P, K = gaps.shape[1:]
    skipped = 0
    for it in range(60):
        k, step = int(rng.integers(len(space.col))), e * float(rng.choice([0.25, 0.06, 0.01]))
        C = moved(space, X, k, step)
        O = scorer.to_offsets(C)
        shift = shifts(scorer, O, offs)
        pidx, kidx = rng.integers(0, P, 200), rng.integers(0, K, 200)
        pidx[:20], kidx[:20] = np.flatnonzero(scorer.once)[:1], scorer.once_k
        screened, need = _bounded(scorer, O, shift[:, pidx], gaps[:, pidx, kidx], stale[:, pidx], pidx, kidx, level)
        plain = scorer.at(C, pidx, kidx)
        assert np.array_equal(short(screened, target), short(plain, target))
        assert np.allclose(violation(screened, target), violation(plain, target), rtol=1e-12, atol=0)
        assert np.array_equal(screened[need], plain[need])
        d, fresh = _full_bounded(scorer, O, shift, gaps, stale, level)
        true = scorer.full(C)
        assert np.array_equal(short(d, target), short(true, target))
        finite = np.isfinite(true)
        assert np.all((true >= d - fresh[:, :, None] - 1e-6 * e)[finite])
        exact = np.broadcast_to((fresh == 0)[:, :, None], d.shape) & finite
        assert np.array_equal(d[exact], true[exact])
        skipped += int((fresh > 0).sum())
        X, gaps, offs, stale = C, d, O, fresh
    assert skipped > 0  # the bound did skip pairs (the test is not vacuous)


def test_full_bounded_without_a_move_is_the_start(setup):
    """Nothing moved, nothing stale: the start's gaps, unchanged, and nothing stale."""
    _, search, _, scorer, target, _, e = setup
    X = initial_stacks(np.random.default_rng(5), len(search.joints), 2, search.gap_min, e)[:2]
    gaps, O = scorer.full(X), scorer.to_offsets(X)
    d, fresh = _full_bounded(scorer, O, np.zeros(gaps.shape[:2]), gaps, np.zeros(gaps.shape[:2]), target)
    assert np.array_equal(d, gaps) and not fresh.any()


def test_certificate_steady_gaps_are_the_sampled_ones(setup):
    """The certificate evaluates the gaps a turn about a shared axis does not change once: they are the
    per-sample gaps to rounding, and the certificate's verdict and bound are the per-sample one's."""
    lk, search, exact, _, _, _, e = setup
    S = exact.natural_offsets() + np.random.default_rng(2).normal(scale=0.05 * e, size=len(exact.mounts))
    offsets = exact.end_offsets(S[None])[0]
    assert exact.cs.axial is not None and (exact.cs.axial[:, 0] > 0).any()
    clearance = 1e-3 * e
    cert = certify(lk, exact.cs, offsets, *FULL, clearance)
    plain = _dist_at(lk, exact.cs, offsets, cert["phis"])
    assert np.allclose(cert["dist"], plain, rtol=0, atol=1e-9 * e)  # (legs_distance: r from |w|^2 - z^2)
    plain_bound = certify_layout(exact, S, FULL, clearance)
    assert plain_bound["certified"] == cert["certified"] and plain_bound["lower"] == pytest.approx(cert["lower"])
