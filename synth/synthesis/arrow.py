"""Block-arrow Jacobians of motion fits and their damped KKT steps in time linear in the number of items
(docs/fit.md, "Many items").

The unknowns of a fit (`synth.synthesis.fit.Layout`) are G global columns (the motion's coefficients, the
reference pose) and one parameter per item (its angle phi_i). Item i's residual rows depend on the globals
and on phi_i only, so J^T J is an arrow: a dense G x G head, a diagonal in the items' columns and the
borders between them. `ArrowJacobian` keeps that structure (no dense rows x columns matrix) and
`ArrowJacobian.system` eliminates the items' columns from the KKT system (a Schur complement): the work per
step is O(N G^2 + (G + k)^3) for N items, k the items' columns that must stay in the dense core (those of
items with equality rows, and those that extra rows couple, e.g. the active hinge rows of a listed order),
instead of O(N^3) for the dense system.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ArrowJacobian", "KKTSystem"]

DAMPING_FLOOR = 1e-12  # added to each diagonal element the damping scales (a column without rows still moves)


@dataclass
class ArrowJacobian:
    """Rows and Jacobians of S seeds, columns [G globals, N item parameters]:

    * item rows: ``item_r`` (S, N, R) residuals (0 for rows that do not count), ``item_g`` (S, N, R, G) their
      derivatives in the globals, ``item_p`` (S, N, R) in the item's own parameter;
    * extra rows: ``extra_r`` (S, m), ``extra_g`` (S, m, G) in the globals, and in at most k item parameters
      each: columns ``extra_cols`` (m, k) (item indices) with derivatives ``extra_vals`` (S, m, k);
    * equality constraints: ``c`` (S, E), ``Jc`` (S, E, G + N) dense (few rows: the Study condition and the
      exact items' rows).
    """

    item_r: np.ndarray
    item_g: np.ndarray
    item_p: np.ndarray
    extra_r: np.ndarray
    extra_g: np.ndarray
    extra_cols: np.ndarray
    extra_vals: np.ndarray
    c: np.ndarray
    Jc: np.ndarray

    @classmethod
    def of_items(cls, item_r, item_g, item_p, c, Jc) -> "ArrowJacobian":
        """Item rows and constraints, no extra rows."""
        S, G = item_g.shape[0], item_g.shape[-1]
        return cls(item_r, item_g, item_p, np.zeros((S, 0)), np.zeros((S, 0, G)), np.zeros((0, 0), int),
                   np.zeros((S, 0, 0)), c, Jc)

    @property
    def cost(self) -> np.ndarray:
        """(S,) the sum of squared residuals."""
        return (self.item_r ** 2).sum((1, 2)) + (self.extra_r ** 2).sum(1)

    def with_rows(self, r, Jg, cols=None, vals=None) -> "ArrowJacobian":
        """These rows with m more residual rows r (S, m), derivatives Jg (S, m, G) in the globals and ``vals``
        (S, m, k) in the item parameters ``cols`` (m, k) (None: none)."""
        S, m = r.shape
        if cols is None:
            cols, vals = np.zeros((m, 0), int), np.zeros((S, m, 0))
        k = max(cols.shape[1], self.extra_cols.shape[1])
        pad = lambda a, width: np.concatenate([a, np.zeros(a.shape[:-1] + (width - a.shape[-1],), a.dtype)], -1)
        return ArrowJacobian(self.item_r, self.item_g, self.item_p, np.concatenate([self.extra_r, r], 1),
                             np.concatenate([self.extra_g, Jg], 1),
                             np.concatenate([pad(self.extra_cols, k), pad(cols, k)], 0),
                             np.concatenate([pad(self.extra_vals, k), pad(vals, k)], 1), self.c, self.Jc)

    def system(self, fixed) -> "KKTSystem":
        """The damped KKT system of these rows with the columns ``fixed`` (S, G + N) bool held."""
        return KKTSystem(self, fixed)


class KKTSystem:
    """[[J^T J + lam D, A^T], [A, 0]] [dx; mu] = [-J^T r; -c] (D = diag(J^T J) + DAMPING_FLOOR, held columns:
    1 on the diagonal, 0 elsewhere) of an `ArrowJacobian`, with the item columns eliminated that no
    constraint touches and that extra rows couple at most to the next item (a tridiagonal block, e.g. the
    hinge rows of a listed order): the lam-independent products are formed once, `step` per lam."""

    def __init__(self, jac: ArrowJacobian, fixed):
        S, N, R, G = jac.item_g.shape
        fixed = np.broadcast_to(np.asarray(fixed, bool), (S, G + N))
        item_g = np.where(fixed[:, None, None, :G], 0.0, jac.item_g)
        item_p = np.where(fixed[:, G:, None], 0.0, jac.item_p)
        cols, vals = jac.extra_cols, np.where(fixed[:, G:][:, jac.extra_cols], 0.0, jac.extra_vals)
        extra_g = np.where(fixed[:, None, :G], 0.0, jac.extra_g)
        # extra rows that are 0 with their derivatives for every seed add nothing (inactive hinge rows): left out
        live = (vals != 0).any((0, 2)) | (jac.extra_r != 0).any(0) | (extra_g != 0).any((0, 2))
        cols, vals, extra_g, extra_r = cols[live], vals[:, live], extra_g[:, live], jac.extra_r[:, live]
        self.A = np.where(fixed[:, None, :], 0.0, jac.Jc)
        core = self._core(self.A[:, :, G:], cols, vals, N)
        local = np.nonzero(~core)[0]
        core = np.nonzero(core)[0]
        self.S, self.G, self.N, self.core, self.local, self.fixed = S, G, N, core, local, fixed
        pos = np.full(N, -1)
        pos[core] = G + np.arange(len(core))
        width = G + len(core)
        Ji = np.zeros((S, N, R, width))  # the item rows in the core columns
        Ji[..., :G] = item_g
        Ji[:, core, :, pos[core]] = np.moveaxis(item_p[:, core], 1, 0)
        m = extra_r.shape[1]
        Je = np.zeros((S, m, width))  # the extra rows in the core columns
        Je[..., :G] = extra_g
        for slot in range(cols.shape[1] if m else 0):
            on = pos[cols[:, slot]] >= 0
            Je[:, np.nonzero(on)[0], pos[cols[on, slot]]] += vals[:, on, slot]
        flat = Ji.reshape(S, N * R, width)
        self.H = np.swapaxes(flat, 1, 2) @ flat + np.swapaxes(Je, 1, 2) @ Je
        self.g = (np.swapaxes(flat, 1, 2) @ jac.item_r.reshape(S, -1, 1))[..., 0] + \
            (np.swapaxes(Je, 1, 2) @ extra_r[..., None])[..., 0]
        pl = item_p[:, local]  # (S, L, R): the eliminated columns
        self.d = (pl * pl).sum(-1)  # their block of J^T J: diagonal, and self.e above it
        self.e = np.zeros((S, max(len(local) - 1, 0)))
        self.border = np.einsum("slr,slrc->slc", pl, Ji[:, local])  # (S, L, width)
        self.g_local = (pl * jac.item_r[:, local]).sum(-1)
        if m:
            self._extra_local(cols, vals, Je, extra_r, N)
        self.fixed_core = np.concatenate([fixed[:, :G], fixed[:, G + core]], 1)
        self.fixed_local = fixed[:, G + local]
        self.Acore = np.concatenate([self.A[:, :, :G], self.A[:, :, G + core]], 2)
        self.c = jac.c

    @staticmethod
    def _core(A_items, cols, vals, N: int) -> np.ndarray:
        """(N,) the item columns kept in the dense core: those of constraints, and those of extra rows that
        touch more than two items or two that are not neighbours."""
        core = np.any(A_items != 0, axis=(0, 1))
        live = np.any(vals != 0, axis=0)  # (m, k)
        if live.size:
            lo = np.where(live, cols, N).min(1)
            hi = np.where(live, cols, -1).max(1)
            wide = (live.sum(1) > 2) | (hi - lo > 1)
            core[cols[wide][live[wide]]] = True
        return core

    def _extra_local(self, cols, vals, Je, extra_r, N: int) -> None:
        """Add the extra rows' parts in the eliminated columns to d, e, border and g_local."""
        lpos = np.full(N, -1)
        lpos[self.local] = np.arange(len(self.local))
        every = slice(None)
        for a in range(cols.shape[1]):
            la = lpos[cols[:, a]]
            on = la >= 0
            va = vals[:, on, a]
            np.add.at(self.d, (every, la[on]), va * va)
            np.add.at(self.border, (every, la[on]), va[..., None] * Je[:, on])
            np.add.at(self.g_local, (every, la[on]), va * extra_r[:, on])
            for b in range(a + 1, cols.shape[1]):
                lb = lpos[cols[:, b]]
                both = on & (lb >= 0)
                prod = vals[:, both, a] * vals[:, both, b]
                same = la[both] == lb[both]
                np.add.at(self.d, (every, la[both][same]), 2 * prod[:, same])
                np.add.at(self.e, (every, np.minimum(la, lb)[both][~same]), prod[:, ~same])  # (neighbours)

    def step(self, lam, solve) -> np.ndarray:
        """dx (S, G + N) of the damped system with damping ``lam`` (S,); ``solve(K, rhs)`` a batched solver."""
        S, width, ne = self.S, self.H.shape[1], self.Acore.shape[1]
        i = np.arange(width)
        Hd = self.H[:, i, i]
        Dl = np.where(self.fixed_local, 1.0, self.d + lam[:, None] * (self.d + DAMPING_FLOOR))
        Z = _tridiagonal_solve(Dl, self.e, np.concatenate([self.border, self.g_local[..., None]], -1))
        Zb, Zg = Z[..., :width], Z[..., width]  # T^-1 border, T^-1 g_local
        K = np.zeros((S, width + ne, width + ne))
        K[:, :width, :width] = self.H - np.swapaxes(self.border, 1, 2) @ Zb
        K[:, i, i] += np.where(self.fixed_core, 1.0 - Hd, lam[:, None] * (Hd + DAMPING_FLOOR))
        K[:, :width, width:] = np.swapaxes(self.Acore, 1, 2)
        K[:, width:, :width] = self.Acore
        rhs = np.concatenate([-self.g + (np.swapaxes(Zb, 1, 2) @ self.g_local[..., None])[..., 0], -self.c], -1)
        y = solve(K, rhs)[:, :width]
        dx = np.zeros((S, self.G + self.N))
        dx[:, :self.G] = y[:, :self.G]
        dx[:, self.G + self.core] = y[:, self.G:]
        dx[:, self.G + self.local] = -Zg - (Zb @ y[..., None])[..., 0]
        return dx


def _tridiagonal_solve(diag, upper, rhs) -> np.ndarray:
    """T^-1 rhs (S, L, k) for the symmetric positive definite tridiagonal T with ``diag`` (S, L) and
    ``upper`` (S, L - 1): a division where T is diagonal, the Thomas recursion over the items that a nonzero
    ``upper`` couples (the active hinge rows: a loop over those only)."""
    out = rhs / diag[..., None]
    band = np.nonzero(np.any(upper != 0, axis=0))[0]
    if not len(band):
        return out
    idx = np.union1d(band, band + 1)
    d, b = diag[:, idx], rhs[:, idx]
    u = np.where(idx[1:] == idx[:-1] + 1, upper[:, idx[:-1]], 0.0)  # (S, n - 1): coupling of idx[j], idx[j + 1]
    n = len(idx)
    cp, bp = np.zeros((len(d), n)), np.empty_like(b)
    denom = d[:, 0]
    for j in range(n):  # forward elimination
        if j:
            denom = d[:, j] - u[:, j - 1] * cp[:, j - 1]
            b_j = b[:, j] - u[:, j - 1, None] * bp[:, j - 1]
        else:
            b_j = b[:, 0]
        if j < n - 1:
            cp[:, j] = u[:, j] / denom
        bp[:, j] = b_j / denom[:, None]
    x = np.empty_like(bp)
    x[:, -1] = bp[:, -1]
    for j in range(n - 2, -1, -1):  # back substitution
        x[:, j] = bp[:, j] - cp[:, j, None] * x[:, j + 1]
    out[:, idx] = x
    return out
