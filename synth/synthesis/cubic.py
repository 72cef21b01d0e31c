"""Cubic motion polynomials through four poses (docs/cubic.md).

The relative displacements ``D_0 = 1, D_1, D_2, D_3`` (conditioned frame, unit dual quaternions) span
a 3-space ``V`` of P^7. ``V`` meets the Study quadric in a quadric surface; when it is *ruled*
(signature (2, 2)) it carries two one-parameter families of real rational cubics through the four
points, each a *pencil* of monic cubic motion polynomials ``C`` with ``C(inf) = 1``, ``C(0) ~ D_1``,
``C(1) ~ D_2`` and ``C(t3) ~ D_3``; ``t3`` is fixed per family.

Conventions of this module (documented for the CLI):

* **Family numbering.** Family 1 is the family with the *larger* value of ``t3``, family 2 the other
  one (the set of the two ``t3`` values is well defined, docs/cubic.md; which ruling is "u" is not).
* **Member label.** A member is named by ``lambda1``, its weight at ``t = 0``: ``C(0) = lambda1 D_1``
  (``D_1`` with unit primal part, ``p0 >= 0``). The label does not depend on the coordinate frame
  (conditioning maps ``C`` and ``D_1`` by the same linear map). ``lambda1 = inf`` is the member that
  misses pose 0; ``lambda1 = 0`` and the members with ``lambda2 = 0`` or ``lambda3 = 0`` have a real
  factor and no 6R linkage.
* **Grid.** The pencil is the projective line spanned by two cubics ``Q_a, Q_b`` that are orthonormal
  as 32-vectors of coefficients; grid members are ``cos(phi) Q_a + sin(phi) Q_b`` for ``phi`` uniform
  in ``[0, pi)``, normalized to be monic.
* **Norm quadratics** of a member are sorted by the real part ``a`` of their root ``a + ib`` (then by
  ``b``): quadratic 0 has the smallest ``a``. A factorization is named by its *order*, the indices of
  the quadratics of its factors from left (base) to right (coupler); the 6 orders are the permutations
  of (0, 1, 2) in lexicographic order.
* **Loop pairs.** Two factorizations close into a genuine 6R loop iff their leftmost quadratics differ
  and their rightmost quadratics differ: 9 unordered pairs. Pairs are numbered 1..9 in lexicographic
  order of (order_h, order_k) with order_h < order_k; branch h is order_h, branch k is order_k.

The factorizations of the members and their loops are built in `synth.synthesis.sixbar_loops`; nothing
here builds a `Linkage`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra.algorithm1 import orders
from synth.errors import SynthesisError

RANK_TOL = 1e-9  # 4th singular value of [D_0..D_3] below this times the 1st: the poses span < 3-space
PLANAR_TOL = 1e-12  # all eigenvalues of A at most this: the 3-space lies inside the Study quadric
CONE_TOL = 1e-9  # smallest |eigenvalue| at most this times the largest: a cone, not a smooth quadric
RULING_TOL = 1e-9  # |det| of ruling coordinates (unit vectors) below this: two poses on one ruling line

PERMS = orders(3)  # (6, 3), lexicographic
PAIRS = np.array([(i, j) for i in range(6) for j in range(i + 1, 6)
                  if PERMS[i, 0] != PERMS[j, 0] and PERMS[i, 2] != PERMS[j, 2]], int)  # (9, 2)

_ONE = np.eye(8)[0]
_G = 0.5 * np.block([[np.zeros((4, 4)), np.eye(4)], [np.eye(4), np.zeros((4, 4))]])


# ============================================================================ the quadric
@dataclass
class Quadric:
    """The section of the Study quadric by the 3-space of four relative displacements."""

    D: np.ndarray  # (4, 8) D_0..D_3
    B: np.ndarray  # (8, 4) orthonormal basis of V (QR of D^T)
    A: np.ndarray  # (4, 4) Gram matrix B^T G B
    eigenvalues: np.ndarray  # (4,) decreasing
    U: np.ndarray  # (4, 4) eigenvectors (columns), same order
    signature: tuple[int, int]  # (positive, negative) eigenvalue counts
    singular_values: np.ndarray  # (4,) of [D_0..D_3]

    @property
    def ruled(self) -> bool:
        return self.signature == (2, 2)

    @property
    def W(self) -> np.ndarray:
        """U diag(sqrt|lambda|): y = W^T x gives x^T A x = y1^2 + y2^2 - y3^2 - y4^2 (ruled case)."""
        return self.U * np.sqrt(np.abs(self.eigenvalues))

    @property
    def P(self) -> np.ndarray:
        """(8, 4) map y -> dual quaternion B W^{-T} y."""
        return self.B @ (self.U / np.sqrt(np.abs(self.eigenvalues)))

    def coordinates(self, h) -> np.ndarray:
        """x = B^T h for dual quaternions h in V, shape (..., 4)."""
        return np.asarray(h, float) @ self.B


def quadric(D) -> Quadric:
    """Gram matrix, eigen-decomposition and signature of V cap S for D (4, 8) with D_0 = 1.

    Raises SynthesisError when the poses do not span a 3-space, or V lies in S (planar or spherical
    pose sets), or the section is a cone."""
    D = np.asarray(D, float)
    sv = np.linalg.svd(D, compute_uv=False)
    if sv[3] < RANK_TOL * sv[0]:
        raise SynthesisError(
            "the four poses are not independent (the fourth relative displacement is a combination of the "
            "others: all four lie on one Bennett motion, or some poses repeat a common screw motion); "
            "there is no unique cubic through them. Use `mpsynth bennett` on three of them, or move one "
            "pose off that motion")
    B = np.linalg.qr(D.T)[0]
    A = B.T @ _G @ B
    A = 0.5 * (A + A.T)
    lam, U = np.linalg.eigh(A)
    ev = lam.tolist()
    order = sorted(range(4), key=lambda i: -ev[i])  # decreasing; stable like argsort for 4 elements
    lam, U = lam[order], U[:, order]
    big = max(abs(x) for x in ev)
    if big <= PLANAR_TOL:
        raise SynthesisError(
            "every relative displacement of the four poses has zero pitch (planar motions, pure translations "
            "or rotations about a common point): the 3-space through them lies inside the Study quadric, so "
            "the cubic motion through the poses is not unique and a planar or spherical mechanism fits them, "
            "not a spatial 6R. Move a pose out of the plane of motion (or off the common centre of rotation)")
    zero = sum(abs(x) <= CONE_TOL * big for x in ev)
    if zero >= 2:
        raise SynthesisError(
            "the quadric through the four poses degenerates into a pair of planes (two Gram eigenvalues "
            "vanish): typically three of the poses are related by planar motions (rotations about parallel "
            "axes without sliding along them, or pure translations), and no cubic 6R motion passes through "
            "all four. Move one of those poses out of their common plane of motion")
    if zero == 1:
        raise SynthesisError(
            "the quadric through the four poses is a cone (one Gram eigenvalue vanishes): the poses are in a "
            "special position where the two families of cubic motions merge and degenerate. Perturb one pose "
            "(e.g. its position by 1% of the pose spread) and try again")
    sig = (sum(x > 0 for x in ev), sum(x < 0 for x in ev))
    return Quadric(D=D, B=B, A=A, eigenvalues=lam, U=U, signature=sig, singular_values=sv)


def oval_message(q: Quadric) -> str:
    return (
        f"no real 6R linkage passes through these four poses: the quadric through their displacements is "
        f"oval (Gram signature {q.signature}, not (2, 2)), so it contains no real lines and there is no "
        "real one-parameter family of cubic motions through the poses (the fourth pose would be reached "
        "at a complex parameter). This is a property of the pose set, not a numerical failure, and "
        "reordering the poses does not change it: change a pose (its orientation or position) and try "
        "again; about 85% of random pose sets admit a solution")


def cubic_member(D, t3, lam) -> np.ndarray:
    """The Lagrange cubic through four displacements D (..., 4, 8) (D_0 = 1) at t = inf, 0, 1, t3 (...):
    ``C(t) = t (t - 1)(t - t3) + lam1 l1(t) D_1 + lam2 l2(t) D_2 + lam3 l3(t) D_3`` with the quadratic
    Lagrange basis l_i of the nodes 0, 1, t3, so that C is monic and ``C(0) = lam1 D_1``, ``C(1) = lam2 D_2``,
    ``C(t3) = lam3 D_3``; lam (..., 3). A motion polynomial for every member when the span of the D_i lies
    in the Study quadric (planar or spherical poses, docs/planar.md). Returns (..., 4, 8), ascending."""
    D = np.asarray(D, float)
    t = np.asarray(t3, float)[..., None]
    lam = np.asarray(lam, float)
    one, zero = np.ones_like(t), np.zeros_like(t)
    cubic = np.concatenate([zero, t, -(1 + t), one], -1)  # t (t - 1)(t - t3), ascending
    basis = np.stack([np.concatenate([t, -(1 + t), one, zero], -1) / t,  # (t - 1)(t - t3) / t3
                      np.concatenate([zero, -t, one, zero], -1) / (1 - t),  # t (t - t3) / (1 - t3)
                      np.concatenate([zero, -one, one, zero], -1) / (t * (t - 1))], -2)  # t (t - 1) / (t3 (t3 - 1))
    C = np.einsum("...i,...ik,...ij->...kj", lam, basis, D[..., 1:, :])
    C[..., 0] += cubic
    return C


# ============================================================================ ruling coordinates
def ruling_matrix(y) -> np.ndarray:
    """M(y) = [[y1 + y3, y2 + y4], [y4 - y2, y1 - y3]] for y (..., 4); det M = y1^2+y2^2-y3^2-y4^2."""
    y = np.asarray(y, float)
    y1, y2, y3, y4 = y[..., 0], y[..., 1], y[..., 2], y[..., 3]
    M = np.empty(y.shape[:-1] + (2, 2))
    np.add(y1, y3, out=M[..., 0, 0])
    np.add(y2, y4, out=M[..., 0, 1])
    np.subtract(y4, y2, out=M[..., 1, 0])
    np.subtract(y1, y3, out=M[..., 1, 1])
    return M


def ruling_inverse(M) -> np.ndarray:
    """y = ((M11+M22)/2, (M12-M21)/2, (M11-M22)/2, (M12+M21)/2) for M (..., 2, 2)."""
    M = np.asarray(M, float)
    return 0.5 * np.stack([M[..., 0, 0] + M[..., 1, 1], M[..., 0, 1] - M[..., 1, 0],
                           M[..., 0, 0] - M[..., 1, 1], M[..., 0, 1] + M[..., 1, 0]], -1)


def ruling_coordinates(q: Quadric, h=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rank-1 factorization M(W^T x) = s u v^T for the points h (default: the four D_i). Returns unit
    u (..., 2), v (..., 2) and the relative size of the second singular value (0 on the quadric)."""
    h = q.D if h is None else np.asarray(h, float)
    M = ruling_matrix(q.coordinates(h) @ q.W)
    Uu, s, Vt = np.linalg.svd(M)
    return Uu[..., :, 0], Vt[..., 0, :], s[..., 1] / s[..., 0]


