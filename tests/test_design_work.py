"""Counted work (synth.design.work, docs/design.md "Deterministic"): the design searches stop on gap
evaluations, never on the clock, so a slow (loaded) machine writes the same design."""
from __future__ import annotations

import time

import pytest

from synth.design.choose import design_for
from synth.design.work import Work
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett

from conftest import REPO

THIN = REPO / "tests" / "data" / "bennett_thin.yaml"  # collides at the default radii: thinning runs


@pytest.fixture(scope="module")
def linkage():
    ps = load_poses(str(THIN))
    return bennett(ps.matrices, ps.names)


def test_budget_and_its_parts_count_together():
    whole = Work(100)
    part = whole.part(10)
    part.charge(4)
    assert not part.spent and part.left == 6 and whole.left == 96
    part.charge(7)  # past its own limit (a move is never cut short): spent, the whole is not
    assert part.spent and part.left == -1 and whole.done == 11 and not whole.spent
    free = whole.part(None)  # no limit of its own: spent only with the whole
    free.charge(88)
    assert not free.spent and whole.done == 99
    free.charge(1)
    assert whole.spent and free.spent and free.left == 0


def test_a_slow_clock_changes_nothing(linkage, monkeypatch, first_sets_only):
    """The thinning and crank budgets were CPU seconds: a clock that jumps 100 s per reading (a machine
    100 times too busy) would have stopped them at once. Counted, the same design comes out."""
    first = design_for(linkage, slenderness=1e9)  # bars as slender as before issue 33: thinning runs
    assert first.collision.thinned is not None  # the path that had a CPU budget was taken
    clock = iter(range(0, 10 ** 9, 100))
    monkeypatch.setattr(time, "process_time", lambda: float(next(clock)))
    again = design_for(linkage, slenderness=1e9)
    assert again.collision.to_dict() == first.collision.to_dict()
    assert again.design.to_dict() == first.design.to_dict()
    assert again.collision.work == first.collision.work > 0


def test_a_small_budget_stops_the_search_early(linkage):
    """A limit of 1e6 gap evaluations: the search stops within one move's evaluations past it (about 1e4
    for this linkage), with the same result on every run; unlimited, it does more (5.5e6)."""
    spent = Work(1e6)
    small = design_for(linkage, work=spent, thin=False, slenderness=1e9)
    assert 1e6 <= spent.done < 1.05e6 and small.collision.work == spent.done
    again = design_for(linkage, work=Work(1e6), thin=False, slenderness=1e9)
    assert again.collision.to_dict() == small.collision.to_dict()
    unlimited = Work()
    design_for(linkage, work=unlimited, thin=False, slenderness=1e9)
    assert unlimited.done > 5 * spent.done
