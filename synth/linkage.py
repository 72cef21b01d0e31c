"""The linkage: a plain data object shared by every synthesis and every exporter.

Conventions (see docs/conventions.md, sections 4-6):
- lengths in metres, angles in radians, everything in the world frame of the poses;
- the *reference configuration* is the first pose (t = infinity, all joint angles 0);
- a joint is a revolute axis given as a normalized Plücker line (unit `direction`, `moment` =
  point x direction) at the reference configuration, and an angle law
  ``theta(t) = rate * 2 atan2(b, t - a)`` (`synth.algebra.anglelaw`; 0 at t = infinity, ``rate`` full turns
  as t runs over R; rate 1 but for a repeated factor (t - h)^rate, docs/exceptional.md section 6);
- the joints form a tree rooted at link ``base``; each joint moves its ``child`` relative to its
  ``parent`` by ``disp(child) = disp(parent) @ Rot(line, theta)`` where ``disp`` is a link's world
  displacement from the reference configuration (product of exponentials);
- each closed loop is cut by duplicating one link: ``closures`` lists (link, duplicate) pairs whose
  relative transform is constant over the motion (URDF ``<gazebo>`` weld);
- the tool frame hangs rigidly on ``tool_link``; at the reference configuration it is ``tool_ref``.

Nothing here reads or writes files.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from synth.algebra.anglelaw import angle_law, angle_law_inverse
from synth.algebra.dq import common_normal_feet, rotation_about_line


@dataclass
class Joint:
    """A revolute joint: Plücker line at the reference configuration and its angle law."""

    name: str
    parent: str
    child: str
    direction: np.ndarray  # (3,) unit
    moment: np.ndarray  # (3,) metres
    a: float  # angle law theta(t) = rate * 2 atan2(b, t - a)
    b: float
    rate: int = 1  # the joint of a factor (t - h)^rate (docs/exceptional.md, section 6)

    @property
    def point(self) -> np.ndarray:
        """Point of the axis closest to the world origin (metres)."""
        return np.cross(self.direction, self.moment)

    def angle(self, t):
        """Joint angle (rad) at parameter t (scalar or array; +-inf gives 0), in [0, 2pi)."""
        return angle_law(self.a, self.b, t, self.rate)

    def parameter(self, theta, branch: int = 0):
        """Parameter t where the joint is at angle theta (`synth.algebra.anglelaw.angle_law_inverse`;
        a joint of rate r reaches every angle at r parameters, ``branch`` 0 .. r - 1); theta = 0: inf."""
        return angle_law_inverse(self.a, self.b, theta, self.rate, branch)


@dataclass
class PoseRecord:
    """One task pose: its name, the 4x4 matrix (metres), its parameter t and the joint angles there."""

    name: str
    matrix: np.ndarray
    t: float
    joint_angles: dict[str, float]
    kind: str = "pose"  # "point": only the tool frame's origin was prescribed (docs/points.md)
    error: tuple[float, float] | None = None  # (metres, radians): the tool frame's miss at joint_angles (fits)
    tolerance: tuple[float, float] | None = None  # (metres, radians), inf = free; None: exact or no task tolerance
    exact: bool = False  # a pose of a fit that is met to machine precision


@dataclass
class Linkage:
    """A synthesized closed-loop linkage (one or several loops)."""

    kind: str  # "bennett", "6r", "motion", "curve"
    joints: list[Joint]  # tree joints, in an order where every parent link precedes its child
    links: dict[str, list[str]]  # link name -> joints whose pins it carries (empty: no geometry)
    branches: list[list[str]]  # joint names of each serial branch, base to coupler
    closures: list[tuple[str, str]]  # (link, duplicate link) welded pairs
    tool_ref: np.ndarray  # (4,4) tool frame at the reference configuration (= first pose)
    motion: np.ndarray  # (n+1, 8) monic motion polynomial of the coupler, world frame, metres
    poses: list[PoseRecord] = field(default_factory=list)
    tool_link: str = "coupler"
    checks: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)  # kind-specific extras, JSON-serializable

    # ------------------------------------------------------------------ queries
    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    @property
    def link_names(self) -> list[str]:
        names = ["base"]
        for j in self.joints:
            if j.child not in names:
                names.append(j.child)
        return names

    def angles_at(self, t) -> dict[str, np.ndarray]:
        """Joint angles (rad) at parameter(s) t."""
        return {j.name: j.angle(t) for j in self.joints}

    def displacements(self, angles: dict[str, Any]) -> dict[str, np.ndarray]:
        """World displacement (4x4, or (...,4,4) for array angles) of every link from the reference
        configuration, for the given joint angles."""
        out: dict[str, np.ndarray] = {"base": np.eye(4)}
        for j in self.joints:
            R = rotation_about_line(j.direction, j.moment, np.asarray(angles[j.name], float))
            out[j.child] = out[j.parent] @ R
        return out

    def tool_pose(self, angles: dict[str, Any]) -> np.ndarray:
        """World pose of the tool frame for the given joint angles."""
        return self.displacements(angles)[self.tool_link] @ self.tool_ref

    def joint_sites(self) -> dict[str, np.ndarray]:
        """A representative point on every joint axis (metres, reference configuration): the mean of
        the feet of the common normals to the neighbouring axes of the links carrying the joint (where
        its pins are); for a joint that no link pairs, the axis point nearest the pose positions.
        Unlike ``Joint.point`` (nearest the world origin) it stays near the mechanism wherever the
        world origin is."""
        feet: dict[str, list[np.ndarray]] = {j.name: [] for j in self.joints}
        byname = {j.name: j for j in self.joints}
        for names in self.links.values():
            js = [byname[n] for n in names if n in byname]
            for j1, j2 in zip(js, js[1:]):
                f1, f2 = pair_feet(j1, j2)
                feet[j1.name].append(f1)
                feet[j2.name].append(f2)
        centre = self._pose_centre()
        out = {}
        for j in self.joints:
            if feet[j.name]:
                out[j.name] = np.mean(feet[j.name], axis=0)
            else:
                out[j.name] = j.point + np.dot(centre - j.point, j.direction) * j.direction
        return out

    def _pose_centre(self) -> np.ndarray:
        pts = [p.matrix[:3, 3] for p in self.poses] + [self.tool_ref[:3, 3]]
        return np.mean(pts, axis=0)

    def counts(self) -> dict[str, int]:
        """``info["counts"]`` of a multi-loop linkage: joints, links (without the welded duplicates),
        links with them, loops."""
        return {"joints": len(self.joints), "links": len(self.links) - len(self.closures),
                "links_with_duplicates": len(self.links), "loops": len(self.closures)}

    def extent(self) -> float:
        """A length scale of the linkage: RMS distance of the joint sites (see ``joint_sites``) and the
        tool positions from their centroid, at least 1e-9 m."""
        pts = list(self.joint_sites().values()) + [p.matrix[:3, 3] for p in self.poses]
        pts = np.array(pts + [self.tool_ref[:3, 3]])
        c = pts.mean(axis=0)
        return float(max(np.sqrt(np.mean(np.sum((pts - c) ** 2, axis=1))), 1e-9))


def pair_feet(j1: Joint, j2: Joint) -> tuple[np.ndarray, np.ndarray]:
    """Feet of the common normal of two joint axes (on j1, on j2). Parallel axes have no unique common
    normal: take the one through the midpoint of the two axis points nearest the origin."""
    u1, u2 = j1.direction, j2.direction
    if np.linalg.norm(np.cross(u1, u2)) < 1e-9:
        mid = (j1.point + j2.point) / 2
        f1 = j1.point + np.dot(mid - j1.point, u1) * u1
        f2 = j2.point + np.dot(f1 - j2.point, u2) * u2
        return f1, f2
    return common_normal_feet(u1, j1.moment, u2, j2.moment)
