"""Least-squares fits of motion polynomials of any degree n to a task (docs/fit.md).

The motion is ``P(phi) = C(phi) Q`` with ``C(phi) = sum_k c_k cos^k(phi) sin^(n-k)(phi)`` the monic motion
polynomial C(t) = t^n + c_{n-1} t^{n-1} + ... + c_0 evaluated in homogeneous form at t = cot(phi)
(phi = 0 is t = inf, where C = 1 and the tool is at its reference pose Q), dual quaternions (8,) in the
layout of `synth.algebra.dq` (pose r - (eps/2) d r), everything in the task's conditioned frame
(`synth.synthesis.conic.condition`: lengths in pose spreads). The unknowns of one seed (`Layout`):
the coefficients c_0 .. c_{n-1} (8 n), a correction of the reference pose (rotation vector-ish w/2 and
translation, 6) and the item parameters phi_i (N; three of them fixed to remove the reparametrizations
t -> (a t + b) / (c t + d)). Equality constraints: the Study condition (2 n dual parts of C C~), the
exact components of items and the direction of prescribed velocities; the other components are
weighted residuals (error / tolerance). `levenberg_marquardt` solves this for a batch of seeds at once
(KKT steps, Jacobians by complex steps), and is generic: any model given as a batched residual
function with the same row/column structure can use it.
"""
from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import dq_left_matrix, dq_right_matrix, structure_constants
from synth.algebra.geometry import cross
from synth.synthesis.arrow import ArrowJacobian

__all__ = ["sample_combinations", "nth_combination", "TaskArrays", "Layout", "LMResult", "task_arrays", "item_errors", "pose_errors", "pose_rows", "twist_rows", "reference_steps", "study_rows", "study_jacobian", "levenberg_marquardt",
           "homogeneous", "monic", "basis", "cost_classes", "rank_seeds", "ERRORS", "ROWS"]

ERRORS = 6  # per item: position error (3, spreads), rotation error 2 sin(angle/2) axis (3)
ROWS = ERRORS + 5  # and 5 velocity rows (components of the twist direction across the prescribed one)
STEP = 1e-30  # complex step
FEASIBLE_FLOOR = 1e-14  # constraint violation (conditioned units) counted as met
NEARLY_FEASIBLE = 1e-6  # during the damped steps: cost-lowering steps may leave this much (`polish_feasible` ends)
CORRECTIONS = 2  # second-order corrections per trial step, while the violation is above CORRECT_ABOVE
CORRECT_ABOVE = 1e-9
POLISH_STEPS = 4
FLAT = 1e-10  # a relative decrease of the cost below this ends a seed's refinement
COST_TIE = 1e-12  # relative: seeds whose costs differ by less are tied (rounding), ranked by seed index
COST_FLOOR = 1e-20  # and costs this close (squared misses over tolerance: 1e-10 of a tolerance) likewise
_DQ = structure_constants().reshape(64, 8).astype(float)
_Q = structure_constants()[:4, :4, :4].reshape(16, 4).astype(float)
_CONJ = np.array([1.0, -1, -1, -1, 1, -1, -1, -1])
_Q_P = _Q.reshape(4, 4, 4).transpose(0, 2, 1).reshape(4, 16)  # (p @ this)[k, j] = d (p q)_k / d q_j
_Q_Q = _Q.reshape(4, 4, 4).transpose(1, 2, 0).reshape(4, 16)  # (q @ this)[k, i] = d (p q)_k / d p_i
_EYE4 = np.eye(4)
_HALF_UNITS = 0.5 * np.eye(4)[1:]  # i/2, j/2, k/2
_POSE_STEPS = 1j * STEP * np.eye(8)[:, None, :]  # complex steps in the 8 components of a pose


def _product(a, b, table):
    """The bilinear product sum_ij a_i b_j table[i, j, :] of (..., k) arrays of any dtype (complex for complex
    steps), broadcast: the dual quaternion (``_DQ``) or quaternion (``_Q``) product."""
    outer = a[..., :, None] * b[..., None, :]  # broadcast, a new contiguous array
    return outer.reshape(outer.shape[:-2] + (-1,)) @ table


def _mul(a, b):
    return _product(a, b, _DQ)


def _times_fixed(a, b, table):
    """The product of a (..., k) by a broadcast factor b (..., k) of fewer elements (a reference pose, a
    target): a @ the matrix of right multiplication by b (k x k per b), k^2 products per a instead of k^3."""
    return (a[..., None, :] @ _right_matrix(b, table))[..., 0, :]


