"""Cubic motion polynomials through four poses (MATH.md section 8).

The relative displacements ``D_0 = 1, D_1, D_2, D_3`` (conditioned frame, unit dual quaternions) span
a 3-space ``V`` of P^7. ``V`` meets the Study quadric in a quadric surface; when it is *ruled*
(signature (2, 2)) it carries two one-parameter families of real rational cubics through the four
points, each a *pencil* of monic cubic motion polynomials ``C`` with ``C(inf) = 1``, ``C(0) ~ D_1``,
``C(1) ~ D_2`` and ``C(t3) ~ D_3``; ``t3`` is fixed per family.

Conventions of this module (documented for the CLI):

* **Family numbering.** Family 1 is the family with the *larger* value of ``t3``, family 2 the other
  one (the set of the two ``t3`` values is well defined, MATH.md section 8; which ruling is "u" is not).
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

Everything is vectorized over batches of members (numpy); nothing here builds a `Linkage`.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from synth.algebra import lapack
from synth.algebra.dq import dq_mul
from synth.errors import SynthesisError

RANK_TOL = 1e-9  # 4th singular value of [D_0..D_3] below this times the 1st: the poses span < 3-space
PLANAR_TOL = 1e-12  # all eigenvalues of A at most this: the 3-space lies inside the Study quadric
CONE_TOL = 1e-9  # smallest |eigenvalue| at most this times the largest: a cone, not a smooth quadric
RULING_TOL = 1e-9  # |det| of ruling coordinates (unit vectors) below this: two poses on one ruling line
GENERIC_TOL = 1e-9  # as in synth.algebra.factorize: remainder leading coefficient not invertible
PRISMATIC_TOL = 1e-7  # as in synth.algebra.factorize: |vec(primal h)| <= tol (1 + |h0|) is a translation

PERMS = np.array(list(itertools.permutations(range(3))), int)  # (6, 3), lexicographic
PAIRS = np.array([(i, j) for i in range(6) for j in range(i + 1, 6)
                  if PERMS[i, 0] != PERMS[j, 0] and PERMS[i, 2] != PERMS[j, 2]], int)  # (9, 2)

_CONJ8 = np.array([1.0, -1, -1, -1, 1, -1, -1, -1])
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
    sv = lapack.svd_values(D)
    if sv[3] < RANK_TOL * sv[0]:
        raise SynthesisError(
            "the four poses are not independent (the fourth relative displacement is a combination of the "
            "others: all four lie on one Bennett motion, or some poses repeat a common screw motion); "
            "there is no unique cubic through them. Use `mpsynth bennett` on three of them, or move one "
            "pose off that motion")
    B = lapack.qr_q(D.T)
    A = B.T @ _G @ B
    A = 0.5 * (A + A.T)
    lam, U = lapack.eigh(A)
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
    Uu, s, Vt = lapack.svd(M)
    return Uu[..., :, 0], Vt[..., 0, :], s[..., 1] / s[..., 0]


def _det2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


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
    _, sv, Vt = lapack.svd(np.array(E))  # (2, 3, 5)
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


# ============================================================================ member scoring
_ANTIDIAG = (np.add.outer(np.arange(4), np.arange(4)).reshape(16, 1) == np.arange(7)).astype(float)  # (16, 7)
_SUBDIAG = np.eye(6, k=-1)  # companion matrix without its last column


def norm_roots(C, newton: int = 2) -> np.ndarray:
    """The three roots z (Im z >= 0) of N(C) for monic cubics C (..., 4, 8), shape (..., 3), sorted by
    (Re z, Im z). Companion-matrix eigenvalues, then ``newton`` Newton steps on N(C)."""
    C = np.asarray(C, float)
    P = C[..., :4]
    batch = P.shape[:-2]
    N = (P @ P.swapaxes(-1, -2)).reshape(-1, 16) @ _ANTIDIAG  # (n, 7): N_k = sum_{i+j=k} P_i.P_j
    comp = np.empty((N.shape[0], 6, 6))
    comp[...] = _SUBDIAG
    comp[:, :, 5] = N[:, :6] / -N[:, 6:7]
    z = np.linalg.eigvals(comp)
    rows = np.arange(z.shape[0])[:, None]
    z = z[rows, np.argsort(-z.imag, axis=-1)[:, :3]]  # one root of each pair
    z = np.where(z.imag < 0, z.conj(), z)
    c = [N[:, k : k + 1] for k in range(7)]  # Horner on N and N' (pre-sliced: numpy calls are the cost)
    d = [c[k] * k for k in range(1, 7)]
    for _ in range(newton):
        f = c[6] * z + c[5]
        df = d[5] * z + d[4]
        for k in range(4, -1, -1):
            f = f * z + c[k]
            if k:
                df = df * z + d[k - 1]
        z = z - f / np.where(df != 0, df, 1)
    return z[rows, np.argsort(z.real + 1e-12 * z.imag, axis=-1, kind="stable")].reshape(batch + (3,))


def root_conditioning(z) -> tuple[np.ndarray, np.ndarray]:
    """MATH.md section 8 member scores for roots z (..., 3) with Im z >= 0:
    ``min Im z / (1 + |z|^2)`` (distance from a real root: a joint whose angle jumps, a real factor)
    and ``min |z - z'| / (1 + max(|z|, |z'|)^2)`` (distance between roots: equal norm factors)."""
    z = np.asarray(z)
    w = 1 + np.abs(z) ** 2
    im = np.min(np.abs(z.imag) / w, axis=-1)
    i, j = np.array([0, 0, 1]), np.array([1, 2, 2])
    sep = np.min(np.abs(z[..., i] - z[..., j]) / np.maximum(w[..., i], w[..., j]), axis=-1)
    return im, sep


def parameter_separation(t3: float) -> float:
    """Chordal distance of t3 from the other pose parameters inf, 0, 1 (MATH.md section 8: t3 near 0 or 1
    means two poses nearly on a common ruling line, poor conditioning)."""
    w = np.sqrt(1 + t3 * t3)
    return float(min(abs(t3) / w, abs(t3 - 1) / (w * np.sqrt(2)), 1 / w))


# ============================================================================ factorization (batched)
@dataclass
class MemberFactors:
    """All factorizations of a batch of monic cubics, by order (PERMS)."""

    C: np.ndarray  # (G, 4, 8)
    roots: np.ndarray  # (G, 3) norm roots, sorted (quadratic k has root roots[:, k])
    H: np.ndarray  # (G, 6, 3, 8) factors h_1, h_2, h_3 of each order (NaN where failed)
    ok: np.ndarray  # (G, 6) Algorithm 1 succeeded (invertible remainders, no translation factor)
    residual: np.ndarray  # (G, 6) multiply-back relative error
    translation: np.ndarray  # (G, 6) some factor is a translation (then not ok)


_sum0 = np.add.reduce  # np.sum(x, 0) without its Python wrapper (the same reduction)


def _dot(a, b):
    """Dot products over the last axis (einsum: faster than sum for short axes)."""
    return np.einsum("...i,...i->...", a, b)


def _mul(a, b):
    """Dual quaternion product, broadcasting (..., 8) x (..., 8)."""
    return dq_mul(a, b)


def _inv(h):
    """Inverse of dual quaternions with nonzero primal part: conj / (n + eps d)."""
    p, q = h[..., :4], h[..., 4:]
    n = _dot(p, p)[..., None]
    d = 2 * _dot(p, q)[..., None]
    c = h * _CONJ8
    return np.concatenate([c[..., :4] / n, c[..., 4:] / n - c[..., :4] * (d / (n * n))], -1)


def factor_members(C, roots=None, *, refine: bool = True, exact_residual: bool = True) -> MemberFactors:
    """All 6 factorizations of every monic cubic in C (G, 4, 8) at once: Algorithm 1 (MATH.md section 4).

    For the order (i, j, k) (quadratic indices of h1, h2, h3): h3 is the right zero ``-r1^{-1} r0`` of
    C mod M_k, C = Q (t - h3) by exact right division (the same for every order ending in k, so only
    3 are computed), h2 the right zero of Q mod M_j, and t - h1 = Q / (t - h2), i.e. h1 = -(q1 + h2).
    Every factorization is multiplied back (``residual``) and each factor's Study condition checked;
    with ``exact_residual=False`` (the scan) the residual is instead read off the two division remainders,
    C - (t - h1)(t - h2)(t - h3) = rem2 (t - h3) + rem1, which costs one product instead of three.

    With ``refine``, the factorizations are polished by Newton's method on the product equations
    (`polish`; section 4 note ii refines the quadratics instead, to the same end): the residual drops
    to ~2e-16 (from ~1e-15 in generic cases, ~1e-12 for nearly real or equal norm roots). The scan
    runs without it."""
    C = np.asarray(C, float)
    G = C.shape[0]
    z = norm_roots(C) if roots is None else np.asarray(roots)
    m0 = np.abs(z) ** 2  # (G, 3): M_k = t^2 + m1 t + m0
    m1 = -2 * z.real
    prim = np.sqrt(np.max(_dot(C[..., :4], C[..., :4]), -1))[:, None]
    c = C[:, None]  # (G, 1, 4, 8)
    h3, q1, q0, rem1, good = _step1(c, m0, m1, prim)
    k_of, j_of = PERMS[:, 2], PERMS[:, 1]
    Q1, Q0 = q1[:, k_of], q0[:, k_of]  # (G, 6, 8)
    h2, rem2, good2 = _step2(Q1, Q0, m0[:, j_of], m1[:, j_of], prim)
    # step 3: Q = (t - h1)(t - h2) exactly: t - h1 = Q / (t - h2), h1 = -(q1 + h2)
    H = np.empty((G, 6, 3, 8))
    H[:, :, 0] = -(Q1 + h2)
    H[:, :, 1] = h2
    H[:, :, 2] = h3[:, k_of]
    ok = good[:, k_of] & good2
    scale = np.maximum(1.0, np.max(np.abs(C), axis=(-2, -1)))[:, None]
    if refine:  # polished factors; their product residual comes with them
        res = np.full((G, 6), np.inf)
        if np.any(ok):
            g, p = np.nonzero(ok)
            H[g, p], rm = polish(C[g], H[g, p], return_residual=True)
            res[g, p] = rm / scale[g, 0]
        res = np.maximum(res, _study(H))
    elif exact_residual:
        res = multiply_back(C, H)
    else:
        with np.errstate(all="ignore"):
            e0 = rem1[:, k_of] - _mul(rem2, H[:, :, 2])
            res = np.maximum(np.max(np.abs(rem2), -1), np.max(np.abs(e0), -1)) / scale
    res = np.where(ok & np.isfinite(res), res, np.inf)
    vnorm = np.sqrt(_dot(H[..., 1:4], H[..., 1:4]))
    trans = np.any(~(vnorm > PRISMATIC_TOL * (1 + np.abs(H[..., 0]))), axis=-1) & ok
    H = np.where(ok[..., None, None], H, np.nan)
    return MemberFactors(C=C, roots=z, H=H, ok=ok & ~trans, residual=res, translation=trans)


_amax = np.maximum.reduce  # np.max without its Python wrapper (the same reduction)


def multiply_back(C, H):
    """Relative multiply-back error of (t - h1)(t - h2)(t - h3) against C (G, 4, 8) for factorizations
    H (G, P, 3, 8), together with each factor's Study condition (dual scalar and v.w, relative): (G, P)."""
    with np.errstate(all="ignore"):
        h1, h2, h3 = H[:, :, 0], H[:, :, 1], H[:, :, 2]
        X = _mul(h1, h2)
        e1 = _amax(np.abs(X + _mul(h1 + h2, h3) - C[:, None, 1]), -1)
        e0 = _amax(np.abs(-_mul(X, h3) - C[:, None, 0]), -1)
        e2 = _amax(np.abs(-(h1 + h2 + h3) - C[:, None, 2]), -1)
        scale = np.maximum(1.0, _amax(np.abs(C), axis=(-2, -1)))[:, None]
        r = np.maximum(np.maximum(np.maximum(e0, e1), e2) / scale, _study(H))
    return np.where(np.isfinite(r), r, np.inf)


