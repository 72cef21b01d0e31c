"""Planar four-bar tasks for the tests and the benchmark: poses of the coupler of a random crank-rocker
(seeded), in a tilted plane in space. The coupler positions are computed here by intersecting circles,
independently of `synth.algebra.fourbar_loop`."""
from __future__ import annotations

import math

import numpy as np


def _rot(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def random_crank_rocker(rng, min_transmission_deg: float = 50.0):
    """(ground, crank, coupler, rocker) lengths of a crank-rocker (crank shortest, Grashof with margin) whose
    transmission angle stays within [min, 180 - min] degrees over the whole turn."""
    lo = math.radians(min_transmission_deg)
    while True:
        g, r, c, s = 1.0, rng.uniform(0.15, 0.35), rng.uniform(0.7, 1.4), rng.uniform(0.6, 1.3)
        if r + max(g, c, s) > sum(sorted((g, c, s))[:2]) + r - 0.05 or r > 0.9 * min(g, c, s):
            continue
        mu = [math.acos(np.clip((c * c + s * s - d * d) / (2 * c * s), -1, 1)) for d in (g - r, g + r)]
        if min(mu) >= lo and max(mu) <= math.pi - lo:
            return g, r, c, s


def coupler_poses(lengths, crank_angles, point=(0.4, 0.3), branch=1, plane_seed=0, scale=0.2):
    """World poses (k, 4, 4) of a tool on the coupler of the four-bar ``lengths`` at crank angles (rad,
    from the ground line), in a tilted plane; the tool point at ``point`` (along, across) the coupler
    A1 -> B1 in coupler lengths; ``scale`` metres per unit length. Also returns the pivots (A0, A1, B0, B1)
    at the first pose in the plane (metres) and the plane's frame (origin, e1, e2)."""
    g, r, c, s = lengths
    rng = np.random.default_rng(plane_seed)
    Q = _rot(rng.normal(size=3), rng.uniform(0.3, 1.2))  # the plane: Q [x, y, 0] + o
    o = rng.normal(size=3) * 0.3
    B = _rot(rng.normal(size=3), rng.uniform(0, math.pi))  # tool orientation relative to the coupler
    out, pivots = [], None
    for phi in crank_angles:
        A1 = np.array([r * math.cos(phi), r * math.sin(phi)])
        B0 = np.array([g, 0.0])
        d = B0 - A1
        L = np.linalg.norm(d)
        alpha = math.acos((c * c + L * L - s * s) / (2 * c * L))
        psi = math.atan2(d[1], d[0]) + branch * alpha
        B1 = A1 + c * np.array([math.cos(psi), math.sin(psi)])
        e = (B1 - A1) / c
        P = A1 + c * (point[0] * e + point[1] * np.array([-e[1], e[0]]))
        T = np.eye(4)
        T[:3, :3] = Q @ _rot([0, 0, 1], psi) @ B
        T[:3, 3] = o + Q @ np.array([P[0], P[1], 0.0]) * scale
        out.append(T)
        if pivots is None:
            pivots = [np.zeros(2), A1 * scale, B0 * scale, B1 * scale]
    return np.array(out), pivots, (o, Q[:, 0], Q[:, 1])


def noisy(T, rng, position: float, angle: float):
    """In-plane noise: each pose turned about the plane normal by up to ``angle`` rad and moved in the plane
    by up to ``position`` metres (uniform), so that the poses stay coplanar."""
    n = np.cross(T[1, :3, 3] - T[0, :3, 3], T[2, :3, 3] - T[0, :3, 3])
    n = n / np.linalg.norm(n)
    out = T.copy()
    for Ti in out:
        Ti[:3, :3] = _rot(n, rng.uniform(-angle, angle)) @ Ti[:3, :3]
        v = rng.normal(size=3)
        v -= np.dot(v, n) * n
        Ti[:3, 3] += v / np.linalg.norm(v) * rng.uniform(0, position)
    return out


def yaml_text(T, names=None, extra: str = "", velocity=None) -> str:
    """A task file of poses T (metres) as matrices, with ``extra`` top-level YAML lines; ``velocity``:
    {pose: (w rad/s, v m/s)} (the file then needs ``units: {angle: rad}``)."""
    lines = [extra.rstrip()] if extra else []
    lines.append("poses:")
    fmt = lambda a: "[" + ", ".join(f"{x:.17g}" for x in a) + "]"  # noqa: E731
    for i, Ti in enumerate(T):
        lines.append(f"  - name: {names[i] if names else f'p{i}'}")
        lines.append(f"    matrix: [{', '.join(fmt(row) for row in Ti)}]")
        if velocity and i in velocity:
            lines.append(f"    velocity: {{angular: {fmt(velocity[i][0])}, linear: {fmt(velocity[i][1])}}}")
    return "\n".join(lines) + "\n"


def coupler_twist(lengths, phi: float, h: float = 1e-6, **kw):
    """(w, v): the tool's world angular velocity and the velocity of its origin per unit crank rate at crank
    angle ``phi`` (central differences of `coupler_poses` with the same keywords)."""
    (Tm, Tp), _, _ = coupler_poses(lengths, [phi - h, phi + h], **kw)
    T0 = coupler_poses(lengths, [phi], **kw)[0][0]
    W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ T0[:3, :3].T
    return np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2, (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
