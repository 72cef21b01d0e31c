"""Known 6R motions for the fit tests and fixtures: a random cubic C = (t-h1)(t-h2)(t-h3) of three random
revolute factors times a random tool pose X0, its poses at parameters t and its tool twists there."""
from __future__ import annotations

import numpy as np

from synth.algebra.dq import dq_mul, dq_to_pose, normalize_dq, translated
from synth.algebra.polynomial import evaluate, product_of_linear


def random_motion(rng, size: float = 1.0):
    """(C (4, 8), X0 (8,)): revolute factors h = h0 + v + eps (v x q) with standard normal h0, v, q (q, the
    tool position: times ``size``)."""
    v, q = rng.standard_normal((3, 3)), rng.standard_normal((3, 3)) * size
    H = np.zeros((3, 8))
    H[:, 0], H[:, 1:4], H[:, 5:] = rng.standard_normal(3), v, np.cross(v, q)
    r = normalize_dq(np.concatenate([rng.standard_normal(4), np.zeros(4)]))
    return product_of_linear(H), translated(r[:4], rng.standard_normal(3) * size)


def poses_at(C, X0, ts) -> np.ndarray:
    """Tool poses (k, 4, 4) of the motion C(t) X0 at the parameters ts (inf allowed)."""
    return dq_to_pose(dq_mul(evaluate(C, np.asarray(ts, float)), X0))


def twist_at(C, X0, t: float, eps: float = 1e-6) -> np.ndarray:
    """The tool twist [w, v] (6,) (world angular velocity, velocity of the tool origin) along dt at t
    (t = inf: along ds, s = -1/t), by central differences."""
    if np.isinf(t):  # s^3 C(-1/s) = reversed coefficients with alternating signs: s = 0 is t = inf
        C = C[::-1] * np.array([1.0, -1.0, 1.0, -1.0])[:, None]
        t = 0.0
    T = [poses_at(C, X0, [t + s * eps])[0] for s in (-1.0, 0.0, 1.0)]
    W = (T[2][:3, :3] - T[0][:3, :3]) / (2 * eps) @ T[1][:3, :3].T
    w = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])
    return np.concatenate([w, (T[2][:3, 3] - T[0][:3, 3]) / (2 * eps)])
