"""Generic batched least squares with equality constraints, for fitting motion polynomials of any degree
to over-determined tasks (docs/sixbar_fit.md).

A problem is a pair of callables over a batch of B parameter vectors x (B, P):

* ``fun(x) -> (r (B, m), g (B, k))``: soft residuals r (each already divided by its tolerance, so that
  |r_j| <= 1 means "within tolerance") and hard residuals g (exact poses, velocity directions: g = 0 is
  required to machine precision);
* optionally ``jac(x) -> (J (B, m, P), G (B, k, P))``; by default `fd_jacobian` (forward differences,
  columns of one ``colors`` group perturbed together because they touch disjoint residuals).

`levenberg_marquardt` minimizes |r|^2 + PENALTY |g|^2 with a per-row damping (each batch row is its own
problem: seeds of a global search), then `project` makes g vanish by minimum-norm Gauss-Newton steps
on g alone. Work is counted (iterations), never timed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LMResult", "fd_jacobian", "levenberg_marquardt", "project"]

PENALTY = 1e8  # weight of the hard residuals during the descent (the projection then makes them exact)
FD_STEP = 1e-7  # relative forward-difference step


@dataclass
class LMResult:
    """Per batch row: parameters (B, P), cost |r|^2 (B,), hard-residual norm |g| (B,), iterations used."""

    x: np.ndarray
    cost: np.ndarray
    hard: np.ndarray
    iterations: int


def fd_jacobian(fun, x, colors=None, support=None):
    """Forward-difference values and Jacobians ``((r, g), (J (B, m, P), G (B, k, P)))`` of ``fun`` at x
    (B, P). ``colors``: column-index arrays perturbed together, with ``support`` = (rows_r (m, P),
    rows_g (k, P)) boolean: which residual rows depend on which column (two columns of a group must not
    share a row); default one column per group. One call of ``fun`` on a (B * (groups + 1), P) batch."""
    x = np.asarray(x, float)
    B, P = x.shape
    groups = [np.array([j]) for j in range(P)] if colors is None else [np.asarray(c, int) for c in colors]
    h = FD_STEP * np.maximum(1.0, np.abs(x))  # (B, P)
    X = np.repeat(x[:, None, :], len(groups) + 1, axis=1)  # row 0: unperturbed
    for n, cols in enumerate(groups):
        X[:, n + 1, cols] += h[:, cols]
    r, g = fun(X.reshape(-1, P))
    r = r.reshape(B, len(groups) + 1, -1)
    g = g.reshape(B, len(groups) + 1, -1)
    J = np.empty((B, r.shape[-1], P))
    G = np.empty((B, g.shape[-1], P))
    for n, cols in enumerate(groups):
        for j in cols.tolist():
            J[:, :, j] = (r[:, n + 1] - r[:, 0]) / h[:, j, None]
            G[:, :, j] = (g[:, n + 1] - g[:, 0]) / h[:, j, None]
    if colors is not None:  # a group's columns share one difference: keep each column's own rows
        J *= support[0][None]
        G *= support[1][None]
    return (r[:, 0], g[:, 0]), (J, G)


def _solve(J, G, r, g, mu):
    """The damped step: (J^T J + W G^T G + mu D) dx = -(J^T r + W G^T g), D = diag of the Gram matrix
    (Marquardt scaling, floored), batched."""
    A = np.swapaxes(J, 1, 2) @ J + PENALTY * (np.swapaxes(G, 1, 2) @ G)
    b = np.swapaxes(J, 1, 2) @ r[..., None] + PENALTY * (np.swapaxes(G, 1, 2) @ g[..., None])
    d = np.einsum("bii->bi", A)
    d = np.maximum(d, 1e-9 * np.maximum(d.max(-1, keepdims=True), 1.0))
    A = A + (mu[:, None] * d)[..., None] * np.eye(A.shape[-1])
    with np.errstate(all="ignore"):
        try:
            return -np.linalg.solve(A, b)[..., 0]
        except np.linalg.LinAlgError:
            return -np.stack([np.linalg.lstsq(a, v, rcond=None)[0] for a, v in zip(A, b)])[..., 0]


def _merit(r, g):
    return np.sum(r * r, -1) + PENALTY * np.sum(g * g, -1)


def levenberg_marquardt(fun, x0, *, jac=None, iterations: int = 40, rtol: float = 1e-12, atol: float = 1e-20,
                        polish: bool = True) -> LMResult:
    """Minimize |r|^2 + PENALTY |g|^2 for every row of x0 (B, P) independently (`fun`, `jac` as in the
    module docstring). Each row keeps its own damping mu (x 1/10 on success, x 4 on failure); a row stops
    when its merit improves by less than ``rtol`` relative or falls below ``atol``; all stop after
    ``iterations``. Then (``polish``) `project` onto the hard constraints."""
    x = np.array(x0, float)
    B = x.shape[0]
    jac = jac or (lambda y: fd_jacobian(fun, y)[1])
    r, g = fun(x)
    merit = _merit(r, g)
    mu = np.full(B, 1e-3)
    active = np.ones(B, bool)
    it = 0
    for it in range(1, iterations + 1):
        idx = np.nonzero(active)[0]
        if not len(idx):
            break
        J, G = jac(x[idx])
        dx = _solve(J, G, r[idx], g[idx], mu[idx])
        xn = x[idx] + np.where(np.isfinite(dx), dx, 0.0)
        rn, gn = fun(xn)
        mn = _merit(rn, gn)
        better = np.isfinite(mn) & (mn < merit[idx])
        gain = np.where(better, (merit[idx] - mn) / np.maximum(merit[idx], 1e-300), 0.0)
        acc = idx[better]
        x[acc], r[acc], g[acc], merit[acc] = xn[better], rn[better], gn[better], mn[better]
        mu[idx] = np.where(better, mu[idx] / 10.0, mu[idx] * 4.0)
        active[idx] = ~((better & (gain < rtol)) | (mu[idx] > 1e12) | (merit[idx] < atol))
    if polish:
        x = project(fun, x, jac)
    r, g = fun(x)
    return LMResult(x=x, cost=np.sum(r * r, -1), hard=np.sqrt(np.sum(g * g, -1)), iterations=it)


def project(fun, x, jac, steps: int = 4):
    """Minimum-norm Gauss-Newton steps x <- x - G^+ g on the hard residuals alone (rows with k = 0 are
    unchanged): brings g to rounding level from a nearby x while moving x as little as possible."""
    x = np.array(x, float)
    _, g = fun(x)
    if g.shape[-1] == 0:
        return x
    for _ in range(steps):
        _, G = jac(x)
        with np.errstate(all="ignore"):
            dx = -(np.linalg.pinv(G, rcond=1e-10) @ g[..., None])[..., 0]
        xn = x + np.where(np.isfinite(dx), dx, 0.0)
        _, gn = fun(xn)
        ok = np.sum(gn * gn, -1) < np.sum(g * g, -1)
        x[ok], g[ok] = xn[ok], gn[ok]
    return x
