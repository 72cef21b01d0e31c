"""The loop equation of a planar four-bar: every joint angle as a function of the crank's (docs/fourbar.md).

A planar four-bar has ground pivots A0, B0, moving pivots A1 (on the crank A0 A1) and B1 (on the rocker
B0 B1), the coupler A1 B1, and all four joint axes parallel to one unit direction n (angles counter-
clockwise about n). In the ground frame (A0 at the origin, B0 at (g, 0)) the crank at angle
``phi = crank_ref + theta`` puts A1 at ``r e^{i phi}``; B1 is where the circles of radius c about A1 and s
about B0 meet, the one on side ``branch`` (+1: counter-clockwise from A1 -> B0 seen from A1):

    psi = arg(B0 - A1) + branch * acos((c^2 + L^2 - s^2) / (2 c L)),  L = |B0 - A1|,  B1 = A1 + c e^{i psi}

and the rocker's angle is ``rho = arg(B1 - B0)``. The four joint angles, relative to the reference
configuration (theta = 0, where every joint angle is 0), are those of the branches h (base -h1-> crank
-h2-> coupler) and k (base -k1-> rocker -k2-> coupler_k):

    h1 = theta,  h2 = (psi - psi_0) - theta,  k1 = rho - rho_0,  k2 = (psi - psi_0) - (rho - rho_0).

Where the loop cannot be assembled (|cos| > 1, not for a crank-rocker) the angles are NaN. The coupler
motion of a general four-bar is not rational (its curve of positions has genus 1), so these angles are
not angle laws of motion-polynomial factors: a joint carrying a `FourBarLaw` gets its angle from the
crank's angle law through it (`synth.linkage.Joint.angle`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

TWO_PI = 2.0 * np.pi
ROLES = ("h1", "h2", "k1", "k2")  # crank, coupler from the crank, rocker, coupler from the rocker
ASSEMBLY_SLACK = 1e-12  # |cos| up to 1 + this is clipped (a flat configuration by rounding)


def loop_angles(ground, crank, coupler, rocker, crank_ref, branch, theta) -> np.ndarray:
    """Joint angles (4, ...) [h1, h2, k1, k2] (rad) of four-bars with link lengths ground, crank, coupler,
    rocker (metres), crank angle ``crank_ref`` (rad, from A0 -> B0) at the reference configuration and
    assembly ``branch`` (+-1), when the crank has turned by ``theta`` (rad) from there. For a crank-rocker
    (crank shortest: the direction A1 -> B0 never turns over, the rocker swings less than half a turn)
    they are continued: continuous in theta, h2 losing a turn per turn of the crank. Every argument
    broadcasts; NaN where the loop does not close."""
    theta = np.asarray(theta, float)
    ref = _link_angles(ground, crank, coupler, rocker, crank_ref, branch)
    now = _link_angles(ground, crank, coupler, rocker, np.add(crank_ref, theta), branch)
    (_, psi, rho), (_, psi0, rho0) = now, ref
    k1 = np.mod(rho - rho0 + np.pi, TWO_PI) - np.pi  # the rocker swings less than half a turn
    return np.stack(np.broadcast_arrays(theta, (psi - psi0) - theta, k1, (psi - psi0) - k1))


def _link_angles(g, r, c, s, phi, branch):
    """Absolute angles (crank phi, coupler psi, rocker rho) in the ground frame at crank angle phi."""
    phi = np.asarray(phi, float)
    dx, dy = g - r * np.cos(phi), -r * np.sin(phi)  # B0 - A1
    L = np.hypot(dx, dy)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_a = (c * c + L * L - s * s) / (2.0 * c * L)
    cos_a = np.where(np.abs(cos_a) <= 1.0 + ASSEMBLY_SLACK, np.clip(cos_a, -1.0, 1.0), np.nan)
    psi = np.arctan2(dy, dx) + np.asarray(branch, float) * np.arccos(cos_a)
    bx, by = r * np.cos(phi) + c * np.cos(psi) - g, r * np.sin(phi) + c * np.sin(psi)  # B1 - B0
    return phi, psi, np.arctan2(by, bx)


def transmission_angle(ground, crank, coupler, rocker, crank_ref, theta) -> np.ndarray:
    """Transmission angle mu in [0, pi] (rad) between coupler and rocker at B1 when the crank has turned by
    ``theta`` from ``crank_ref`` (cosine law on the diagonal A1 B0; independent of the branch). Broadcasts."""
    phi = np.add(crank_ref, theta)
    L2 = ground * ground + crank * crank - 2.0 * ground * crank * np.cos(phi)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.arccos(np.clip((coupler * coupler + rocker * rocker - L2) / (2.0 * coupler * rocker), -1.0, 1.0))


@dataclass(frozen=True)
class FourBarLaw:
    """The angle of joint ``joint`` (one of ROLES) of a planar four-bar as a function of the crank's angle
    theta (rad): `loop_angles` of these parameters. Lengths in metres, angles in radians."""

    ground: float
    crank: float
    coupler: float
    rocker: float
    crank_ref: float
    branch: int
    joint: str

    def angle(self, theta) -> np.ndarray:
        """The joint's angle in [0, 2 pi) (NaN where the loop does not close) at crank angle(s) theta."""
        q = loop_angles(self.ground, self.crank, self.coupler, self.rocker, self.crank_ref, self.branch, theta)
        return np.mod(q[ROLES.index(self.joint)], TWO_PI)

    def continued(self, theta) -> np.ndarray:
        """The joint's angle continued over turns of the crank (0 at theta = 0; `loop_angles`)."""
        q = loop_angles(self.ground, self.crank, self.coupler, self.rocker, self.crank_ref, self.branch, theta)
        return q[ROLES.index(self.joint)]

    def speed(self, theta, h: float = 1e-6) -> np.ndarray:
        """d angle / d theta (central difference over +-h rad of the crank; error ~ h^2)."""
        theta = np.asarray(theta, float)
        return (self.continued(theta + h) - self.continued(theta - h)) / (2.0 * h)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> FourBarLaw:
        """From `to_dict`'s keys; ValueError on a missing key, a non-finite or non-positive length, a branch
        other than +-1 or an unknown joint role."""
        law = cls(*(float(d[k]) for k in ("ground", "crank", "coupler", "rocker", "crank_ref")),
                  int(d["branch"]), str(d["joint"]))
        lengths = np.array([law.ground, law.crank, law.coupler, law.rocker, abs(law.crank_ref) + 1.0])
        if not np.all(np.isfinite(lengths)) or np.any(lengths <= 0) or law.branch not in (1, -1) or law.joint not in ROLES:
            raise ValueError(f"not a four-bar loop law: {d}")
        return law