def _right_matrix(b, table):
    """(..., k, k): the matrix M of right multiplication by b (..., k), a b = a @ M."""
    k = b.shape[-1]
    return (b @ table.reshape(k, k, k).transpose(1, 0, 2).reshape(k, k * k)).reshape(b.shape[:-1] + (k, k))


def _qmul(a, b):
    return _product(a, b, _Q)


def _vdot(a, b):
    return (a * b).sum(axis=-1)


@dataclass(frozen=True)
class TaskArrays:
    """A task in the conditioned frame: target poses ``Q`` (N, 8) (unit), positions ``X`` (N, 3),
    ``weight`` (N, ROWS) (1 / tolerance of free residual rows, 0 for rows that do not count), ``exact``
    (N, ROWS) bool (equality rows), ``perp`` (N, 5, 6) (rows spanning the complement of a prescribed
    twist direction [w, v], zero rows where there is none)."""

    Q: np.ndarray
    X: np.ndarray
    weight: np.ndarray
    exact: np.ndarray
    perp: np.ndarray

    @functools.cached_property
    def target_right(self) -> np.ndarray:
        """(N, 4, 4): right multiplication by the targets' conjugate rotations (p q_i~ = p @ this[i])."""
        return _right_matrix(self.Q[:, :4] * _CONJ[:4], _Q)

    @functools.cached_property
    def has_velocity(self) -> bool:
        """Whether an item has a prescribed twist direction (the rows use C' then)."""
        return bool(self.exact[:, ERRORS:].any())


def task_arrays(Q, X, tolerance, velocity, scale: float) -> TaskArrays:
    """TaskArrays of targets Q (N, 8), X (N, 3) (conditioned, lengths / ``scale``), ``tolerance`` (N, 2)
    [metres, radians] (None: all exact) and ``velocity`` (N, 6) [w rad/s, v m/s] (NaN: not given)."""
    n = len(Q)
    tol = np.zeros((n, 2)) if tolerance is None else np.asarray(tolerance, float).copy()
    tol[:, 0] /= scale
    tol_rows = np.repeat(tol, 3, axis=1)  # (N, 6)
    weight = np.zeros((n, ROWS))
    exact = np.zeros((n, ROWS), bool)
    exact[:, :ERRORS] = tol_rows == 0
    free = np.isfinite(tol_rows) & (tol_rows > 0)
    weight[:, :ERRORS][free] = 1.0 / tol_rows[free]
    perp = np.zeros((n, 5, 6))
    if velocity is not None:
        for i, v in enumerate(np.asarray(velocity, float)):
            given = ~np.isnan(v)
            if not given.any():
                continue
            g = np.where(given, v, 0.0)
            g[3:] /= scale
            basis = np.linalg.svd(np.eye(6)[given] - np.outer(g[given] / np.linalg.norm(g), g / np.linalg.norm(g)))[2]
            k = int(given.sum()) - 1
            perp[i, :k] = basis[:k] * given  # rows across g within the given components
            exact[i, ERRORS:ERRORS + k] = True
    return TaskArrays(Q=np.asarray(Q, float), X=np.asarray(X, float), weight=weight, exact=exact, perp=perp)


def homogeneous(coef, phi, derivative: bool = False):
    """C(phi) (..., N, 8) = sum_k c_k cos^k sin^(n-k) with c_n = 1, coefficients ``coef`` (..., n, 8)
    (c_0 .. c_{n-1}) and angles ``phi`` (..., N); with ``derivative`` also dC/dphi."""
    n = coef.shape[-2]
    full = monic(coef)
    b, db = basis(phi, n)
    return (b @ full, db @ full) if derivative else b @ full


def monic(coef):
    """The coefficients c_0 .. c_n (..., n+1, 8) of the monic C: ``coef`` (c_0 .. c_{n-1}, (..., n, 8), any
    dtype) and c_n = 1."""
    n = coef.shape[-2]
    full = np.zeros(coef.shape[:-2] + (n + 1, 8), coef.dtype)
    full[..., :n, :] = coef
    full[..., n, 0] = 1.0
    return full


