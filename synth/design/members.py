"""A collision-free member of the 7R Darboux construction (docs/exceptional.md, section 6; docs/design.md).

The 7R loop of a general Darboux motion (`synth.synthesis.darboux`) is one member of a family: the three
parallel axes k1 k2 k3 may turn about the segment direction d (``turn``) and the 3R chain's h1, h2 may move
in their family (``shift`` s, h1 - eps s, h2 + eps s). The default member (turn 0, s = 0) is kept when its
design is collision-free over the full cycle; otherwise `choose_member` screens the members of `member_grid`
in order with a quick full-cycle design search each (`SCREEN_EFFORT`, at most `SCREEN_CAP` gap evaluations,
`synth.design.work`), within `SCREEN_WORK` in all or until `WANT` free ones are found, and picks among the free ones the one with the fewest
singular configurations (`synth.synthesis.darboux.singular_parameters`: fewer branch crossings for a built
linkage to be guided through), then the most compact design (RMS spread of its solids' end points); its screen design (certified like
any other) is the one written.
Lengths in metres, angles in radians.
"""
from __future__ import annotations

import math

import numpy as np

from synth.design.model import capsules
from synth.design.search import collision_rank
from synth.design.work import GAPS_PER_SECOND, Work
from synth.info import DarbouxMember, MemberChoice
from synth.synthesis.darboux import add_singular, darboux_member

TURNS = tuple(k * math.pi / 8 for k in (0, 1, 2, 3, 5, 6, 7))  # pi / 2: two degrees of freedom, refused
SHIFTS = ((0.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (1.0, 0.0), (0.0, -1.0))  # directions e1, e2 of the 3R family
SHIFT = 0.75  # length of a shift, times the default member's extent
FIRST_CAP = 1.5 * GAPS_PER_SECOND  # gap evaluations of the full-cycle search on the default member
SCREEN_EFFORT, SCREEN_CAP = 0.2, 0.25 * GAPS_PER_SECOND  # quick full-cycle searches of the other members
SCREEN_WORK = 5.0 * GAPS_PER_SECOND  # the budget of the screen
WANT = 2  # free members to compare before stopping the screen


def member_grid(extent: float) -> list[tuple[float, tuple[float, float]]]:
    """(turn, shift (f, g) metres) of the members screened, in order: the turns of `TURNS`, each with the
    shifts of `SHIFTS` times `SHIFT` * ``extent``; the default member (0, (0, 0)) first."""
    return [(t, (SHIFT * extent * f, SHIFT * extent * g)) for t in TURNS for f, g in SHIFTS]


def design_size(linkage, design) -> float:
    """RMS distance of the design's solids' end points (bars, hubs, pins) from their centroid, metres."""
    pts = np.array([p for c in capsules(linkage, design) for p in (c.p0, c.p1)])
    return float(np.sqrt(np.mean(np.sum((pts - pts.mean(axis=0)) ** 2, axis=1))))


def choose_member(linkage, design, *, work: float = SCREEN_WORK, want: int = WANT):
    """(linkage, DesignResult or None): ``linkage`` (a `darboux_linkage`) and its full-cycle design when
    that is collision-free; else the preferred collision-free member (module docstring) with its design,
    ``info.synthesis.darboux.member_choice`` saying why; else ``linkage`` and None (the caller designs it as
    usual: task range, thinner and cranked bars). ``design(linkage, ranges, full_work, effort, work) ->
    DesignResult`` (`synth.design.search.design_linkage`'s arguments; ``work``: the `Work` every search
    charges); ``work`` here: the screen's budget of gap evaluations."""
    first = design(linkage, ("full",), FIRST_CAP, 1.0, Work())
    if collision_rank(first.collision) == 0:
        return linkage, first
    spent = Work()
    free, tried = [], 0
    for turn, shift in member_grid(linkage.extent())[1:]:
        if len(free) >= want or spent.done > work:
            break
        lk = darboux_member(linkage, turn, shift, singular=False, check_samples=20)
        if lk is None:
            continue
        tried += 1
        result = design(lk, ("full",), SCREEN_CAP, SCREEN_EFFORT, spent)
        if collision_rank(result.collision) == 0:
            free.append((turn, shift, lk, result))
    if not free:
        _record_choice(linkage, MemberChoice(
            member=None, tried=tried,
            reason=f"no collision-free full-cycle design found for the default member nor {tried} others"))
        return linkage, None
    scored = []
    for turn, shift, lk, result in free:
        add_singular(lk)
        scored.append((len(lk.info.synthesis.darboux.singular_t), design_size(lk, result.design), turn, shift, lk,
                       result))
    scored.sort(key=lambda x: x[:2])
    n_sing, size, turn, shift, lk, result = scored[0]
    final = darboux_member(linkage, turn, shift)  # the same geometry, with the full self-check: same design
    _record_choice(final, MemberChoice(
        member=DarbouxMember(turn=turn, shift=tuple(shift)), tried=tried, free_found=len(free),
        singular_configurations=n_sing, design_size=size,
        reason=(f"the default member (turn 0, shift 0) has no collision-free design over the full cycle; "
                f"of the {tried} other members screened, {len(free)} had one; this one has the fewest "
                f"singular configurations ({n_sing}), then the most compact design")))
    return final, result


def _record_choice(linkage, choice: MemberChoice) -> None:
    """Store ``choice`` in the linkage's Darboux record."""
    darboux = linkage.info.synthesis.darboux.replace(member_choice=choice)
    linkage.info = linkage.info.with_synthesis(darboux=darboux)