# ============================================================================ families
@dataclass
class CubicFamily:
    """One pencil of monic cubics through the four poses (conditioned frame)."""

    index: int  # 1 or 2 (family 1 has the larger t3)
    transpose: bool  # False: u linear / v quadratic; True: the roles swapped (M^T)
    t3: float
    basis: np.ndarray  # (2, 4, 8) Q_a, Q_b: orthonormal 32-vectors spanning the pencil (not monic)
    lead: np.ndarray  # (2,) leading scalar coefficients of Q_a, Q_b
    weights: np.ndarray  # (2, 4) lambda_i numerators: Q(t_i) = weights[:, i] D_i (i = 0 is the lead)
    D: np.ndarray  # (4, 8)
    ts: np.ndarray  # (4,) inf, 0, 1, t3

    # -------------------------------------------------------------- members
    def members(self, phi) -> tuple[np.ndarray, np.ndarray]:
        """Monic members cos(phi) Q_a + sin(phi) Q_b for phi of shape S: (C (*S, 4, 8), lambda1 (*S))."""
        phi = np.asarray(phi, float)
        c, s = np.cos(phi), np.sin(phi)
        lead = c * self.lead[0] + s * self.lead[1]
        C = (c[..., None, None] * self.basis[0] + s[..., None, None] * self.basis[1]) / lead[..., None, None]
        C[..., 3, :] = np.eye(8)[0]
        lam1 = (c * self.weights[0, 1] + s * self.weights[1, 1]) / lead
        return C, lam1

    def lambdas(self, phi) -> np.ndarray:
        """(lambda1, lambda2, lambda3) of the monic members at phi, shape (*S, 3)."""
        phi = np.asarray(phi, float)
        c, s = np.cos(phi), np.sin(phi)
        w = c[..., None] * self.weights[0] + s[..., None] * self.weights[1]
        return w[..., 1:] / w[..., :1]

    def phi_of_lambda1(self, lam1: float) -> float:
        """The pencil angle of the member with C(0) = lam1 D_1 (inverse of the Moebius map)."""
        # cos(phi) (w_a1 - lam1 l_a) + sin(phi) (w_b1 - lam1 l_b) = 0
        if not np.isfinite(lam1):
            ea, eb = self.lead
        else:
            ea = self.weights[0, 1] - lam1 * self.lead[0]
            eb = self.weights[1, 1] - lam1 * self.lead[1]
        return float(np.mod(np.arctan2(-ea, eb), np.pi))

    def member(self, lam1: float) -> np.ndarray:
        """The monic member with C(0) = lam1 D_1, shape (4, 8)."""
        lam1 = float(lam1)
        if not np.isfinite(lam1):
            raise SynthesisError("member lambda1 must be a finite number (lambda1 = inf misses pose 0)")
        (la, lb), (wa, wb) = self.lead.tolist(), self.weights[:, 1].tolist()
        det = la * wb - lb * wa  # a (la, lb) + b ... : a la + b lb = 1, a wa + b wb = lam1 (Cramer)
        if abs(det) <= 1e-14 * max(abs(la), abs(lb), abs(wa), abs(wb)) ** 2:
            raise SynthesisError(f"family {self.index}: the member label lambda1 is degenerate for these poses")
        a, b = (wb - lb * lam1) / det, (la * lam1 - wa) / det
        C = a * self.basis[0] + b * self.basis[1]
        C[3] = _ONE
        return C

    def bad_members(self) -> dict[str, float]:
        """lambda1 of the members to avoid: 'lead' (misses pose 0, lambda1 = inf), 'lambda1' (0), and
        'lambda2', 'lambda3' (C(1) = 0 or C(t3) = 0)."""
        out = {"lead": float("inf"), "lambda1": 0.0}
        for i, key in ((2, "lambda2"), (3, "lambda3")):
            phi = float(np.arctan2(-self.weights[0, i], self.weights[1, i]))
            lam = self.lambdas(phi)[0]
            out[key] = float(lam) if np.isfinite(lam) else float("inf")
        return out