def basis(phi, n: int):
    """cos^k sin^(n-k) of phi (..., N) for k = 0 .. n, and their derivatives: two (..., N, n+1) arrays."""
    pw = _powers(np.stack([np.cos(phi), np.sin(phi)], -1), n + 1)  # (..., N, 2, n+2): cos^j, sin^j
    c, s = pw[..., 0, :], pw[..., 1, :]
    k = _COUNTS[:n + 1]
    # d/dphi cos^k sin^(n-k) = -k cos^(k-1) sin^(n-k+1) + (n-k) cos^(k+1) sin^(n-k-1), by slices (views)
    down = -k[1:] * c[..., :n] * s[..., n:0:-1]  # k = 1 .. n
    up = k[n:0:-1] * c[..., 1:n + 1] * s[..., n - 1::-1]  # k = 0 .. n-1
    d = np.empty(up.shape[:-1] + (n + 1,), up.dtype)
    d[..., 0], d[..., n] = up[..., 0], down[..., n - 1]
    np.add(down[..., :n - 1], up[..., 1:], out=d[..., 1:n])
    return c[..., :n + 1] * s[..., n::-1], d


_COUNTS = np.arange(16.0)


def _powers(x, m: int):
    """x^0 .. x^m (..., m+1) by products (exact for complex steps)."""
    out = np.empty(x.shape + (m + 1,), x.dtype)
    out[..., 0] = 1.0
    for j in range(1, m + 1):
        out[..., j] = out[..., j - 1] * x
    return out


def reference_pose(ref0, x_ref):
    """The seed's reference pose ref0 (..., 8) corrected by x_ref (..., 6) = (w, dp): first the rotation
    (1, w/2), then the translation by dp, both before ref0 (world frame)."""
    D = np.zeros(x_ref.shape[:-1] + (8,), x_ref.dtype)  # (r, dp r): r = (1, w/2), dp = (0, -dp/2)
    D[..., 0] = 1.0
    np.multiply(x_ref[..., :3], 0.5, out=D[..., 1:4])
    np.multiply(x_ref[..., 3:], -0.5, out=D[..., 5:8])
    D[..., 4:] = _qmul(D[..., 4:], D[..., :4])
    return _mul(D, ref0)


def reference_steps(ref0, x_ref):
    """(..., 6, 8): the derivatives of `reference_pose` (ref0 (..., 8), x_ref (..., 6)) in x_ref = (w, dp): of
    D = (r, dp r) (r = (1, w/2), dp = (0, -dp/2)) times ref0, dD / dw_a = (e_a / 2, dp e_a / 2) and dD / ddp_a =
    (0, -e_a r / 2) (e_a the quaternion units i, j, k)."""
    dD = np.zeros(x_ref.shape[:-1] + (6, 8))
    dp = np.zeros(x_ref.shape[:-1] + (1, 4))
    dp[..., 0, 1:] = -0.5 * x_ref[..., 3:]
    r = np.zeros(x_ref.shape[:-1] + (1, 4))
    r[..., 0, 0] = 1.0
    r[..., 0, 1:] = 0.5 * x_ref[..., :3]
    dD[..., :3, :4] = _HALF_UNITS
    dD[..., :3, 4:] = _qmul(dp, _HALF_UNITS)
    dD[..., 3:, 4:] = _qmul(-_HALF_UNITS, r)
    return _mul(dD, ref0[..., None, :])


def item_errors(coef, ref, phi, task: TaskArrays):
    """Rows (..., N, ROWS) of the items: position error (predicted - target, conditioned), rotation error
    2 sin(angle / 2) times its axis, and the prescribed-twist rows ``perp @ [w, v] / |[w, v]|`` (w the
    angular velocity, v the velocity of the tool origin, along phi). coef (..., n, 8), ref (..., 8),
    phi (..., N); any float or complex dtype."""
    e = _item_rows(coef, ref, phi, task)
    return e if e.shape[-1] == ROWS else np.concatenate([e, np.zeros(e.shape[:-1] + (ROWS - ERRORS,), e.dtype)], -1)


def _item_rows(coef, ref, phi, task: TaskArrays):
    """`item_errors` without the twist rows (..., N, ERRORS) when the task prescribes no velocity. The poses
    P = C(phi) Q = basis @ (the coefficients times Q)."""
    b, db = basis(phi, coef.shape[-2])
    CQ = monic(coef) @ _right_matrix(ref, _DQ)  # (..., n+1, 8): the coefficients of C Q
    P = b @ CQ
    e = pose_rows(P, task)[0]
    return np.concatenate([e, twist_rows(P, db @ CQ, task)], -1) if task.has_velocity else e


