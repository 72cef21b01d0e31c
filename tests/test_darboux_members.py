"""The choice of a collision-free member of the 7R Darboux construction (synth/design/members.py): the grid,
the preference (fewest singular configurations, then the most compact design) with a stand-in design
search, and the fall-backs. The real search on the fixture runs in tests/test_darboux7.py (end to end)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from synth.algebra.expr import parse_polynomial
from synth.design.members import SCREEN_CAP, SHIFT, choose_member, design_size, member_grid
from synth.design.model import straight_design
from synth.design.model import CollisionReport, DesignResult
from synth.synthesis.darboux import darboux_linkage

GENERAL = "(t^2 + 1)*(t - k) + eps*(i + k/2 - (j + k/2)*t)*(t - k)"  # fixtures/motion_darboux_general.yaml


@pytest.fixture(scope="module")
def default():
    C = np.array(parse_polynomial(GENERAL), float)
    return darboux_linkage(C, check_samples=20)


def test_grid_is_deterministic_default_first():
    g = member_grid(2.0)
    assert len(g) == 35 and g[0] == (0.0, (0.0, 0.0)) and len(set(g)) == 35
    assert all(abs(t - math.pi / 2) > 0.1 for t, _ in g)  # the turn with two degrees of freedom is not tried
    assert {round(math.hypot(*s), 12) for _, s in g} == {0.0, round(2.0 * SHIFT, 12)}


def _stand_in(free_keys, calls):
    """A design search that finds a free design exactly for the members (turn index k of pi/8, shift
    direction) in ``free_keys``; the design is the straight one, so its size is the member's own."""
    def design(lk, ranges, full_work, effort, work):
        work.charge(full_work)  # as a search that spends its cap
        m = lk.info.synthesis.darboux.member.to_dict()
        s = np.sign(np.round(m["shift"], 9)).astype(int)
        key = (round(m["turn"] / (math.pi / 8)), int(s[0]), int(s[1]))
        calls.append((key, ranges, effort))
        free = key in free_keys
        d = straight_design(lk, pin_radius=0.005, bar_radius=0.01, hub_length=0.02)
        rep = CollisionReport(free=free, range="full", clearance=0.0025, min_distance=0.003 if free else -0.01,
                              driver="h1", driver_range=(0.0, 2 * math.pi), certified=True)
        return DesignResult(d, rep)
    return design


def test_fewest_singular_configurations_win(default):
    """Turn 0 keeps 4 singular configurations, turn pi/8 has 6: the turn-0 member wins though screened too."""
    calls = []
    lk, res = choose_member(default, _stand_in({(1, -1, 0), (0, 1, 0)}, calls))
    m = lk.info.synthesis.darboux.member.to_dict()
    assert m["turn"] == 0.0 and m["shift"][0] > 0 and res.collision.free
    choice = lk.info.synthesis.darboux.member_choice.to_dict()
    assert choice["free_found"] == 2 and choice["singular_configurations"] == 4 == len(lk.info.synthesis.darboux.singular_t)
    assert choice["tried"] == 6 and calls[0] == ((0, 0, 0), ("full",), 1.0)  # the default first, at full effort
    assert lk.checks["max_closure_error"] < 1e-12 and "fewest singular configurations (4)" in choice["reason"]


def test_then_the_most_compact_design(default):
    calls = []
    lk, res = choose_member(default, _stand_in({(1, 0, 0), (1, -1, 0)}, calls))
    sizes = {}
    for k in ((0.0, 0.0), (-1.0, 0.0)):
        other = choose_member(default, _stand_in({(1, int(k[0]), 0)}, []))[0]
        sizes[k] = design_size(other, straight_design(other, pin_radius=0.005, bar_radius=0.01, hub_length=0.02))
    best = min(sizes, key=sizes.get)
    assert np.sign(lk.info.synthesis.darboux.member.shift[0]) == np.sign(best[0])
    assert lk.info.synthesis.darboux.member_choice.design_size == pytest.approx(min(sizes.values()))


def test_default_kept_when_free_and_none_when_nothing_is(default):
    calls = []
    lk, res = choose_member(default, _stand_in({(0, 0, 0)}, calls))
    assert lk is default and res.collision.free and len(calls) == 1
    calls = []
    lk, res = choose_member(default, _stand_in(set(), calls), work=2 * SCREEN_CAP)
    assert lk is default and res is None and lk.info.synthesis.darboux.member_choice.member is None
    assert len(calls) == 1 + 3  # the default, then members until the counted budget is spent (not the clock)
    default.info = default.info.with_synthesis(darboux=default.info.synthesis.darboux.replace(member_choice=None))
