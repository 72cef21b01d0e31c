"""Layered designs of partly planar linkages: most joint axes parallel, a few not (docs/design.md, "Layers
of a partly planar linkage"). The parallel joints and the bars between two of them are layered as in
`synth.design.layers`; then one shift of the whole layered stack along its axis and the stacks of the
other joints are found by the coordinate search of `synth.design.coordinate`, the layering fixed, and the
result is certified. Lengths in metres.
"""
from __future__ import annotations

import time

import numpy as np

from synth.design.collision import shared_joints, subset
from synth.design.coordinate import FULL, Scorer, Space, score, search_rounds, violation
from synth.design.layers import LAYER_NODES, MARGIN, height_offsets, layer_plan, level_pitch, stack_geometry, touch_note
from synth.design.model import joint_links
from synth.design.work import Work
from synth.design.search import (FULL_SAMPLES, SEARCH_MERGED, SPREADS, TASK_SAMPLES, DesignResult, Layout,
                                 certify_layout, cranked_result, search_target, settled_margin, sizes_of,
                                 task_phi_range)

MIN_PARALLEL = 4  # joints sharing a direction before their part of the linkage is layered


def dominant_axis(linkage, tol: float = 1e-9):
    """(u, joints) of the direction shared by the most joints that hold links, when at least `MIN_PARALLEL`
    share it and not all do (those are planar: `synth.design.layers`); else None."""
    jl = joint_links(linkage)
    js = [j for j in linkage.joints if jl[j.name]]
    best = None
    for j in js:
        u = j.direction / np.linalg.norm(j.direction)
        group = {k.name for k in js if np.linalg.norm(np.cross(k.direction / np.linalg.norm(k.direction), u)) <= tol}
        if best is None or len(group) > len(best[1]):
            best = (u, group)
    if best is None or len(best[1]) < MIN_PARALLEL or len(best[1]) == len(js):
        return None
    return best


class _Stack:
    """The parametrization X = [delta | c | sigma | g | e] (N, 1 + 3 Js + R): the layered mounts and crank
    points at their heights shifted by delta along u; the stacks of the ``Js`` other joints as in
    `search.Layout`; how far (e >= 0) each of the R risers out of the stack reaches beyond it."""

    def __init__(self, layout: Layout, u, heights: dict, crank_heights: list, outward: list, spatial: list):
        self.layout, self.spatial = layout, spatial
        self.col = [layout.joints.index(j) for j in spatial]
        self.S0, self.dS = height_offsets(layout, heights, u)
        self.W0 = np.asarray(crank_heights, float)
        self.riser = np.flatnonzero(outward)
        self.out = np.asarray(outward, float)[self.riser]

    def offsets(self, X):
        n, Js, J = len(X), len(self.spatial), len(self.layout.joints)
        c, sigma, g = np.zeros((n, J)), np.ones((n, J)), np.zeros((n, J))
        e = 1 + 3 * Js
        c[:, self.col], sigma[:, self.col], g[:, self.col] = X[:, 1:1 + Js], X[:, 1 + Js:1 + 2 * Js], X[:, 1 + 2 * Js:e]
        S = self.S0 + X[:, :1] * self.dS + self.layout.mount_offsets(c, sigma, g)
        W = self.W0 + X[:, :1]
        W[:, self.riser] += X[:, e:] * self.out
        return S, W


def _moving_pairs(layout: Layout, spatial: list, risers) -> None:
    """Keep in ``layout`` (the search's) only the capsule pairs with an end that the search moves other than
    by the common shift: a mount or pin end on a joint of ``spatial``, or a riser's via point (column
    ``risers`` of W). The gaps between two layered parts do not depend on the search (the certificate
    checks them all)."""
    moving = []
    for kind, index, _ in layout.ends:
        if kind == 0:
            moving.append(layout.mounts[index][1] in spatial)
        elif kind in (1, 2):
            moving.append(layout.joints[index] in spatial)
        else:
            moving.append(index in set(int(r) for r in risers))
    moving = np.array(moving, bool)
    cs = layout.cs
    rows = moving[cs.pairs].any(axis=1)
    layout.cs = subset(cs, rows)


def _space(Js, R, gmin, scale) -> Space:
    col, add, mul = [0, 0], [1, -1], [1, 1]
    for j in range(Js):
        for c, a, m in ((1 + j, 1, 1), (1 + j, -1, 1), (1 + 2 * Js + j, 1, 1), (1 + 2 * Js + j, -1, 1),
                        (1 + Js + j, 0, -1)):
            col.append(c), add.append(a), mul.append(m)
    e = 1 + 3 * Js
    for r in range(R):
        col += [e + r, e + r]
        add += [1, -1]
        mul += [1, 1]
    lo = np.concatenate([np.full(1 + 2 * Js, -np.inf), np.full(Js, gmin), np.zeros(R)])

    def size(X):
        return (np.abs(X[:, 0]) + np.abs(X[:, 1:1 + Js]).mean(axis=1) + (X[:, 1 + 2 * Js:e] - gmin).mean(axis=1)
                + X[:, e:].sum(axis=1)) / scale

    return Space(np.array(col), np.array(add, float), np.array(mul, float), lo, size)


