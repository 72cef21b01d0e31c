"""The listed order as a constraint of a motion fit (docs/fit.md, "Order").

With ``order: listed`` the first driver must carry the tool through the items in the listed order: on the
projective line of the motion's parameter (angles phi in [0, pi), item 0 at phi = 0) the items' angles
increase (direction +1) or decrease (-1) from item 0 on, less than one turn in all. Two parts:

* `project_listed`: the items placed on a seed motion in the listed order, the least total weighted miss
  over strictly monotone placements on a grid (dynamic programming, both directions; more than
  MAX_CELLS / 2 items share MAX_CELLS cells, monotone: linear in the items), to be zoomed
  (`synth.synthesis.fit_seeds.zoom`);
* `ListedOrder`: a model for `synth.synthesis.fit.levenberg_marquardt` adding hinge rows
  ``ORDER_WEIGHT * max(0, ORDER_MARGIN - gap)`` on the N gaps between consecutive angles (from 0 to pi in the
  seed's direction), so the refinement keeps the order instead of a filter dropping fits afterwards.
"""
from __future__ import annotations

import numpy as np

from synth.synthesis.fit_seeds import EXACT_WEIGHT, GRID, distances

__all__ = ["project_listed", "ListedOrder", "directions", "ORDER_MARGIN", "ORDER_WEIGHT"]

ORDER_MARGIN = 1e-3  # smallest gap (rad of phi) between consecutive items kept by the hinge rows
ORDER_WEIGHT = 1e4  # weight of a hinge row (per rad), against residuals in tolerances
MAX_CELLS = 256  # cells of the ordered projection at most (beyond 128 items, several items share a cell)


def project_listed(coef, ref, task, grid: int = GRID, exact_weight: float = EXACT_WEIGHT):
    """The items' angles phi (2 S, N) on each seed motion (coef (S, n, 8), reference (S, 8)) in the listed
    order, rows 0..S-1 increasing from item 0 on, rows S..2S-1 decreasing: item 0 at its nearest of ``grid``
    cells (at least 2 N), the others in strictly monotone cells after it (less than a turn) of least total
    `distances` (more than MAX_CELLS / 2 items: MAX_CELLS cells, monotone but not strictly). Returns (phi, the seeds' rows (2 S,) into coef, that total (2 S,), the cells' spacing) for
    `synth.synthesis.fit_seeds.zoom` (with half the spacing, which keeps the order)."""
    S, N = len(coef), len(task.Q)
    G = max(grid, 2 * N)
    strict = G <= MAX_CELLS
    G = min(G, MAX_CELLS)  # (more items than MAX_CELLS / 2: several per cell, their order left to the hinge rows)
    h = np.pi / G
    cells = (np.arange(G) + 0.5) * h
    d2 = distances(coef, ref, task, np.broadcast_to(cells, (S, 1, G)), exact_weight)  # (S, N, G)
    g0 = np.argmin(d2[:, 0], -1)  # (S,)
    out, miss = [], []
    for sign in (1, -1):
        cell = (g0[:, None] + sign * np.arange(G)) % G  # (S, G): k cells after item 0 in this direction
        D = np.take_along_axis(d2[:, 1:], cell[:, None, :], -1)
        steps, total = _monotone(D, strict)  # (S, N - 1), k >= 1
        out.append(np.concatenate([g0[:, None], np.take_along_axis(cell, steps, -1)], 1))
        miss.append(total + np.take_along_axis(d2[:, 0], g0[:, None], -1)[:, 0])
    return cells[np.concatenate(out)], np.tile(np.arange(S), 2), np.concatenate(miss), h


def _monotone(D, strict: bool = True) -> np.ndarray:
    """(S, M) strictly increasing cell indices k_1 < ... < k_M in 1..K-1 of least sum_i D[:, i, k_i]
    (D (S, M, K)), by dynamic programming, and that least sum (S,); not ``strict``: k_1 <= ... <= k_M."""
    shift = 0 if strict else 1  # the previous item's cells: before k, or up to k
    S, M, K = D.shape
    best = np.full((S, K), np.inf)
    best[:, 0] = 0.0  # item 0 at cell 0
    back = np.zeros((S, M, K), int)
    ar = np.arange(K)
    for i in range(M):
        prefix = np.minimum.accumulate(best, -1)  # best over cells <= k
        at = np.maximum.accumulate(np.where(best <= prefix, ar, 0), -1)
        new = np.full((S, K), np.inf)
        new[:, 1:] = D[:, i, 1:] + prefix[:, shift:K - 1 + shift]  # (strictly) after the previous item
        back[:, i, 1:] = at[:, shift:K - 1 + shift]
        best = new
    k = np.empty((S, M), int)
    k[:, -1] = np.argmin(best, -1)
    total = best[np.arange(S), k[:, -1]]
    for i in range(M - 1, 0, -1):
        k[:, i - 1] = back[np.arange(S), i, k[:, i]]
    return k, total


def directions(phi) -> np.ndarray:
    """(S,) +1 where the items' angles phi (S, N) (item 0 at 0, in [0, pi)) increase from item 1 to item
    N - 1, else -1."""
    return np.where(np.mod(phi[:, -1], np.pi) >= np.mod(phi[:, 1], np.pi), 1, -1)


class ListedOrder:
    """``model`` (rows, jacobians over x (S, P) with the items' angles last, N columns) with the hinge rows
    of the listed order appended to its residuals; ``sign`` (S,) the direction of each seed."""

    def __init__(self, model, sign, items: int):
        self.model, self.sign, self.items = model, np.asarray(sign, float), items

    def _hinge(self, x):
        """(rows (S, N), d rows / d phi (S, N, N)) of the gaps between consecutive angles."""
        phi = x[..., -self.items:]
        s = self.sign.reshape(self.sign.shape + (1,) * (phi.ndim - 1))
        ends = np.where(s > 0, np.pi, 0.0)[..., 0]
        seq, start = np.empty_like(phi), np.empty_like(phi)  # the gaps' ends and starts
        seq[..., :-1], seq[..., -1] = phi[..., 1:], ends
        start[..., 0], start[..., 1:] = np.pi - ends, phi[..., 1:]
        gap = s * (seq - start)  # (S, N - 1 + 1): item 0 -> 1, ..., N-1 -> the turn's end
        active = gap < ORDER_MARGIN
        rows = ORDER_WEIGHT * np.where(active, ORDER_MARGIN - gap, 0.0)
        return rows, active

    def rows(self, x):
        r, c = self.model.rows(x)
        return np.concatenate([r, self._hinge(x)[0]], -1), c

    def constraints(self, x):
        return self.model.constraints(x)

    def jacobians(self, x):
        """The model's `synth.synthesis.arrow.ArrowJacobian` with the hinge rows: row j (the gap from item j to
        j + 1, the last to the turn's end) in the angles of items j + 1 and j."""
        jac = self.model.jacobians(x)
        h, active = self._hinge(x)
        S, N = h.shape
        j = np.arange(N)
        w = -ORDER_WEIGHT * self.sign[:, None] * active  # d row / d gap times d gap / d (its end)
        cols = np.stack([np.minimum(j + 1, N - 1), j], 1)  # gap j ends at item j + 1, starts at item j
        vals = np.stack([np.where(j < N - 1, w, 0.0), np.where(j > 0, -w, 0.0)], -1)  # (item 0's start: the turn end)
        return jac.with_rows(h, np.zeros((S, N, jac.item_g.shape[-1])), cols, vals)
