"""Line and rigid-body geometry, once, batched over leading axes, components last (docs/conventions.md).

Vectors are (..., 3); a line is a unit ``direction`` u and a ``moment`` m = c x u for any point c of it
(Plücker coordinates, metres); rotations are (..., 3, 3) matrices, poses (..., 4, 4) homogeneous
matrices (rotation R, translation d: a body point b sits at R b + d) or unit dual quaternions (..., 8)
(`synth.algebra.dq`). Angles are in radians, lengths in the caller's unit.

- vectors: `cross`, `skew`, `perpendicular_basis`, `line_point`;
- rotations: `rotation_about_axis` (Rodrigues), `rotation_about_line` (4x4), `rotation_angle`, `pose_difference`,
  `dq_pose_difference`, `pose_difference_squares`, `chord_angle`, `invert_pose`; quaternion <-> matrix are `synth.algebra.dq.quat_to_matrix` and
  `matrix_to_quat` (the dual-quaternion algebra builds on them);
- pairs of lines: `common_normal`, `ring_normals` (consecutive axes around closed loops),
  `dh_parameters` (Denavit-Hartenberg), `line_distance`;
- sizes: `spread` (centroid and RMS distance of points), `extent` (a length scale of a point set),
  `joint_sites` (where a linkage's pins are).

**Parallel lines** (one rule): ``|u1 x u2| < PARALLEL_TOL`` (the sine of the angle between them). The
common normal of such a pair is taken through the midpoint of the two lines' points nearest the origin
(feet: that midpoint projected onto each line). Below this angle the cross product, computed with an
absolute error of a few ulps, has lost more than 7 of its digits, and the exact common normal lies more
than 1e9 distances along the axes: neither accurate nor a place for a pin. (The syntheses used 1e-12 with
the foot on the first line's origin point, the linkage's pin sites 1e-9 with the midpoint; for exactly
parallel axes, as in every planar fixture, the two give the same feet up to rounding.)
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import dot, dq_translation

PARALLEL_TOL = 1e-9  # |u1 x u2| below this: parallel lines (see the module docstring)
INTERSECT_TOL = 1e-12  # a common normal at most this long: intersecting lines (normal = u1 x u2 / |u1 x u2|)
MIN_EXTENT = 1e-9  # `extent` is at least this
_PARALLEL_TOL2 = PARALLEL_TOL * PARALLEL_TOL
_FLOAT = np.dtype(np.float64)

_CROSS_A, _CROSS_B = np.array([1, 2, 0, 2, 0, 1]), np.array([2, 0, 1, 1, 2, 0])  # a_j b_k, then a_k b_j


# ----------------------------------------------------------------- vectors
def cross(a, b) -> np.ndarray:
    """Cross products a x b of 3-vectors (..., 3), broadcast, float (complex input stays complex: the
    complex-step derivatives of `synth.synthesis.fit`). ``numpy.cross`` costs ~15 us of overhead per call,
    which dominates a single synthesis, and is 2-5x slower than componentwise products on large broadcast
    batches: up to a few hundred vectors by one product of two index permutations (all six a_j b_k at
    once), more component by component into the result."""
    a = np.asarray(a)
    if a.dtype is not _FLOAT and a.dtype.kind != "c":
        a = a.astype(float)
    b = np.asarray(b)
    if b.dtype is not _FLOAT and b.dtype.kind != "c":
        b = b.astype(float)
    if a.size + b.size <= 3000:
        ab = a.take(_CROSS_A, -1) * b.take(_CROSS_B, -1)
        return ab[..., :3] - ab[..., 3:]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), np.result_type(a, b))
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        np.subtract(a[..., j] * b[..., k], a[..., k] * b[..., j], out=out[..., i])
    return out


def skew(v) -> np.ndarray:
    """Cross-product matrices K (..., 3, 3) of vectors v (..., 3): K @ x == cross(v, x)."""
    v = np.asarray(v, float)
    K = np.zeros(v.shape + (3,))
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -z, y, -x
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = z, -y, x
    return K


def perpendicular_basis(n) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors e1, e2 (3,) completing the unit vector n (3,) to the right-handed orthonormal basis
    (e1, e2, n): e1 = n x e_k / |n x e_k| with e_k the coordinate axis least along n, e2 = n x e1."""
    n = np.asarray(n, float)
    e1 = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def line_point(u, m) -> np.ndarray:
    """The point u x m (..., 3) of each line (u unit, m moment) nearest the origin."""
    return cross(u, m)