_BZ = np.zeros((3, 5, 2))  # coefficient vectors of t^0, t^1 in b(t) for z = e_k (t^2: set per family)
_BZ[0, 3:5] = np.eye(2)
_BZ[1, 1:3] = np.eye(2)
_RULING_INV = 0.5 * np.array([[1.0, 0, 0, 1], [0, 1, -1, 0], [1, 0, 0, -1], [0, 1, 1, 0]])  # y = R vec(M)


def _families(q: Quadric, u, v):
    """Both families at once (index 0: u linear / v quadratic, index 1: the roles swapped). Returns,
    per family, either (t3, basis, lead, weights) or a string saying why the family does not exist.
    u, v: the ruling coordinates of the four poses."""
    a = np.array([u, v])  # (2, 4, 2): the linear ruling of each family
    b = a[::-1]  # the quadratic ruling
    # the 2 x 2 determinants and the system E in plain floats (elementwise, as numpy would do them)
    why, alpha, beta, t3, E = [None, None], [0.0, 0.0], [0.0, 0.0], [2.0, 2.0], []
    for f, (A, B) in enumerate(((u.tolist(), v.tolist()), (v.tolist(), u.tolist()))):
        why[f], alpha[f], beta[f], t3f = _ruling_parameters(A)
        if why[f] is None:
            t3[f] = t3f  # else a placeholder keeps the batch finite
        # v(t) = gamma b0 t^2 + w1 t + w0 with det(v(t_i), b_i) = 0, i = 1, 2, 3; unknowns z = (gamma, w1, w0)
        E.append([[t * t * (B[0][0] * bi[1] - B[0][1] * bi[0]), t * bi[1], -t * bi[0], bi[1], -bi[0]]
                  for t, bi in zip((0.0, 1.0, t3[f]), B[1:])])
    _, sv, Vt = np.linalg.svd(np.array(E))  # (2, 3, 5)
    for f in (0, 1):
        if why[f] is None and sv[f, 2] < RULING_TOL * sv[f, 0]:
            why[f] = "the pose parameters coincide (t3 = 0 or 1): two poses lie on one ruling line"
    alpha, beta = np.array(alpha), np.array(beta)
    tt = np.array([[0.0, 1.0, t3[0]], [0.0, 1.0, t3[1]]])[..., None]  # (2, 3, 1)
    null = Vt[:, 3:]  # (2, 2, 5)
    # M(t) = a(t) b(t)^T with a(t) = alpha a_0 t + beta a_1 and b(t) = gamma b_0 t^2 + w1 t + w0 is
    # bilinear in (a, z); coefficient of t^j: sum over p + r = j of a_p b_r(z)^T
    Az = np.empty((2, 2, 2))  # family, t^p
    Az[:, 0] = beta[:, None] * a[:, 1]
    Az[:, 1] = alpha[:, None] * a[:, 0]
    Bz = np.array([_BZ, _BZ])
    Bz[:, 2, 0] = b[:, 0]
    full = Az[:, :, None, None, :, None] * Bz[:, None, :, :, None, :]  # (f, p, r, k, 2, 2)
    Mz = np.empty((2, 4, 5, 2, 2))
    Mz[:, 0] = full[:, 0, 0]
    np.add(full[:, 0, 1], full[:, 1, 0], out=Mz[:, 1])
    np.add(full[:, 0, 2], full[:, 1, 1], out=Mz[:, 2])
    Mz[:, 3] = full[:, 1, 2]
    Mz[1] = np.swapaxes(Mz[1], -1, -2)  # family 2 uses M^T
    Y = Mz.reshape(2, 4, 5, 4) @ _RULING_INV.T  # y(M) per coefficient and unit z: (2, 4, 5, 4)
    Q = (null @ np.swapaxes(Y, 1, 2).reshape(2, 5, 16)).reshape(2, 2, 4, 4) @ q.P.T  # (2, 2, 4, 8)
    # orthonormal pencil basis (Gram-Schmidt on the two 32-vectors)
    Qa, Qb = Q[:, 0].reshape(2, 32), Q[:, 1].reshape(2, 32)
    Qa = Qa / np.sqrt(np.add.reduce(Qa * Qa, -1, keepdims=True))  # (np.linalg.norm's own reduction)
    Qb = Qb - np.add.reduce(Qa * Qb, -1, keepdims=True) * Qa
    Qb = Qb / np.sqrt(np.add.reduce(Qb * Qb, -1, keepdims=True))
    basis = np.concatenate([Qa, Qb], 1).reshape(2, 2, 4, 8)
    lead = basis[:, :, 3, 0]  # (2, 2)
    # weights: Q(t_i) . D_i (primal parts; |p(D_i)| = 1), and the lead for i = 0
    V = tt ** np.arange(4)  # (2, 3, 4)
    vals = V[:, None] @ basis[..., :4]  # (2, 2, 3, 4)
    w = np.concatenate([lead[..., None], np.add.reduce(vals * q.D[1:, :4], -1)], -1)  # (2, 2, 4)
    return [why[f] if why[f] else (float(t3[f]), basis[f], lead[f], w[f]) for f in (0, 1)]


