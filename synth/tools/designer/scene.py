"""What the designer's page draws of a linkage: a stick figure over one cycle of its motion.

Every link is a polyline through the sites of the joints it carries (`Linkage.joint_sites`), every
joint a short segment along its axis, the tool a frame, plus the tool path and the task poses. All
positions are in the task's length unit (the page shows the task's numbers), rounded to 1e-5 of the
figure's size; frames sample the cycle uniformly in phi = atan(t) (`synth.io.readback.cycle_parameters`,
the cheap spacing: this is redrawn on every change).
"""
from __future__ import annotations

import numpy as np

from synth.io.readback import cycle_parameters

FRAMES = 72  # samples of one cycle
PATH_SAMPLES = 240  # samples of the tool path


def _rounded(a: np.ndarray, size: float) -> list:
    """``a`` rounded to about 1e-5 of ``size`` (decimal places: short JSON numbers)."""
    digits = int(5 - np.floor(np.log10(max(size, 1e-300))))
    return np.round(np.asarray(a, float), digits).tolist()


def scene(linkage, scale: float, frames: int = FRAMES) -> dict:
    """The page's drawing of ``linkage`` (metres) in task units (``scale`` metres per unit): ``links``
    [{name, points (F, k, 3)}], ``axes`` [{name, ends (F, 2, 3)}], ``tool`` (F, 4, 4) row-major,
    ``path`` (S, 3), ``t`` (F,) parameters (None: inf), ``size`` (a length of the figure)."""
    ts = cycle_parameters(linkage, frames, spacing="phi")
    ts = np.roll(ts, 1)  # frame 0: t = inf, the reference configuration
    disp = linkage.displacements(linkage.angles_at(ts))  # link -> (F, 4, 4)
    sites = linkage.joint_sites()
    tool = np.broadcast_to(disp[linkage.tool_link], (len(ts), 4, 4)) @ linkage.tool_ref
    path_t = cycle_parameters(linkage, PATH_SAMPLES, spacing="phi")
    path = linkage.tool_pose(linkage.angles_at(path_t))[:, :3, 3]
    pts = np.array(list(sites.values()) + [p.matrix[:3, 3] for p in linkage.poses], float)
    size = float(np.ptp(np.concatenate([pts, path]), axis=0).max()) or 1.0
    half = 0.06 * size

    def moved(link, p):  # (F, 3): point p (metres, reference) carried by link
        D = np.broadcast_to(disp[link], (len(ts), 4, 4))
        return np.einsum("fij,j->fi", D[..., :3, :3], p) + D[..., :3, 3]

    links = []
    for name, joints in linkage.links.items():
        if len(joints) >= 2 and name in disp:
            P = np.stack([moved(name, sites[j]) for j in joints], axis=1)
            links.append({"name": name, "points": _rounded(P / scale, size / scale)})
    axes = []
    for j in linkage.joints:
        d = np.asarray(j.direction, float)
        ends = np.stack([moved(j.child, sites[j.name] - half * d), moved(j.child, sites[j.name] + half * d)], axis=1)
        axes.append({"name": j.name, "ends": _rounded(ends / scale, size / scale)})
    T = tool.copy()
    T[:, :3, 3] /= scale
    return {"links": links, "axes": axes, "tool": _rounded(T, size / scale),
            "path": _rounded(path / scale, size / scale),
            "t": [None if np.isinf(t) else float(t) for t in ts], "size": size / scale}


def pose_frames(matrices: np.ndarray, scale: float) -> list:
    """(N, 4, 4) task poses (metres) -> row-major lists in task units."""
    T = np.array(matrices, float).copy()
    T[:, :3, 3] /= scale
    return T.round(12).tolist()


def clearances(linkage, collision, scale: float) -> dict:
    """The design's collision status for colours, lengths in task units: ``free``, ``clearance`` (the gap
    asked for), ``min_distance`` (the smallest gap found), and ``bodies``: {body: its smallest gap} for every
    link or pin of an offending pair (`synth.design.model.CollisionReport.pairs`); links not named keep
    at least the clearance."""
    bodies: dict[str, float] = {}
    for p in collision.pairs:
        for b in p["bodies"]:
            bodies[b] = min(bodies.get(b, np.inf), p["min_distance"] / scale)
    return {"free": bool(collision.free), "clearance": collision.clearance / scale,
            "min_distance": float(collision.min_distance) / scale, "bodies": bodies}
