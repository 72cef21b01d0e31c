"""The cubic motion model of 6R fits (docs/sixbar_fit.md): parametrization, residuals, seeds.

Model (conditioned frame: origin at the poses' centroid, unit = their RMS spread): the tool pose at
the angle theta of the projective parameter line (t = tan theta) is

    T(theta) = (s - c h1)(s - c h2)(s - c h3) X0,    s = sin theta, c = cos theta,

the homogeneous form of ``C(t) X0`` with the monic cubic ``C = (t - h1)(t - h2)(t - h3)`` (a product
of revolute factors, so C satisfies the Study condition whatever the parameters) and X0 the tool pose
at t = inf. Pose 0 is visited at theta = pi/2 (t = inf: all joint angles 0), which fixes the choice of
the point at infinity; the affine reparametrizations of t stay free (damped).

Parameter vector x (P = 28 + N - 1): per factor h = h0 + v + eps w with w = v x q (so that v.w = 0):
(h0, v, q) = 7 numbers, three factors; X0 = r + eps (-1/2 d r) by the quaternion r (4, any scale) and
the position d (3); then theta_1 .. theta_{N-1}.

Residuals per pose i: position error (3, conditioned units) and rotation error 2 vec(e)/|e| (3,
radians for small angles; e = rotation of T times the target's inverse, sign of e0 >= 0). Soft rows are
divided by the pose's tolerances (0 weight for an unconstrained component); exact poses are hard rows.
A prescribed velocity adds the hard rows (h - (h.w) w) / |h|: the tool twist h = [omega, v] at the
pose (v: velocity of the tool origin) must be parallel to the unit prescribed twist w (its given
components).
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from synth.algebra.dq import dq_mul, dq_translation, pose_to_dq, qconj, qmul
from synth.errors import SynthesisError
from synth.synthesis.conic import relative_displacements
from synth.synthesis.cubic import families, quadric
from synth.synthesis.sixbar import grid_members
from synth.synthesis.sixbar_loops import factor_members

__all__ = ["FitTargets", "targets", "unpack", "pack", "tool_curve", "CubicModel", "seeds", "NFACTOR"]

NFACTOR = 21  # 3 revolute factors x (h0, v, q)
NX0 = 7  # tool pose at t = inf: quaternion (4) + position (3)
THETA_GRID = 96  # parameter samples when placing poses on a seed curve
QUADRUPLES = 12  # quadruples (pose 0 and three others) sampled for seeds
MEMBERS = 24  # pencil members per family scanned per quadruple
KEEP = 2  # best members kept per quadruple (over both families)


@dataclass
class FitTargets:
    """A task in the conditioned frame: unit dual quaternions Q (N, 8), positions (N, 3), rotations
    as unit quaternions (N, 4), soft weights (N, 2) = 1 / tolerance (0: unconstrained; [m, rad] over
    conditioned units), exact (N,) bool, velocity directions (N, 6) [omega, v] unit (0 where not given)
    with mask (N, 6), has_velocity (N,)."""

    Q: np.ndarray
    positions: np.ndarray
    quats: np.ndarray
    weights: np.ndarray
    exact: np.ndarray
    velocity: np.ndarray
    vmask: np.ndarray

    @property
    def n(self) -> int:
        return len(self.Q)

    @property
    def has_velocity(self) -> np.ndarray:
        return self.vmask.any(-1)


def targets(Tc, scale: float, tolerance=None, velocity=None) -> FitTargets:
    """FitTargets of conditioned poses Tc (N, 4, 4) with tolerances (N, 2) [metres, radians] (None: all
    exact; 0: exact; inf: free) and velocities (N, 6) world [rad/s, m/s] (NaN: not given); ``scale``:
    metres per conditioned unit."""
    Tc = np.asarray(Tc, float)
    N = len(Tc)
    Q = pose_to_dq(Tc)
    tol = np.zeros((N, 2)) if tolerance is None else np.array(tolerance, float).reshape(N, 2)
    tol = tol / np.array([scale, 1.0])
    exact = np.all(tol == 0, -1)
    with np.errstate(divide="ignore"):
        w = np.where(np.isinf(tol), 0.0, 1.0 / tol)
    w[exact] = 0.0
    if np.any(~exact & (tol == 0).any(-1)):  # one component exact, the other toleranced: exact pose
        exact |= (tol == 0).any(-1)
        w[exact] = 0.0
    vel = np.full((N, 6), np.nan) if velocity is None else np.array(velocity, float).reshape(N, 6).copy()
    vel[:, 3:] /= scale
    vmask = np.isfinite(vel)
    vel = np.where(vmask, vel, 0.0)
    nrm = np.linalg.norm(vel, axis=-1, keepdims=True)
    vel = np.where(nrm > 0, vel / np.where(nrm > 0, nrm, 1.0), 0.0)
    vmask &= nrm > 0
    return FitTargets(Q=Q, positions=Tc[:, :3, 3], quats=Q[:, :4], weights=w, exact=exact, velocity=vel,
                      vmask=vmask)


# ============================================================================ parametrization
def unpack(x, n: int):
    """(H (R, 3, 8), X0 (R, 8), theta (R, n)) of parameter rows x (R, P); theta_0 = pi/2."""
    x = np.asarray(x, float)
    R = x.shape[0]
    f = x[:, :NFACTOR].reshape(R, 3, 7)
    H = np.zeros((R, 3, 8))
    H[..., :4] = f[..., :4]
    H[..., 5:] = np.cross(f[..., 1:4], f[..., 4:7])
    r = x[:, NFACTOR:NFACTOR + 4]
    d = np.concatenate([np.zeros((R, 1)), x[:, NFACTOR + 4:NFACTOR + 7]], -1)
    X0 = np.concatenate([r, -0.5 * qmul(d, r)], -1)
    theta = np.concatenate([np.full((R, 1), np.pi / 2), x[:, NFACTOR + NX0:]], -1)
    return H, X0, theta


def pack(H, X0, theta):
    """Inverse of `unpack` for revolute factors H (R, 3, 8) (w = v x q with q = (w x v)/|v|^2), tool
    poses X0 (R, 8) (Study condition) and parameters theta (R, n) (theta_0 ignored)."""
    H = np.asarray(H, float)
    v, w = H[..., 1:4], H[..., 5:8]
    q = np.cross(w, v) / np.sum(v * v, -1, keepdims=True)
    f = np.concatenate([H[..., :4], q], -1).reshape(len(H), NFACTOR)
    X0 = np.asarray(X0, float)
    d = dq_translation(X0)
    r = X0[:, :4] / np.linalg.norm(X0[:, :4], axis=-1, keepdims=True)
    return np.concatenate([f, r, d, np.asarray(theta, float)[:, 1:]], -1)


def tool_curve(H, X0, theta, derivative: bool = False):
    """T(theta) (R, n, 8) (unnormalized dual quaternions) of the model, and with ``derivative`` also
    dT/dtheta (R, n, 8)."""
    s, c = np.sin(theta)[..., None, None], np.cos(theta)[..., None, None]  # (R, n, 1, 1)
    one = np.eye(8)[0]
    L = s * one - c * H[:, None]  # (R, n, 3, 8)
    L12 = dq_mul(L[:, :, 0], L[:, :, 1])
    X = X0[:, None]
    L3X = dq_mul(L[:, :, 2], X)
    T = dq_mul(L12, L3X)
    if not derivative:
        return T, None
    dL = c * one + s * H[:, None]
    dT = (dq_mul(L12, dq_mul(dL[:, :, 2], X)) + dq_mul(dq_mul(L[:, :, 0], dL[:, :, 1]), L3X)
          + dq_mul(dq_mul(dL[:, :, 0], L[:, :, 1]), L3X))
    return T, dT


def pose_residuals(T, tg: FitTargets):
    """(position error (R, n, 3), rotation error (R, n, 3)) of poses T (R, n, 8) against the targets."""
    p = T[..., :4]
    pp = np.sum(p * p, -1)
    pos = dq_translation(T, pp) - tg.positions
    e = qmul(p, qconj(tg.quats))
    sgn = np.where(e[..., :1] < 0, -2.0, 2.0) / np.sqrt(pp)[..., None]
    return pos, e[..., 1:] * sgn


def twist_residuals(T, dT, tg: FitTargets):
    """(R, n, 6) velocity residuals (h - (h.w) w) / |h| (zero where no velocity is prescribed)."""
    p = T[..., :4]
    pp = np.sum(p * p, -1)[..., None]
    X = dq_mul(dT, T * np.array([1, -1, -1, -1, 1, -1, -1, -1.0])) * (2.0 / pp)  # 2 T' T~ / |p|^2
    omega = X[..., 1:4]
    d = dq_translation(T, pp[..., 0])
    v = -X[..., 5:8] + np.cross(omega, d)
    h = np.concatenate([omega, v], -1) * tg.vmask
    hn = np.sqrt(np.sum(h * h, -1, keepdims=True))
    res = h - np.sum(h * tg.velocity, -1, keepdims=True) * tg.velocity
    return np.where(tg.vmask, res / np.where(hn > 0, hn, 1.0), 0.0)


class CubicModel:
    """The fit problem of `synth.synthesis.fit` for targets ``tg``: ``self(x) -> (r, g)``, ``jac(x)``
    (forward differences, the theta columns perturbed together), ``support``."""

    def __init__(self, tg: FitTargets):
        self.tg = tg
        n = tg.n
        self.P = NFACTOR + NX0 + n - 1
        soft = ~tg.exact
        self.soft_w = np.repeat(tg.weights[soft], 3, axis=-1).reshape(-1)  # (6 Ns,)
        self.soft, self.hard = np.nonzero(soft)[0], np.nonzero(tg.exact)[0]
        self.vel = np.nonzero(tg.has_velocity)[0]
        rows_r = np.repeat(self.soft, 6)
        rows_g = np.concatenate([np.repeat(self.hard, 6), np.repeat(self.vel, 6)])
        cols = np.arange(self.P)
        pose_of_col = np.where(cols >= NFACTOR + NX0, cols - (NFACTOR + NX0) + 1, -1)
        shared = pose_of_col < 0
        self.support = ((rows_r[:, None] == pose_of_col) | shared, (rows_g[:, None] == pose_of_col) | shared)
        self.colors = [np.array([j]) for j in range(NFACTOR + NX0)] + [np.arange(NFACTOR + NX0, self.P)]

    def __call__(self, x):
        tg = self.tg
        H, X0, theta = unpack(x, tg.n)
        T, dT = tool_curve(H, X0, theta, derivative=len(self.vel) > 0)
        pos, rot = pose_residuals(T, tg)
        E = np.concatenate([pos, rot], -1)  # (R, n, 6)
        r = E[:, self.soft].reshape(len(x), -1) * self.soft_w
        g = [E[:, self.hard].reshape(len(x), -1)]
        if len(self.vel):
            g.append(twist_residuals(T[:, self.vel], dT[:, self.vel], _rows(tg, self.vel)).reshape(len(x), -1))
        return r, np.concatenate(g, -1)

    def jac(self, x):
        from synth.synthesis.cubic_lm import fd_jacobian

        return fd_jacobian(self, x, self.colors, self.support)[1]


def _rows(tg: FitTargets, idx) -> FitTargets:
    return FitTargets(Q=tg.Q[idx], positions=tg.positions[idx], quats=tg.quats[idx], weights=tg.weights[idx],
                      exact=tg.exact[idx], velocity=tg.velocity[idx], vmask=tg.vmask[idx])


# ============================================================================ seeds
def quadruples(tg: FitTargets, count: int = QUADRUPLES) -> list[tuple[int, int, int, int]]:
    """A deterministic sample of quadruples (0, i, j, k): exact poses first, then spread evenly over
    the lexicographic list of all."""
    allq = list(combinations(range(1, tg.n), 3))
    key = [-int(tg.exact[list(q)].sum()) for q in allq]
    order = sorted(range(len(allq)), key=lambda i: key[i])
    if len(allq) <= count:
        return [(0,) + allq[i] for i in order]
    best = [i for i in order if key[i] == key[order[0]]]
    pick = [best[int(k)] for k in np.linspace(0, len(best) - 1, min(count, len(best))).round()]
    rest = [allq[i] for i in np.linspace(0, len(allq) - 1, count).round().astype(int)]
    out = list(dict.fromkeys([allq[i] for i in pick[: count // 2]] + rest))[:count]
    return [(0,) + q for q in out]


def _place(C, X, tg: FitTargets, grid):
    """Place every pose on the curves T = C(t) X (C (G, 4, 8) monic cubics): (cost (G,), theta (G, n))
    of the best grid angle per pose, by the squared errors |x - y|^2 and 4 (1 - (p.r)^2) (~ angle^2)
    weighted by the tolerances (exact poses as the tightest)."""
    th = np.linspace(-np.pi / 2, np.pi / 2, grid, endpoint=False) + np.pi / (2 * grid)
    s, c = np.sin(th), np.cos(th)
    V = np.stack([c ** 3, s * c * c, s * s * c, s ** 3], -1)  # homogeneous basis (grid, 4)
    T = dq_mul(np.einsum("gk,mkj->mgj", V, C), X)  # (G, grid, 8)
    pp = np.sum(T[..., :4] ** 2, -1)
    x = dq_translation(T, pp)
    y = tg.positions
    d2 = np.sum(x * x, -1)[..., None] - 2 * x @ y.T + np.sum(y * y, -1)
    cr = (T[..., :4] @ tg.quats.T) ** 2 / pp[..., None]
    tight = np.max(np.where(tg.exact[:, None], 0.0, tg.weights), 0)
    w = np.where(tg.exact[:, None], np.maximum(tight, 1.0), np.maximum(tg.weights, 1.0)) ** 2
    err = d2 * w[:, 0] + 4 * np.maximum(1 - cr, 0.0) * w[:, 1]  # (G, grid, n)
    k = np.argmin(err, axis=1)  # (G, n)
    best = np.take_along_axis(err, k[:, None], 1)[:, 0]
    return best[:, 1:].sum(-1), th[k]


def seeds(tg: FitTargets, Tc) -> tuple[np.ndarray, int]:
    """Seed parameter rows (S, P) from exact sub-solutions: for each sampled quadruple (`quadruples`) the
    scanned members of both cubic families through it, each with the other poses placed at their best
    parameter (`_place`, one batch for all quadruples), the KEEP best members with a factorization kept.
    Returns (rows, quadruples that gave members)."""
    Cs, t3s, quads = [], [], []
    for quad in quadruples(tg):
        try:
            fams, _ = families(quadric(relative_displacements(Tc[list(quad)])))
        except SynthesisError:
            continue
        if not fams:
            continue
        C, _, _, fl = grid_members(fams, MEMBERS)
        ok = np.isfinite(C).all((-2, -1)) & (np.abs(C).max((-2, -1)) < 1e6)
        Cs.append(C[ok])
        t3s.append(np.array([f.t3 for f in fl])[ok])
        quads += [quad] * int(ok.sum())
    if not quads:
        return np.empty((0, NFACTOR + NX0 + tg.n - 1)), 0
    C, t3s, qi = np.concatenate(Cs), np.concatenate(t3s), np.array(quads)
    P0 = tg.Q[0]
    cost, theta = _place(C, P0, tg, THETA_GRID)
    pick = []
    for quad in dict.fromkeys(quads):
        rows = np.nonzero((qi == quad).all(-1))[0]
        pick += rows[np.argsort(cost[rows], kind="stable")[: 2 * KEEP]].tolist()
    mf = factor_members(C[pick])
    out, got = [], {}
    for b, m in enumerate(pick):
        good = np.nonzero(mf.ok[b])[0]
        quad = tuple(qi[m].tolist())
        if not len(good) or got.get(quad, 0) >= KEEP:
            continue
        th = theta[m].copy()
        th[list(quad)] = [np.pi / 2, 0.0, np.pi / 4, np.arctan(t3s[m])]
        out.append(pack(mf.H[b, good[0]][None], P0[None], th[None])[0])
        got[quad] = got.get(quad, 0) + 1
    return np.array(out).reshape(-1, NFACTOR + NX0 + tg.n - 1), len(got)
