"""Samples of a linkage's motion for the design searches and the certificate (docs/design.md): ``phi``
with ``t = tan(phi)`` (phi in [-pi/2, pi/2] is the whole cycle, +-pi/2 the reference configuration),
bounds of the joints' rates, samples spaced evenly in joint rotation, and the bodies' displacements there
(`synth.design.collision` measures the capsules' gaps along them). Angles in radians.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.anglelaw import driven_speed_max


def bodies(linkage) -> list[str]:
    """Links that hold joints (the rigid bodies with geometry), in ``linkage.links`` order."""
    return [name for name, js in linkage.links.items() if js]


def t_of_phi(phi) -> np.ndarray:
    """t = tan(phi); infinity at phi = +-pi/2 (to rounding)."""
    phi = np.asarray(phi, float)
    c = np.cos(phi)
    return np.where(np.abs(c) < 1e-15, np.inf, np.sin(phi) / np.where(c == 0, 1.0, c))


def phi_of_t(t) -> np.ndarray:
    """phi in (-pi/2, pi/2] with tan(phi) = t (infinity: pi/2)."""
    t = np.asarray(t, float)
    return np.where(np.isinf(t), np.pi / 2, np.arctan(np.where(np.isinf(t), 0.0, t)))


def rate_bound(linkage, phi0, phi1) -> np.ndarray:
    """(J, n) upper bounds of |dtheta_j/dphi| over each interval [phi0[i], phi1[i]] (phi0 <= phi1): t = tan phi
    is the parameter of a driver with angle law (0, 1) at angle pi - 2 phi (`driven_speed_max`)."""
    phi0, phi1 = np.asarray(phi0, float), np.asarray(phi1, float)
    a = np.array([j.a for j in linkage.joints], float)[:, None]
    b = np.array([j.b for j in linkage.joints], float)[:, None]
    rate = np.array([j.rate for j in linkage.joints])[:, None]
    return 2.0 * driven_speed_max(a, b, 0.0, 1.0, np.pi - 2 * phi1, np.pi - 2 * phi0, rate)[0]


def _kept(linkage, key: tuple, make, limit: int = 8):
    """``make()``, remembered on ``linkage`` under ``key`` with the joints' data (each sizing round of a design
    and each certificate asks for the same samples and motion again; at most ``limit`` kept, oldest out)."""
    joints = tuple((j.name, j.parent, j.child, float(j.a), float(j.b), j.rate, id(j.law), np.asarray(j.direction).tobytes(),
                    np.asarray(j.moment).tobytes()) for j in linkage.joints)
    kept = linkage.__dict__.setdefault("_design_kept", {})
    key = (key, joints, tuple(map(tuple, linkage.links.values())))
    if key not in kept:
        if len(kept) >= limit:
            kept.pop(next(iter(kept)))
        kept[key] = make()
    return kept[key]


def even_samples(linkage, lo: float, hi: float, n: int, fine: int = 4096) -> np.ndarray:
    """n + 1 values of phi from lo to hi, spaced evenly in the total joint rotation sum_j |theta_j| (so no
    joint turns much between two samples, however unevenly the parameter drives it)."""
    def make():
        grid = np.linspace(lo, hi, fine + 1)
        rates = rate_bound(linkage, grid[:-1], grid[1:]).sum(axis=0)
        cum = np.concatenate([[0.0], np.cumsum(rates * np.diff(grid))])
        return np.interp(np.linspace(0, cum[-1], n + 1), cum, grid)

    return _kept(linkage, ("even", float(lo), float(hi), n, fine), make).copy()


def body_motion(linkage, phis, keep: bool = False) -> dict[str, np.ndarray]:
    """{body: (K, 4, 4)} world displacements from the reference configuration at the samples (read only);
    ``keep``: remembered on the linkage (samples asked for again: a search's, a certificate's first)."""
    phis = np.asarray(phis, float)

    def make():
        disp = linkage.displacements(linkage.angles_at(t_of_phi(phis)))
        return {name: np.broadcast_to(disp[name], phis.shape + (4, 4)) for name in bodies(linkage)}

    return _kept(linkage, ("motion", phis.tobytes()), make) if keep else make()
