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

from synth.algebra.geometry import rotation_angle
from synth.synthesis.conic import position_spread

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


def transmission_refusal(T, names, rho: float, fast: str, slow: str) -> str:
    """`synth.synthesis.bennett.check_transmission`'s message for poses T (3, 4, 4) named ``names`` whose
    linkage's joint ``fast`` turns ``rho`` times faster than joint ``slow`` somewhere (`worst_pairs`)."""
    return transmission_sentence(rho, fast, slow) + near_degenerate(T, names, pose_spread(T))


def near_degenerate(T, names, spread) -> str:
    """' (poses i and j ...)' naming the pair of poses closest to a degenerate relation, or ''."""
    found = near_relations(T, names, spread)
    if sum(1 for k, _ in found if k == 2) == 3:
        return " (the three poses are nearly related by planar motions)"
    return f" ({min(found)[1]})" if found else ""


def near_relations(T, names, spread) -> list[tuple[int, str]]:
    """(kind, text) for each pair of poses nearly coinciding (0), nearly related by a pure translation
    (1) or by a pure rotation (2), within 1e-3 (relative); the text says by how much."""
    found = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        R = T[j, :3, :3] @ T[i, :3, :3].T
        d = T[j, :3, 3] - R @ T[i, :3, 3]
        ang = float(rotation_angle(R))
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        along = abs(float(np.dot(d, w / np.linalg.norm(w)))) if np.linalg.norm(w) > 1e-300 else 0.0
        trans = float(np.linalg.norm(d)) / spread
        pair = f"poses {i} ({names[i]!r}) and {j} ({names[j]!r})"
        if ang < 1e-3 and trans < 1e-3:
            found.append((0, f"{pair} nearly coincide (they differ by {max(ang, trans):.1e}, relative)"))
        elif ang < 1e-3:
            found.append((1, f"{pair} differ by nearly a pure translation (rotation {ang:.1e} rad)"))
        elif along / spread < 1e-3 * max(ang, 1e-300) or along / spread < 1e-6:
            found.append((2, f"{pair} differ by nearly a pure rotation (translation along the axis "
                             f"{along / spread:.1e}, relative)"))
    return found


def pose_spread(T) -> float:
    """RMS distance of the positions of poses (k, 4, 4) from their centroid, at least 1e-300
    (`synth.synthesis.conic.position_spread`)."""
    return max(float(position_spread(T)[1]), 1e-300)
