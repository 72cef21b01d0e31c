"""Conditioning of a linkage's motion: the transmission ratio of its angle laws (docs/conventions.md,
section "Transmission ratio").

Joint j turns by theta_j(t) = 2 atan2(b_j, t - a_j) (norm root z_j = a_j + i b_j, b_j > 0). The largest
ratio of the speeds of joints i and j over the whole motion is

    rho_ij = max_t |d theta_i / d theta_j| = exp(d(z_i, z_j))
           = (S + |z_i - z_j| |z_i - conj z_j|) / (2 b_i b_j),   S = (a_i - a_j)^2 + b_i^2 + b_j^2,

d the hyperbolic distance of the upper half plane: symmetric, 1 for equal laws, and unchanged by any
real reparametrization t -> (alpha t + beta) / (gamma t + delta). A linkage whose largest ratio is huge
is degenerate in practice: while one joint moves by 1 / rho the other makes a whole turn, a motion that
double precision (and any drive) cannot resolve. Syntheses refuse such results (`transmission_problem`;
`synth.synthesis.bennett.check_transmission`, `synth.synthesis.sixbar`).
"""
from __future__ import annotations

import numpy as np

TRANSMISSION_LIMIT = 1e4  # largest accepted speed ratio of two joints anywhere in the cycle (module docstring)


def transmission_ratios(a, b) -> np.ndarray:
    """Largest speed ratios rho_ij (..., J, J) of the joints with angle laws a, b (..., J) (b != 0):
    exp of the hyperbolic distance of the norm roots a + i|b| (module docstring); inf where b is 0 or
    not finite."""
    a = np.asarray(a, float)
    b = np.abs(np.asarray(b, float))
    with np.errstate(all="ignore"):
        return pair_ratio(a[..., :, None] - a[..., None, :], b[..., :, None], b[..., None, :])


def pair_ratio(da, bi, bj) -> np.ndarray:
    """rho_ij of two joints (broadcast arrays): ``da`` = a_i - a_j, ``bi``, ``bj`` = |b_i|, |b_j|
    (`transmission_ratios`; a Bennett linkage's two distinct norm roots give its largest ratio); at
    least 1, inf where not finite. Call under ``np.errstate(all="ignore")`` (b = 0 divides by zero).
    With h1 = |z_i - z_j|, h2 = |z_i - conj z_j|: S = (h1^2 + h2^2) / 2, so the module's formula is
    rho = (h1 + h2)^2 / (4 b_i b_j), a sum of positive terms (no cancellation near rho = 1)."""
    h = np.hypot(da, bi - bj)
    h = h + np.hypot(da, bi + bj)
    rho = (h * h) / (4.0 * bi * bj)
    return np.where(rho >= 1.0, rho, np.where(rho != rho, np.inf, 1.0))  # NaN (0 / 0): inf


def transmission_ratio(a, b) -> np.ndarray:
    """The largest of `transmission_ratios` over all pairs of joints: shape (...)."""
    return np.max(transmission_ratios(a, b), axis=(-2, -1))


def worst_pairs(a, b) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The largest ratio of `transmission_ratios` of N linkages' laws a, b (N, J), its faster joint (the
    one with the smaller |b|: it turns fastest where t is near its a) and its slower joint (indices):
    three (N,) arrays."""
    R = transmission_ratios(a, b)
    N, J = R.shape[0], R.shape[-1]
    flat = R.reshape(N, J * J)
    k = np.argmax(flat, axis=1)
    i, j = np.divmod(k, J)
    rows = np.arange(N)
    first = np.abs(np.asarray(b, float)[rows, i]) <= np.abs(np.asarray(b, float)[rows, j])
    return flat[rows, k], np.where(first, i, j), np.where(first, j, i)


def worst_pair(linkage) -> tuple[float, str, str]:
    """(largest ratio, faster joint, slower joint) of a `synth.linkage.Linkage` (`worst_pairs`)."""
    js = linkage.joints
    rho, fast, slow = worst_pairs(np.array([[j.a for j in js]], float), np.array([[j.b for j in js]], float))
    return float(rho[0]), js[int(fast[0])].name, js[int(slow[0])].name


def transmission_sentence(rho: float, fast: str, slow: str, limit: float = TRANSMISSION_LIMIT) -> str:
    """The sentence saying that joint ``fast`` turns ``rho`` times faster than joint ``slow`` somewhere,
    more than ``limit`` allows."""
    return (f"the linkage is ill-conditioned (nearly degenerate): at one point of its cycle joint {fast} "
            f"turns {rho:.2g} times faster than joint {slow} (transmission ratio {rho:.2g}, at most "
            f"{limit:.0e} is accepted), a motion no drive and no double-precision check can follow")


def transmission_problem(linkage, limit: float = TRANSMISSION_LIMIT) -> str | None:
    """The sentence saying why ``linkage`` is too ill-conditioned to give (ratio above ``limit``), or None."""
    rho, fast, slow = worst_pair(linkage)
    if rho <= limit:
        return None
    return transmission_sentence(rho, fast, slow, limit)