def _study(H):
    """Study condition of the factors t - h of factorizations H (..., 3, 8), relative: the dual scalar
    and v.w of h must vanish; the largest violation per factorization."""
    with np.errstate(all="ignore"):
        hs = np.maximum(1.0, _amax(np.abs(H), axis=(-2, -1)))
        return _amax(np.abs(H[..., 4]) + np.abs(_dot(H[..., 1:4], H[..., 5:8])) / hs[..., None], -1) / hs


def _step1(c, m0, m1, prim=None):
    """Algorithm 1, first step, for the quadratics (m0, m1) (G, K) of cubics c (G, 1, 4, 8): the right
    zero h3 of C mod M, the quotient C = (t^2 + q1 t + q0)(t - h3) + rem, the remainder and whether the
    remainder's leading coefficient is invertible (GENERIC_TOL)."""
    m0, m1 = m0[..., None], m1[..., None]
    c0, c1, c2, c3 = c[..., 0, :], c[..., 1, :], c[..., 2, :], c[..., 3, :]
    # C mod M = r1 t + r0 (t^2 = -m1 t - m0, t^3 = (m1^2 - m0) t + m1 m0)
    r1 = c1 - m1 * c2 + (m1 * m1 - m0) * c3
    r0 = c0 - m0 * c2 + (m1 * m0) * c3
    good = None
    if prim is not None:
        good = _dot(r1[..., :4], r1[..., :4]) > (GENERIC_TOL * prim) ** 2
        r1 = np.where(good[..., None], r1, _ONE)
    h3 = -_mul(_inv(r1), r0)
    q1 = c2 + h3  # exact right division by t - h3 (c3 = 1)
    q0 = c1 + _mul(q1, h3)
    rem = c0 + _mul(q0, h3)
    return h3, q1, q0, rem, good


