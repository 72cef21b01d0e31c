"""The choice among candidate linkages by what their physical designs achieve (docs/design.md, "Choosing
among 6R candidates"): collision-free over the full cycle first, then over the task range, then the kinematic
score; budgets in gap evaluations (`synth.design.work`)."""
from __future__ import annotations

from synth.design.model import DesignResult
from synth.design.search import SCREEN_EFFORT, SCREEN_WORK, collision_rank
from synth.design.work import GAPS_PER_SECOND, Work


def design_rank(result: DesignResult) -> float:
    """`collision_rank` of ``result``'s report, plus 0.5 when its bars as written are more slender than
    the limit although their radius was sized (``result.slenderness``, `synth.design.sturdy`): a
    candidate whose sturdy bars are free comes first."""
    s = result.slenderness
    return collision_rank(result.collision) + (0.5 if s is not None and not s.met and not s.given else 0.0)


def rank_buildable(candidates, design, *, limit: int = 8, work: float = 6.0 * GAPS_PER_SECOND,
                   first: float = 2.5 * GAPS_PER_SECOND, per_candidate: float = 1.2 * GAPS_PER_SECOND,
                   reserve: float = 1.0 * GAPS_PER_SECOND, screen: float = SCREEN_WORK) -> list[tuple]:
    """Choose among candidate linkages (given best first by their kinematic score) collision-freedom first.

    ``design(linkage, ranges, full_work, work, effort) -> DesignResult`` (`design_linkage`'s arguments;
    ``work``: the `Work` every search charges). Budgets in gap evaluations (`synth.design.work`). Phase 0
    (more than one candidate): a quick full-cycle-only search (`SCREEN_EFFORT`, at most ``screen``) on each
    candidate in order until one is free or ``work - reserve`` is spent (whether a full-cycle design is
    found differs much more between candidates than between searches on one, and a quick search often
    finds it: fixtures/sixbar_example.yaml's 8th candidate, 2e6 evaluations, after 7 failed deep ones).
    Phase 1: a full-cycle-only search of at most ``first`` on the best-scored candidate and
    ``per_candidate`` on each next one, in order, until one is free, ``limit`` were tried, or ``work -
    reserve`` are spent (the first is always searched). Phase 2, when none is free over the full cycle:
    the task-range search on the candidates in order until one is free over it or ``work`` is spent (at
    least the first). A success is a design of `design_rank` 0 (phases 0, 1) or at most 1 (phase 2): free,
    with bars as sturdy as the slenderness asks. Returns [(linkage, DesignResult)] of the final designs
    sorted by (`design_rank`, kinematic order): a phase-0 or phase-1 success alone, else the phase-2 designs."""
    spent = Work()
    candidates = list(candidates)
    if len(candidates[:limit]) > 1 and screen:
        for linkage in candidates[:limit]:
            if spent.done + screen > work - reserve:
                break
            result = design(linkage, ("full",), screen, spent, SCREEN_EFFORT)
            if design_rank(result) == 0:
                return [(linkage, result)]
    for k, linkage in enumerate(candidates[:limit]):
        cap = first if k == 0 else per_candidate
        if k and spent.done + cap > work - reserve:
            break
        result = design(linkage, ("full",), cap, spent, 1.0)
        if design_rank(result) == 0:
            return [(linkage, result)]
    done = []
    for k, linkage in enumerate(candidates[:limit]):
        result = design(linkage, ("task",), None, spent, 1.0)
        done.append((design_rank(result), k, linkage, result))
        if done[-1][0] <= 1 or spent.done > work:
            break
    done.sort(key=lambda x: x[:2])
    return [(lk, r) for _, _, lk, r in done]