def pose_errors(P, dP, task: TaskArrays):
    """`item_errors` from the tool's poses P = C Q (..., N, 8) at the items and their derivatives dP = C' Q
    along phi (needed for the twist rows only: None when the task prescribes no velocity)."""
    e = pose_rows(P, task)[0]
    tw = np.zeros(e.shape[:-1] + (5,), e.dtype) if dP is None else twist_rows(P, dP, task)
    return np.concatenate([e, tw], -1)


def _translation(P):
    """The tool origins 2 vec(p q~) / |p|^2 (..., 3) of poses P (..., 8) (synth.algebra.dq) and |p|^2."""
    p = P[..., :4]
    pp = _vdot(p, p)
    return 2.0 * _qmul(p, P[..., 4:] * _CONJ[:4])[..., 1:] / pp[..., None], pp


def pose_rows(P, task: TaskArrays, jacobian: bool = False):
    """The first ERRORS rows of `item_errors` (position error, rotation error 2 sin(angle / 2) times its
    axis) of the tool poses P (..., N, 8) (any dtype), and with ``jacobian`` their derivatives in P
    (..., N, ERRORS, 8) (real P): x = 2 vec(p q~) / |p|^2 is linear in q and, times |p|^2, in p; the
    rotation error is the normalized vector part of e = p t~ (t the target), linear in p."""
    p = P[..., :4]
    x, pp = _translation(P)
    e = (p[..., None, :] @ task.target_right)[..., 0, :]  # rotation from the target to the prediction (times |p|)
    sign = np.where(e[..., :1].real < 0, -1.0, 1.0)
    norm = np.sqrt(_vdot(e, e))[..., None]
    rot = 2.0 * sign * e[..., 1:] / norm
    rows = np.concatenate([x - task.X, rot], -1)
    if not jacobian:
        return rows, None
    J = np.zeros(rows.shape + (8,))
    inv = (1.0 / pp)[..., None, None]
    qc = P[..., 4:] * _CONJ[:4]
    J[..., :3, 4:] = (2.0 * inv) * (p @ _Q_P).reshape(p.shape + (4,))[..., 1:, :] * _CONJ[:4]  # dx / dq
    J[..., :3, :4] = (2.0 * inv) * (qc @ _Q_Q).reshape(p.shape + (4,))[..., 1:, :] - (2.0 * inv) * x[..., None] * p[..., None, :]
    u = e / norm  # d rot / d e = 2 sign (I - u u^T)[1:] / |e|, then d e / d p = target_right^T
    de = (2.0 * sign / norm)[..., None] * (_EYE4[1:] - u[..., 1:, None] * u[..., None, :])
    J[..., 3:, :4] = de @ np.swapaxes(task.target_right, -1, -2)
    return rows, J


def twist_rows(P, dP, task: TaskArrays):
    """The twist rows of `item_errors` (..., N, 5) from the poses P and dP = C' Q (..., N, 8): P' P~ =
    |Q|^2 C' C~ (Q on the Study quadric) has the vector parts (w, -(velocity of the body point at the
    origin)) times a positive factor, which the normalization removes. Any dtype (complex steps)."""
    x = _translation(P)[0]
    tw = _mul(dP, P * _CONJ)
    w = tw[..., 1:4]
    z = np.concatenate([w, cross(w, x) - tw[..., 5:8]], -1)
    z = z / np.sqrt(_vdot(z, z))[..., None]
    return (task.perp @ z[..., None])[..., 0]


def study_rows(coef):
    """The Study condition of the monic C with coefficients c_0 .. c_{n-1} (..., n, 8): the 2n dual parts
    of C C~ (halved), sum_{j+k=m} p_j . q_k for m = 0 .. 2n-1 (c_n = 1). Returns (..., 2n)."""
    n = coef.shape[-2]
    p = monic(coef)[..., :4]
    pq = (p[..., :, None, :] * coef[..., None, :, 4:]).sum(-1)  # (..., n+1, n): p_j . q_k
    return pq.reshape(pq.shape[:-2] + (-1,)) @ _study_sums(n)


def study_jacobian(coef):
    """(..., 2n, 8n): the derivatives of `study_rows` in the coefficients c_0 .. c_{n-1} (..., n, 8) (their
    8 components in order): row m in p_j is q_{m-j}, in q_k is p_{m-k} (bilinear; p_n = 1, q_n = 0)."""
    n = coef.shape[-2]
    T = _study_sums(n).reshape(n + 1, n, 2 * n)  # [j, k, m]: j + k == m
    J = np.empty(coef.shape[:-2] + (2 * n, n, 8))
    J[..., :4] = np.einsum("jkm,...ka->...mja", T[:n], coef[..., 4:])  # in p_j (j < n)
    J[..., 4:] = np.einsum("jkm,...ja->...mka", T, monic(coef)[..., :4])  # in q_k
    return J.reshape(coef.shape[:-2] + (2 * n, 8 * n))


