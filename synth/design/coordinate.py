"""The coordinate search shared by the mount search and the crank search (docs/design.md, "What is
searched"): candidates are rows of a parameter matrix X (N, D), scored by their sampled capsule gaps over
the full cycle and the task range at once, improved by coordinate moves screened on the critical
entries, and certified round by round. Lengths in metres, angles (phi) in radians.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.design.collision import item_distances, pair_distances, pair_distances_at, subset, world_ends
from synth.design.sampling import body_motion, even_samples
from synth.design.work import Work

FULL = (-math.pi / 2, math.pi / 2)  # phi of the whole cycle
SEARCH_DTYPE = np.float32  # the search's sampled gaps (the certificate: float64)
BEHIND = 1.25  # once a start is feasible, the others are moved only while at most this many times its size
ROUNDS = 4  # search rounds, each adding the samples where the last certificate failed
MARGIN = 1e-3  # a gap whose bound clears the target by this fraction is not evaluated (`improve`; float32 rounding)


class Scorer:
    """Sampled capsule gaps of batches of candidates X (N, D) over the full cycle and the task range at
    once (task samples are flagged in ``is_task``); ``to_offsets(X)`` gives their end offsets (N, E).
    A pair whose gap does not change with the motion (``once``: `CapsuleSet.axial`, two links' parts about
    their shared axis) is evaluated at one sample (``once_k``; inf at the others): a violation weighs as
    much as one sampled contact, not as many as there are samples; its gap is certified as sampled, so it
    gets no safety margin: ``settled`` (metres) is added to it.
    Every gap evaluated is charged to ``work`` (`synth.design.work.Work`), which the searches check."""

    def __init__(self, layout: Layout, full_samples: int, task_samples: int, task: tuple[float, float], to_offsets,
                 work: Work | None = None, settled: float = 0.0):
        lk = layout.linkage
        pf = even_samples(lk, *FULL, full_samples)
        pt = even_samples(lk, *task, task_samples)
        self.phis = np.concatenate([pf, pt])
        self.is_task = np.concatenate([_inside(pf, task), np.ones(len(pt), bool)])
        self.layout = layout
        self.task = task
        self.to_offsets = to_offsets
        Q, U = world_ends(layout.cs, body_motion(lk, self.phis, keep=True))
        self.Q, self.U = Q.astype(SEARCH_DTYPE), U.astype(SEARCH_DTYPE)
        axial = layout.cs.axial
        self.once = np.zeros(len(layout.cs.pairs), bool) if axial is None else axial[:, 0] > 0
        self.once_k = len(pf)  # a sample of both ranges: where the pairs that do not move (`once`) count
        self.settled = settled
        self._moving = subset(layout.cs, ~self.once), subset(layout.cs, self.once)
        self._position = np.zeros(len(self.once), int)  # each pair's row in its part of ``_moving``
        self._position[~self.once] = np.arange(int((~self.once).sum()))
        self._position[self.once] = np.arange(int(self.once.sum()))
        self._split()
        self.evaluations = 0
        self.work = Work() if work is None else work

    def add_samples(self, phis) -> None:
        """Sample the motion at ``phis`` too (where a certificate found a gap the samples missed)."""
        lk = self.layout.linkage
        phis = np.asarray(phis, float)
        Q, U = world_ends(self.layout.cs, body_motion(lk, phis))
        self.phis = np.concatenate([self.phis, phis])
        self.is_task = np.concatenate([self.is_task, _inside(phis, self.task)])
        self.Q = np.concatenate([self.Q, Q.astype(SEARCH_DTYPE)], axis=3)
        self.U = np.concatenate([self.U, U.astype(SEARCH_DTYPE)], axis=3)
        self._split()

    def keep_first(self, k: int) -> None:
        """Forget the samples after the first ``k`` (those `add_samples` added): the scorer as it was made."""
        self.phis, self.is_task = self.phis[:k], self.is_task[:k]
        self.Q, self.U = np.ascontiguousarray(self.Q[..., :k]), np.ascontiguousarray(self.U[..., :k])
        self._split()

    def _split(self) -> None:
        """The end points of the moving pairs at every sample and of the `once` pairs at ``once_k``."""
        m, k = ~self.once, self.once_k
        self._ends = (self.Q[:, :, m], self.U[:, :, m], self.Q[:, :, ~m, k:k + 1], self.U[:, :, ~m, k:k + 1])

    def offsets(self, X):
        return self.to_offsets(X).astype(SEARCH_DTYPE)

    def full(self, X) -> np.ndarray:
        """(N, P, K) gaps at every sample (the `once` pairs': inf but at ``once_k``)."""
        self.evaluations += len(X)
        o, (P, K), m = self.offsets(X), self.Q.shape[2:], ~self.once
        if not self.once.any():
            self.work.charge(len(X) * P * K)  # N x P x K
            return pair_distances(self.layout.cs, self.Q, self.U, o)
        self.work.charge(len(X) * (int(m.sum()) * K + int(self.once.sum())))
        moving, once = self._moving
        Qm, Um, Qo, Uo = self._ends
        d = np.full((len(X), P, K), np.inf)
        d[:, m] = pair_distances(moving, Qm, Um, o)
        d[:, self.once, self.once_k] = pair_distances(once, Qo, Uo, o)[:, :, 0] + self.settled
        return d

    def grid(self, X, samples) -> np.ndarray:
        """(N, P, k) gaps of every pair at the samples ``samples`` (k increasing indices, ``once_k`` among
        them; a `once` pair's: inf but there): `at` at every such entry, in its order, with the same numbers
        and count, evaluated as in `full` (whole blocks of samples, no gather per entry: half the time)."""
        o, m, samples = self.offsets(X), ~self.once, np.asarray(samples)
        self.work.charge(len(X) * (int(m.sum()) * len(samples) + int(self.once.sum())))
        (moving, once), (Qm, Um, Qo, Uo) = self._moving, self._ends
        d = np.full((len(X), len(self.once), len(samples)), np.inf)
        d[:, m] = pair_distances(moving, Qm[..., samples], Um[..., samples], o)
        if self.once.any():
            d[:, self.once, int(np.flatnonzero(samples == self.once_k)[0])] = (
                pair_distances(once, Qo, Uo, o)[:, :, 0] + self.settled)
        return d

    @property
    def full_count(self) -> int:
        """Gap evaluations of one candidate in `full`: every pair at every sample, a `once` pair once."""
        return int((~self.once).sum()) * self.Q.shape[3] + int(self.once.sum())

    def at_count(self, pidx, kidx) -> int:
        """Gap evaluations of one candidate at the entries ``pidx``, ``kidx`` (`at`): a `once` pair's at
        ``once_k`` only."""
        once = self.once[pidx]
        return int((~once).sum() + (once & (np.asarray(kidx) == self.once_k)).sum())

    def items(self, O, cand, pidx, kidx) -> np.ndarray:
        """(L,) gaps of L items: candidate ``cand[i]`` (end offsets: a row of O (n, E)) at the entry
        ``pidx[i]``, ``kidx[i]`` (a `once` pair's at ``once_k``), the numbers of `full` and `at`; not charged."""
        d = item_distances(self.layout.cs, self.Q, self.U, O.astype(SEARCH_DTYPE), cand, pidx, kidx)
        return d + np.where(self.once[pidx], self.settled, 0.0)

    def at(self, X, pidx, kidx) -> np.ndarray:
        """(N, L) gaps at chosen (pair, sample) entries (a `once` pair's: inf but at ``once_k``)."""
        pidx, kidx = np.asarray(pidx), np.asarray(kidx)
        if not self.once.any():
            self.work.charge(len(X) * len(pidx))
            return pair_distances_at(self.layout.cs, self.Q, self.U, self.offsets(X), pidx, kidx)
        o, once = self.offsets(X), self.once[pidx]
        moving, at_k = ~once, once & (kidx == self.once_k)
        self.work.charge(len(X) * int(moving.sum() + at_k.sum()))
        (mcs, ocs), (Qm, Um, Qo, Uo), pos = self._moving, self._ends, self._position
        d = np.full((len(X), len(pidx)), np.inf)
        if moving.any():
            d[:, moving] = pair_distances_at(mcs, Qm, Um, o, pos[pidx[moving]], kidx[moving])
        if at_k.any():
            d[:, at_k] = pair_distances_at(ocs, Qo, Uo, o, pos[pidx[at_k]], np.zeros(int(at_k.sum()), int)) + self.settled
        return d


@dataclass
class Space:
    """A searched parameter space: coordinate moves ``X[:, col] <- max(lo[col], X[:, col] * mul + add * step)``
    (arrays, one entry per move) and the compactness ``size(X) -> (N,)`` (smaller is better)."""

    col: np.ndarray
    add: np.ndarray
    mul: np.ndarray
    lo: np.ndarray
    size: object


def mount_space(J, gmin, scale) -> Space:
    """X = [c | sigma | g] (N, 3J): per joint shift the centre both ways, widen / narrow the stack, flip it."""
    col, add, mul = [], [], []
    for j in range(J):
        for c, a, m in ((j, 1, 1), (j, -1, 1), (2 * J + j, 1, 1), (2 * J + j, -1, 1), (J + j, 0, -1)):
            col.append(c), add.append(a), mul.append(m)
    lo = np.concatenate([np.full(2 * J, -np.inf), np.full(J, gmin)])
    return Space(np.array(col), np.array(add, float), np.array(mul, float), lo,
                  lambda X: _size(X[:, :J], X[:, 2 * J:], gmin, scale))


def crank_space(V, scale) -> Space:
    """X = W (N, V) crank offsets: each moved both ways; compact = small mean |w|."""
    return Space(np.repeat(np.arange(V), 2), np.tile([1.0, -1.0], V), np.ones(2 * V), np.full(V, -np.inf),
                  lambda X: np.abs(X).mean(axis=1) / scale)


def _inside(phis, rng) -> np.ndarray:
    lo, hi = rng
    return (phis - lo) % math.pi <= (hi - lo) + 1e-12


def _size(c, g, gmin, scale):
    return (np.abs(c).mean(axis=1) + (g - gmin).mean(axis=1)) / scale


def violation(d, target, mask=None) -> np.ndarray:
    """(N,) sum over the (masked) entries of d (N, ..., K) of (target - d)^2 where d < target, over
    target^2: zero exactly for the designs whose sampled gaps all reach the target."""
    v = np.maximum(target - d, 0.0) / target
    v = v * v
    if mask is not None:
        v = v * mask
    return v.reshape(len(d), -1).sum(axis=1)


def score(violation, size):
    """Feasible (no violation) first, then compact (small ``size``); else the smaller violation (a
    sum over every sample and pair: a move that relieves one contact counts even when another is
    deeper)."""
    return np.where(violation <= 0, 1e6 - size, -violation)


class _Critical:
    """The (pair, sample) entries where candidates came closest: a candidate's violation there bounds its
    violation from below, so moves are screened there before a full evaluation. Keeps the ``cap`` most
    recently seen entries (each entry's last sighting as a count: one array, no set operations)."""

    def __init__(self, mask, cap):
        self.mask, self.cap = mask, cap
        self.stamp = None  # (P K,) per entry p * K + k the count of its last sighting (0: never)
        self.clock, self.K, self.codes = 0, None, np.zeros(0, int)

    def add(self, d):  # d (N, P, K)
        dm = np.where(self.mask[None, None, :], d, np.inf)
        k = dm.argmin(axis=2)  # (N, P): each pair's closest sample
        flat = dm.reshape(len(d), -1)
        top = np.argpartition(flat, min(16, flat.shape[1] - 1), axis=1)[:, :16]
        if self.stamp is None:
            self.K, self.stamp = d.shape[2], np.zeros(flat.shape[1], np.int64)
        seen = np.concatenate([(np.arange(d.shape[1]) * self.K + k).ravel(), top.ravel()])
        # seen again: moved to the most recent end, in the order of their last sighting
        np.maximum.at(self.stamp, seen, np.arange(self.clock + 1, self.clock + 1 + len(seen)))
        self.clock += len(seen)
        codes = np.flatnonzero(self.stamp)
        if len(codes) > self.cap:
            codes = codes[np.argpartition(-self.stamp[codes], self.cap - 1)[:self.cap]]
        self.codes = codes[np.argsort(self.stamp[codes])]

    def arrays(self):
        return self.codes // self.K, self.codes % self.K


def _behind(best) -> np.ndarray:
    """(n,) the feasible starts no longer moved: those more than `BEHIND` times as large as the smallest
    feasible one (`score`: 1e6 - size when feasible)."""
    return (best > 0) & (1e6 - best > BEHIND * (1e6 - best.max()) + 1e-9)


def improve(scorer: Scorer, space: Space, mask, target, X, *, step0, step_min, iterations, tries=2):
    """Coordinate moves of ``space`` from each start (rows of X). Moves are screened on the critical
    entries; the best per start is evaluated fully and taken when it improves; after ``tries`` failures
    (or when no move passes the screen) the step halves. Once a start is feasible, only it and the
    feasible starts nearly as compact move on (`_behind`). Stops early once ``scorer.work`` is spent."""
    n, D = X.shape
    nm = len(space.col)
    crit = _Critical(mask, cap=4 * scorer.Q.shape[2] + 64)
    gaps, offs = scorer.full(X), scorer.to_offsets(X)  # each start's gaps (n, P, K) and end offsets (n, E) ...
    stale = np.zeros(gaps.shape[:2])  # ... and per pair how far its true gaps may be below them (`_bounded`)
    crit.add(gaps)
    best = score(violation(gaps, target, mask), space.size(X))
    pairs, level = scorer.layout.cs.pairs, target * (1 + MARGIN)
    step = np.full(n, step0)
    stall = np.zeros(n, int)
    rows_m = np.arange(nm)
    for _ in range(iterations):
        live = np.flatnonzero((step >= step_min) & ~_behind(best))
        if not len(live) or scorer.work.spent:
            break
        m = len(live)
        C = np.repeat(X[live][None], nm, axis=0)  # (moves, m, D)
        moved = X[live][:, space.col].T * space.mul[:, None] + space.add[:, None] * step[live][None]
        C[rows_m, :, space.col] = np.maximum(space.lo[space.col][:, None], moved)
        C = C.reshape(nm * m, D)
        O = scorer.to_offsets(C)
        shift = np.abs(O - np.tile(offs[live], (nm, 1)))  # how far each end point moved (metres)
        moved = shift[:, pairs[:, :2]].max(axis=2) + shift[:, pairs[:, 2:]].max(axis=2)  # (nm m, P): a gap's change
        pidx, kidx = crit.arrays()
        scorer.work.charge(len(C) * scorer.at_count(pidx, kidx))
        screened, fresh_at = _bounded(scorer, O, moved[:, pidx], np.tile(gaps[live][:, pidx, kidx], (nm, 1)),
                                      np.tile(stale[live][:, pidx], (nm, 1)), pidx, kidx, level)
        ub = score(violation(screened, target), space.size(C)).reshape(nm, m)
        kbest = np.argmax(ub, axis=0)  # (m,)
        hopeful = ub[kbest, np.arange(m)] > best[live] + 1e-12
        rows = np.flatnonzero(hopeful)
        pick = kbest[rows] * m + rows
        accepted = np.zeros(m, bool)
        if len(pick):
            scorer.evaluations += len(pick)
            scorer.work.charge(len(pick) * scorer.full_count)
            at_k = scorer.once[pidx] & (kidx == scorer.once_k)  # the screen's `once` gaps: the same numbers
            known = np.full((len(pick), len(pairs)), np.nan)
            known[:, pidx[at_k]] = np.where(fresh_at[pick][:, at_k], screened[pick][:, at_k], np.nan)
            d, fresh = _full_bounded(scorer, O[pick], moved[pick], gaps[live[rows]], stale[live[rows]], level, known)
            crit.add(d)
            sc = score(violation(d, target, mask), space.size(C[pick]))
            for j, (r, w, v) in enumerate(zip(rows, pick, sc)):
                i = live[r]
                if v > best[i] + 1e-12:
                    X[i], best[i] = C[w], v
                    gaps[i], stale[i], offs[i] = d[j], fresh[j], O[w]
                    accepted[r] = True
        # a hopeful move that failed its full evaluation taught the screen something: retry once
        s = stall[live] + np.where(hopeful, 1, tries)
        s[accepted] = 0
        halve = s >= tries
        step[live] = np.where(halve, step[live] / 2, step[live])
        stall[live] = np.where(halve, 0, s)
    return X, best


def _bounded(scorer: Scorer, O, moved, gaps, stale, pidx, kidx, level):
    """(n, L) gaps of n candidates (end offsets O (n, E)) at the entries ``pidx``, ``kidx``, each candidate
    a start moved: ``gaps`` (n, L) the start's gaps there, true to within ``stale`` (n, L) from above, and
    ``moved`` (n, L) how much the move can change them (the largest shift of an end of each capsule,
    summed: a gap is 1-Lipschitz in each capsule's position). An entry is evaluated (`Scorer.items`) only
    when the move or staleness may bring it below ``level``: else it keeps the start's number, which is
    exact when nothing moved and at least the target (no violation, like the true gap) otherwise. Also
    returned: (n, L) bool, the entries evaluated."""
    need = ((moved > 0) | (stale > 0)) & (gaps - stale - moved < level)
    out = np.array(gaps, float)
    c, e = np.nonzero(need)
    if len(c):
        out[c, e] = scorer.items(O, c, pidx[e], kidx[e])
    return out, need


def _full_bounded(scorer: Scorer, O, moved, gaps, stale, level, known=None):
    """(n, P, K) gaps of n moved starts at every sample (`Scorer.full`, `_bounded`'s rule by pair: a pair
    is evaluated at every sample when its start's smallest gap may come below ``level``), and (n, P) how
    far each pair's true gaps may be below the returned ones (0 where evaluated). ``O`` (n, E), ``moved``
    (n, P), ``gaps`` (n, P, K), ``stale`` (n, P): as `_bounded`; ``known`` (n, P): the gaps of the `once`
    pairs the screen evaluated (nan: not), the same numbers, taken as they are."""
    n, P, K = gaps.shape
    redo = ((moved > 0) | (stale > 0)) & (gaps.min(axis=2) - stale - moved < level)
    out = np.array(gaps, float)
    if known is not None:  # (the `once` pairs' gaps the screen has: a kernel call less)
        have = redo & scorer.once[None] & ~np.isnan(known)
        out[:, :, scorer.once_k][have] = known[have]
        c, p = np.nonzero(redo & ~have)
    else:
        c, p = np.nonzero(redo)
    once = scorer.once[p]
    c = np.concatenate([np.repeat(c[~once], K), c[once]])
    k = np.concatenate([np.tile(np.arange(K), int((~once).sum())), np.full(int(once.sum()), scorer.once_k)])
    p = np.concatenate([np.repeat(p[~once], K), p[once]])
    if len(c):
        out[c, p, k] = scorer.items(O, c, p, k)
    return out, np.where(redo, 0.0, stale + moved)


def search_rounds(scorer, space, X, mask, target, scale, *, effort, certify_best, step=0.25):
    """Search rounds from the starts X: improve (first moves ``step`` times ``scale``); when the best is
    feasible at the samples, certify it (``certify_best(x) -> cert``); where the certificate fails, sample
    there too and go on (`ROUNDS`). A round that finds nothing feasible is repeated only while it still
    reduces the violation by a fifth; none starts once ``scorer.work`` is spent. Returns (x, cert) of a
    certified design or None, and (X, best) of the last round."""
    step0 = step * scale
    previous = -math.inf
    last = None
    for _ in range(ROUNDS):
        if scorer.work.spent:
            break
        X, best = improve(scorer, space, mask(), target, X, step0=step0, step_min=0.01 * scale,
                           iterations=int(40 * effort))
        last = (X, best)
        i = int(np.argmax(best))
        if best[i] < 1e5:  # nothing feasible: another round only while it still gains (a fifth)
            if best[i] <= 0.8 * previous:
                break
            previous = best[i]
            continue
        cert = certify_best(X[i])
        if cert["certified"]:
            return (X[i].copy(), cert), last
        # the samples missed a close approach: sample there too and search on
        scorer.add_samples(cert["where"][cert["sampled"] < target])
        step0 = min(step0, 0.1 * scale)
    return None, last
