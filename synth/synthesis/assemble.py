"""Build a two-branch single-loop linkage (Bennett, 6R) from two factorizations of one motion
polynomial, following the "two branches, one weld" convention of docs/conventions.md."""
from __future__ import annotations

import functools
import math

import numpy as np

from synth.linkage import Joint, Linkage, PoseRecord

TWO_PI = 2.0 * math.pi
INF = math.inf


def joint_from_factor(name: str, parent: str, child: str, h) -> Joint:
    """Revolute joint t - h: Plücker line (u = -v/|v|, m = w/|v|) and angle law a = h0, b = |v|."""
    h0, v1, v2, v3, _, w1, w2, w3 = map(float, h.tolist() if isinstance(h, np.ndarray) else h)
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
    (t-k1)...(t-kn); poses (m, 4, 4) with parameters ts (first = inf). ``motion=None`` leaves
    ``linkage.motion`` None (for a caller that sets it later)."""
    specs, links, branches = _layout(len(H))
    laws, lines = [], []
    for h in (*H, *K):  # joint_from_factor, with all Plücker coordinates in one array
        if type(h) is not tuple:
            h = h.tolist() if isinstance(h, np.ndarray) else tuple(map(float, h))
        h0, v1, v2, v3, _, w1, w2, w3 = h
        b = math.sqrt(v1 * v1 + v2 * v2 + v3 * v3)
        laws.append((float(h0), b))
        lines += (-v1 / b, -v2 / b, -v3 / b, w1 / b, w2 / b, w3 / b)
    lines = np.array(lines, float).reshape(-1, 3)
    joints = [Joint(name, parent, child, lines[2 * i], lines[2 * i + 1], a, b)
              for i, ((name, parent, child), (a, b)) in enumerate(zip(specs, laws))]
    poses = np.asarray(poses, float)
    jn = [spec[0] for spec in specs]
    records = []
    for name, T, t in zip(names, poses, map(float, ts)):
        if t == INF or t == -INF:  # as _angle
            ang = dict.fromkeys(jn, 0.0)
        else:
            ang = {n: (2.0 * math.atan2(b, t - a)) % TWO_PI for n, (a, b) in zip(jn, laws)}
        records.append(PoseRecord(name, T, t, ang))
    return Linkage(kind, joints, {k: list(v) for k, v in links.items()}, [list(x) for x in branches],
                   [("coupler", "coupler_k")], poses[0], None if motion is None else np.asarray(motion, float),
                   records, info=dict(info) if info else {})


@functools.lru_cache(maxsize=None)
def _layout(n: int):
    """(joint (name, parent, child) in tree order, links, branches) of two branches of n joints."""
    specs = []
    links: dict[str, tuple] = {"base": ("h1", "k1")}
    for branch in "hk":
        for i in range(n):
            parent = "base" if i == 0 else f"link_{branch}{i}"
            if i == n - 1:
                child = "coupler" if branch == "h" else "coupler_k"
            else:
                child = f"link_{branch}{i + 1}"
                links[child] = (f"{branch}{i + 1}", f"{branch}{i + 2}")
            specs.append((f"{branch}{i + 1}", parent, child))
    links["coupler"] = (f"h{n}", f"k{n}")
    links["coupler_k"] = ()
    branches = (tuple(f"h{i + 1}" for i in range(n)), tuple(f"k{i + 1}" for i in range(n)))
    return tuple(specs), links, branches