@functools.lru_cache(maxsize=4)
def _study_sums(n: int) -> np.ndarray:
    """(n+1) n x 2n 0/1 matrix summing p_j . q_k over j + k = m."""
    j, k = np.meshgrid(np.arange(n + 1), np.arange(n), indexing="ij")
    return ((j + k).reshape(-1, 1) == np.arange(2 * n)).astype(float)


@dataclass(frozen=True)
class Layout:
    """Unknowns of one seed of a degree-n fit of N items: x = [c_0..c_{n-1} (8 n), w, dp (6), phi (N)].
    ``gauge`` (S, 3): per seed, the items whose phi is held fixed (the reparametrizations)."""

    n: int
    items: int
    gauge: np.ndarray

    @property
    def size(self) -> int:
        return 8 * self.n + 6 + self.items

    @property
    def fixed(self) -> np.ndarray:
        """(S, P) bool: the columns held fixed."""
        g = np.asarray(self.gauge, int)
        f = np.zeros((len(g), self.size), bool)
        f[np.arange(len(g))[:, None], 8 * self.n + 6 + g] = True
        return f

    def split(self, x):
        n = self.n
        return x[..., :8 * n].reshape(x.shape[:-1] + (n, 8)), x[..., 8 * n:8 * n + 6], x[..., 8 * n + 6:]

    def join(self, coef, x_ref, phi):
        return np.concatenate([coef.reshape(coef.shape[:-2] + (8 * self.n,)), x_ref, phi], -1)


@dataclass
class LMResult:
    """Per seed: ``x`` (S, P), ``cost`` (S,) (sum of squared weighted residuals), ``violation`` (S,)
    (max |constraint|), ``iterations`` (int, the same for all: counted work)."""

    x: np.ndarray
    cost: np.ndarray
    violation: np.ndarray
    iterations: int


def _chained(b, db, dEC, dEdC):
    """Derivatives (S, N, R, 8 n) of item rows in the coefficients c_0 .. c_{n-1}, from their derivatives
    dEC (S, N, R, 8) in C and dEdC in C' (None: the rows do not depend on C') at the items, and the basis
    b, db (S, N, n + 1) there (`basis`: C = b @ [c; 1], C' = db @ [c; 1])."""
    S, N, R, _ = dEC.shape
    n = b.shape[-1] - 1
    dcoef = b[:, :, None, :n, None] * dEC[:, :, :, None, :]
    if dEdC is not None:
        dcoef += db[:, :, None, :n, None] * dEdC[:, :, :, None, :]
    return dcoef.reshape(S, N, R, 8 * n)