def _step2(Q1, Q0, m0, m1, prim=None):
    """Algorithm 1, second step: the right zero h2 of Q = t^2 + Q1 t + Q0 mod M_j = (Q1 - m1) t + (Q0 - m0),
    and Q's right value at h2 (zero when t - h2 divides Q exactly)."""
    s1 = Q1 - m1[..., None] * _ONE
    s0 = Q0 - m0[..., None] * _ONE
    good = None
    if prim is not None:
        good = _dot(s1[..., :4], s1[..., :4]) > (GENERIC_TOL * prim) ** 2
        s1 = np.where(good[..., None], s1, _ONE)
    h2 = -_mul(_inv(s1), s0)
    return h2, Q0 + _mul(Q1, h2) + _mul(h2, h2), good


_T = dq_mul(np.eye(8)[:, None, :], np.eye(8)[None, :, :])  # (a b)_k = sum_ij a_i b_j _T[i, j, k]
_TL = _T.reshape(8, 64)  # a -> L(a): a x = x @ L(a)
_TR = _T.transpose(1, 0, 2).reshape(8, 64)  # a -> R(a): x a = x @ R(a)


def _lmat(a):
    return (a @ _TL).reshape(a.shape[:-1] + (8, 8))


def _rmat(a):
    return (a @ _TR).reshape(a.shape[:-1] + (8, 8))


