"""The plane of a planar task: poses anywhere in space whose motion is planar, in 2D (docs/fourbar.md, section 1).

Poses T_i (k, 4, 4) are a planar task when one unit direction n is the rotation axis of every relative
rotation R_i R_0^T and every tool origin lies in one plane perpendicular to n. The plane's frame is the
tool origin of pose 0 with the unit vectors e1 (the tool's x axis, or y when x is along n, projected into
the plane) and e2 = n x e1. In it pose i is ``(q_i, theta_i)``: the tool origin's coordinates and the
rotation angle about n (counter-clockwise, theta_0 = 0), and a point with plane coordinates w at pose 0
(moving with the tool) is at ``q_i + Rot(theta_i) w`` at pose i. The syntheses work in conditioned
coordinates ``(x - centre) / scale`` (centre and RMS spread of the q_i) and map back with `to_world`.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from synth.algebra.geometry import spread as position_spread
from synth.errors import InputError, SynthesisError
from synth.info import Plane

COPLANAR_TOL = 1e-9  # |(R_i R_0^T - I) n| and |(p_i - p_0) . n| / spread above this: not a planar task
ROTATION_MIN = 1e-9  # every relative rotation angle below this: pure translations, no revolute joint


@dataclass(frozen=True)
class PlanarTask:
    """A planar task in its plane (module docstring): frame ``origin``, ``e1``, ``e2``, ``normal`` (3,);
    ``q`` (k, 2) tool origins (metres) and ``theta`` (k,) angles (rad) in the plane; conditioning
    ``centre`` (2,) and ``scale`` (metres)."""

    origin: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    normal: np.ndarray
    q: np.ndarray
    theta: np.ndarray
    centre: np.ndarray
    scale: float
    velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (m, 3): [a, rate] (`with_velocities`)
    velocity_items: np.ndarray = field(default_factory=lambda: np.zeros(0, int))  # (m,) the pose of each

    @property
    def qc(self) -> np.ndarray:
        """Conditioned tool origins (k, 2)."""
        return (self.q - self.centre) / self.scale

    @property
    def rotations(self) -> np.ndarray:
        """Rot(theta_i) (k, 2, 2)."""
        c, s = np.cos(self.theta), np.sin(self.theta)
        return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)

    def to_world(self, xc) -> np.ndarray:
        """World points (..., 3) of conditioned plane coordinates xc (..., 2) (at pose 0)."""
        x = np.asarray(xc, float) * self.scale + self.centre
        return self.origin + x[..., :1] * self.e1 + x[..., 1:2] * self.e2

    def describe(self) -> Plane:
        """The plane for the linkage's info: origin, e1, e2, normal (world frame, metres)."""
        return Plane(origin=tuple(self.origin.tolist()), e1=tuple(self.e1.tolist()), e2=tuple(self.e2.tolist()),
                     normal=tuple(self.normal.tolist()))


def plane_of_motion(T, names, source: str = "<poses>") -> PlanarTask:
    """The plane of the poses T (k, 4, 4), metres (module docstring). InputError naming the first pose that
    leaves the plane (its rotation axis is not the common normal, or its origin is off the plane), with
    the amounts; SynthesisError when the poses differ by translations only."""
    T = np.asarray(T, float)
    R = T[:, :3, :3] @ T[0, :3, :3].T  # relative rotations R_i R_0^T
    n = plane_normal(R, source)
    p = T[:, :3, 3]
    spread = max(float(position_spread(p)[1]), 1e-300)
    tilt = np.linalg.norm(R @ n - n, axis=1)
    off = np.abs((p - p[0]) @ n) / spread
    bad = np.flatnonzero((tilt > COPLANAR_TOL) | (off > COPLANAR_TOL))
    if len(bad):
        i = int(bad[0])
        what = []
        if tilt[i] > COPLANAR_TOL:
            what.append(f"its rotation axis is {np.degrees(2 * np.arcsin(min(1.0, tilt[i] / 2))):.3g} deg off the "
                        f"common normal ({', '.join(f'{x:.4f}' for x in n)})")
        if off[i] > COPLANAR_TOL:
            what.append(f"its origin is {off[i] * spread:.3g} m off the plane")
        raise InputError(f"{source}: pose {i} ({names[i]}) is not in the plane of motion of the others: "
                         f"{' and '.join(what)}; a planar four-bar needs poses in one plane")
    x = T[0, :3, 0] - np.dot(T[0, :3, 0], n) * n
    if np.linalg.norm(x) < 0.1:
        x = T[0, :3, 1] - np.dot(T[0, :3, 1], n) * n
    e1 = x / np.linalg.norm(x)
    e2 = np.cross(n, e1)
    d = p - p[0]
    q = np.stack([d @ e1, d @ e2], -1)
    Re1 = R @ e1
    theta = np.arctan2(Re1 @ e2, Re1 @ e1)
    theta[0] = 0.0
    scale = float(position_spread(np.concatenate([q, np.zeros((len(q), 1))], axis=1))[1])
    if not scale > 0:
        raise SynthesisError(f"{source}: the tool origin does not move: the poses are rotations about it, which one "
                             "revolute joint performs; choose a tool point off the rotation axis")
    return PlanarTask(p[0].copy(), e1, e2, n, q, theta, np.zeros(2), scale)