class MotionModel:
    """The rows of a motion fit (`item_errors`, `study_rows`) as (residuals, constraints) of x."""

    def __init__(self, layout: Layout, task: TaskArrays, ref0):
        self.layout, self.task, self.ref0 = layout, task, np.asarray(ref0, float)
        width = ROWS if task.has_velocity else ERRORS  # (`_item_rows`)
        self.free = (task.weight[:, :width] != 0).ravel()
        self.eq = task.exact[:, :width].ravel()

    def rows(self, x):
        """(residuals (..., M), constraints (..., E)) at x (..., P); leading axes broadcast with ref0's."""
        coef, x_ref, phi = self.layout.split(x)
        ref = reference_pose(self.ref0.reshape(self.ref0.shape[:1] + (1,) * (x.ndim - 2) + (8,)), x_ref)
        e = _item_rows(coef, ref, phi, self.task)
        flat = e.reshape(e.shape[:-2] + (-1,))
        r = (e * self.task.weight[:, :e.shape[-1]]).reshape(flat.shape)[..., self.free]
        c = np.concatenate([flat[..., self.eq], study_rows(coef)], -1)
        return r, c

    def jacobians(self, x):
        """The rows and Jacobians at x (S, P) as a `synth.synthesis.arrow.ArrowJacobian` (item rows uncompressed:
        the rows that do not count are 0). The rows are a function of the tool poses P = C Q at the items
        (and of P' = C' Q, with velocities) alone: their derivatives in P (`pose_rows`; the twist rows by
        complex steps in P and P'), chained by matrix products to C (P = C Q: Q's right-multiplication
        matrix) and the coefficients (`basis`), to the reference correction (C's left-multiplication matrix
        times dQ / dx_ref, `reference_steps`) and to phi (dP / dphi = P'); the Study rows' by `study_jacobian`."""
        lay, task = self.layout, self.task
        n, g, S = lay.n, 8 * lay.n + 6, x.shape[0]
        coef, x_ref, phi = lay.split(x)
        vel = task.has_velocity
        if vel:  # the second derivative too: real parts the basis and its derivative, imaginary / STEP d / dphi
            bc, dbc = basis(phi + 1j * STEP, n)
            b, db = bc.real, dbc.real
            W = np.stack([b, db, dbc.imag / STEP], -2)  # (S, N, 3, n+1)
        else:
            b, db = basis(phi, n)
            W = np.stack([b, db], -2)
        N, k = phi.shape[1], W.shape[2]
        CC = W.reshape(S, N * k, n + 1) @ monic(coef)  # C, C' (and C'') at the items: (S, N k, 8)
        ref = reference_pose(self.ref0, x_ref)  # (S, 8)
        right = dq_right_matrix(ref)  # (S, 8, 8): P = C @ right
        PP = (CC @ right).reshape(S, N, k, 8)  # P, P' (and P'')
        CC = CC.reshape(S, N, k, 8)
        P, dP = PP[:, :, 0], PP[:, :, 1]
        E0, JP = pose_rows(P, task, jacobian=True)  # (S, N, ERRORS), (S, N, ERRORS, 8)
        JdP = None
        if vel:  # the twist rows: complex steps in P and P' (8 + 8 directions)
            step = _POSE_STEPS
            Pz = np.concatenate([P[:, None] + step, np.broadcast_to(P[:, None], (S, 8) + P.shape[1:])], 1)
            dPz = np.concatenate([np.broadcast_to(dP[:, None], (S, 8) + P.shape[1:]), dP[:, None] + step], 1)
            T = twist_rows(Pz, dPz, task)  # (S, 16, N, 5)
            dT = np.moveaxis(T.imag, 1, -1) / STEP  # (S, N, 5, 16)
            E0 = np.concatenate([E0, T[:, 0].real], -1)
            JdP = np.concatenate([np.zeros(JP.shape), dT[..., 8:]], -2)
            JP = np.concatenate([JP, dT[..., :8]], -2)
        RT = np.swapaxes(right, 1, 2)[:, None]  # (S, 1, 8, 8): dP / dC
        dref_T = np.swapaxes(reference_steps(self.ref0, x_ref), 1, 2)[:, None]  # (S, 1, 8, 6)
        dcoef = _chained(b, db, JP @ RT, None if JdP is None else JdP @ RT)
        dx_ref = JP @ (np.swapaxes(dq_left_matrix(CC[:, :, 0]), -1, -2) @ dref_T)  # (S, N, rows, 6)
        dphi = (JP @ dP[..., None])[..., 0]  # (S, N, rows)
        if vel:
            dx_ref += JdP @ (np.swapaxes(dq_left_matrix(CC[:, :, 1]), -1, -2) @ dref_T)
            dphi += (JdP @ PP[:, :, 2, :, None])[..., 0]
        Jg = np.concatenate([dcoef, dx_ref], -1)  # (S, N, rows, g): rows = ROWS (ERRORS without velocities)
        c, Jc = self._study(coef, x.shape[-1])
        if self.eq.any():  # the exact rows of the items that have them
            items = np.nonzero(task.exact.any(1))[0]
            eq = task.exact[items, :Jg.shape[2]].ravel()
            owner = np.repeat(items, Jg.shape[2])[eq]
            Je = np.zeros((S, len(owner), lay.size))
            Je[..., :g] = Jg[:, items].reshape(S, -1, g)[:, eq]
            Je[:, np.arange(len(owner)), g + owner] = dphi[:, items].reshape(S, -1)[:, eq]
            c, Jc = np.concatenate([E0[:, items].reshape(S, -1)[:, eq], c], -1), np.concatenate([Je, Jc], 1)
        w = task.weight[:, :ERRORS]  # (the twist rows are never residuals)
        counts = w != 0  # (rows that do not count: 0, whatever their values)
        return ArrowJacobian.of_items(np.where(counts, E0[..., :ERRORS] * w, 0.0),
                                      np.where(counts[..., None], Jg[:, :, :ERRORS] * w[..., None], 0.0),
                                      np.where(counts, dphi[..., :ERRORS] * w, 0.0), c, Jc)

    def _study(self, coef, columns: int):
        """The Study rows (S, 2n) of the coefficients (S, n, 8) and their Jacobian (S, 2n, columns)
        (`study_jacobian`)."""
        n = self.layout.n
        J = np.zeros((coef.shape[0], 2 * n, columns))
        J[..., :8 * n] = study_jacobian(coef)
        return study_rows(coef), J

    def constraints(self, x):
        """(c (S, E), its Jacobian (S, E, P)) at x (S, P): `jacobians` for the constraints only, of the items
        with exact rows alone."""
        items = np.nonzero(self.task.exact.any(1))[0]
        if not len(items):
            return self._study(self.layout.split(x)[0], x.shape[-1])
        t, g = self.task, 8 * self.layout.n + 6
        sub = MotionModel(Layout(self.layout.n, len(items), np.zeros((0, 3), int)),
                          TaskArrays(t.Q[items], t.X[items], t.weight[items], t.exact[items], t.perp[items]), self.ref0)
        jac = sub.jacobians(np.concatenate([x[:, :g], x[:, g + items]], 1))
        Jc = np.zeros(jac.Jc.shape[:2] + (x.shape[-1],))
        Jc[..., :g], Jc[..., g + items] = jac.Jc[..., :g], jac.Jc[..., g:]
        return jac.c, Jc