def mixed_design(linkage, result: DesignResult, *, nodes: int = LAYER_NODES, work: Work | None = None,
                 seed: int = 0, effort: float = 1.0) -> DesignResult:
    """A certified design of a partly planar linkage (`dominant_axis`): the parallel part layered, the
    rest searched around it; ``result`` unchanged when it is free, the linkage is not partly planar, no
    layering or no certified design is found. ``nodes``: the layering programme's budget of
    branch-and-bound nodes; ``work``: the search's budget of gap evaluations (`synth.design.work.Work`;
    None: no limit). Keeps the sizes of ``result.design``."""
    t0 = time.process_time()
    found = None if result.collision.free else dominant_axis(linkage)
    if found is None:
        return result
    u, keep = found
    old = result.design
    rng_phi = FULL if result.collision.range == "full" else task_phi_range(linkage)
    reach = MARGIN * (old.hub_radius + old.bar_radius + old.clearance)
    risers = [(link, a, b) for link, names in linkage.links.items() for a, b in zip(names, names[1:])
              if (a in keep) != (b in keep)]  # bars from the stack to another joint
    exits = sorted({a if a in keep else b for _, a, b in risers})
    for untested in (stack_pairs(linkage, keep), None):  # links sharing a spatial joint tested, else none
        for attempt in ((exits, ()) if exits else ((),)):  # risers out of the stack, else straight bars
            found = _attempt(linkage, result, u, keep, attempt, rng_phi, reach, (nodes, work), seed, effort, untested)
            if found is not None:
                found.collision.seconds = result.collision.seconds + time.process_time() - t0
                return found
    result.collision.message += " (a layering of its parallel joints was searched too)"
    return result


def stack_pairs(linkage, keep) -> frozenset:
    """The pairs of links (frozensets) that share joints of the parallel stack ``keep`` only: the layering
    programme of a partly planar linkage does not keep their bars apart (`layer_plan`'s ``shared``; with
    them tested, and even with only those whose risers leave the stack at the shared joint, motion_darboux
    found no design)."""
    keep = set(keep)
    return frozenset(pair for pair, js in shared_joints(linkage).items() if js <= keep)


def _attempt(linkage, result, u, keep, exits, rng_phi, reach, budget, seed, effort, untested):
    """`mixed_design` with risers at ``exits`` (none: straight bars from the stack); None when no
    layering or no certified design is found. ``budget``: (nodes, work) as `mixed_design`'s; ``untested``:
    the pairs of links that share a joint left untested (`stack_pairs`; None: every such pair)."""
    old = result.design
    nodes, work = budget
    plan = layer_plan(linkage, u, rng_phi, reach, nodes, keep=keep, exits=exits, shared=False)  # as before
    if plan is None:  # issue 33's rows for links that share a joint lost motion_darboux's design (docs/design.md)
        return None
    levels = plan.levels
    heights, cranks, crank_heights, outward = stack_geometry(linkage, levels, u, level_pitch(old), keep=keep)
    sizes = sizes_of(old)
    pairs = dict(adjacent=untested is not None, untested=untested or frozenset())
    search = Layout(linkage, merged=SEARCH_MERGED, cranks=cranks, **sizes, **pairs)
    exact = Layout(linkage, merged=False, cranks=cranks, **sizes, **pairs)
    spatial = [j for j in exact.joints if j not in keep]
    stack = _Stack(search, u, heights, crank_heights, outward, spatial)
    stack_exact = _Stack(exact, u, heights, crank_heights, outward, spatial)
    Js, J, R = len(spatial), len(exact.joints), len(stack.riser)
    _moving_pairs(search, spatial, stack.riser)
    scale = linkage.extent()
    task = task_phi_range(linkage)
    gmin = search.gap_min
    target = search_target(old.clearance, old.bar_radius)
    effort = effort * min(1.0, (6 / max(Js, 1)) ** 2)

    def to_offsets(X):
        S, W = stack.offsets(X)
        return search.end_offsets(S, W)

    scorer = Scorer(search, FULL_SAMPLES * J, TASK_SAMPLES * J, task, to_offsets, work, settled_margin(target))
    space = _space(Js, R, gmin, scale)
    rng = np.random.default_rng(seed)
    n = int(effort * 16 * Js) + 8
    spread = rng.choice(SPREADS, size=(n, 1)) * scale
    X0 = np.concatenate([rng.uniform(-1, 1, size=(n, 1 + Js)) * spread, rng.choice([-1.0, 1.0], size=(n, Js)),
                         gmin * (1 + rng.exponential(0.5, size=(n, Js)) * (rng.random((n, Js)) < 0.3)),
                         rng.exponential(0.1, size=(n, R)) * spread], axis=1)
    e = 1 + 3 * Js
    X0[0, :1 + Js], X0[0, 1 + Js:1 + 2 * Js], X0[0, 1 + 2 * Js:e], X0[0, e:] = 0.0, 1.0, gmin, 0.0  # natural
    mask = np.ones(len(scorer.phis), bool) if rng_phi == FULL else scorer.is_task
    coarse = np.flatnonzero(mask)[::3]
    P = len(search.cs.pairs)
    pidx, kidx = np.repeat(np.arange(P), len(coarse)), np.tile(coarse, P)
    d0 = scorer.at(X0, pidx, kidx).reshape(n, P, -1)
    starts = np.argsort(-score(violation(d0, target), space.size(X0)), kind="stable")[:max(2, int(4 * effort))]

    def certify_best(x):
        S, W = stack_exact.offsets(x[None])
        return certify_layout(exact, S[0], rng_phi, old.clearance, W[0])

    found, _ = search_rounds(scorer, space, X0[starts].copy(),  # the mask grows with samples a certificate adds
                             lambda: np.ones(len(scorer.phis), bool) if rng_phi == FULL else scorer.is_task,
                             target, scale, effort=effort, certify_best=certify_best)
    if found is None:
        return None
    x, cert = found
    S, W = stack_exact.offsets(x[None])
    out = cranked_result(linkage, exact, S[0], W[0], old, result.collision.range, cert, cranks)
    out.collision.message = (touch_note(plan, adjacent=False) if untested is None else  # (the claim says what is left out)
                             "links that share a joint of the parallel stack are not certified apart in this layering")
    out.collision.layers = len({lv for k, v in levels.items() if k[-1] != "exit" for lv in v})
    return out