def _product_residual(C, H):
    """Coefficient errors of (t - h1)(t - h2)(t - h3) - C for t^0, t^1, t^2 as (..., 3, 8), and h1 h2."""
    h1, h2, h3 = H[..., 0, :], H[..., 1, :], H[..., 2, :]
    X = _mul(h1, h2)
    r = np.empty(H.shape)
    r[..., 0, :] = -_mul(X, h3) - C[..., 0, :]
    r[..., 1, :] = X + _mul(h1 + h2, h3) - C[..., 1, :]
    r[..., 2, :] = -(h1 + h2 + h3) - C[..., 2, :]
    return r, X


def _newton_step(H, X, r):
    """Newton correction (..., 3, 8) of the product equations for factors H (..., 3, 8) with residuals
    r (..., 3, 8) (t^0, t^1, t^2; X = h1 h2). The t^2 equation is linear, -(dh1 + dh2 + dh3) = -r2, so
    dh1 = r2 - dh2 - dh3 and a 16 x 16 system remains (row-vector convention, a x = x L(a), x a = x R(a)):
    t^0: dh2 (R(h2 h3) - L(h1) R(h3)) + dh3 (R(h2 h3) - L(h1 h2)) = -(r0 - r2 h2 h3),
    t^1: dh2 (L(h1) - R(h2)) + dh3 (L(h1 + h2) - R(h2 + h3)) = -(r1 + r2 (h2 + h3))."""
    h1, h2, h3 = H[..., 0, :], H[..., 1, :], H[..., 2, :]
    r2 = r[..., 2, :]
    Y = _mul(h2, h3)
    h23 = h2 + h3
    batch = h1.shape[:-1]
    Lm = (np.concatenate([h1, X, h1 + h2], -1).reshape(-1, 8) @ _TL).reshape(batch + (3, 8, 8))
    Rm = (np.concatenate([Y, h3, h2, h23], -1).reshape(-1, 8) @ _TR).reshape(batch + (4, 8, 8))
    J = np.empty(batch + (16, 16))
    J[..., :8, :8] = Rm[..., 0, :, :] - Lm[..., 0, :, :] @ Rm[..., 1, :, :]
    J[..., :8, 8:] = Lm[..., 0, :, :] - Rm[..., 2, :, :]
    J[..., 8:, :8] = Rm[..., 0, :, :] - Lm[..., 1, :, :]
    J[..., 8:, 8:] = Lm[..., 2, :, :] - Rm[..., 3, :, :]
    rhs = np.concatenate([_mul(r2, Y) - r[..., 0, :], -r[..., 1, :] - _mul(r2, h23)], -1)
    d = np.linalg.solve(np.swapaxes(J, -1, -2), rhs[..., None])  # (..., 16, 1)
    D = np.empty(H.shape)
    D[..., 1:, :] = d.reshape(batch + (2, 8))
    D[..., 0, :] = r2 - D[..., 1, :] - D[..., 2, :]
    return D