def levenberg_marquardt(model, x0, fixed, iterations: int = 60) -> LMResult:
    """Minimize |r(x)|^2 subject to c(x) = 0 for a batch of seeds x0 (S, P) by damped Gauss-Newton steps on
    the KKT system [[J^T J + lam D, A^T], [A, 0]] [dx; mu] = [-J^T r; -c] (D = diag(J^T J) + 1e-12), each
    followed by a second-order correction back onto c = 0 (min-norm along A's rows). A step is accepted
    (lam / 3, else lam * 4) when it lowers |r|^2 and keeps max |c| below max(NEARLY_FEASIBLE, its value), or
    halves max |c| while that is above NEARLY_FEASIBLE (a filter: exact rows never trade against the cost);
    `polish_feasible` then meets c = 0 to rounding. ``fixed`` (S, P) bool: columns held, per seed. ``model``:
    ``rows(x) -> (r, c)``, ``jacobians(x) -> ArrowJacobian`` and ``constraints(x) -> (c, A)`` (its KKT system is solved with the items'
    columns eliminated, `synth.synthesis.arrow.KKTSystem`: linear in the number of items). Stops after ``iterations`` Jacobians
    or when every seed's step is below 1e-13 (relative) or its cost stops moving (FLAT, relative): counted
    work only."""
    x = np.array(x0, float)
    fixed = np.broadcast_to(np.asarray(fixed, bool), x.shape)
    S = x.shape[0]
    lam = np.full(S, 1e-3)
    done = np.zeros(S, bool)
    it = 0
    jac = model.jacobians(x)
    cost, viol = jac.cost, np.abs(jac.c).max(-1, initial=0.0)
    for it in range(1, iterations + 1):
        system = jac.system(fixed)
        A, ne = system.A, system.A.shape[1]
        pending = ~done
        for _ in range(8):  # damping tries per Jacobian
            xn = x + system.step(lam, _solve)
            rn, cn = model.rows(xn)
            for _ in range(CORRECTIONS if ne else 0):  # second-order corrections: back onto c = 0 along A's rows
                if np.abs(cn[pending]).max(initial=0.0) <= CORRECT_ABOVE:
                    break
                xn = xn - _min_norm(A, cn)
                rn, cn = model.rows(xn)
            cost_n, viol_n = (rn * rn).sum(-1), np.abs(cn).max(-1, initial=0.0)
            restores = viol_n <= 0.5 * viol  # feasibility progress, any cost (far from c = 0)
            improves = (cost_n < cost) & (viol_n <= np.maximum(viol, NEARLY_FEASIBLE))
            ok = pending & np.isfinite(cost_n) & (improves | (restores & (viol > NEARLY_FEASIBLE)))
            step = np.max(np.abs(xn - x), axis=1)
            flat = ok & (cost - cost_n <= FLAT * cost + 1e-28)  # the cost no longer moves
            x[ok] = xn[ok]
            cost, viol = np.where(ok, cost_n, cost), np.where(ok, viol_n, viol)
            lam = np.where(ok, np.maximum(lam / 3, 1e-12), np.where(pending, lam * 4, lam))
            small = step <= 1e-13 * (1 + np.max(np.abs(x), axis=1))
            done |= pending & (small | flat) & (viol <= NEARLY_FEASIBLE)
            pending &= ~ok & ~done
            if not pending.any():
                break
        if done.all():
            break
        jac = model.jacobians(x)
    x = polish_feasible(model, x, fixed)
    r, c = model.rows(x)
    return LMResult(x=x, cost=(r * r).sum(-1), violation=np.abs(c).max(-1, initial=0.0), iterations=it)


