"""Motion polynomials through given poses (docs/conic.md).

Poses are 4x4 arrays in metres. Synthesis works on *conditioned* poses: world origin moved to the
centroid ``c`` of the positions, lengths divided by their RMS spread ``L``; ``to_world`` maps dual
quaternions (factors, polynomials) back. Relative displacements are taken in the world frame,
``D_i = T_i T_0^{-1}``, so that the first pose is the reference configuration (t = infinity).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import dq_conj, dq_left_matrix, dq_mul, normalize_dq, pose_to_dq, study_form
from synth.algebra.geometry import Conditioning, spread
from synth.errors import SynthesisError

_ONE = np.eye(8)[0]
TS = np.array([np.inf, 0.0, 1.0])  # the parameters of the three poses on the conic (read-only)
TS.flags.writeable = False


def position_spread(T) -> tuple[np.ndarray, np.ndarray]:
    """(centroid (..., 3), RMS distance from it (...)) of the positions of poses T (..., k, 4, 4)."""
    return spread(np.asarray(T, float)[..., :3, 3])


def conditioning(T) -> Conditioning:
    """The centroid of the positions of poses T (..., k, 4, 4) (centre (..., 3)) and their RMS spread
    (scale (...), 1 where the positions coincide)."""
    c, L = position_spread(T)
    return Conditioning(centre=c, scale=np.where(L > 0, L, 1.0))


def condition(T) -> tuple[np.ndarray, Conditioning]:
    """Move the origin to the centroid of the positions and divide lengths by their RMS spread
    (`conditioning`). Works on (..., k, 4, 4); the centre is (..., 3), the scale (...)."""
    T = np.asarray(T, float)
    cond = conditioning(T)
    Tc = T.copy()
    Tc[..., :3, 3] = (T[..., :3, 3] - cond.centre[..., None, :]) / cond.scale[..., None, None]
    return Tc, cond


def to_world(h, cond: Conditioning):
    """Map dual quaternions h (..., 8) from conditioned to world coordinates: scale the dual part by L,
    then conjugate by the translation to the centroid (h -> tau h tau^-1 with tau = 1 - eps c / 2, which
    adds vec(p) x c to the dual vector part): one linear map h -> h W of each set (`world_map`). A
    batched ``cond`` (scale (B,), centre (B, 3)) applies to the leading axis of h."""
    h = np.asarray(h, float)
    L = np.asarray(cond.scale, float)
    W = world_map(L, cond.centre)
    extra = h.ndim - 1 - L.ndim  # axes of h between the sets and the coefficients
    if extra == 0:
        return np.matmul(h[..., None, :], W)[..., 0, :]
    return np.matmul(h, W.reshape(L.shape + (1,) * (extra - 1) + (8, 8)))


def world_map(L, c) -> np.ndarray:
    """The matrices W (..., 8, 8) of `to_world` (row vectors: h_world = h W) for scales L (...) and
    centres c (..., 3): diag(1, 1, 1, 1, L, L, L, L) plus vec(p) x c in the dual vector rows."""
    Lc = np.empty(np.shape(L) + (4,))
    Lc[..., 0] = L
    Lc[..., 1:] = c
    W = Lc @ _WORLD_LC
    W += _WORLD_ONE
    return W.reshape(Lc.shape[:-1] + (8, 8))


def condition_map(L, c) -> np.ndarray:
    """The matrices S (..., 8, 8) (row vectors: h S) moving poses as unit dual quaternions (..., 8) to
    the conditioned frame of centre c (..., 3) and scale L (...): the translation by -c, then the dual
    part divided by L, i.e. (1 + eps c / 2) h with q / L (`condition`)."""
    g = np.empty(np.shape(L) + (4,))
    g[..., 0] = 1.0
    g[..., 1:] = c
    g /= np.asarray(L, float)[..., None]  # (1, c) / L
    S = g @ _CONDITION_GC
    S += _WORLD_ONE
    return S.reshape(g.shape[:-1] + (8, 8))


def _condition_constants():
    """(4, 64): S = (1, c) / L @ A + `_WORLD_ONE`, flattened (`condition_map`)."""
    A = np.zeros((4, 8, 8))
    A[0, 4:, 4:] = np.eye(4)
    A[1:] = 0.5 * dq_left_matrix(np.eye(8)[5:])  # eps c_i / 2 e_i h
    return A.reshape(4, 64)


def _world_constants():
    """(4, 64) and (64,): W = (L, c) @ A + B, flattened (`world_map`)."""
    A = np.zeros((4, 8, 8))
    A[0, 4:, 4:] = np.eye(4)
    for j, k, i in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):  # (p x c)_i = p_j c_k - p_k c_j (vector axes 1..3)
        A[1 + k, 1 + j, 5 + i] = 1.0
        A[1 + j, 1 + k, 5 + i] = -1.0
    B = np.zeros((8, 8))
    B[:4, :4] = np.eye(4)
    return A.reshape(4, 64), B.reshape(64)


_WORLD_LC, _WORLD_ONE = _world_constants()
_CONDITION_GC = _condition_constants()


def relative_displacements(T):
    """D_i = T_i T_0^{-1} as unit dual quaternions with p0 >= 0, shape (..., k, 8); D_0 = 1."""
    return relative_displacements_dq(pose_to_dq(np.asarray(T, float)))


def relative_displacements_dq(H):
    """`relative_displacements` of poses given as unit dual quaternions H (..., k, 8) (D_0 = 1 exactly)."""
    H0inv = dq_conj(H[..., :1, :])  # unit: inverse = conjugate
    D = np.empty(H.shape)
    D[..., 0, :] = _ONE
    D[..., 1:, :] = normalize_dq(dq_mul(H[..., 1:, :], H0inv))
    return D




@dataclass
class ConicData:
    C: np.ndarray  # (3, 8) monic quadratic motion polynomial (conditioned frame)
    ts: np.ndarray  # parameters of the poses: inf, 0, 1
    B: np.ndarray  # (B01, B02, B12)


def conic(D, tol=1e-9) -> ConicData:
    """The monic quadratic C with C(inf) = 1, C(0) ~ D_1, C(1) ~ D_2 (docs/conic.md).

    D: (..., 3, 8) with D_0 = 1 (conditioned frame, unit dual quaternions). Raises SynthesisError
    for a single input whose Study-form values vanish (pure rotations or translations between poses)."""
    D = np.asarray(D, float)
    D1, D2 = D[..., 1, :], D[..., 2, :]
    B = np.empty(D.shape[:-2] + (3,))  # B01, B02, B12
    np.multiply(D[..., 1:, 4], 0.5, out=B[..., :2])
    B[..., 2] = study_form(D1, D2)
    if D.ndim == 2:
        check_conic_degeneracy(D, *B, tol)
    lam = B[..., 1::-1] / B[..., 2:]  # B02 / B12, B01 / B12: C(0) = lam1 D_1, C(1) = lam2 D_2 (docs/conic.md, section 2)
    return ConicData(C=conic_member(D, lam), ts=TS, B=B)


def conic_member(D, lam) -> np.ndarray:
    """The monic quadratic C(t) = t (t - 1) - lam1 (t - 1) D_1 + lam2 t D_2 of the plane of D (..., 3, 8)
    (D_0 = 1): C(inf) = 1, C(0) = lam1 D_1, C(1) = lam2 D_2; lam (..., 2). It is a motion polynomial
    when the weights solve the Study condition (`conic`), and for every lam when the plane lies in the
    Study quadric (planar or spherical poses, docs/planar.md). Returns (..., 3, 8)."""
    D = np.asarray(D, float)
    lam = np.asarray(lam, float)
    C = np.matmul(_MEMBER_ROWS, lam[..., :, None] * D[..., 1:, :])  # l1 D_1, l2 D_2 - l1 D_1, 0
    C += _MEMBER_CONSTANT  # + t (t - 1)
    return C


_MEMBER_ROWS = np.array([[1.0, 0.0], [-1.0, 1.0], [0.0, 0.0]])
_MEMBER_CONSTANT = np.zeros((3, 8))
_MEMBER_CONSTANT[1, 0], _MEMBER_CONSTANT[2, 0] = -1.0, 1.0


def check_conic_degeneracy(D, B01, B02, B12, tol):
    """Plain-language refusal of inputs whose conic degenerates (docs/conic.md)."""
    pairs = {(0, 1): B01, (0, 2): B02, (1, 2): B12}
    zero = [p for p, b in pairs.items() if abs(b) <= tol]
    if len(zero) == 3:
        raise SynthesisError(
            "the three poses are nearly, but not exactly, related by planar or spherical motions (every relative "
            "screw has a pitch below 1e-9 of the pose spread): the spatial conic through them is numerically "
            "degenerate; make the poses exactly planar (or spherical) for a four-bar, or move a pose out of "
            "the plane of motion")
    if zero:
        i, j = zero[0]
        rel = dq_mul(D[j], D[i] * np.array([1.0, -1, -1, -1, 1, -1, -1, -1]))
        rot = np.linalg.norm(rel[1:4])
        what = "a pure translation" if rot < 1e-9 else "a pure rotation (zero pitch)"
        raise SynthesisError(
            f"poses {i} and {j} differ by {what}: the conic through the poses degenerates and no "
            "Bennett linkage passes through them; move one of these poses along or about its screw axis")
