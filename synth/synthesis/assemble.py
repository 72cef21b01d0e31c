"""Build a two-branch single-loop linkage (Bennett, 6R) from two factorizations of one motion
polynomial, following the "two branches, one weld" convention of docs/conventions.md."""
from __future__ import annotations

import functools

import numpy as np

from synth.algebra.anglelaw import angle_law
from synth.algebra.dq import factor_lines
from synth.info import LinkageInfo
from synth.linkage import Joint, Linkage, PoseRecord


def joint_from_factor(name: str, parent: str, child: str, h) -> Joint:
    """Revolute joint t - h: Plücker line (u = -v/|v|, m = w/|v|) and angle law a = h0, b = |v|
    (`synth.algebra.dq.factor_lines`)."""
    lines, laws = _joint_lines([h])
    (a, b), = laws
    return Joint(name=name, parent=parent, child=child, direction=lines[0, 0], moment=lines[0, 1], a=a, b=b)


def pose_records(joints, poses, names, ts, angles=None) -> list[PoseRecord]:
    """One PoseRecord per pose (4x4 matrix, name, parameter t) with every joint's angle there
    (`synth.algebra.anglelaw.angle_law`, all poses and joints in one call; ``angles`` (poses, joints):
    these angle laws' values, when the caller has them already)."""
    ts = np.asarray(ts, float).tolist()
    if angles is None:
        law = np.array([(j.a, j.b, j.rate) for j in joints], float).reshape(-1, 3).T
        rate = law[2] if any(j.rate != 1 for j in joints) else 1
        angles = angle_law(law[0], law[1], np.array(ts)[:, None], rate)
    ang = np.asarray(angles, float).tolist()
    jn = [j.name for j in joints]
    return [PoseRecord(name, T, t, dict(zip(jn, row))) for name, T, t, row in zip(names, poses, ts, ang)]


def two_branch_linkage(kind: str, H, K, motion, poses, names, ts, info: LinkageInfo | None = None, rates=None, angles=None,
                       lines=None) -> Linkage:
    """Linkage with branch h: base -h1-> link_h1 ... -hn-> coupler and branch k likewise ending in
    coupler_k. H, K: (n, 8) and (m, 8) factors in the world frame (metres) with C = (t-h1)...(t-hn) =
    (t-k1)...(t-kn) (m = n but for joints of rate other than 1: ``rates`` (n + m,) in the order h, k, the
    products of (t - h)^rate being C times real polynomials, docs/exceptional.md section 6); poses (m, 4, 4)
    with parameters ts (first = inf). ``motion=None`` leaves ``linkage.motion`` None (for a caller that
    sets it later). ``angles``: the joints' angles at the poses (`pose_records`), when at hand.
    ``lines``: the joints' (lines (n + m, 2, 3), angle laws (n + m, 2)) in the order h, k, when at hand
    (`synth.synthesis.bennett_core.solve` computes them from the factors and certifies those)."""
    specs, links, branches = _layout(len(H), len(K))
    if lines is None:
        lines, laws = _joint_lines((*H, *K))
    else:
        lines, laws = np.array(lines[0], float), lines[1].tolist()
    rates = [1] * len(laws) if rates is None else [int(r) for r in rates]
    joints = [Joint(name, parent, child, line[0], line[1], a, b, r)
              for (name, parent, child), line, (a, b), r in zip(specs, lines, laws, rates)]
    poses = np.asarray(poses, float)
    records = pose_records(joints, poses, names, ts, angles)
    return Linkage(kind, joints, {k: list(v) for k, v in links.items()}, [list(x) for x in branches],
                   [("coupler", "coupler_k")], poses[0], None if motion is None else np.asarray(motion, float),
                   records, info=info or LinkageInfo())


def _joint_lines(factors) -> tuple:
    """(lines (J, 2, 3), angle laws [(a, b)] * J) of the joints t - h of the factors h (8,) (arrays or
    sequences of numbers, `synth.algebra.dq.factor_lines`)."""
    lines, laws = factor_lines(np.array([np.asarray(h, float) for h in factors]))
    return lines, laws.tolist()


@functools.lru_cache(maxsize=None)
def _layout(n: int, m: int):
    """(joint (name, parent, child) in tree order, links, branches) of two branches of n (h) and m (k)
    joints."""
    specs = []
    links: dict[str, tuple] = {"base": ("h1", "k1")}
    for branch, count in (("h", n), ("k", m)):
        for i in range(count):
            parent = "base" if i == 0 else f"link_{branch}{i}"
            if i == count - 1:
                child = "coupler" if branch == "h" else "coupler_k"
            else:
                child = f"link_{branch}{i + 1}"
                links[child] = (f"{branch}{i + 1}", f"{branch}{i + 2}")
            specs.append((f"{branch}{i + 1}", parent, child))
    links["coupler"] = (f"h{n}", f"k{m}")
    links["coupler_k"] = ()
    branches = (tuple(f"h{i + 1}" for i in range(n)), tuple(f"k{i + 1}" for i in range(m)))
    return tuple(specs), links, branches


WATT_JOINTS = (("h1", "base", "link_h1"), ("h2", "link_h1", "link_h2"), ("h3", "link_h2", "coupler"),
               ("k2", "link_h1", "link_k2"), ("k3", "link_k2", "coupler_k"),
               ("g1", "base", "link_g1"), ("g2", "link_g1", "link_h2_g"))
WATT_LINKS = {"base": ["h1", "g1"], "link_h1": ["h1", "h2", "k2"], "link_h2": ["h2", "h3", "g2"],
              "coupler": ["h3", "k3"], "link_k2": ["k2", "k3"], "link_g1": ["g1", "g2"],
              "coupler_k": [], "link_h2_g": []}


def watt_linkage(kind: str, F, motion, poses, names, ts, info: LinkageInfo | None = None) -> Linkage:
    """The Watt six-bar of three factorizations of one cubic sharing factors (docs/planar.md, section 4):
    ``C = (t-h1)(t-h2)(t-h3) = (t-h1)(t-k2)(t-k3) = (t-g1)(t-g2)(t-h3)``; F (7, 8) = h1 h2 h3 k2 k3 g1 g2 in
    the world frame (metres). Links: base (h1, g1), link_h1 (h1, h2, k2), link_h2 (h2, h3, g2), coupler
    (h3, k3), link_k2 (k2, k3), link_g1 (g1, g2); two loops, cut at the coupler (duplicate ``coupler_k``)
    and at link_h2 (duplicate ``link_h2_g``), welded as in docs/conventions.md, section 6."""
    joints = [joint_from_factor(n, p, c, h) for (n, p, c), h in zip(WATT_JOINTS, np.asarray(F, float))]
    records = pose_records(joints, np.asarray(poses, float), names, ts)
    return Linkage(kind, joints, {k: list(v) for k, v in WATT_LINKS.items()},
                   [["h1", "h2", "h3"], ["h1", "k2", "k3"], ["g1", "g2"]],
                   [("coupler", "coupler_k"), ("link_h2", "link_h2_g")], np.asarray(poses, float)[0],
                   np.asarray(motion, float), records, info=info or LinkageInfo())