STEP_TOL = 1e-10  # a Newton correction at most this (relative) leaves only rounding for the next one


def polish(C, H, iterations: int = 2, return_residual: bool = False):
    """Newton's method on the product equations (t - h1)(t - h2)(t - h3) = C for factorizations
    H (..., 3, 8) of cubics C (..., 4, 8) (broadcast): 24 equations (coefficients of t^0, t^1, t^2) in
    the 24 unknowns h1, h2, h3 (the t^2 equation is linear and eliminated, `_newton_step`). A
    factorization is locally unique, so the Jacobian is regular and one or two steps bring the
    multiply-back error to rounding level (MATH.md section 4 note ii: nearly real or nearly equal norm
    roots lose digits in Algorithm 1). At most ``iterations`` steps; none after a step of at most
    STEP_TOL (relative), whose successor, quadratically smaller, would be below rounding. A step is kept
    only where it lowers the residual. Returns the polished factors (and, with ``return_residual``, the
    largest absolute coefficient error of each product)."""
    C = np.asarray(C, float)
    H = np.array(np.broadcast_to(H, np.broadcast_shapes(C.shape[:-2], np.shape(H)[:-2]) + (3, 8)), float)
    tiny = 2e-16 * np.maximum(1.0, np.abs(C).max((-2, -1)))
    r, X = _product_residual(C, H)
    rm = np.abs(r).max((-2, -1))
    with np.errstate(all="ignore"):
        for _ in range(iterations):
            if not (rm > tiny).any():
                break
            try:
                D = _newton_step(H, X, r)
            except np.linalg.LinAlgError:
                break
            Hn = H + D
            rn, Xn = _product_residual(C, Hn)
            rmn = np.abs(rn).max((-2, -1))
            better = rmn < rm  # keep the step only where it helped
            if better.all():
                H, X, r, rm = Hn, Xn, rn, rmn
            else:
                b = better[..., None, None]
                H, r, X, rm = np.where(b, Hn, H), np.where(b, rn, r), np.where(b[..., 0], Xn, X), np.where(better, rmn, rm)
            big = np.abs(D).max((-2, -1)) > STEP_TOL * np.maximum(1.0, np.abs(H).max((-2, -1)))
            if not (better & big).any():
                break
    return (H, rm) if return_residual else H


# ============================================================================ loop geometry
def lines(H) -> tuple[np.ndarray, np.ndarray]:
    """Plücker lines (u, m) of factors (..., 8): u = -v/|v|, m = w/|v|."""
    v, w = H[..., 1:4], H[..., 5:8]
    n = np.sqrt(_dot(v, v))[..., None]
    return -v / n, w / n


