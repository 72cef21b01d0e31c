"""A ranked four-bar as a `Linkage` in the world frame (docs/fourbar.md, section 4).

Joints (every axis along the plane's normal n, angles counter-clockwise about n): ``h1`` at the crank's
fixed pivot A0 (base -> link_h1, the driver), ``h2`` at its moving pivot A1 (link_h1 -> coupler), ``k1``
at the rocker's fixed pivot B0 (base -> link_k1), ``k2`` at B1 (link_k1 -> coupler_k); the loop is welded
at coupler / coupler_k. The reference configuration (all angles 0) is the four-bar at pose 0's crank
angle. The crank's angle law is ``theta = 2 atan2(1, t)`` (a = 0, b = 1); h2, k1 and k2 follow the loop
law `synth.algebra.fourbar_loop.FourBarLaw` of the crank's angle. The motion of a general four-bar's
coupler is not a motion polynomial: ``linkage.motion`` is None.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.anglelaw import angle_law_inverse
from synth.algebra.fourbar_loop import ROLES, FourBarLaw, loop_angles
from synth.algebra.geometry import rotation_about_axis
from synth.info import LinkageInfo
from synth.linkage import Joint, Kind, Linkage, PoseRecord
from synth.synthesis.fourbar_plane import PlanarTask
from synth.synthesis.fourbar_rank import FourBars, coupler_poses

LINKS = {"base": ["h1", "k1"], "link_h1": ["h1", "h2"], "coupler": ["h2", "k2"], "link_k1": ["k1", "k2"],
         "coupler_k": []}
TREE = (("h1", "base", "link_h1"), ("h2", "link_h1", "coupler"), ("k1", "base", "link_k1"),
        ("k2", "link_k1", "coupler_k"))


def reference_pivots(fb: FourBars, n: int) -> np.ndarray:
    """(4, 2) conditioned plane positions of A0, A1, B0, B1 at the reference configuration of four-bar n."""
    phi = fb.phi[n, 0]
    A1 = fb.A0[n] + fb.crank[n] * np.array([np.cos(phi), np.sin(phi)])
    d = fb.B0[n] - A1
    L = np.linalg.norm(d)
    cos_a = np.clip((fb.coupler[n] ** 2 + L * L - fb.rocker[n] ** 2) / (2 * fb.coupler[n] * L), -1.0, 1.0)
    psi = np.arctan2(d[1], d[0]) + fb.branch[n] * np.arccos(cos_a)
    return np.array([fb.A0[n], A1, fb.B0[n], A1 + fb.coupler[n] * np.array([np.cos(psi), np.sin(psi)])])


def fourbar_linkage(task: PlanarTask, fb: FourBars, n: int, T, names, info: LinkageInfo) -> Linkage:
    """The Linkage of four-bar ``n`` of ``fb`` through the poses T (k, 4, 4) (metres) named ``names``; its
    pose records carry the joint angles at each pose's crank angle (and ``error``, the tool frame's miss
    there, metres and radians, for a fit)."""
    T = np.asarray(T, float)
    s = task.scale
    P = task.to_world(reference_pivots(fb, n))
    u = task.normal
    d = fb.B0[n] - fb.A0[n]
    law = dict(ground=fb.ground[n] * s, crank=fb.crank[n] * s, coupler=fb.coupler[n] * s, rocker=fb.rocker[n] * s,
               crank_ref=float(fb.phi[n, 0] - np.arctan2(d[1], d[0])), branch=int(fb.branch[n]))
    law = {k: float(v) if k != "branch" else v for k, v in law.items()}
    site = {"h1": P[0], "h2": P[1], "k1": P[2], "k2": P[3]}
    joints = [Joint(name, parent, child, u.copy(), np.cross(site[name], u), 0.0, 1.0,
                    law=None if name == "h1" else FourBarLaw(**law, joint=name))
              for name, parent, child in TREE]
    theta = np.mod(fb.phi[n] - fb.phi[n, 0], 2 * np.pi)
    q = np.mod(loop_angles(law["ground"], law["crank"], law["coupler"], law["rocker"], law["crank_ref"],
                           law["branch"], theta), 2 * np.pi)  # (4, k)
    q[:, 0] = 0.0
    ts = angle_law_inverse(0.0, 1.0, theta)
    records = [PoseRecord(str(name), T[i], float(ts[i]), dict(zip(ROLES, map(float, q[:, i]))))
               for i, name in enumerate(names)]
    tool_ref = reference_displacement(task, fb, n) @ T[0]
    return Linkage(Kind.PLANAR_FOURBAR, joints, {k: list(v) for k, v in LINKS.items()}, [["h1", "h2"], ["k1", "k2"]],
                   [("coupler", "coupler_k")], tool_ref, None, records, info=info)


def reference_displacement(task: PlanarTask, fb: FourBars, n: int) -> np.ndarray:
    """World 4x4 displacement of the coupler from pose 0's plane position to the reference configuration
    (the identity, to rounding, for an exact task)."""
    tool, beta = coupler_poses(task, _row(fb, n), fb.phi[n:n + 1, :1])
    R = rotation_about_axis(task.normal, float(beta[0, 0]))
    D = np.eye(4)
    D[:3, :3] = R
    D[:3, 3] = task.to_world(tool[0, 0]) - R @ task.origin  # pose 0's tool origin goes to tool[0, 0]
    return D


def _row(fb: FourBars, n: int) -> FourBars:
    sl = slice(n, n + 1)
    return FourBars(fb.A0[sl], fb.B0[sl], fb.wa[sl], fb.wb[sl], fb.ground[sl], fb.crank[sl], fb.coupler[sl],
                    fb.rocker[sl], fb.branch[sl], fb.phi[sl], fb.error[sl])
