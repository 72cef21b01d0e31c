"""Seeds of 6R fits (docs/sixbar_fit.md): cubic motions through quadruples of the task's poses.

For a deterministic sample of quadruples (pose 0 and three others, exact poses first) the two families of
cubics through them (`synth.synthesis.cubic`) are scanned (MEMBERS members each); every member is a
monic C with C(inf) = 1 relative to pose 0, so the tool pose at t is C(t) Q_0 and the quadruple's poses
are at t = inf, 0, 1, t3. The other poses are placed on each member at their best parameter
(`synth.synthesis.fit_seeds.project`), and the KEEP best-fitting members of each quadruple become seeds
in the layout of `synth.synthesis.fit` (coefficients c_0..c_2, reference pose Q_0, angles phi with
t = cot phi), their gauge the quadruple's poses at t = inf and 0 and 1 (phi = 0, pi/2, pi/4).
"""
from __future__ import annotations

import math
from itertools import combinations, islice

import numpy as np

from synth.errors import SynthesisError
from synth.synthesis.conic import relative_displacements_dq
from synth.synthesis.cubic import families, quadric
from synth.synthesis.fit import ERRORS, TaskArrays, item_errors, nth_combination, rank_seeds
from synth.synthesis.fit_seeds import EXACT_WEIGHT, GRID, nearest, project, to_gauge, zoom
from synth.synthesis.sixbar import grid_members

__all__ = ["quadruples", "seeds", "point_seeds", "QUADRUPLES", "MEMBERS", "KEEP"]

QUADRUPLES = 12  # quadruples (pose 0 and three others) sampled for seeds
MEMBERS = 12  # pencil members per family scanned per quadruple
KEEP = 2  # best-fitting members kept per quadruple (over both families)
LISTED_QUADRUPLES = 100_000  # up to this many (about 85 poses) all are listed and scored; beyond, by rank
POINT_SUBSETS = 24  # 7-subsets of a point task's positions sampled for seeds
POINT_SAMPLES = 24  # samples of the four free parameters per subset
POINT_PRESCORED = 24  # seeds of a point task refined (STAGE1), by their summed grid misses


def quadruples(exact, count: int = QUADRUPLES) -> list[tuple[int, int, int, int]]:
    """A deterministic sample of quadruples (0, i, j, k) of N poses (``exact`` (N,) bool): those with the
    most exact poses first (half the sample), then spread evenly over the lexicographic list of all."""
    total = math.comb(len(exact) - 1, 3)
    if total > LISTED_QUADRUPLES:  # never list them all (10,000 poses: 1.7e11): exact ones first, then by rank
        ex = [i for i in range(1, len(exact)) if exact[i]]
        first = list(islice(combinations(ex, 3), count // 2))
        spread = [tuple(1 + a for a in nth_combination(len(exact) - 1, 3, int(r)))
                  for r in np.linspace(0, total - 1, count).round()]
        return [(0,) + q for q in list(dict.fromkeys(first + spread))[:count]]
    allq = list(combinations(range(1, len(exact)), 3))
    if len(allq) <= count:
        return [(0,) + q for q in allq]
    score = np.array([exact[list(q)].sum() for q in allq])
    first = [allq[i] for i in np.argsort(-score, kind="stable")[: count // 2] if score[i] > 0]
    spread = [allq[i] for i in np.linspace(0, len(allq) - 1, count).round().astype(int)]
    return [(0,) + q for q in list(dict.fromkeys(first + spread))[:count]]


def _members(Q, quads):
    """Monic members (G, 4, 8) of both families through each quadruple (relative to pose 0, conditioned),
    the quadruple of each (G, 4) and its t3 (G,); degenerate or oval quadruples are skipped."""
    Cs, t3s, qs = [], [], []
    for quad in quads:
        try:
            fams, _ = families(quadric(relative_displacements_dq(Q[list(quad)])))
        except SynthesisError:
            continue
        if not fams:
            continue
        C, _, _, fl = grid_members(fams, MEMBERS)
        with np.errstate(all="ignore"):
            ok = np.isfinite(C).all((-2, -1)) & (np.abs(C).max((-2, -1)) < 1e6)
        Cs.append(C[ok])
        t3s.append(np.array([f.t3 for f in fl])[ok])
        qs += [quad] * int(ok.sum())
    if not qs:
        return np.empty((0, 4, 8)), np.empty((0, 4), int), np.empty(0)
    return np.concatenate(Cs), np.array(qs, int), np.concatenate(t3s)


def seeds(Q, task: TaskArrays):
    """Seeds (coef (S, 3, 8), reference (S, 8), phi (S, N), gauge (S, 3), quadruples used) of a task with
    conditioned target poses Q (N, 8) and rows ``task`` (`synth.synthesis.fit.task_arrays`)."""
    exact = task.exact[:, :ERRORS].all(1)
    C, qi, t3 = _members(Q, quadruples(exact))
    N = len(Q)
    if not len(C):
        return np.empty((0, 3, 8)), np.empty((0, 8)), np.empty((0, N)), np.empty((0, 3), int), 0
    coef, ref = C[:, :3], np.broadcast_to(Q[0], (len(C), 8))
    phi = project(coef, ref, task)
    phi[np.arange(len(C))[:, None], qi] = np.stack([np.zeros(len(C)), np.full(len(C), np.pi / 2),
                                                    np.full(len(C), np.pi / 4), np.mod(np.arctan2(1.0, t3), np.pi)], 1)
    with np.errstate(all="ignore"):
        e = item_errors(coef, ref, phi, task)
    w = task.weight + EXACT_WEIGHT * task.exact
    cost = np.nan_to_num(((e * w) ** 2).sum((-2, -1)), nan=np.inf)
    keep = []
    for quad in np.unique(qi, axis=0):
        rows = np.nonzero((qi == quad).all(1))[0]
        keep += rows[rank_seeds(cost[rows])[:KEEP]].tolist()
    keep = np.array(keep, int)
    return coef[keep], np.array(ref[keep]), phi[keep], qi[keep, :3], len(np.unique(qi, axis=0))


def point_seeds(X, task: TaskArrays):
    """Seeds of a point task (more than seven positions X (N, 3), conditioned), in the layout of `seeds`:
    the cubic motions through 7-subsets (`synth.synthesis.pointfit.subset_motions`: POINT_SUBSETS subsets,
    POINT_SAMPLES choices of the four free parameters each), the POINT_PRESCORED of least summed grid
    misses (`synth.synthesis.fit_seeds.nearest`) zoomed and moved onto the gauge (`to_gauge`)."""
    from synth.synthesis.pointfit import subset_motions

    coef, ref = subset_motions(X, 3, POINT_SUBSETS, POINT_SAMPLES)
    ok = np.isfinite(coef).all((1, 2))
    if not ok.any():
        raise SynthesisError("no seed motion: every 7-subset of the points is degenerate")
    coef, ref = coef[ok], ref[ok]
    phi, miss = nearest(coef, ref, task)
    best = rank_seeds(miss)[:POINT_PRESCORED]
    coef, ref = coef[best], ref[best]
    coef, ref, phi, gauge = to_gauge(coef, ref, zoom(coef, ref, task, phi[best], np.pi / GRID))
    return coef, ref, phi, gauge, int(ok.sum())