# ----------------------------------------------------------------- rotations and poses
def rotation_about_axis(u, theta) -> np.ndarray:
    """Rotations (..., 3, 3) by ``theta`` (...) (right-hand rule) about the unit axes u (..., 3), broadcast:
    Rodrigues' formula R = I + sin(theta) K + (1 - cos(theta)) K^2, K = `skew` (u)."""
    theta = np.asarray(theta, float)
    return rotation_about_axis_sincos(u, np.sin(theta), np.cos(theta))


def rotation_about_axis_sincos(u, s, c) -> np.ndarray:
    """`rotation_about_axis` from the sine ``s`` and cosine ``c`` (...) of the angle (so that a caller can pass
    exact values, e.g. for multiples of 90 degrees)."""
    K = skew(u)
    s = np.asarray(s, float)[..., None, None]
    c = np.asarray(c, float)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def rotation_about_line(u, m, theta) -> np.ndarray:
    """Rigid motions (..., 4, 4) rotating by ``theta`` (right-hand rule) about the line (u, m) (unit u,
    moment m, (..., 3)), broadcast: rotation `rotation_about_axis` (u, theta), translation c - R c with
    c = u x m."""
    R = rotation_about_axis(u, theta)
    p = line_point(np.asarray(u, float), np.asarray(m, float))
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p - (R @ p[..., None])[..., 0]
    T[..., 3, 3] = 1.0
    return T


def rotation_angle(R) -> np.ndarray:
    """Rotation angle in [0, pi] (rad) of rotation matrices (..., 3, 3), accurate for small and large angles:
    atan2(|axial vector| / 2, (trace - 1) / 2)."""
    R = np.asarray(R, float)
    s = 0.5 * np.linalg.norm(np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                                       R[..., 1, 0] - R[..., 0, 1]], -1), axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1)
    return np.arctan2(s, c)


def pose_difference(A, B):
    """(translation distance, rotation angle) between poses A and B (..., 4, 4), broadcast: |d_A - d_B|
    and `rotation_angle` (R_A^T R_B)."""
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    dt = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    dr = rotation_angle(np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3])
    return dt, dr


def dq_pose_difference(A, B=None):
    """(translation distance, rotation angle) between the poses of dual quaternions A, B (..., 8) (Study
    condition assumed, any nonzero scale), or of X[0] and X[1] for one stacked array X = A (2, ..., 8)
    when B is None (one evaluation for both): |d_A - d_B| with d = 2 vec(p q~)/|p|^2, and the angle of
    p_A~ p_B in [0, pi] as 4 asin(|p_A - s p_B| / 2) for the unit primal parts (s = sign(p_A . p_B)),
    accurate for small and large angles."""
    if B is None:
        X = A
    else:
        A, B = np.broadcast_arrays(np.asarray(A, float), np.asarray(B, float))
        X = np.stack([A, B])
    P = X[..., :4]
    n = dot(P, P)
    d = dq_translation(X, n)
    d = d[0] - d[1]
    dt = np.sqrt(dot(d, d))
    u = P / np.sqrt(n)[..., None]
    w = u[0] - np.copysign(1.0, dot(u[0], u[1]))[..., None] * u[1]  # |w| <= sqrt(2)
    return dt, chord_angle(dot(w, w))


def chord_angle(w2):
    """The rotation angle in [0, pi] between unit quaternions u_A, u_B from w2 = |u_A - s u_B|^2 (s =
    sign(u_A . u_B), so w2 <= 2): 4 asin(|w| / 2), accurate for small and large angles."""
    return 4.0 * np.arcsin(0.5 * np.sqrt(w2))


_NEXT, _AFTER = (1, 2, 0), (2, 0, 1)  # cyclic index shifts of a cross product