def plane_normal(R, source: str) -> np.ndarray:
    """The rotation axis (3,) shared by most relative rotations R (k, 3, 3) (R[0] = I): each rotation's own
    axis (the null vector of R_i - I) is tried, the one most rotations keep fixed wins (the first on ties),
    refined over those rotations by one SVD; sign: largest component positive. So one pose off the plane is
    the one named, not the others."""
    A = R[1:] - np.eye(3)
    _, sv, Vt = np.linalg.svd(A)
    turned = sv[:, 0] >= ROTATION_MIN
    if not turned.any():
        raise SynthesisError(f"{source}: the poses differ by translations only: no revolute joint turns the tool; "
                             "rotate at least one pose about the plane's normal")
    axes = Vt[turned, -1]  # (m, 3)
    fixed = np.linalg.norm(np.einsum("kab,mb->mka", R, axes) - axes[:, None], axis=-1) <= COPLANAR_TOL
    best = int(np.argmax(fixed.sum(axis=1)))
    _, _, V = np.linalg.svd(A[fixed[best, 1:]].reshape(-1, 3))
    n = V[-1] / np.linalg.norm(V[-1])
    return n if n[np.argmax(np.abs(n))] > 0 else -n


def with_velocities(task: PlanarTask, velocity, names, source: str = "<poses>") -> PlanarTask:
    """The task with the prescribed tool twists ``velocity`` (k, 6) [w rad/s, v m/s of the tool origin] (NaN
    rows: none) as Hermite conditions: each in the plane as the velocity field X' = a + rate J X (conditioned
    coordinates, J the quarter turn), ``velocity`` rows [a, rate]. InputError naming a pose whose twist has
    only one part or leaves the plane."""
    rows, items = [], []
    for i, v in enumerate(np.asarray(velocity, float)):
        if np.isnan(v).all():
            continue
        if np.isnan(v).any():
            raise InputError(f"{source}: pose {i} ({names[i]}): a four-bar's velocity needs both 'angular' and "
                             "'linear'")
        w, lin = v[:3], v[3:]
        size = max(np.linalg.norm(w) * task.scale, np.linalg.norm(lin), 1e-300)
        if (np.linalg.norm(w - (w @ task.normal) * task.normal) * task.scale > COPLANAR_TOL * 1e3 * size
                or abs(lin @ task.normal) > COPLANAR_TOL * 1e3 * size):
            raise InputError(f"{source}: pose {i} ({names[i]}): its velocity leaves the plane of motion (the angular "
                             f"velocity must be along the normal ({', '.join(f'{x:.4f}' for x in task.normal)}) and "
                             "the linear one in the plane)")
        rate = float(w @ task.normal)
        vo = np.array([lin @ task.e1, lin @ task.e2]) / task.scale
        o = task.qc[i]
        rows.append([vo[0] + rate * o[1], vo[1] - rate * o[0], rate])  # a = v_o - rate J o
        items.append(i)
    return replace(task, velocity=np.array(rows, float).reshape(-1, 3), velocity_items=np.array(items, int))
