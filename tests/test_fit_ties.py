"""Ranking seeds by cost (synth/synthesis/fit.py, `rank_seeds`): costs that differ in rounding only are
ties, broken by seed index, so a fit's answer does not depend on the last bits of its seeds' costs."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from synth.synthesis import bennett_fit
from synth.synthesis.fit import COST_TIE, LMResult, cost_classes, rank_seeds

from test_bennett_fit import sampled, spread_of, task


def test_worked_ranking():
    cost = np.array([1.0, 1.0 + 1e-14, 0.5, np.nan, 1.0 - 1e-15, 2.0, np.inf, 0.0, 1e-30])
    assert cost_classes(cost).tolist() == [2, 2, 1, 5, 2, 3, 4, 0, 0]
    # 0 and 1e-30 tie (absolute floor), the three costs near 1 tie: by index; NaN and inf last
    assert rank_seeds(cost).tolist() == [7, 8, 2, 0, 1, 4, 5, 6, 3]
    feasible = np.array([True, True, True, True, True, False, True, False, True])
    assert rank_seeds(cost, ~feasible).tolist() == [8, 2, 0, 1, 4, 6, 3, 7, 5]
    assert rank_seeds(np.array([1.0, 1.0 + 1e-10])).tolist() == [0, 1]  # a real difference is not a tie
    assert rank_seeds(np.array([1.0 + 1e-10, 1.0])).tolist() == [1, 0]


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.lists(st.integers(0, 5), min_size=1, max_size=30), st.integers(0, 2**32 - 1))
def test_rounding_noise_does_not_reorder(levels, seed):
    """Costs on a few well separated levels, each seed's cost moved by rounding-sized noise (well inside
    COST_TIE): the same order as without the noise, the seeds of a level by index."""
    rng = np.random.default_rng(seed)
    clean = 10.0 ** np.asarray(levels, float)
    noisy = clean * (1 + rng.uniform(-0.4, 0.4, len(clean)) * COST_TIE)
    order = rank_seeds(noisy)
    assert order.tolist() == np.lexsort((np.arange(len(clean)), clean)).tolist()
    assert order.tolist() == rank_seeds(clean).tolist()


def test_bennett_fit_keeps_the_lowest_index_of_tied_seeds(monkeypatch):
    """fit_motion's refined seeds (all four converge to the one minimum of this task) given one cost, the
    same for all (a stable sort keeps index order), then costs a hair (2e-13 relative, rounding-sized)
    lower for later seeds, which a plain sort would put first: the same best fit, to the bit."""
    T, _ = sampled(9, 9, noise=1e-4, exact=(0,))
    ps = task(T, (2e-3 * spread_of(T), 2e-3), exact=(0,))
    real = bennett_fit.levenberg_marquardt

    def run(tilt):
        def tied(*args, **kw):
            res = real(*args, **kw)
            cost = np.full(len(res.cost), res.cost.min()) * (1 - tilt * np.arange(len(res.cost)))
            return LMResult(res.x, cost, res.violation, res.iterations)

        monkeypatch.setattr(bennett_fit, "levenberg_marquardt", tied)
        return bennett_fit.fit_motion(ps)

    equal, tilted = run(0.0), run(2e-13)
    assert np.array_equal(tilted[0][0], equal[0][0]) and np.array_equal(tilted[2][0], equal[2][0])
    assert not np.array_equal(run(2e-11)[0][0], equal[0][0])  # a difference above COST_TIE does reorder