def pose_difference_squares(H, A, B) -> tuple[np.ndarray, np.ndarray]:
    """Squared pose differences of pairs of dual quaternions given by components: H (8, L, ...) (Study
    condition assumed, any nonzero scale), pose A[i] against pose B[i] of the L axis (index arrays of equal
    length K). Returns (K, ...) arrays dt2 = |d_A - d_B|^2 (d = 2 vec(p q~) / |p|^2, the translation) and
    w2 = |u_A - s u_B|^2 (u = p / |p|, s = sign(u_A . u_B)): the rotation angle is `chord_angle` (w2).
    `dq_pose_difference`'s formulas in the component layout
    for many poses (e.g. `synth.checks.check_figures`' samples): each pose's features once, plain
    component arithmetic over long arrays, no small matrix products (for a few poses, where the count of
    numpy calls is the cost, `dq_pose_difference` is ~2x cheaper: measured, bench/RESULTS.md issue 36)."""
    n = np.multiply(H[0], H[0])  # |p|^2, d, u of every pose: one component array at a time, no copies
    tmp = np.empty_like(n)
    for c in (1, 2, 3):
        n += np.multiply(H[c], H[c], out=tmp)
    scale = np.divide(2.0, n)
    d = np.empty((3,) + n.shape)
    for i in range(3):  # d_i = 2 (q0 p_i - p0 q_i - (pv x qv)_i) / |p|^2
        x, y = 1 + _NEXT[i], 1 + _AFTER[i]
        di = np.multiply(H[4], H[1 + i], out=d[i])
        di -= np.multiply(H[0], H[5 + i], out=tmp)
        di -= np.multiply(H[x], H[4 + y], out=tmp)
        di += np.multiply(H[y], H[4 + x], out=tmp)
        di *= scale
    np.sqrt(n, out=tmp)
    u = np.multiply(H[:4], np.divide(1.0, tmp, out=n))
    dt2 = np.empty((len(A),) + n.shape[1:])
    w2 = np.empty(dt2.shape)
    t, s = np.empty(n.shape[1:]), np.empty(n.shape[1:])
    for k, (a, b) in enumerate(zip(np.asarray(A).tolist(), np.asarray(B).tolist())):
        acc = np.subtract(d[0, a], d[0, b], out=dt2[k])  # sums in component order, as sum(axis=0)
        acc *= acc
        for i in (1, 2):
            np.subtract(d[i, a], d[i, b], out=t)
            t *= t
            acc += t
        np.multiply(u[0, a], u[0, b], out=s)
        for c in (1, 2, 3):
            s += np.multiply(u[c, a], u[c, b], out=t)
        np.copysign(1.0, s, out=s)
        acc = np.subtract(u[0, a], np.multiply(u[0, b], s, out=t), out=w2[k])
        acc *= acc
        for c in (1, 2, 3):
            np.subtract(u[c, a], np.multiply(u[c, b], s, out=t), out=t)
            t *= t
            acc += t
    return dt2, w2


