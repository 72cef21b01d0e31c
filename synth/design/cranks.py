"""Cranked bars: where straight bars must cross, bow them past each other along the axes (docs/design.md,
"Cranked bars"). Lengths in metres."""
from __future__ import annotations

import time

import numpy as np

from synth.algebra.geometry import perpendicular_basis
from synth.design.coordinate import FULL, Scorer, crank_space, search_rounds
from synth.design.work import Work
from synth.design.search import (FULL_SAMPLES, SEARCH_MERGED, SPREADS, TASK_SAMPLES, DesignResult, Layout,
                                 certify_layout, cranked_result, search_target, settled_margin, sizes_of,
                                 task_phi_range)

CRANK_FRACTIONS = (0.25, 0.75)  # where along a bar its two via points sit (from its first mount)


def crank_direction(u, d) -> np.ndarray:
    """Unit crank direction of a bar along d (3,) mounted on an axis of direction u (3,): u without its
    component along the bar (for parallel axes: the axis, the bar is lifted out of its plane); any unit
    vector normal to d when u is along d."""
    d = d / max(np.linalg.norm(d), 1e-300)
    n = u - np.dot(u, d) * d
    if np.linalg.norm(n) < 1e-6:
        return perpendicular_basis(d)[0]
    return n / np.linalg.norm(n)


def crank_bars(linkage, result: DesignResult, *, seed: int = 0, effort: float = 1.0,
               work: Work | None = None) -> DesignResult:
    """Cranked bars for a design that straight bars could not make free (docs/design.md).

    The mounts and pins of ``result.design`` stay; every bar of a body in ``result.collision.pairs``
    becomes a polyline mount -> via -> via -> mount, the via points at `CRANK_FRACTIONS` of the straight
    bar moved by w along `crank_direction`, and the offsets w are searched (the same coordinate search,
    scorer and certificate as the mounts, over ``result.collision.range``). Returns the cranked design
    when it is certified free, else ``result`` unchanged. ``work``: the budget of gap evaluations
    (`synth.design.work.Work`; None: no limit)."""
    t0 = time.process_time()
    old = result.design
    if result.collision.free or not result.collision.pairs:
        return result
    sizes = sizes_of(old)
    sites = linkage.joint_sites()
    colliding = {b for p in result.collision.pairs for b in p["bodies"]}
    cranks = {}
    for bar in old.bars:
        if bar.link not in colliding or bar.via:
            continue
        a, b = bar.joints
        pa = sites[a] + old.mount(bar.link, a).offset * linkage.joint(a).direction
        pb = sites[b] + old.mount(bar.link, b).offset * linkage.joint(b).direction
        n = crank_direction(linkage.joint(a).direction, pb - pa)
        cranks[(bar.link, a, b)] = (pa + CRANK_FRACTIONS[0] * (pb - pa), pa + CRANK_FRACTIONS[1] * (pb - pa), n)
    if not cranks:
        return result
    search = Layout(linkage, merged=SEARCH_MERGED, cranks=cranks, **sizes)
    exact = Layout(linkage, merged=False, cranks=cranks, **sizes)
    S = np.array([old.mount(link, j).offset for link, j in exact.mounts])
    V, J = len(exact.vias), len(exact.joints)
    scale = linkage.extent()
    task = task_phi_range(linkage)
    rng_phi = FULL if result.collision.range == "full" else task
    target = search_target(old.clearance, old.bar_radius)
    effort = effort * min(1.0, (6 / J) ** 2)
    scorer = Scorer(search, FULL_SAMPLES * J, TASK_SAMPLES * J, task,
                     lambda W: search.end_offsets(np.broadcast_to(S, (len(W), len(S))), W), work,
                     settled_margin(target))
    rng = np.random.default_rng(seed)
    n_starts = max(2, int(4 * effort))
    # straight bars, then random cranks of up to a few bar thicknesses to half the extent
    X = np.concatenate([np.zeros((1, V)), rng.uniform(-1, 1, size=(n_starts - 1, V))
                        * rng.choice(SPREADS, size=(n_starts - 1, 1)) * 0.5 * scale])
    found, _ = search_rounds(scorer, crank_space(V, scale), X,
                       lambda: np.ones(len(scorer.phis), bool) if rng_phi == FULL else scorer.is_task,
                       target, scale, effort=effort,
                       certify_best=lambda w: certify_layout(exact, S, rng_phi, old.clearance, w))
    if found is None:
        result.collision.message += " (cranked bars of the colliding links were searched too)"
        return result
    W, cert = found
    out = cranked_result(linkage, exact, S, W, old, result.collision.range, cert, cranks)
    out.collision.seconds = result.collision.seconds + time.process_time() - t0
    return out