def _ruling_parameters(A):
    """(why not, alpha, beta, t3) of one family from the linear ruling coordinates A (4 points x 2) of the
    poses: alpha a_0 + beta a_1 = a_2 (Cramer) and t3, in plain floats; ``why`` says why the family
    does not exist (None if it does)."""
    (a00, a01), (a10, a11), (a20, a21), (a30, a31) = A
    d01 = a00 * a11 - a01 * a10
    why = None
    if abs(d01) < RULING_TOL:
        why = "poses 0 and 1 lie on one ruling line (they differ by a pure rotation or translation)"
        d01 = 1.0
    alpha = (a20 * a11 - a21 * a10) / d01
    beta = (a00 * a21 - a01 * a20) / d01
    d03 = a00 * a31 - a01 * a30
    with np.errstate(all="ignore"):  # numpy's division: +-inf or NaN for a zero denominator
        t3 = float(np.float64(-beta * (a10 * a31 - a11 * a30)) / np.float64(alpha * d03))
    if why:
        pass
    elif abs(alpha) < RULING_TOL or abs(beta) < RULING_TOL:
        why = "pose 2 lies on a ruling line through pose 0 or 1 (a pure rotation or translation between them)"
    elif abs(d03) < RULING_TOL:
        why = "pose 3 lies on the ruling line through pose 0 (a pure rotation or translation between them, t3 = inf)"
    elif min(abs(t3), abs(t3 - 1)) < RULING_TOL:
        why = ("pose 3 lies on a ruling line through pose 1 or 2 (a pure rotation or translation between "
               "them): every member of this family has a real factor")
    return why, alpha, beta, t3