def invert_pose(T) -> np.ndarray:
    """Inverses of rigid motions T (..., 4, 4): rotation R^T, translation -R^T d (no general inverse)."""
    T = np.asarray(T, float)
    Ti = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    Ti[..., :3, :3] = Rt
    Ti[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    Ti[..., 3, 3] = 1.0
    return Ti


# ----------------------------------------------------------------- pairs of lines
@dataclass
class Conditioning:
    """The conditioning frame of a pose set (docs/conic.md): the positions' centroid and RMS spread."""

    centre: np.ndarray  # (3,) metres
    scale: float  # metres per conditioned unit


@dataclass(slots=True)
class CommonNormals:
    """Common normals of pairs of lines (line 1, line 2), arrays over the pairs' batch shape (...)."""

    feet: np.ndarray  # (..., 2, 3) the foot on line 1, the foot on line 2
    distance_twist: np.ndarray  # (2, ...) `distance` and `twist`, stacked
    normal: np.ndarray  # (..., 3) unit, foot 1 -> foot 2 (intersecting: u1 x u2 / |u1 x u2|; coinciding: 0)
    cross: np.ndarray  # (..., 3) u1 x u2
    cosine: np.ndarray  # (...) u1 . u2
    parallel: np.ndarray  # (...) bool: |u1 x u2| < PARALLEL_TOL
    some_parallel: bool  # any of them

    @property
    def distance(self) -> np.ndarray:
        """Length (...) of the common normal, >= 0."""
        return self.distance_twist[0]

    @property
    def twist(self) -> np.ndarray:
        """Signed angle (...) in [-pi, pi] from u1 to u2 about `normal` (right-hand rule)."""
        return self.distance_twist[1]

    @property
    def line_angle(self) -> np.ndarray:
        """Angle (...) in [0, pi/2] between the undirected lines: atan2(|u1 x u2|, |u1 . u2|)."""
        return np.arctan2(np.sqrt(dot(self.cross, self.cross)), np.abs(self.cosine))


def common_normal(u1, m1, u2, m2) -> CommonNormals:
    """Common normals of the lines (u1, m1) and (u2, m2) (unit directions, moments; (..., 3), broadcast):
    feet, distance, signed twist, unit normal (parallel lines: the module's rule)."""
    u1, m1, u2, m2 = np.broadcast_arrays(*(np.asarray(x, float) for x in (u1, m1, u2, m2)))
    UU = np.stack([u1, u2], axis=-2)
    return _normals(UU, cross(UU, np.stack([m1, m2], axis=-2)), cross(u1, u2))


def ring_normals(U, M) -> CommonNormals:
    """Common normals of consecutive axes around closed loops: lines U, M (..., J, 3) in loop order, pair
    i = (i, i+1 mod J), arrays (..., J)."""
    U = np.asarray(U, float)
    M = np.asarray(M, float)
    J = U.shape[-2]
    pair = _pair_index(J)  # (J, 2): i, i+1
    UU = U.take(pair, axis=-2)  # (..., J, 2, 3): u_i, u_{i+1}
    # u_i x m_i (the axis point p_i nearest the origin) and u_i x u_{i+1}, one product
    X = cross(UU[..., 0, None, :], np.concatenate([M, U], axis=-2).take(_moment_next_index(J), axis=-2))
    return _normals(UU, X[..., 0, :].take(pair, axis=-2), X[..., 1, :])


def _normals(UU, PP, c) -> CommonNormals:
    """Common normals of the lines through the points PP (..., 2, 3) with unit directions UU (..., 2, 3),
    c = u1 x u2 (..., 3)."""
    u1, u2 = UU[..., 0, :], UU[..., 1, :]
    s2 = dot(c, c)
    par = s2 < _PARALLEL_TOL2
    some_parallel = np.count_nonzero(par) > 0  # (count_nonzero: a quarter of any()'s call overhead)
    d = PP[..., 1, :] - PP[..., 0, :]
    # feet p1 + k1 u1, p2 + k2 u2 with (k2, k1) = ((d x u1) . c, (d x u2) . c) / |c|^2
    k = dot(cross(d[..., None, :], UU), c[..., None, :]) / (np.where(par, 1.0, s2) if some_parallel else s2)[..., None]
    feet = PP + k[..., ::-1, None] * UU
    if some_parallel:  # through the midpoint of p1 and p2, projected onto each line
        mid = 0.5 * (PP[..., 0, :] + PP[..., 1, :])
        f1 = PP[..., 0, :] + dot(mid - PP[..., 0, :], u1)[..., None] * u1
        f2 = PP[..., 1, :] + dot(f1 - PP[..., 1, :], u2)[..., None] * u2
        feet = np.where(par[..., None, None], np.stack([f1, f2], axis=-2), feet)
    dv = feet[..., 1, :] - feet[..., 0, :]
    dt = np.empty((2,) + s2.shape)  # distance, twist
    dist = np.sqrt(dot(dv, dv), out=dt[0, ...])
    apart = dist > INTERSECT_TOL
    # Lines not parallel: the normal is c / |c|, signed from foot 1 to foot 2 (the feet's difference
    # cancels when the feet lie far out along nearly parallel lines); parallel lines: the feet's difference.
    nc = np.sqrt(s2)
    signed = np.copysign(nc, dot(dv, c))
    if not some_parallel and np.count_nonzero(apart) == apart.size:
        n = c * (signed / s2)[..., None]
    else:  # intersecting lines: the normal of their plane (0 when they also coincide)
        signed = np.where(apart, signed, nc)
        n = np.where((par & apart)[..., None], dv / np.where(apart, dist, 1.0)[..., None],
                     np.where(nc[..., None] > INTERSECT_TOL, c * (signed / np.where(s2 > 0, s2, 1.0))[..., None], 0.0))
        signed = np.where(apart & ~par, signed, dot(c, n))
    cosine = dot(u1, u2)
    np.arctan2(signed, cosine, out=dt[1, ...])
    return CommonNormals(feet=feet, distance_twist=dt, normal=n, cross=c, cosine=cosine, parallel=par,
                         some_parallel=some_parallel)


@dataclass(slots=True)
class DHParameters:
    """Denavit-Hartenberg parameters around closed loops, each (..., J): for joint i ``a``/``alpha`` to the
    next joint (distance; twist signed about the common normal from i to i+1), ``d`` the offset along axis
    i from the incoming to the outgoing common normal's foot, ``theta`` the angle between those normals
    about axis i."""

    a: np.ndarray
    alpha: np.ndarray
    d: np.ndarray
    theta: np.ndarray

    def table(self, joints, row=()) -> list[dict]:
        """linkage.json's DH table of the loop of ``joints`` (names, loop order) at index ``row`` of the
        batch axes: one dict per joint (``joint``, ``next``, a, alpha, d, theta; floats)."""
        a, alpha, d, theta = (np.asarray(x)[row].tolist() for x in (self.a, self.alpha, self.d, self.theta))
        joints = list(joints)
        return [{"joint": j, "next": nxt, "a": x1, "alpha": x2, "d": x3, "theta": x4}
                for j, nxt, x1, x2, x3, x4 in zip(joints, joints[1:] + joints[:1], a, alpha, d, theta)]


def dh_parameters(U, M=None, normals: CommonNormals | None = None) -> DHParameters:
    """`DHParameters` of the loops of lines U, M (..., J, 3) in loop order; ``normals``: their
    `ring_normals`, when the caller has them (then M is not needed)."""
    U = np.asarray(U, float)
    if normals is None:
        normals = ring_normals(U, M)
    prv = _cyclic_index(U.shape[-2], -1)
    n_out = normals.normal
    f_in, n_in = normals.feet[..., 1, :].take(prv, axis=-2), n_out.take(prv, axis=-2)
    d = dot(normals.feet[..., 0, :] - f_in, U)
    theta = np.arctan2(dot(cross(n_in, n_out), U), dot(n_in, n_out))
    return DHParameters(a=normals.distance, alpha=normals.twist, d=d, theta=theta)


@functools.lru_cache(maxsize=None)
def _cyclic_index(J: int, step: int) -> np.ndarray:
    """(i + step) mod J for i < J (read-only, cached)."""
    out = (np.arange(J) + step) % J
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=None)
def _moment_next_index(J: int) -> np.ndarray:
    """Rows (m_i, u_{i+1}) of the J moments stacked on the J directions, (J, 2) (read-only, cached)."""
    out = np.stack([np.arange(J), J + _cyclic_index(J, 1)], axis=-1)
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=None)
def _pair_index(J: int) -> np.ndarray:
    """The consecutive pairs (i, i+1 mod J) around a loop of J joints, (J, 2) (read-only, cached)."""
    out = np.stack([np.arange(J), _cyclic_index(J, 1)], axis=-1)
    out.flags.writeable = False
    return out


