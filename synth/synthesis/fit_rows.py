"""The rows of motion fits (docs/fit.md, `synth.synthesis.fit`): the motion ``P(phi) = C(phi) Q`` of a
monic C of degree n in homogeneous form (`homogeneous`, `basis`: t = cot phi, phi = 0 at t = inf where
C = 1 and the tool is at its reference pose Q), the task in the conditioned frame (`TaskArrays`), the items'
errors at their poses P (`pose_rows` with their derivatives in P, `twist_rows`, `item_errors`), the
reference pose's correction (`reference_pose`, `reference_steps`) and the Study rows (`study_rows`,
`study_jacobian`). Dual quaternions (8,) in the layout of `synth.algebra.dq` (pose r - (eps/2) d r); any
float or complex dtype unless said otherwise (complex steps).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import structure_constants
from synth.algebra.geometry import cross

__all__ = ["TaskArrays", "task_arrays", "homogeneous", "monic", "basis", "reference_pose", "reference_steps",
           "item_errors", "item_rows", "pose_rows", "twist_rows", "study_rows", "study_jacobian", "ERRORS", "ROWS",
           "STEP", "POSE_STEPS"]

ERRORS = 6  # per item: position error (3, spreads), rotation error 2 sin(angle/2) axis (3)
ROWS = ERRORS + 5  # and 5 velocity rows (components of the twist direction across the prescribed one)
STEP = 1e-30  # complex step
_DQ = structure_constants().reshape(64, 8).astype(float)
_Q = structure_constants()[:4, :4, :4].reshape(16, 4).astype(float)
_CONJ = np.array([1.0, -1, -1, -1, 1, -1, -1, -1])
_Q_P = _Q.reshape(4, 4, 4).transpose(0, 2, 1).reshape(4, 16)  # (p @ this)[k, j] = d (p q)_k / d q_j
_Q_Q = _Q.reshape(4, 4, 4).transpose(1, 2, 0).reshape(4, 16)  # (q @ this)[k, i] = d (p q)_k / d p_i
_EYE4 = np.eye(4)
_HALF_UNITS = 0.5 * np.eye(4)[1:]  # i/2, j/2, k/2
POSE_STEPS = 1j * STEP * np.eye(8)[:, None, :]  # complex steps in the 8 components of a pose


def _product(a, b, table):
    """The bilinear product sum_ij a_i b_j table[i, j, :] of (..., k) arrays of any dtype (complex for complex
    steps), broadcast: the dual quaternion (``_DQ``) or quaternion (``_Q``) product."""
    outer = a[..., :, None] * b[..., None, :]  # broadcast, a new contiguous array
    return outer.reshape(outer.shape[:-2] + (-1,)) @ table


def _mul(a, b):
    return _product(a, b, _DQ)


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
    e = item_rows(coef, ref, phi, task)
    return e if e.shape[-1] == ROWS else np.concatenate([e, np.zeros(e.shape[:-1] + (ROWS - ERRORS,), e.dtype)], -1)


def item_rows(coef, ref, phi, task: TaskArrays):
    """`item_errors` (..., N, ROWS) without the twist rows (..., N, ERRORS) when the task prescribes no velocity. The poses
    P = C(phi) Q = basis @ (the coefficients times Q)."""
    b, db = basis(phi, coef.shape[-2])
    CQ = monic(coef) @ _right_matrix(ref, _DQ)  # (..., n+1, 8): the coefficients of C Q
    P = b @ CQ
    e = pose_rows(P, task)[0]
    return np.concatenate([e, twist_rows(P, db @ CQ, task)], -1) if task.has_velocity else e


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
