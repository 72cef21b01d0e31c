"""Hand-built linkages for exporter tests (no synthesis code involved).

`bennett_linkage()` is the Bennett linkage of MATH.md section 11 D. The factors printed there have 10
digits, so the loop built from them closes only to ~1e-9; we refine them by Newton's method on the
exact product equations (C = t^2 + c1 t + c0 with the rational c0, c1 of section 11 D):
    h1 + h2 = -c1,  h1 h2 = c0      and      k1 + k2 = -c1,  k1 k2 = c0,
which brings pose and closure errors down to ~1e-15.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.dq import dq_mul, plucker, quat_to_matrix
from synth.info import LinkageInfo
from synth.linkage import Joint, Linkage, PoseRecord
from synth.synthesis.bennett import bennett_parameters_of

C1 = np.array([-38 / 53, 40 / 53, 0, -20 / 53, 0, 15 / 212, -29 / 53, 83 / 212])
C0 = np.array([15 / 53, 0, 0, 20 / 53, 5 / 53, -15 / 106, 10 / 53, -15 / 212])

H1 = [0.2128367441, 0.08843778676, 0.3574025895, 0.09373229741, 0, 0.2366164531, -0.01103577354, -0.181171505]
H2 = [0.504144388, -0.8431547679, -0.3574025895, 0.2836261932, 0, -0.3073711701, 0.5582055849, -0.210337929]
K1 = [0.504144388, -0.8431547679, 0.3574025895, 0.2836261932, 0, 0.03216128991, 0.5264176378, -0.5677405185]
K2 = [0.2128367441, 0.08843778676, -0.3574025895, 0.09373229741, 0, -0.1029160069, 0.02075217352, 0.1762310845]


def _pose(position, wxyz):
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(np.array(wxyz, float))
    T[:3, 3] = position
    return T


POSES = [
    ("T0", _pose([0, 0, 0], [1, 0, 0, 0]), float("inf")),
    ("T1", _pose([1, 0, 0.5], [0.6, 0, 0, 0.8]), 0.0),
    ("T2", _pose([0.25, 1, 0.2], [0.6, 0.8, 0, 0]), 1.0),
]


def _refine(x, residual, steps=8):
    """Newton on an 8x8 polynomial system; the Jacobian by central differences (the map is quadratic,
    so central differences are exact up to rounding)."""
    x = np.array(x, float)
    for _ in range(steps):
        r = residual(x)
        if np.max(np.abs(r)) < 1e-15:
            break
        J = np.empty((8, 8))
        for i in range(8):
            e = np.zeros(8)
            e[i] = 1e-4
            J[:, i] = (residual(x + e) - residual(x - e)) / 2e-4
        x = x - np.linalg.solve(J, r)
    return x


def exact_factors():
    """(h1, h2, k1, k2) refined to rounding error."""
    h1 = _refine(H1, lambda h: dq_mul(h, -C1 - h) - C0)
    k2 = _refine(K2, lambda k: dq_mul(-C1 - k, k) - C0)
    return h1, -C1 - h1, -C1 - k2, k2


def _joint(name, parent, child, h):
    u, m = plucker(h)
    return Joint(name, parent, child, u, m, float(h[0]), float(np.linalg.norm(h[1:4])))


def bennett_linkage(exact: bool = True) -> Linkage:
    h1, h2, k1, k2 = exact_factors() if exact else (np.array(v, float) for v in (H1, H2, K1, K2))
    joints = [
        _joint("h1", "base", "link_h1", h1),
        _joint("h2", "link_h1", "coupler", h2),
        _joint("k1", "base", "link_k1", k1),
        _joint("k2", "link_k1", "coupler_k", k2),
    ]
    motion = np.array([C0, C1, [1, 0, 0, 0, 0, 0, 0, 0]], float)
    lk = Linkage(
        kind="bennett",
        joints=joints,
        links={"base": ["h1", "k1"], "link_h1": ["h1", "h2"], "link_k1": ["k1", "k2"],
               "coupler": ["h2", "k2"], "coupler_k": []},
        branches=[["h1", "h2"], ["k1", "k2"]],
        closures=[("coupler", "coupler_k")],
        tool_ref=np.eye(4),
        motion=motion,
    )
    for name, T, t in POSES:
        lk.poses.append(PoseRecord(name, T, t, {k: float(v) for k, v in lk.angles_at(t).items()}))
    pose_err = max(pose_error(lk.tool_pose(p.joint_angles), p.matrix) for p in lk.poses)
    lk.checks = {"max_pose_error": pose_err, "max_closure_error": closure_error(lk)}
    # MATH.md 11 D (norm roots 0.2128367441 + 0.3799257778 i, 0.504144388 + 0.9586920209 i): its Bennett parameters
    lk.info = LinkageInfo(bennett=bennett_parameters_of(lk))
    return lk


def pose_error(A, B):
    """Translation distance plus rotation angle between two 4x4 poses."""
    R = A[:3, :3].T @ B[:3, :3]
    s = np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2
    return float(np.linalg.norm(A[:3, 3] - B[:3, 3]) + np.arctan2(s, (np.trace(R) - 1) / 2))


def closure_error(lk: Linkage, samples: int = 200) -> float:
    """Largest pose error between coupler and coupler_k displacements over t = tan(phi)."""
    t = np.tan(np.linspace(-np.pi / 2, np.pi / 2, samples + 2)[1:-1])
    D = lk.displacements(lk.angles_at(t))
    worst = 0.0
    for a, b in lk.closures:
        worst = max(worst, max(pose_error(D[a][i], D[b][i]) for i in range(len(t))))
    return worst


def move_urdf_axis(urdf_path, joint: str, dx: float = 1e-3) -> None:
    """Add ``dx`` to the x component of a continuous joint's axis in a written URDF (a corrupted output
    for the checkers to catch)."""
    import re

    text = urdf_path.read_text()
    m = re.search(rf'(<joint name="{joint}" type="continuous">.*?<axis xyz=")([^"]+)"', text, re.S)
    axis = [float(v) for v in m.group(2).split()]
    axis[0] += dx
    urdf_path.write_text(text[:m.start(2)] + " ".join(repr(v) for v in axis) + text[m.end(2):])