def _edge_tables():
    """Distinct joints and consecutive-joint edges of the 9 loops of a member.

    A member has 12 distinct joints: the 3 leftmost factors (one per quadratic), the 3 rightmost ones
    and the 6 middle factors (one per order). JOINTS (12, 2) = (order, position) picks each from
    MemberFactors.H; EDGES (18, 2) are the joint pairs that are consecutive in some loop; LOOP_EDGES
    (9, 6) lists, per pair, its edges around h1 h2 h3 k3 k2 k1."""
    left = {int(PERMS[p, 0]): p for p in range(6)}
    right = {int(PERMS[p, 2]): p for p in range(6)}
    joints = [(left[i], 0) for i in range(3)] + [(right[k], 2) for k in range(3)] + [(p, 1) for p in range(6)]
    jid = {("l", i): i for i in range(3)} | {("r", k): 3 + k for k in range(3)} | {("m", p): 6 + p for p in range(6)}
    edges: list[tuple[int, int]] = []

    def edge(a, b):
        key = (min(a, b), max(a, b))
        if key not in edges:
            edges.append(key)
        return edges.index(key)

    loops = []
    for ph, pk in PAIRS:
        sh, sk = PERMS[ph], PERMS[pk]
        ring = [jid["l", int(sh[0])], jid["m", int(ph)], jid["r", int(sh[2])],
                jid["r", int(sk[2])], jid["m", int(pk)], jid["l", int(sk[0])]]
        loops.append([edge(ring[i], ring[(i + 1) % 6]) for i in range(6)])
    return np.array(joints), np.array(edges), np.array(loops)


JOINTS, EDGES, LOOP_EDGES = _edge_tables()


def loop_geometry(mf: MemberFactors) -> dict[str, np.ndarray]:
    """Geometry of the 9 loops of every member, computed once per distinct edge (18 per member):
    ``min_offset`` (smallest distance of consecutive axes), ``min_twist`` (smallest angle between
    consecutive axes, in [0, pi/2]) and ``extent`` (largest distance of a common-normal foot of
    consecutive axes from the origin), each (G, 9); lengths in the units of the factors."""
    J = mf.H[:, JOINTS[:, 0], JOINTS[:, 1]]  # (G, 12, 8)
    u, m = lines(J)
    u = np.moveaxis(u, -1, 0)
    m = np.moveaxis(m, -1, 0)
    e0, e1 = EDGES[:, 0], EDGES[:, 1]
    p = _cross(u, m)  # each joint's point nearest the origin, once (not once per edge)
    dist, ang, f1, f2 = _pair_geometry(u[..., e0], None, u[..., e1], None, p[..., e0], p[..., e1])  # (G, 18)
    foot = np.maximum(_sum0(f1 * f1), _sum0(f2 * f2))
    return {"min_offset": np.minimum.reduce(dist[:, LOOP_EDGES], -1),
            "min_twist": np.minimum.reduce(ang[:, LOOP_EDGES], -1),
            "extent": np.sqrt(np.maximum.reduce(foot[:, LOOP_EDGES], -1))}


def _cross(a, b):
    """Cross product of component-first vectors (3, ...)."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    out = np.empty((3,) + np.broadcast_shapes(a0.shape, b0.shape))
    np.subtract(a1 * b2, a2 * b1, out=out[0])
    np.subtract(a2 * b0, a0 * b2, out=out[1])
    np.subtract(a0 * b1, a1 * b0, out=out[2])
    return out


def _pair_geometry(u, m, u2, m2, p1=None, p2=None):
    """Distance, line angle in [0, pi/2] and common-normal feet of line pairs given component-first
    (3, ...). Parallel pairs: feet at the first line's point closest to the origin and its projection
    onto the second line. ``p1``, ``p2``: those points u x m if known (then m, m2 are not used)."""
    if p1 is None:
        p1, p2 = _cross(u, m), _cross(u2, m2)
    c = _cross(u, u2)
    s2 = _sum0(c * c)
    ang = np.arctan2(np.sqrt(s2), np.abs(_sum0(u * u2)))
    d = p2 - p1
    par = s2 < 1e-24
    s2s = np.where(par, 1.0, s2)
    a1 = np.where(par, 0.0, _sum0(_cross(d, u2) * c) / s2s)
    a2 = np.where(par, _sum0(-d * u2), _sum0(_cross(d, u) * c) / s2s)
    f1 = p1 + a1 * u
    f2 = p2 + a2 * u2
    return np.sqrt(_sum0((f2 - f1) ** 2)), ang, f1, f2