# ----------------------------------------------------------------- sizes
def spread(points):
    """(centroid (..., 3), RMS distance from it (...)) of points (..., k, 3)."""
    pts = np.asarray(points, float)
    c = np.add.reduce(pts, axis=-2) / pts.shape[-2]  # (the sum without ndarray.sum's Python wrapper)
    return c, _rms(pts - c[..., None, :])


def _rms(rel) -> np.ndarray:
    """sqrt(sum |rel_i|^2 / k) of vectors rel (..., k, 3)."""
    k = rel.shape[-2]
    rel = rel.reshape(rel.shape[:-2] + (3 * k,))
    return np.sqrt(dot(rel, rel) / k)


def extent(points, centred: bool = False) -> np.ndarray:
    """A length scale (...) of point sets (..., k, 3): their RMS distance from the centroid (`spread`),
    at least MIN_EXTENT. ``centred``: the points are already relative to their centroid (a caller that
    gets them from one linear map, as the Bennett pipeline does). A linkage's extent
    (`synth.linkage.Linkage.extent`) is that of its joint sites and tool positions."""
    pts = np.asarray(points, float)
    return np.maximum(_rms(pts) if centred else spread(pts)[1], MIN_EXTENT)


def joint_sites(U, M, pairs, centre) -> np.ndarray:
    """Where the pins of joints (lines U, M (..., J, 3)) are: the mean of the feet of the common normals of
    ``pairs`` (P, 2) (joint indices, the same for every linkage of the batch; consecutive joints carried by
    one link) on each joint, and for a joint in no pair the point of its axis nearest ``centre`` (..., 3).
    Returns (..., J, 3); the feet are summed in pair order (the same bits for a batch and for one)."""
    U = np.asarray(U, float)
    M = np.asarray(M, float)
    P = line_point(U, M)
    sites = P + dot(np.asarray(centre, float)[..., None, :] - P, U)[..., None] * U
    pairs = np.asarray(pairs, int).reshape(-1, 2)
    if len(pairs):
        i, k = pairs[:, 0], pairs[:, 1]
        feet = common_normal(U[..., i, :], M[..., i, :], U[..., k, :], M[..., k, :]).feet  # (..., P, 2, 3)
        acc = np.zeros(U.shape)
        for p, ends in enumerate(pairs.tolist()):
            for side, j in enumerate(ends):
                acc[..., j, :] += feet[..., p, side, :]
        count = np.bincount(pairs.reshape(-1), minlength=U.shape[-2]).astype(float)[:, None]
        sites = np.where(count > 0, acc / np.maximum(count, 1.0), sites)
    return sites


