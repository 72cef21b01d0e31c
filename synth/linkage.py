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

import enum
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from synth.algebra.anglelaw import angle_law, angle_law_inverse
from synth.algebra.fourbar_loop import FourBarLaw
from synth.algebra.geometry import extent, joint_sites, line_point, rotation_about_line
from synth.info import Counts, LinkageInfo


class Kind(enum.StrEnum):
    """What a linkage is; the values are linkage.json's ``kind`` strings."""

    BENNETT = "bennett"  # spatial Bennett 4R (docs/conic.md)
    SIXBAR = "6r"  # spatial 6R of a cubic motion (docs/cubic.md)
    PLANAR_4R = "planar_4r"  # four-bar of planar poses (docs/planar.md)
    SPHERICAL_4R = "spherical_4r"
    PLANAR_SIXBAR = "planar_sixbar"  # Watt six-bar of planar poses (docs/planar.md)
    SPHERICAL_SIXBAR = "spherical_sixbar"
    MOTION = "motion"  # multi-loop linkage performing a rational motion (docs/exceptional.md)
    CURVE = "curve"  # multi-loop linkage whose tracer draws a rational curve
    PLANAR_FOURBAR = "planar_fourbar"  # the classical four-bar of 3 or more planar poses (docs/fourbar.md)

    @property
    def label(self) -> str:
        """The kind in words, for titles and summaries ("spatial 6R")."""
        return KIND_LABELS.get(self, self.value)


KIND_LABELS = {Kind.BENNETT: "Bennett 4R", Kind.SIXBAR: "spatial 6R", Kind.PLANAR_4R: "planar four-bar",
               Kind.SPHERICAL_4R: "spherical four-bar", Kind.PLANAR_SIXBAR: "planar Watt six-bar",
               Kind.SPHERICAL_SIXBAR: "spherical Watt six-bar"}
_KINDS = {k.value: k for k in Kind}


def kind_label(kind) -> str:
    """`Kind.label` of a kind or its string; an unknown string (an output read back) as it is."""
    k = _KINDS.get(kind)
    return k.label if k is not None else str(kind)


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
    law: FourBarLaw | None = None  # a planar four-bar's loop law: the angle is law.angle(crank angle), the
    # crank's angle being the law (a, b) above (docs/fourbar.md); None: (a, b, rate) is this joint's own law

    @property
    def point(self) -> np.ndarray:
        """Point of the axis closest to the world origin (metres)."""
        return line_point(self.direction, self.moment)

    def angle(self, t):
        """Joint angle (rad) at parameter t (scalar or array; +-inf gives 0), in [0, 2pi)."""
        theta = angle_law(self.a, self.b, t, self.rate)
        return theta if self.law is None else self.law.angle(theta)

    def parameter(self, theta, branch: int = 0):
        """Parameter t where the joint is at angle theta (`synth.algebra.anglelaw.angle_law_inverse`;
        a joint of rate r reaches every angle at r parameters, ``branch`` 0 .. r - 1); theta = 0: inf.
        Not for a joint with a loop ``law`` (its angle is not a bijection of the cycle): ValueError."""
        if self.law is not None:
            raise ValueError(f"joint {self.name} follows a loop law: invert the crank's angle law instead")
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

    kind: Kind  # (a `Kind` value given as a string becomes the Kind; another string, read back, stays)
    joints: list[Joint]  # tree joints, in an order where every parent link precedes its child
    links: dict[str, list[str]]  # link name -> joints whose pins it carries (empty: no geometry)
    branches: list[list[str]]  # joint names of each serial branch, base to coupler
    closures: list[tuple[str, str]]  # (link, duplicate link) welded pairs
    tool_ref: np.ndarray  # (4,4) tool frame at the reference configuration (= first pose)
    motion: np.ndarray  # (n+1, 8) monic motion polynomial of the coupler, world frame, metres
    poses: list[PoseRecord] = field(default_factory=list)
    tool_link: str = "coupler"
    checks: dict[str, float] = field(default_factory=dict)
    info: LinkageInfo = field(default_factory=LinkageInfo)  # what the synthesis found (`synth.info`)

    def __post_init__(self):
        self.kind = _KINDS.get(self.kind, self.kind)

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
        its pins are); for a joint that no link pairs, the axis point nearest the pose positions
        (`synth.algebra.geometry.joint_sites`). Unlike ``Joint.point`` (nearest the world origin) it stays
        near the mechanism wherever the world origin is."""
        index = {j.name: i for i, j in enumerate(self.joints)}
        pairs = []
        for names in self.links.values():
            ids = [index[n] for n in names if n in index]
            pairs += zip(ids, ids[1:])
        U = np.array([j.direction for j in self.joints], float).reshape(-1, 3)
        M = np.array([j.moment for j in self.joints], float).reshape(-1, 3)
        centre = self._pose_centre()
        key = (tuple(index), tuple(pairs), U.tobytes(), M.tobytes(), centre.tobytes())  # the sites' inputs
        cached = self.__dict__.get("_sites")  # the design search asks many times (issue 36)
        if cached is None or cached[0] != key:
            cached = (key, joint_sites(U, M, pairs, centre))
            self.__dict__["_sites"] = cached
        return {name: cached[1][i].copy() for i, name in enumerate(index)}

    def _pose_centre(self) -> np.ndarray:
        pts = [p.matrix[:3, 3] for p in self.poses] + [self.tool_ref[:3, 3]]
        return np.mean(pts, axis=0)

    def counts(self) -> Counts:
        """Joints, links (without the welded duplicates), links with them, loops (a multi-loop linkage's
        ``info.synthesis.counts``)."""
        return Counts(joints=len(self.joints), links=len(self.links) - len(self.closures),
                      links_with_duplicates=len(self.links), loops=len(self.closures))

    def extent(self) -> float:
        """A length scale of the linkage (`synth.algebra.geometry.extent`): RMS distance of the joint sites
        (see ``joint_sites``) and the tool positions from their centroid, at least 1e-9 m."""
        pts = list(self.joint_sites().values()) + [p.matrix[:3, 3] for p in self.poses]
        return float(extent(np.array(pts + [self.tool_ref[:3, 3]], float)))
