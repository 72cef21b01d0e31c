"""Build a two-branch single-loop linkage (Bennett, 6R) from two factorizations of one motion
polynomial, following OUTPUT.md's "two branches, one weld" convention."""
from __future__ import annotations

import math

import numpy as np

from .linkage import Joint, Linkage, PoseRecord


def joint_from_factor(name: str, parent: str, child: str, h) -> Joint:
    """Revolute joint t - h: Plücker line (u = -v/|v|, m = w/|v|) and angle law a = h0, b = |v|."""
    h0, v1, v2, v3, _, w1, w2, w3 = (float(x) for x in (h.tolist() if isinstance(h, np.ndarray) else h))
    b = math.sqrt(v1 * v1 + v2 * v2 + v3 * v3)
    return Joint(name=name, parent=parent, child=child, direction=np.array([-v1 / b, -v2 / b, -v3 / b]),
                 moment=np.array([w1 / b, w2 / b, w3 / b]), a=h0, b=b)


def _angle(a: float, b: float, t: float) -> float:
    """`Joint.angle` for a scalar t, in plain floats: 2 atan2(b, t - a) mod 2 pi, 0 at t = +-inf."""
    if math.isinf(t):
        return 0.0
    return (2.0 * math.atan2(b, t - a)) % (2.0 * math.pi)


def two_branch_linkage(kind: str, H, K, motion, poses, names, ts, info=None) -> Linkage:
    """Linkage with branch h: base -h1-> link_h1 ... -hn-> coupler and branch k likewise ending in
    coupler_k. H, K: (n, 8) factors in the world frame (metres) with C = (t-h1)...(t-hn) =
    (t-k1)...(t-kn); poses (m, 4, 4) with parameters ts (first = inf)."""
    n = len(H)
    joints: list[Joint] = []
    links: dict[str, list[str]] = {"base": ["h1", "k1"]}
    for branch, F in (("h", H), ("k", K)):
        for i in range(n):
            parent = "base" if i == 0 else f"link_{branch}{i}"
            if i == n - 1:
                child = "coupler" if branch == "h" else "coupler_k"
            else:
                child = f"link_{branch}{i + 1}"
                links[child] = [f"{branch}{i + 1}", f"{branch}{i + 2}"]
            joints.append(joint_from_factor(f"{branch}{i + 1}", parent, child, F[i]))
    links["coupler"] = [f"h{n}", f"k{n}"]
    links["coupler_k"] = []
    linkage = Linkage(
        kind=kind,
        joints=joints,
        links=links,
        branches=[[f"h{i + 1}" for i in range(n)], [f"k{i + 1}" for i in range(n)]],
        closures=[("coupler", "coupler_k")],
        tool_ref=np.asarray(poses[0], float),
        motion=np.asarray(motion, float),
        info=dict(info or {}),
    )
    poses = np.asarray(poses, float)
    for name, T, t in zip(names, poses, np.asarray(ts, float).tolist()):
        ang = {j.name: _angle(j.a, j.b, t) for j in joints}
        linkage.poses.append(PoseRecord(name=name, matrix=T, t=t, joint_angles=ang))
    return linkage
