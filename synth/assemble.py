"""Build a two-branch single-loop linkage (Bennett, 6R) from two factorizations of one motion
polynomial, following OUTPUT.md's "two branches, one weld" convention."""
from __future__ import annotations

import numpy as np

from .dq import plucker
from .linkage import Joint, Linkage, PoseRecord


def joint_from_factor(name: str, parent: str, child: str, h) -> Joint:
    """Revolute joint t - h: Plücker line (u = -v/|v|, m = w/|v|) and angle law a = h0, b = |v|."""
    h = np.asarray(h, float)
    u, m = plucker(h)
    return Joint(name=name, parent=parent, child=child, direction=u, moment=m,
                 a=float(h[0]), b=float(np.linalg.norm(h[1:4])))


def two_branch_linkage(kind: str, H, K, motion, poses, names, ts, info=None) -> Linkage:
    """Linkage with branch h: base -h1-> link_h1 ... -hn-> coupler and branch k likewise ending in
    coupler_k. H, K: (n, 8) factors in the world frame (metres) with C = (t-h1)...(t-hn) =
    (t-k1)...(t-kn); poses (m, 4, 4) with parameters ts (first = inf)."""
    H = np.asarray(H, float)
    K = np.asarray(K, float)
    n = H.shape[0]
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
    for name, T, t in zip(names, poses, ts):
        ang = {j.name: float(j.angle(t)) for j in joints}
        linkage.poses.append(PoseRecord(name=name, matrix=np.asarray(T, float), t=float(t), joint_angles=ang))
    return linkage
