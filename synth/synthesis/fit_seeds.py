"""Seeds of motion fits onto the gauge of `synth.synthesis.fit` (docs/fit.md): the items projected onto a
seed motion (`project`: the nearest of a grid of parameters, then `zoom`), and the reparametrization
(`regauge`, `gauge_matrix`, `gauge_items`) that holds three items at GAUGE_ANGLES.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.dq import dot, dq_inv, dq_mul, dq_translation, normalize_dq
from synth.errors import SynthesisError
from synth.synthesis.fit import basis, homogeneous, monic

__all__ = ["project", "nearest", "zoom", "distances", "regauge", "to_gauge", "gauge_matrix", "gauge_items", "inv2", "GAUGE_ANGLES", "GRID",
           "EXACT_WEIGHT"]

GRID = 48  # parameter samples per seed motion for projecting the items onto it (`project`)
ZOOMS = 3  # refinements of each projection around its nearest sample
ZOOM_SAMPLES = 9  # samples per refinement
EXACT_WEIGHT = 1e3  # weight of exact rows when projecting and ranking seeds (conditioned units)


def gauge_matrix(phi) -> np.ndarray:
    """M (..., 2, 2) mapping the homogeneous parameters (1, 0), (0, 1), (1, 1) to those of the items with
    angles ``phi`` (..., 3) (up to scale): the reparametrization putting them at t = inf, 0, 1."""
    w = np.stack([np.cos(phi), np.sin(phi)], -2)  # (..., 2, 3) columns
    det = w[..., 0, 0] * w[..., 1, 1] - w[..., 0, 1] * w[..., 1, 0]  # 0: two items at one point (NaN out)
    with np.errstate(all="ignore"):
        alpha = (w[..., 0, 2] * w[..., 1, 1] - w[..., 1, 2] * w[..., 0, 1]) / det
        beta = (w[..., 0, 0] * w[..., 1, 2] - w[..., 1, 0] * w[..., 0, 2]) / det
    return w[..., :2] * np.stack([alpha, beta], -1)[..., None, :]


GAUGE_ANGLES = np.array([0.0, np.pi / 3, 2 * np.pi / 3])  # where the gauge items are held (t = inf, +-1/sqrt 3)


def gauge_items(phi) -> np.ndarray:
    """(S, 3): item 0 and the items a third and two thirds along the motion from it (cyclic order of the
    angles phi (S, N) on the projective line), which `fit_motion` holds at GAUGE_ANGLES (spread evenly,
    for well-conditioned coefficients)."""
    N = phi.shape[1]
    order = np.argsort(np.mod(phi - phi[:, :1], np.pi), axis=1, kind="stable")
    return np.stack([order[:, 0], order[:, max(1, N // 3)], order[:, max(2, (2 * N) // 3)]], 1)


def regauge(coef, ref, phi, M):
    """The same motion in the parameter t' with homogeneous (u, v) = M (u', v'): coefficients (..., n, 8)
    of the monic C'(t') = C(M(t')) lead^-1, reference lead Q and the items' new angles (..., N)."""
    n = coef.shape[-2]
    psi = (np.arange(n + 1) + 0.5) * (np.pi / (n + 1))
    uv = M @ np.stack([np.cos(psi), np.sin(psi)])  # (..., 2, n+1)
    rho, theta = np.hypot(uv[..., 0, :], uv[..., 1, :]), np.arctan2(uv[..., 1, :], uv[..., 0, :])
    values = homogeneous(coef, theta) * (rho ** n)[..., None]  # (..., n+1, 8)
    k = np.arange(n + 1)
    basis = np.cos(psi)[:, None] ** k * np.sin(psi)[:, None] ** (n - k)
    full = np.linalg.solve(basis, values)  # (..., n+1, 8): coefficients of C(M(.))
    lead = full[..., n, :]
    inv = dq_inv(lead)
    new = dq_mul(full[..., :n, :], inv[..., None, :])
    new_ref = normalize_dq(dq_mul(lead, ref))
    w = inv2(M) @ np.stack([np.cos(phi), np.sin(phi)], -2)
    return new, new_ref, np.mod(np.arctan2(w[..., 1, :], w[..., 0, :]), np.pi)


def to_gauge(coef, ref, phi):
    """Seeds (coef (S, n, 8), reference (S, 8), item angles phi (S, N)) moved onto the gauge: item 0 and the
    items a third and two thirds along (`gauge_items`) at GAUGE_ANGLES (`regauge`). Returns (coef, ref,
    phi, gauge (S', 3)) of the seeds that stay finite; SynthesisError when none does."""
    gauge = gauge_items(phi)
    with np.errstate(all="ignore"):
        M = gauge_matrix(np.take_along_axis(phi, gauge, 1)) @ inv2(gauge_matrix(GAUGE_ANGLES))
        coef, ref, phi = regauge(coef, ref, phi, M)
    np.put_along_axis(phi, gauge, GAUGE_ANGLES[None], 1)
    ok = np.isfinite(coef).all((1, 2)) & np.isfinite(ref).all(1) & np.isfinite(phi).all(1)
    if not ok.any():
        raise SynthesisError("every seed motion is degenerate (the items fall on one point of it)")
    return coef[ok], ref[ok], phi[ok], gauge[ok]


def inv2(M):
    """Inverses of 2x2 matrices (..., 2, 2) (NaN for singular ones)."""
    det = M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
    adj = np.stack([np.stack([M[..., 1, 1], -M[..., 0, 1]], -1), np.stack([-M[..., 1, 0], M[..., 0, 0]], -1)], -2)
    with np.errstate(all="ignore"):
        return adj / det[..., None, None]


def project(coef, ref, task, grid: int = GRID, exact_weight: float = EXACT_WEIGHT, rounds: int = ZOOMS):
    """Each item's angle phi (S, N) on each seed motion (coef (S, n, 8), reference (S, 8)): the nearest of
    ``grid`` samples by `distances` (`nearest`), then `zoom` (a seed's parameter may crowd the items into
    one cell of the coarse grid)."""
    phi, _ = nearest(coef, ref, task, grid, exact_weight)
    return zoom(coef, ref, task, phi, np.pi / grid, exact_weight, rounds)


def nearest(coef, ref, task, grid: int = GRID, exact_weight: float = EXACT_WEIGHT):
    """(phi (S, N), miss (S,)): each item at the nearest of ``grid`` samples (spacing pi / grid) of each
    seed motion, and the sum of the items' `distances` there (a cheap pre-score of the seed)."""
    S, h = len(coef), np.pi / grid
    cand = np.broadcast_to((np.arange(grid) + 0.5) * h, (S, 1, grid))
    d2 = distances(coef, ref, task, cand, exact_weight)
    k = np.argmin(d2, -1)[..., None]
    phi = np.take_along_axis(np.broadcast_to(cand, d2.shape), k, -1)[..., 0]
    return phi, np.take_along_axis(d2, k, -1)[..., 0].sum(-1)


def zoom(coef, ref, task, phi, h: float, exact_weight: float = EXACT_WEIGHT, rounds: int = ZOOMS):
    """``rounds`` refinements of the items' angles phi (S, N) on the seed motions: the nearest
    (`distances`) of ZOOM_SAMPLES samples across phi +- h, h shrinking by ZOOM_SAMPLES / 2 each round."""
    offsets = np.linspace(-1.0, 1.0, ZOOM_SAMPLES)
    for _ in range(rounds):
        cand = phi[..., None] + h * offsets
        phi = np.take_along_axis(cand, np.argmin(distances(coef, ref, task, cand, exact_weight), -1)[..., None],
                                 -1)[..., 0]
        h *= 2.0 / (ZOOM_SAMPLES - 1)
    return np.mod(phi, np.pi)


def distances(coef, ref, task, cand, exact_weight: float = EXACT_WEIGHT):
    """(S, N, K): the weighted squared miss of each item at the angles cand (S, N, K) (or (S, 1, K), shared
    by the items) of the seed motions: position and angle (8 (1 - |p . q|)) misses, exact components
    weighted ``exact_weight``; NaN as inf."""
    S, K = len(coef), cand.shape[-1]
    shared = cand.shape[1] == 1
    ang = cand[:, 0] if shared else cand.reshape(S, -1)
    n = coef.shape[-2]
    full = monic(coef)
    with np.errstate(all="ignore"):
        P = basis(ang, n)[0] @ dq_mul(full, ref[:, None])  # (S, G, 8): C(phi) Q, linear in the basis
        pp = dot(P[..., :4], P[..., :4])
        x = dq_translation(P, pp)
        p = P[..., :4] / np.sqrt(pp)[..., None]
    w = task.weight[:, [0, 3]] + exact_weight * task.exact[:, [0, 3]]  # (N, 2): position, angle
    if shared:  # (S, N, G): each item's target against all the samples
        xt, X = np.swapaxes(x, 1, 2)[:, :, None, :], task.X[:, :, None]  # (S, 3, 1, G), (N, 3, 1)
        cos = np.swapaxes(np.abs(p @ task.Q[:, :4].T), 1, 2)  # |p . q|: (S, N, G)
    else:
        N = cand.shape[1]
        xt, X = np.moveaxis(x.reshape(S, N, K, 3), -1, 1), task.X[:, :, None]  # (S, 3, N, K), (N, 3, 1)
        cos = np.abs(dot(p.reshape(S, N, K, 4), task.Q[:, None, :4]))
    d2 = np.subtract(xt[:, 0], X[:, 0])  # the squared position miss, component by component (few temporaries)
    d2 *= d2
    part = np.empty_like(d2)
    for i in (1, 2):
        np.subtract(xt[:, i], X[:, i], out=part)
        part *= part
        d2 += part
    d2 *= w[:, :1] ** 2
    np.minimum(cos, 1.0, out=part)  # the angle miss, 8 (1 - |p . q|)
    np.subtract(1.0, part, out=part)
    part *= 8.0
    part *= w[:, 1:] ** 2
    d2 += part
    return np.nan_to_num(d2, copy=False, nan=np.inf)
