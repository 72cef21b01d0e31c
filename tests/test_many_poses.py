"""Issue #35: a fit task of many poses (up to the reader's 10,000) never lists every triple, quadruple
or 5-subset of its items (1000 poses: 1.7e8 triples, which hung `mpsynth bennett` for minutes and
gigabytes); the sample is the same as drawing from the full list."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from synth.synthesis.cubic_fit import quadruples
from synth.synthesis.fit import nth_combination, sample_combinations


def listed_sample(items, k, size, first=()):
    """The former way: list all k-subsets, then draw by index (generator seed 0)."""
    allt = list(itertools.combinations(items, k))
    if len(allt) <= size:
        return allt
    first = list(first)
    pick = np.random.default_rng(0).choice(len(allt), size=size - len(first), replace=False)
    return first + [allt[i] for i in sorted(pick)]


@pytest.mark.parametrize("n, k, size", [(5, 3, 60), (8, 3, 60), (20, 3, 60), (40, 3, 60), (12, 5, 40), (30, 5, 40)])
def test_sample_is_the_one_drawn_from_the_full_list(n, k, size):
    items = list(range(0, 3 * n, 3))
    first = list(itertools.islice(itertools.combinations(items[:5], k), size // 2))
    assert sample_combinations(items, k, size, first) == listed_sample(items, k, size, first)


def test_nth_combination_is_lexicographic():
    assert [nth_combination(6, 3, i) for i in range(20)] == list(itertools.combinations(range(6), 3))


def test_ten_thousand_poses_are_sampled_without_listing():
    """1.7e11 triples: drawn by rank, in well under a second of work (listing them would never end)."""
    got = sample_combinations(range(10_000), 3, 60)
    assert len(got) == 60 == len(set(got)) and got == sorted(got)
    assert all(0 <= a < b < c < 10_000 for a, b, c in got)
    assert got == sample_combinations(range(10_000), 3, 60)  # deterministic
    exact = np.zeros(10_000, bool)
    exact[[0, 5, 17, 900]] = True
    q = quadruples(exact)
    assert q[0] == (0, 5, 17, 900) and len(q) == 12 and all(t[0] == 0 and t[1] < t[2] < t[3] for t in q)