def families(q: Quadric) -> tuple[list[CubicFamily], dict[int, str]]:
    """Both families of a ruled quadric, numbered (family 1: larger t3). Returns (families, reasons)
    where reasons maps the number of a missing family to why it does not exist."""
    if not q.ruled:
        raise SynthesisError(oval_message(q))
    u, v, _ = ruling_coordinates(q)
    raw = list(zip(_families(q, u, v), (False, True)))
    good = sorted([(r, tr) for r, tr in raw if not isinstance(r, str)], key=lambda x: -x[0][0])
    bad = [r for r, tr in raw if isinstance(r, str)]
    fams = []
    for i, ((t3, basis, lead, w), tr) in enumerate(good):
        fams.append(CubicFamily(index=i + 1, transpose=tr, t3=t3, basis=basis, lead=lead, weights=w, D=q.D,
                                ts=np.array([np.inf, 0.0, 1.0, t3])))
    reasons = {len(fams) + k + 1: why for k, why in enumerate(bad)}
    return fams, reasons


def parameter_separation(t3):
    """Chordal distance (`chordal_separation`) of t3 (scalar or (...)) from the other pose parameters inf,
    0, 1 (docs/cubic.md: t3 near 0 or 1 means two poses nearly on a common ruling line, poor conditioning):
    min(|t3| / w, |t3 - 1| / (sqrt(2) w), 1 / w), w = sqrt(1 + t3^2). A float for a scalar t3."""
    t3 = np.asarray(t3, float)
    t = np.stack(np.broadcast_arrays(0.0, 1.0, t3), axis=-1)
    out = chordal_separation(t)
    return float(out) if out.ndim == 0 else out


def chordal_separation(t) -> np.ndarray:
    """Smallest chordal distance between the parameters (..., k) and infinity (the first pose or point):
    |t - s| / (sqrt(1 + t^2) sqrt(1 + s^2)) and 1 / sqrt(1 + t^2). Two poses or points at nearly the same
    parameter make a poorly conditioned member."""
    t = np.asarray(t, float)
    w = np.sqrt(1 + t * t)
    i, j = np.triu_indices(t.shape[-1], 1)
    d = np.abs(t[..., i] - t[..., j]) / (w[..., i] * w[..., j])
    return np.minimum(d.min(-1), (1 / w).min(-1))