def line_box_distance(point, direction, box: Box) -> np.ndarray:
    """(...) the distance of the lines ``point + s direction`` (each (..., 3), direction nonzero) from the
    axis-aligned box (``box.lo``, ``box.hi`` (3,)), exactly: the squared distance is convex and piecewise quadratic in s, with breaks
    where a coordinate crosses a face; its minimum is at a break or at a piece's stationary point."""
    p, d = np.asarray(point, float), np.asarray(direction, float)
    lo, hi = box.lo, box.hi
    with np.errstate(divide="ignore", invalid="ignore"):
        brk = np.concatenate([(lo - p) / d, (hi - p) / d], axis=-1)  # (..., 6), inf/nan where d_k = 0
    brk = np.sort(np.where(np.isfinite(brk), brk, 0.0), axis=-1)
    mids = np.concatenate([brk[..., :1] - 1.0, (brk[..., 1:] + brk[..., :-1]) / 2, brk[..., -1:] + 1.0], axis=-1)
    x = p[..., None, :] + mids[..., None] * d[..., None, :]  # (..., 7, 3): a point of each piece
    face = np.where(x < lo, lo, np.where(x > hi, hi, np.nan))  # the active face per coordinate, nan: inside
    out = ~np.isnan(face)
    dd = np.where(out, d[..., None, :], 0.0)
    s_star = -np.sum(dd * np.where(out, p[..., None, :] - face, 0.0), axis=-1) / np.maximum(np.sum(dd * dd, -1), 1e-300)
    lo_s = np.concatenate([np.full(brk.shape[:-1] + (1,), -np.inf), brk], axis=-1)
    hi_s = np.concatenate([brk, np.full(brk.shape[:-1] + (1,), np.inf)], axis=-1)
    s = np.concatenate([brk, np.clip(s_star, lo_s, hi_s)], axis=-1)  # (..., 13) candidates
    y = p[..., None, :] + s[..., None] * d[..., None, :]
    gap = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
    return np.sqrt(np.sum(gap * gap, axis=-1)).min(axis=-1)
