"""The choice of a linkage's physical design (docs/design.md): the sizes (defaults scaled to the linkage,
or given), then the collision-free search with straight bars, thinner bars and pins, a layering of the
parallel part, cranked bars, in this order, until a design is free.

``design_for(linkage, ...) -> DesignResult`` is what the commands and the batch jobs call; the exporters
(`synth.io.export`) write the finished `DesignResult`.

Default sizes scale with ``linkage.extent()`` (E, the RMS spread of the joints' feet and tool
positions): pin radius 0.02 E, bar radius 0.015 E (raised to keep every bar as written within the
slenderness, `synth.design.sturdy`, in counted sizing rounds after the search), hub length 0.06 E
(``--pin-length`` sets the hub length: a joint's pin spans the hubs of its two links, so it is at least
that long). The hole clearance
defaults to 0.2 mm (a common 3D-printing fit), but at most a tenth of the pin radius for tiny linkages.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

from synth.design.sizes import check_sizes
from synth.design.cranks import crank_bars
from synth.design.layers import LAYER_NODES, layered_design, parallel_axis
from synth.design.mixed import dominant_axis, mixed_design
from synth.design.model import PIN_FITS, DesignResult
from synth.design.coordinate import FULL
from synth.design.mounting import place_mounting
from synth.design.search import collision_rank, design_linkage, natural_result, task_phi_range
from synth.design.seats import seat_pins
from synth.design.sturdy import ROUND_MARGIN, SLENDERNESS, bar_radius_for, next_radius, written_slenderness
from synth.design.work import GAPS_PER_SECOND, Work
from synth.errors import InputError

PIN_RADIUS = 0.02  # times linkage.extent()
LINK_RADIUS = 0.015
HUB_LENGTH = 0.06
HOLE_CLEARANCE = 2e-4  # metres (0.2 mm) ...
HOLE_CLEARANCE_MAX_FRACTION = 0.1  # ... but at most this fraction of the pin radius


def _positive(name, v, allow_zero=False):
    try:
        ok = math.isfinite(float(v)) and (float(v) > 0 or (allow_zero and float(v) == 0))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} length in metres, got {v!r}")
    return float(v)


def default_sizes(linkage, pin_radius=None, link_radius=None, pin_length=None,
                  slenderness: float = SLENDERNESS) -> tuple[float, float, float]:
    """(pin_radius, bar radius, hub length) in metres: explicit values, or fractions of the extent (the
    bar radius raised so no bar is more slender than ``slenderness``, `synth.design.sturdy`).
    ``pin_length`` is the hub length (see the module docstring)."""
    e = linkage.extent()
    sizes = (
        PIN_RADIUS * e if pin_radius is None else pin_radius,
        bar_radius_for(linkage, LINK_RADIUS * e, slenderness) if link_radius is None else link_radius,
        HUB_LENGTH * e if pin_length is None else pin_length,
    )
    return tuple(_positive(name, v) for name, v in zip(("pin radius", "link radius", "pin length"), sizes))


def default_hole_clearance(pin_radius: float) -> float:
    """Radial clearance of a bore around its pin (metres): 0.2 mm, at most a tenth of the pin radius."""
    return min(HOLE_CLEARANCE, HOLE_CLEARANCE_MAX_FRACTION * pin_radius)


def design_for(linkage, pin_radius=None, link_radius=None, pin_length=None, hole_clearance=None,
               clearance=None, thin=True, work: Work | None = None, slenderness: float = SLENDERNESS,
               pin_fit: str = "press", mount_boxes: tuple = (None, None), **search) -> DesignResult:
    """The physical design of ``linkage`` (`synth.design.search.design_linkage`) with the given or default
    sizes (metres; see `default_sizes`, `default_hole_clearance`; clearance None: the search's default);
    ``search``: further arguments of `design_linkage` (ranges, full_work, effort, seed); ``work``: a
    `synth.design.work.Work` that every search below charges (its limit, if any, stops them all).
    Every budget is counted work, never time: the same input gives the same design on any machine.
    ``slenderness``: no default-sized or thinned bar is longer than this many diameters, as written (mount
    to mount through its cranks, `synth.design.sturdy`): when the search's bars are, the design is searched
    again with thicker ones (`_sturdy`); the result's ``slenderness`` states it (also for a given radius).
    ``pin_fit``: how the pins hold (`synth.design.model.PIN_FITS`; their heads and grooves lie inside the
    hubs, so the search is the same for all). ``mount_boxes``: the task's (base, envelope) boxes
    (`synth.task.Box` or None) for the mounting plate (`synth.design.mounting.place_mounting`), placed on
    the base once the design is chosen.

    Thinning (docs/design.md): when the search covered the task range and found no free design, and
    neither radius was given (``thin``), it is retried with the bar and pin radii of the default times
    `thin_scales` (hole clearance by its rule, default clearance with the bar) within `THIN_WORK` gap
    evaluations in all (none when the first search took over `THIN_FIRST_MAX`); the first free design is
    returned, its report's ``thinned`` saying so; else the default-size result.

    A partly planar linkage (`synth.design.mixed.dominant_axis`) gets, before all that, its parallel part
    layered and the rest searched around it (`synth.design.mixed.mixed_design`, within `LAYER_NODES` of
    the layering programme and `LAYER_WORK`); the rest follows only when that finds nothing (docs/design.md).

    Then, when that is still not free and the search covered the task range (docs/design.md): a planar
    linkage (every axis parallel) gets a layered design (`synth.design.layers.layered_design`, within
    `LAYER_NODES`), any other one cranked bars for the colliding bodies (`synth.design.cranks.crank_bars`,
    within `CRANK_WORK`); a certified free result replaces it (its report's ``cranked`` names the cranked
    bars, ``layers`` the levels of a layered design)."""
    check_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                     hole_clearance=hole_clearance, clearance=clearance), linkage.extent())
    if not (isinstance(slenderness, (int, float)) and math.isfinite(slenderness) and slenderness > 0):
        raise InputError(f"slenderness must be a positive ratio (bar length / diameter), got {slenderness!r}")
    if pin_fit not in PIN_FITS:
        raise InputError(f"pin fit must be one of {', '.join(PIN_FITS)}, got {pin_fit!r}")
    t0, work = time.process_time(), Work() if work is None else work
    start = work.done

    def again(pins, bar_radius, gap, start=None):  # the whole design with these sizes, the rest as given; the
        # search starts from the mounts of ``start`` (the last round's design) when given (`design_linkage`)
        if start is not None and not 1 / WARM_RATIO <= bar_radius / start.design.bar_radius <= WARM_RATIO:
            start = None  # a much thicker or thinner bar: the last design is no start, the search from scratch
        more = search if start is None else {**search, "start": start}
        if (start is not None and start.collision.free and start.collision.range == "task"
                and bar_radius >= start.design.bar_radius and "task" in search.get("ranges", ("full", "task"))):
            more = {**more, "ranges": ("task",)}  # thicker bars are not freer: the full cycle, which the last
            # round's thinner bars missed, is not searched again (issue 36)
        return _design_for(linkage, pins, bar_radius, pin_length, hole_clearance, gap, thin, work, slenderness, more)

    result = again(pin_radius, link_radius, clearance)
    searched = 0.0
    if link_radius is None:
        task = "task" in search.get("ranges", ("full", "task"))
        result, searched = _sturdy(linkage, result, again, pin_radius, clearance, slenderness, task)
    result.design.pin_fit = pin_fit
    result.design = seat_pins(linkage, result.design)  # blind bores where a bar covers the face (synth.design.seats)
    result.collision.work = work.done - start  # every stage's (full cycle, cranks, task range, thinning)
    result.collision.seconds = time.process_time() - t0  # information only
    result = place_mounting(linkage, result, base=mount_boxes[0], envelope=mount_boxes[1])
    result.slenderness = replace(written_slenderness(linkage, result.design, slenderness, link_radius is not None),
                                 searched=searched)
    return result


def _sturdy(linkage, first: DesignResult, again, pin_radius, clearance, slenderness: float,
            task: bool) -> tuple[DesignResult, float]:
    """`design_for`'s sizing rounds (docs/design.md, "Parts sized to be built"): while the bars as written
    (`synth.design.sturdy.written_slenderness`) are more slender than the limit, the whole design is searched
    again with the bar radius `next_radius` (the default clearance stays the first design's), at most
    `STURDY_ROUNDS` times, `MORE_ROUNDS` more while none met the limit; each round starts from the last
    round's design when the radius is within `WARM_RATIO` of its (``again``'s ``start``); a design much sturdier than asked (below `STURDY_SLACK` of the limit: its mounts
    moved closer) is searched once more with the radius its own bars ask, when that is thinner than its
    own and not below the first design's. Returned: the thinnest design that meets the limit and is as
    free as any that does (`collision_rank`), else the least slender of the most free; but when the
    search covered the task range (``task``: a final answer, not a quick full-cycle search that falls
    back to it) and no design that meets the limit is free over any range, the free one. ``again(pin
    radius, bar radius, clearance)``: the whole design with those sizes (`_design_for`); ``pin_radius``,
    ``clearance``: as given to `design_for` (None: default). Also returned: the thickest bar radius
    searched (0: no round)."""
    pins = first.design.pin_radius if first.collision.thinned and pin_radius is None else pin_radius
    if clearance is None:  # the default clearance stays the first design's: a printer's gap, not the bar's
        clearance = first.design.clearance
    done = [(first, written_slenderness(linkage, first.design, slenderness))]
    thinner = False
    for k in range(STURDY_ROUNDS + MORE_ROUNDS):
        if k >= STURDY_ROUNDS and any(s.met for _, s in done):
            break
        last = done[-1][1]
        if last.met and (thinner or last.ratio >= STURDY_SLACK * slenderness):
            break
        if last.met:
            radius, thinner = max(last.sturdier * (1 + ROUND_MARGIN), first.design.bar_radius), True
            if radius >= done[-1][0].design.bar_radius:  # already as thin as the sizes before the rounds
                break
        else:
            radius = next_radius([(r.design.bar_radius, s.length) for r, s in done], slenderness)
        r = again(pins, radius, clearance, done[-1][0])
        done.append((r, written_slenderness(linkage, r.design, slenderness)))
    best = min(done, key=lambda x: (not x[1].met, collision_rank(x[0].collision),
                                    x[0].design.bar_radius if x[1].met else x[1].ratio))[0]
    if task and not best.collision.free:
        best = min(done, key=lambda x: (collision_rank(x[0].collision), x[1].ratio))[0]
    return best, (max(r.design.bar_radius for r, _ in done) if len(done) > 1 else 0.0)


def _design_for(linkage, pin_radius, link_radius, pin_length, hole_clearance, clearance, thin, work, slenderness,
                search) -> DesignResult:
    """`design_for` after its checks."""
    work = Work() if work is None else work
    task = "task" in search.get("ranges", ("full", "task"))
    partly_planar = task and dominant_axis(linkage) is not None
    if partly_planar:  # straight bars in its planar part cross (as in a planar linkage): layers first
        natural = _design(linkage, pin_radius, link_radius, pin_length, hole_clearance, clearance, search,
                          natural=True, slenderness=slenderness)
        first = mixed_design(linkage, natural, nodes=LAYER_NODES, work=work.part(LAYER_WORK))
        if first.collision.free:
            return first
    sizes = (pin_radius, link_radius, pin_length)
    ranges = search.get("ranges", ("full", "task"))
    if "full" in ranges and not partly_planar and parallel_axis(linkage) is None and task_phi_range(linkage) != FULL:
        full = _full_cycle(linkage, sizes, hole_clearance, clearance, {**search, "slenderness": slenderness}, work)
        if full.collision.free or not task:
            return full
        search = {**search, "ranges": tuple(r for r in ranges if r != "full")}
    result = _straight(linkage, sizes, hole_clearance, clearance, thin, {**search, "slenderness": slenderness}, work)
    if result.collision.free or not task:
        return result
    if parallel_axis(linkage) is not None:
        return layered_design(linkage, result, nodes=LAYER_NODES)
    if partly_planar:
        result.collision.message += " (a layering of its parallel joints was searched too)"
    return crank_bars(linkage, result, work=work.part(CRANK_WORK))


def _full_cycle(linkage, sizes, hole_clearance, clearance, search, work) -> DesignResult:
    """The full-cycle part of `design_for` for a spatial linkage: straight bars (the default sizes), then,
    when they are not free, cranked bars of the colliding bodies over the full cycle (within
    `CRANK_FULL_WORK`, or `CRANK_SHARE` of the straight search's cap ``full_work``); the straight result when
    neither is free (docs/design.md, "Full cycle first")."""
    straight = _straight(linkage, sizes, hole_clearance, clearance, False, {**search, "ranges": ("full",)}, work)
    if straight.collision.free or straight.collision.range != "full":
        return straight
    cap = search.get("full_work")
    cranked = crank_bars(linkage, straight, work=work.part(CRANK_FULL_WORK if cap is None else CRANK_SHARE * cap))
    return cranked if cranked.collision.free else straight


def _straight(linkage, sizes, hole_clearance, clearance, thin, search, work) -> DesignResult:
    """`design_for` with straight bars: the default ``sizes`` (pin radius, link radius, pin length or
    None each), then thinner ones."""
    pin_radius, link_radius, pin_length = sizes
    slenderness = search.pop("slenderness", SLENDERNESS)
    hub = default_sizes(linkage, pin_radius, link_radius, pin_length)[2]
    result = _design(linkage, pin_radius, link_radius, hub, hole_clearance, clearance, {**search, "work": work},
                     slenderness=slenderness)
    if (not thin or result.collision.free or pin_radius is not None or link_radius is not None
            or "task" not in search.get("ranges", ("full", "task")) or result.collision.work > THIN_FIRST_MAX):
        return result
    pin0, bar0, _ = default_sizes(linkage, slenderness=slenderness)
    bar_min = bar_radius_for(linkage, 0.0, slenderness)  # thinner bars stay within the slenderness
    budget = work.part(THIN_WORK)
    tried = None
    for s in thin_scales(bar0):
        if budget.spent:
            break
        bar = max(s * bar0, bar_min)
        r = _design(linkage, s * pin0, bar, hub, hole_clearance, clearance, {**search, "work": budget})
        if r.collision.free:
            r.collision.thinned = {"scale": s, "pin_radius": s * pin0, "bar_radius": bar,
                                   "default_pin_radius": pin0, "default_bar_radius": bar0,
                                   "default_pairs": [p["bodies"] for p in result.collision.pairs]}
            return r
        tried = s
    if tried is not None:
        result.collision.message += f" (the search tried bars and pins down to {tried:g} x the default radii too)"
    return result


STURDY_ROUNDS = 3  # searches with a thicker bar when the written bars are more slender than the limit ...
MORE_ROUNDS = 2  # ... and at most this many more while none met it (issue 36: a round that starts from the last
# design is cheap, and the growing margin escapes a written length that grows faster than the radius)
WARM_RATIO = 2.0  # a sizing round starts from the last design when its bar radius is within this factor of it
STURDY_SLACK = 0.8  # a design below this fraction of the limit is searched again with thinner bars (once)

# budgets in gap evaluations (synth.design.work; they were CPU seconds: X s -> X * GAPS_PER_SECOND)
CRANK_WORK = 1.0 * GAPS_PER_SECOND  # the crank search after the straight bars failed
CRANK_FULL_WORK = 1.0 * GAPS_PER_SECOND  # the crank search over the full cycle, before the task range ...
CRANK_SHARE = 0.5  # ... or this fraction of the full-cycle cap of a quick search (a choice among candidates)
LAYER_WORK = 60.0 * GAPS_PER_SECOND  # the search around the layered part of a partly planar linkage
THIN_SCALES = (0.5, 0.25)  # bar and pin radii tried, times the defaults, when the defaults collide
THIN_MIN_BAR_RADIUS = 4e-4  # metres: a bar 0.8 mm thick, two extrusion widths of a 0.4 mm nozzle
THIN_WORK = 1.0 * GAPS_PER_SECOND  # all the retries together (each search stops when it is spent)
THIN_FIRST_MAX = 2.0 * GAPS_PER_SECOND  # no retry after a first search this costly: a retry's fixed costs
# (screening the starts, the certificate) scale like the first search's, so it would overrun its budget


def thin_scales(bar_radius: float) -> list[float]:
    """The scales of the default sizes retried when they collide: `THIN_SCALES`, each raised so the bar
    radius stays at least `THIN_MIN_BAR_RADIUS` (never above the default), without repeats (docs/design.md)."""
    out = []
    for s in THIN_SCALES:
        s = max(s, min(1.0, THIN_MIN_BAR_RADIUS / bar_radius))
        if s < 1.0 and (not out or s < out[-1]):
            out.append(s)
    return out


def _design(linkage, pin_radius, link_radius, hub_length, hole_clearance, clearance, search,
            natural=False, slenderness: float = SLENDERNESS) -> DesignResult:
    """`design_linkage` with the sizes resolved (defaults, validation); ``natural``: not searched, the
    natural stack with those sizes (`natural_result`)."""
    pin_radius, link_radius, hub_length = default_sizes(linkage, pin_radius, link_radius, hub_length, slenderness)
    hole = default_hole_clearance(pin_radius) if hole_clearance is None else _positive(
        "hole clearance", hole_clearance, allow_zero=True)
    if clearance is not None:
        clearance = _positive("clearance", clearance, allow_zero=True)
    if natural:
        return natural_result(linkage, pin_radius=pin_radius, bar_radius=link_radius, hub_length=hub_length,
                              hole_clearance=hole, clearance=clearance)
    return design_linkage(linkage, pin_radius=pin_radius, bar_radius=link_radius, hub_length=hub_length,
                          hole_clearance=hole, clearance=clearance, **search)