def _min_norm(A, c):
    """The least-norm dx (S, P) with A dx = c (A (S, E, P))."""
    if not A.shape[1]:
        return np.zeros((A.shape[0], A.shape[2]))
    return (np.swapaxes(A, 1, 2) @ _solve(A @ np.swapaxes(A, 1, 2), c)[..., None])[..., 0]


def polish_feasible(model, x, fixed, steps: int = POLISH_STEPS):
    """Newton steps onto c(x) = 0 (min-norm along the constraint Jacobian's rows, held columns fixed), for
    the exact rows' last digits after the damped steps (which keep them only below NEARLY_FEASIBLE).
    Counted steps."""
    for _ in range(steps):
        c = model.rows(x)[1]  # (cheaper than the Jacobians, which only a violated constraint needs)
        if not c.shape[-1] or np.abs(c).max() <= FEASIBLE_FLOOR:
            break
        c, Jc = model.constraints(x)
        xn = x - _min_norm(np.where(fixed[:, None, :], 0.0, Jc), c)
        cn = model.rows(xn)[1]
        better = np.abs(cn).max(-1) < np.abs(c).max(-1)
        x[better] = xn[better]
    return x


def _solve(K, rhs):
    """Batched solve; a singular system (a degenerate seed) gives a zero step."""
    try:
        return np.linalg.solve(K, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        out = np.zeros_like(rhs)
        for s in range(len(K)):
            try:
                out[s] = np.linalg.solve(K[s], rhs[s])
            except np.linalg.LinAlgError:
                pass
        return out


def nth_combination(n: int, k: int, index: int) -> tuple:
    """The ``index``-th k-subset of range(n) in the lexicographic order of itertools.combinations."""
    out, start = [], 0
    for left in range(k, 0, -1):
        for a in range(start, n):
            count = math.comb(n - a - 1, left - 1)  # subsets that start with a
            if index < count:
                out.append(a)
                start = a + 1
                break
            index -= count
    return tuple(out)


def sample_combinations(items, k: int, size: int, first=()) -> list:
    """Up to ``size`` k-subsets of ``items`` (tuples, in the lexicographic order of
    itertools.combinations): all when there are at most ``size``; else ``first`` (some of them, kept
    in front) and a seeded sample (generator seed 0) of the rest, picked by rank, never listing all
    (a task of 10,000 poses has 1.7e11 triples). The same subsets as sampling from the full list."""
    items = list(items)
    total = math.comb(len(items), k)
    if total <= size:
        return list(itertools.combinations(items, k))
    first = list(first)
    pick = np.random.default_rng(0).choice(total, size=size - len(first), replace=False)
    return first + [tuple(items[i] for i in nth_combination(len(items), k, int(r))) for r in sorted(pick)]


def cost_classes(cost, rel: float = COST_TIE) -> np.ndarray:
    """(S,) int: the rank of each of the costs ``cost`` (S,) (NaN as inf) with rounding-level ties merged:
    walking the costs upwards, a cost within ``rel`` (relative, plus `COST_FLOOR`) of the first cost of
    its class joins that class. Two seeds that converge to one minimum get costs that differ in their last
    bits, in an order that rounding decides; ranking by (class, seed index) makes it the seeds' order."""
    cost = np.nan_to_num(np.asarray(cost, float), nan=np.inf)
    out = np.empty(len(cost), int)
    k, base = -1, np.nan
    for i in np.argsort(cost, kind="stable"):
        if not cost[i] - base <= rel * abs(base) + COST_FLOOR:  # (NaN for the first and for inf - inf: a new class)
            k, base = k + 1, cost[i]
        out[i] = k
    return out


def rank_seeds(cost, *before) -> np.ndarray:
    """The seed indices (S,) ordered by the keys ``before`` (each (S,), most significant first, e.g. "not
    feasible"), then by cost (`cost_classes`: ties within `COST_TIE`), then by seed index."""
    return np.lexsort((np.arange(len(cost)), cost_classes(cost), *reversed(before)))
