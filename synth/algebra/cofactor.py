"""Theorem 2 of the survey: a real co-factor R with C R = (t - h_1)...(t - h_m) for a bounded monic
motion polynomial C whose primal part has a real factor (docs/exceptional.md, sections 2-3).

Pipeline (``factorize_with_cofactor``):

1. g = mrpf(P) (``realfactor``); deg g = 0: Algorithm 1, R = 1; a real zero of g: unbounded, refused.
   A real factor of C itself (M | P and M | Q) is split off first: it does not change the motion and
   is written back as a coaxial pair (t - ~x)(t - x).
2. Template split (linear): P0 = P / g = (t - p_1)...(t - p_d) over H (Algorithm 1); g = prod B_i,
   B_i = M_i^k_i. Items: the rotations t - p_j - eps d_j (d_j ⊥ vec p_j, 2 unknowns) and the primary
   translations B_i + eps E_i (E_i vectorial, deg E_i < 2 k_i) inserted between them. The dual part of
   the product is linear in (E_i, d_j); least squares against Q, accepted below 1e-8. "All
   translations first" is tried first; other orders/positions when a rotation shares its norm with g.
3. Kernel search: in the affine solution family, Levenberg-Marquardt on the circularity equations
   (|F_i|^2 mod M_i = 0, two real quadratics per k = 1 block) saves a factor M_i of R each (E4).
4. Each primary translation T_i = B_i + eps E_i is factored after multiplying by R_i:
   k = 1 circular -> 2 rotations (R_i = 1, the min-norm member of the family of eq. (5));
   k = 1 otherwise -> T_i M_i = (M_i + eps F1)(M_i + eps F2) with circular F1 + F2 = F (R_i = M_i);
   k >= 2 planar -> patterns x+^k x-^k, x-^k x+^k (R_i = 1) or x+^k x-^2k x+^k (R_i = M_i^k);
   k >= 2 non-planar -> the nested chain [a.., ~a.., b.., ~b..] by LM over the directions (R_i = M_i^k),
   last resort two planar halves (deg R > deg g, ``bound_met = False``).
5. Assemble, denormalize, multiply back: ``residual`` = |prod(t - h) - C R| / max(1, |C R|).

Everything runs in floating point after an affine normalization of t and a scaling of lengths;
rational answers are certified by ``exact_check`` on rationalized factors.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from synth.algebra.dq import qmul
from synth.errors import NoFactorizationError
from synth.algebra.polynomial import poly_mul
from synth.algebra.realfactor import RealFactor, mrpf, poly_text, require_bounded

TEMPLATE_TOL = 1e-8  # relative least-squares residual of the template split
CIRCULAR_TOL = 1e-10  # relative circularity residual |F|^2 mod M
FINAL_TOL = 1e-8  # relative multiply-back residual accepted
MAX_TEMPLATES = 200


class FactorizationError(NoFactorizationError):
    """No template of the co-factor algorithm produced a factorization."""


@dataclass
class CofactorResult:
    """C R = (t - factors[0]) ... (t - factors[m-1]), R real monic (ascending coefficients)."""

    C: np.ndarray  # (n+1, 8) input (float)
    R: np.ndarray  # ascending real coefficients, monic
    factors: np.ndarray  # (m, 8)
    residual: float
    g: np.ndarray  # mrpf(P), ascending monic
    bound_met: bool  # deg R <= deg g
    generic: bool
    report: list = field(default_factory=list)  # one dict per component
    template: list = field(default_factory=list)  # item labels, left to right
    real_content: list = field(default_factory=list)  # real quadratics [c0, c1] split off C
    family: dict | None = None  # the circular-translation family when C is one

    @property
    def deg_R(self) -> int:
        return len(self.R) - 1

    def product(self) -> np.ndarray:
        from synth.algebra.polynomial import product_of_linear

        return product_of_linear(self.factors)

    def as_dict(self) -> dict:
        return {
            "cofactor": [float(x) for x in self.R],
            "cofactor_text": poly_text(self.R),
            "deg_R": self.deg_R,
            "mrpf": [float(x) for x in self.g],
            "mrpf_text": poly_text(self.g),
            "bound_met": self.bound_met,
            "generic": self.generic,
            "residual": self.residual,
            "factors": [[float(x) for x in h] for h in self.factors],
            "template": list(self.template),
            "report": self.report,
            "real_content": [[float(x) for x in q] for q in self.real_content],
            "family": self.family,
        }


# ====================================================================== polynomial helpers
def qp_mul(A, B):
    """Product of quaternion polynomials (..., na, 4) x (..., nb, 4) (ascending; order matters)."""
    return poly_mul(A, B, mul=qmul)


def real_mul(a, b):
    return np.convolve(np.asarray(a, float), np.asarray(b, float))


def real_pow(a, k):
    out = np.ones(1)
    for _ in range(k):
        out = real_mul(out, a)
    return out


def quad(M):
    """Ascending coefficients [c0, c1, 1] of the monic quadratic M = [c0, c1]."""
    return np.array([M[0], M[1], 1.0])


def alpha_beta(M):
    c0, c1 = float(M[0]), float(M[1])
    alpha = -c1 / 2
    return alpha, float(np.sqrt(max(c0 - alpha * alpha, 0.0)))


def _as_qpoly(real):
    real = np.asarray(real, float)
    out = np.zeros((len(real), 4))
    out[:, 0] = real
    return out


def _divide_real(P, g):
    """Exact quotient P / g of a (n+1, c) polynomial by a real monic g, by least squares."""
    P = np.asarray(P, float)
    m = P.shape[0] - len(g) + 1
    G = np.zeros((P.shape[0], m))
    for j in range(m):
        G[j:j + len(g), j] = g
    return np.linalg.lstsq(G, P, rcond=None)[0]


def _mod_real(E, M):
    """Remainder of the (n, c) polynomial E by the monic real polynomial M (ascending)."""
    E = np.array(E, float)
    d = len(M) - 1
    for k in range(E.shape[0] - 1, d - 1, -1):
        c = E[k].copy()
        E[k - d:k + 1] -= np.outer(M, c)
    return E[:d]


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _perp_basis(n):
    """Two unit vectors completing the unit n to a right-handed orthonormal basis."""
    n = _unit(n)
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    e1 = _unit(np.cross(n, a))
    return e1, np.cross(n, e1)


def _rot(alpha, beta, n, d):
    """The dual quaternion alpha + beta n + eps d (n unit, d vector)."""
    h = np.zeros(8)
    h[0] = alpha
    h[1:4] = beta * np.asarray(n, float)
    h[5:8] = d
    return h


# ====================================================================== items and the linear dual system
@dataclass
class _Item:
    kind: str  # "rot" or "trans"
    primal: np.ndarray  # quaternion polynomial (deg+1, 4)
    basis: np.ndarray  # (L, deg_dual+1, 4): dual = sum_l z_l basis_l
    label: str = ""
    block: int = -1  # index of the translation block
    x: np.ndarray | None = None  # rotation primal quaternion
    perp: np.ndarray | None = None  # (2, 3) basis of d for a rotation


def _rot_item(x, label=""):
    x = np.asarray(x, float)
    v = x[1:4]
    e1, e2 = _perp_basis(v)
    basis = np.zeros((2, 1, 4))
    basis[0, 0, 1:] = -e1
    basis[1, 0, 1:] = -e2
    primal = np.array([-x, [1.0, 0, 0, 0]])
    return _Item("rot", primal, basis, label, x=x, perp=np.array([e1, e2]))


def _trans_item(B, block, label=""):
    B = np.asarray(B, float)
    deg = len(B) - 1
    basis = np.zeros((3 * deg, deg, 4))
    for c in range(deg):
        for a in range(3):
            basis[3 * c + a, c, 1 + a] = 1.0
    return _Item("trans", _as_qpoly(B), basis, label, block=block)


def _dual_matrix(items, n):
    """Matrix A (4n x L_total) mapping the stacked unknowns to the dual part of the product of the items
    (flattened (n, 4), ascending)."""
    prim = [it.primal for it in items]
    prefix = [np.array([[1.0, 0, 0, 0]])]
    for p in prim:
        prefix.append(qp_mul(prefix[-1], p))
    suffix = [np.array([[1.0, 0, 0, 0]])]
    for p in reversed(prim):
        suffix.append(qp_mul(p, suffix[-1]))
    suffix = suffix[::-1]  # suffix[s] = product of items s.. end
    cols = []
    for s, it in enumerate(items):
        contrib = qp_mul(qp_mul(prefix[s], it.basis), suffix[s + 1])  # (L, deg, 4)
        full = np.zeros((contrib.shape[0], n, 4))
        m = min(n, contrib.shape[1])
        full[:, :m] = contrib[:, :m]
        cols.append(full.reshape(contrib.shape[0], -1).T)
    return np.concatenate(cols, axis=1), prefix[-1]


def _solve_items(items, target, n):
    """Least squares for the unknowns of ``items`` so that the product's dual part is ``target`` (n, 4).
    Returns (z0 min-norm solution, kernel basis (L, dim), relative residual)."""
    A, _ = _dual_matrix(items, n)
    b = np.asarray(target, float).reshape(-1)
    U, sv, Vt = np.linalg.svd(A, full_matrices=True)
    tol = 1e-10 * (sv[0] if len(sv) and sv[0] > 0 else 1.0)
    rank = int(np.sum(sv > tol))
    z0 = Vt[:rank].T @ ((U[:, :rank].T @ b) / sv[:rank])
    K = Vt[rank:].T
    r = A @ z0 - b
    scale = max(float(np.max(np.abs(b))), 1e-300)
    return z0, K, float(np.max(np.abs(r))) / scale if np.max(np.abs(b)) > 0 else float(np.max(np.abs(r)))


def _split_unknowns(items, z):
    """Per item: its slice of z."""
    out, pos = [], 0
    for it in items:
        L = it.basis.shape[0]
        out.append(z[pos:pos + L])
        pos += L
    return out


def _rotation_from(it, zs):
    d = zs @ it.perp
    h = np.zeros(8)
    h[:4] = it.x
    h[5:8] = d
    return h


def _E_from(it, zs):
    """Vectorial dual polynomial E (deg, 3) of a translation item."""
    return zs.reshape(-1, 3)


# ====================================================================== primary translations
def circular_residual(M, E):
    """|F|^2 mod M (two numbers) for F = E[1] t + E[0], relative to |F|^2 scale."""
    c0, c1 = float(M[0]), float(M[1])
    v, u = E[0], E[1]
    r1 = 2 * u @ v - (u @ u) * c1
    r0 = v @ v - (u @ u) * c0
    scale = max(u @ u * max(1.0, abs(c0)) + v @ v, 1e-300)
    return np.array([r1, r0]) / scale


def factor_circular(M, E):
    """Two rotations with M + eps F = (t - h1)(t - h2), F = E[1] t + E[0] circular: the min-norm member
    h2 = y + eps d2, h1 = ~y + eps d1, y = u v / |u|^2, d2 = -u/2, d1 = -u - d2. Returns ([h1, h2],
    family) with family = the two dual directions (eq. (5)): h1 - eps s, h2 + eps s, s ⊥ axis."""
    alpha, beta = alpha_beta(M)
    v, u = np.asarray(E[0], float), np.asarray(E[1], float)
    uu = u @ u
    vec_y = np.cross(u, v) / uu
    n = _unit(vec_y)
    d2 = -u / 2
    d2 = d2 - (d2 @ n) * n
    d1 = -u - d2
    d1 = d1 - (d1 @ n) * n
    h1 = _rot(alpha, -beta, n, d1)
    h2 = _rot(alpha, beta, n, d2)
    e1, e2 = _perp_basis(n)
    family = {"h1": h1.tolist(), "h2": h2.tolist(),
              "directions": [e1.tolist(), e2.tolist()],
              "note": "h1 - eps(f e1 + g e2), h2 + eps(f e1 + g e2) for all real f, g"}
    return [h1, h2], family


def factor_real(M, axis=(0.0, 0.0, 1.0)):
    """M = (t - ~x)(t - x) with x = alpha + beta axis (a coaxial pair through the origin)."""
    alpha, beta = alpha_beta(M)
    n = _unit(axis)
    return [_rot(alpha, -beta, n, np.zeros(3)), _rot(alpha, beta, n, np.zeros(3))]


def ellipse_split(M, E):
    """F = F1 + F2 with both M + eps Fi circular (section 5 step 4): returns (F1, F2) as (2, 3) arrays."""
    alpha, beta = alpha_beta(M)
    v, u = np.asarray(E[0], float), np.asarray(E[1], float)
    vp = (v + alpha * u) / beta
    c = np.cross(u, vp)
    scale = max(np.linalg.norm(u), np.linalg.norm(vp), 1e-300)
    if np.linalg.norm(c) > 1e-12 * scale * scale:
        n = _unit(c)
    else:  # u ∥ v': any unit n ⊥ u and ⊥ v'
        ref = u if np.linalg.norm(u) >= np.linalg.norm(vp) else vp
        n = _perp_basis(ref)[0] if np.linalg.norm(ref) > 0 else np.array([0.0, 0, 1])
    u1 = (u - np.cross(n, vp)) / 2
    u2 = (u + np.cross(n, vp)) / 2
    v1p = np.cross(n, u1)
    v2p = -np.cross(n, u2)
    F1 = np.array([beta * v1p - alpha * u1, u1])
    F2 = np.array([beta * v2p - alpha * u2, u2])
    return F1, F2


def _factor_k1(M, E):
    """Factor M + eps F (after multiplying by R_i). Returns (R_i, rotations, report)."""
    scale = max(float(np.max(np.abs(E))), 0.0)
    if scale == 0.0:
        return np.ones(1), factor_real(M), {"kind": "real", "deg_R": 0}
    res = float(np.max(np.abs(circular_residual(M, E))))
    if res <= CIRCULAR_TOL:
        hs, fam = factor_circular(M, E)
        return np.ones(1), hs, {"kind": "circular", "deg_R": 0, "circularity_residual": res, "family": fam}
    F1, F2 = ellipse_split(M, E)
    h12, _ = factor_circular(M, F1)
    h34, _ = factor_circular(M, F2)
    return quad(M), h12 + h34, {"kind": "ellipse", "deg_R": 2, "circularity_residual": res}


def _planar_normal(E):
    """(normal n, rank) of the span of the vector coefficients of E (deg, 3); n None if not planar."""
    _, sv, Vt = np.linalg.svd(np.asarray(E, float))
    tol = 1e-9 * max(sv[0], 1e-300)
    rank = int(np.sum(sv > tol))
    if rank <= 1:
        ref = Vt[0] if sv[0] > 0 else np.array([1.0, 0, 0])
        return _perp_basis(ref)[0], rank
    if rank == 2:
        return Vt[2], rank
    return None, rank


def _solve_chain(primals, target_dual, n):
    """Duals d_j ⊥ vec x_j with prod(t - x_j - eps d_j) having dual part target (n, 4). Returns (rotations,
    relative residual)."""
    items = [_rot_item(x) for x in primals]
    z0, _, res = _solve_items(items, target_dual, n)
    hs = [_rotation_from(it, zs) for it, zs in zip(items, _split_unknowns(items, z0))]
    return hs, res


def _factor_planar(M, k, E, n_vec):
    alpha, beta = alpha_beta(M)
    xp = np.array([alpha, *(beta * n_vec)])
    xm = np.array([alpha, *(-beta * n_vec)])
    Mq = quad(M)
    Ed = np.zeros((2 * k, 4))
    Ed[:, 1:] = E
    patterns = [("x+^k x-^k", [xp] * k + [xm] * k, 0), ("x-^k x+^k", [xm] * k + [xp] * k, 0),
                ("x+^k x-^2k x+^k", [xp] * k + [xm] * (2 * k) + [xp] * k, k),
                ("x-^k x+^2k x-^k", [xm] * k + [xp] * (2 * k) + [xm] * k, k)]
    for name, prim, kr in patterns:
        Rk = real_pow(Mq, kr)
        target = qp_mul(_as_qpoly(Rk), Ed) if kr else Ed
        nn = len(prim)
        tgt = np.zeros((nn, 4))
        tgt[:target.shape[0]] = target[:nn]
        hs, res = _solve_chain(prim, tgt, nn)
        if res < TEMPLATE_TOL:
            return Rk, hs, {"kind": "planar", "pattern": name, "deg_R": 2 * kr, "residual": res}
    return None


def _nested_primals(params, alpha, beta, k):
    dirs = params.reshape(2 * k, 3)
    out = []
    for half in range(2):
        xs = []
        for i in range(k):
            nv = dirs[half * k + i]
            nv = nv / max(np.linalg.norm(nv), 1e-300)
            xs.append(np.array([alpha, *(beta * nv)]))
        conj = [x * np.array([1, -1, -1, -1]) for x in reversed(xs)]
        out += xs + conj
    return out


def _factor_nonplanar(M, k, E, rng):
    from scipy.optimize import least_squares

    alpha, beta = alpha_beta(M)
    Mq = quad(M)
    Rk = real_pow(Mq, k)
    Ed = np.zeros((2 * k, 4))
    Ed[:, 1:] = E
    target = qp_mul(_as_qpoly(Rk), Ed)
    nn = 4 * k
    tgt = np.zeros((nn, 4))
    tgt[:target.shape[0]] = target[:nn]
    b = tgt.reshape(-1)
    bscale = max(float(np.max(np.abs(b))), 1e-300)

    def resid(p):
        items = [_rot_item(x) for x in _nested_primals(p, alpha, beta, k)]
        A, _ = _dual_matrix(items, nn)
        z = np.linalg.lstsq(A, b, rcond=None)[0]
        return (A @ z - b) / bscale

    for start in range(12):
        p0 = rng.normal(size=6 * k)
        try:
            sol = least_squares(resid, p0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=4000)
        except Exception:  # pragma: no cover - numerical trouble at a start
            continue
        if np.max(np.abs(sol.fun)) < 1e-11:
            hs, res = _solve_chain(_nested_primals(sol.x, alpha, beta, k), tgt, nn)
            if res < TEMPLATE_TOL:
                return Rk, hs, {"kind": "nonplanar-nested", "deg_R": 2 * k, "residual": res, "starts": start + 1}
    return None


def _factor_block(M, k, E, rng):
    """Factor the primary translation M^k + eps E (E (2k, 3)) after multiplying by R_i.
    Returns (R_i, rotations, report)."""
    E = np.asarray(E, float)
    Mq = quad(M)
    # strip real factors M | E
    stripped = 0
    while k >= 1:
        if np.max(np.abs(E)) == 0 or np.max(np.abs(_mod_real(E, Mq))) <= 1e-10 * np.max(np.abs(E)):
            if np.max(np.abs(E)) == 0:
                stripped += k
                k = 0
                break
            E = _divide_real(E, Mq)[: 2 * (k - 1)]
            k -= 1
            stripped += 1
        else:
            break
    real_hs = []
    for _ in range(stripped):
        real_hs += factor_real(M)
    if k == 0:
        return np.ones(1), real_hs, {"kind": "real", "deg_R": 0, "real_factors": stripped}
    if k == 1:
        R, hs, rep = _factor_k1(M, E)
    else:
        n_vec, rank = _planar_normal(E)
        out = None
        if n_vec is not None:
            out = _factor_planar(M, k, E, n_vec)
        if out is None and n_vec is None:
            out = _factor_nonplanar(M, k, E, rng)
        if out is None:
            out = _factor_split(M, k, E)
        R, hs, rep = out
    if stripped:
        rep = dict(rep, real_factors=stripped)
    return R, hs + real_hs, rep


def _factor_split(M, k, E):
    """Last resort: E = Ea + Eb with planar parts; T M^k = Ta Tb, each factored with R = M^k."""
    E = np.asarray(E, float)
    n1 = np.array([0.0, 0, 1]) if np.linalg.norm(E[:, :2]) > 0 else np.array([1.0, 0, 0])
    # Ea: components in the plane ⊥ n1, Eb: along n1 (a segment: planar with any normal ⊥ n1)
    Eb = np.outer(E @ n1, n1)
    Ea = E - Eb
    Mq = quad(M)
    Rk = real_pow(Mq, k)
    hs_all = []
    for part in (Ea, Eb):
        if np.max(np.abs(part)) == 0:
            continue
        nv, _ = _planar_normal(part)
        got = _factor_planar(M, k, part, nv)
        if got is None:
            raise FactorizationError("the non-planar repeated translation could not be factored")
        _, hs, _ = got
        hs_all.append((got[0], hs))
    # (M^k + eps Ea)(M^k + eps Eb) = M^k T: R = M^k * prod(R_part)
    R = Rk.copy()
    hs = []
    for Rp, h in hs_all:
        R = real_mul(R, Rp)
        hs += h
    return R, hs, {"kind": "split", "deg_R": len(R) - 1}


# ====================================================================== kernel search
def _kernel_search(items, z0, K, blocks, target_blocks, rng, starts=12):
    """Find s with z0 + K s making the k = 1 translation blocks in ``target_blocks`` circular.
    Returns z or None."""
    if K.shape[1] == 0 or not target_blocks:
        return None
    sl = _split_unknowns(items, np.arange(len(z0)))
    idx = {it.block: s for it, s in zip(items, sl) if it.kind == "trans"}
    parts = []
    for b in target_blocks:
        ix = idx[b]
        M = blocks[b][0]
        c0, c1 = float(M[0]), float(M[1])
        v0, u0 = z0[ix][:3], z0[ix][3:6]
        V, U = K[ix][:3], K[ix][3:6]
        parts.append((c0, c1, v0, u0, V, U))
    zscale = max(float(np.max(np.abs(z0))), 1e-300)

    def fun_jac(s):
        r, J = [], []
        for c0, c1, v0, u0, V, U in parts:
            v = v0 + V @ s
            u = u0 + U @ s
            r += [2 * u @ v - (u @ u) * c1, v @ v - (u @ u) * c0]
            J += [2 * (U.T @ v + V.T @ u) - 2 * c1 * (U.T @ u), 2 * V.T @ v - 2 * c0 * (U.T @ u)]
        return np.array(r) / zscale**2, np.array(J) / zscale**2

    for start in range(starts):
        s = np.zeros(K.shape[1]) if start == 0 else rng.normal(size=K.shape[1]) * zscale * (1 + start / 3)
        lam = 1e-3
        r, J = fun_jac(s)
        for _ in range(200):
            f = float(r @ r)
            if f < 1e-30:
                break
            # damped min-norm step (works for under-determined systems)
            Jd = np.vstack([J, np.sqrt(lam) * np.eye(J.shape[1])])
            rd = np.concatenate([r, np.zeros(J.shape[1])])
            step = -np.linalg.lstsq(Jd, rd, rcond=None)[0]
            r2, J2 = fun_jac(s + step)
            if r2 @ r2 < f:
                s, r, J = s + step, r2, J2
                lam = max(lam / 10, 1e-15)
            else:
                lam *= 10
                if lam > 1e12:
                    break
        z = z0 + K @ s
        ok = True
        for b in target_blocks:
            ix = idx[b]
            E = z[ix].reshape(-1, 3)
            if np.max(np.abs(E)) <= 1e-9 * zscale or np.max(np.abs(circular_residual(blocks[b][0], E))) > CIRCULAR_TOL:
                ok = False
        if ok:
            return z
    return None


# ====================================================================== normalization
def _compose_affine(C, sigma, tau):
    """C(sigma s + tau) / sigma^n as a polynomial in s (monic when C is)."""
    C = np.asarray(C, float)
    n = C.shape[0] - 1
    out = np.zeros((1, C.shape[1]))
    out[0] = C[n]
    for k in range(n - 1, -1, -1):
        # out = out * (sigma s + tau) + C[k]
        new = np.zeros((out.shape[0] + 1, C.shape[1]))
        new[1:] += sigma * out
        new[:-1] += tau * out
        new[0] += C[k]
        out = new
    return out / sigma**n


def _normalization(C):
    """(tau, sigma, lam): t = sigma s + tau, dual parts divided by lam."""
    from synth.algebra.polynomial import norm_poly

    N = norm_poly(C)
    z = np.roots(N[::-1])
    tau = float(np.mean(z.real)) if len(z) else 0.0
    sigma = float(np.sqrt(np.mean(np.abs(z - tau) ** 2))) if len(z) else 1.0
    if not np.isfinite(sigma) or sigma <= 0:
        sigma = 1.0
    Cs = _compose_affine(C, sigma, tau)
    lam = float(np.max(np.abs(Cs[:, 4:])))
    if lam <= 0 or not np.isfinite(lam):
        lam = 1.0
    return tau, sigma, lam


def _denormalize_factor(h, tau, sigma, lam):
    h = np.array(h, float)
    h[4:] *= lam
    h = h * sigma
    h[0] += tau
    return h


def _denormalize_real(R, tau, sigma):
    """R(s) -> sigma^deg R((t - tau)/sigma) (monic in t)."""
    R = np.asarray(R, float)
    d = len(R) - 1
    if d == 0:
        return np.ones(1)
    out = _compose_affine(R[:, None] * np.eye(8)[0], 1 / sigma, -tau / sigma)[:, 0]
    return out / out[-1]


# ====================================================================== main
def _primary_blocks(rf_quads, mult):
    return [(np.asarray(q, float), int(k)) for q, k in zip(rf_quads, mult)]


def _templates(n_rot, n_blocks, orders, limit=MAX_TEMPLATES):
    """Yield (order index, positions tuple): translations first, then last, then the rest."""
    seen = set()
    firsts = [(0, (0,) * n_blocks), (0, (n_rot,) * n_blocks)]
    count = 0
    for oi in range(len(orders)):
        for pos in itertools.chain(firsts if oi == 0 else [], itertools.product(range(n_rot + 1), repeat=n_blocks)):
            key = (oi, tuple(pos))
            if key in seen:
                continue
            seen.add(key)
            yield key
            count += 1
            if count >= limit:
                return


def _build_items(rot_primals, blocks, positions):
    items = []
    d = len(rot_primals)
    for p in range(d + 1):
        for b, pos in enumerate(positions):
            if pos == p:
                M, k = blocks[b]
                items.append(_trans_item(real_pow(quad(M), k), b, label=f"T{b + 1}"))
        if p < d:
            items.append(_rot_item(rot_primals[p], label=f"r{p + 1}"))
    return items


def _real_content(C, rf):
    """Split real quadratic factors of C itself (M | P and M | Q). Returns (C', list of quadratics)."""
    Cw = np.array(C, float)
    out = []
    for M, k in zip(rf.quadratics, rf.multiplicity):
        Mq = quad(M)
        for _ in range(k):
            Q = Cw[:, 4:]
            qs = max(float(np.max(np.abs(Q))), 1e-300)
            if np.max(np.abs(Q)) == 0 or np.max(np.abs(_mod_real(Q, Mq))) <= 1e-10 * qs:
                Cw = _divide_real(Cw, Mq)
                Cw[-1] = np.eye(8)[0]
                out.append(np.asarray(M, float))
            else:
                break
    return Cw, out


def _generic(C):
    from synth.algebra.factorize import factorize

    res = factorize(C, validate=False)
    f = min(res.factorizations, key=lambda f: f.residual)
    return f.factors


def factorize_with_cofactor(C, *, seed: int = 0, max_templates: int = MAX_TEMPLATES) -> CofactorResult:
    """C R = (t - h_1)...(t - h_m) for a bounded monic motion polynomial C (rows of 8 floats, or of
    ints/Fractions for exact mrpf detection). Raises UnboundedMotionError (a real zero of mrpf(P)),
    InputError (not a monic motion polynomial) or FactorizationError."""
    from synth.algebra.factorize import check_motion_polynomial
    from synth.algebra.polynomial import product_of_linear, relative_error

    rows = C
    Cf = np.array([[float(x) for x in r] for r in np.asarray(C, dtype=object)], float) \
        if not isinstance(C, np.ndarray) else np.asarray(C, float)
    check_motion_polynomial(Cf)
    rf = mrpf(rows)
    require_bounded(rf)
    rng = np.random.default_rng(seed)
    n = Cf.shape[0] - 1

    if rf.generic:
        hs = _generic(Cf)
        res = float(relative_error(product_of_linear(hs), Cf))
        return CofactorResult(C=Cf, R=np.ones(1), factors=np.asarray(hs), residual=res, g=np.ones(1),
                              bound_met=True, generic=True, template=[f"r{i + 1}" for i in range(n)],
                              report=[])

    tau, sigma, lam = _normalization(Cf)
    Cs = _compose_affine(Cf, sigma, tau)
    Cs[:, 4:] /= lam
    Cs[-1] = np.eye(8)[0]
    rfs = mrpf(Cs, exact=False) if rf.exact is None else None
    if rfs is None:  # transport the exact g to s
        g_s = _compose_affine(rf.g[:, None] * np.eye(8)[0], sigma, tau)[:, 0]
        from synth.algebra.factorize import norm_quadratics

        quads, mult, _ = norm_quadratics(g_s)
        rfs = RealFactor(g=g_s, exact=None, bounded=True, quadratics=quads, multiplicity=list(mult))
    Cs2, real_quads = _real_content(Cs, rfs)
    real_hs = []
    for M in real_quads:
        real_hs += factor_real(M)
    g_s = np.ones(1)
    blocks_q, blocks_k = [], []
    rq = [tuple(np.round(np.asarray(q) / 1e-9)) for q in real_quads]
    for M, k in zip(rfs.quadratics, rfs.multiplicity):
        k_left = k - sum(1 for q in rq if q == tuple(np.round(np.asarray(M) / 1e-9)))
        if k_left > 0:
            blocks_q.append(np.asarray(M, float))
            blocks_k.append(k_left)
            g_s = real_mul(g_s, real_pow(quad(M), k_left))
    blocks = list(zip(blocks_q, blocks_k))
    n2 = Cs2.shape[0] - 1

    def finish(hs_s, R_s, template, report, family=None):
        hs_s = list(hs_s) + real_hs
        R_t = _denormalize_real(R_s, tau, sigma)
        hs = np.array([_denormalize_factor(h, tau, sigma, lam) for h in hs_s])
        CR = np.zeros((n + len(R_t), 8))
        for k, r in enumerate(R_t):
            CR[k:k + n + 1] += r * Cf
        res = float(relative_error(product_of_linear(hs), CR))
        return CofactorResult(C=Cf, R=R_t, factors=hs, residual=res, g=rf.g.copy(),
                              bound_met=len(R_t) - 1 <= len(rf.g) - 1, generic=False, template=template,
                              report=report, real_content=[np.asarray(q) for q in real_quads], family=family)

    if not blocks:  # only real content: C' is generic
        hs = list(_generic(Cs2)) if n2 > 0 else []
        return finish(hs, np.ones(1), [f"r{i + 1}" for i in range(n2)],
                      [{"kind": "real", "quadratic": q.tolist(), "deg_R": 0} for q in real_quads])

    P = Cs2[:, :4]
    Q = Cs2[:n2, 4:]
    P0 = _divide_real(P, g_s)
    P0[-1] = [1.0, 0, 0, 0]
    d = P0.shape[0] - 1
    if d > 0:
        from synth.algebra.factorize import factorize

        P0dq = np.concatenate([P0, np.zeros_like(P0)], axis=1)
        fres = factorize(P0dq, validate=False)
        orders = [f.factors[:, :4] for f in fres.factorizations]
    else:
        orders = [np.zeros((0, 4))]

    best = None
    for oi, positions in _templates(d, len(blocks), orders, max_templates):
        items = _build_items(orders[oi], blocks, positions)
        z0, K, res = _solve_items(items, Q, n2)
        if res > TEMPLATE_TOL:
            continue
        k1 = [b for b, (M, k) in enumerate(blocks) if k == 1]
        E0 = {it.block: s.reshape(-1, 3) for it, s in zip(items, _split_unknowns(items, z0)) if it.kind == "trans"}
        noncirc = [b for b in k1 if np.max(np.abs(E0[b])) > 0
                   and np.max(np.abs(circular_residual(blocks[b][0], E0[b]))) > CIRCULAR_TOL]
        z = z0
        if noncirc and K.shape[1] > 0:
            found = None
            for size in range(len(noncirc), 0, -1):
                for subset in itertools.combinations(noncirc, size):
                    others = [b for b in k1 if b not in noncirc]  # already circular: keep them so
                    found = _kernel_search(items, z0, K, blocks, list(subset) + others, rng)
                    if found is not None:
                        break
                if found is not None:
                    break
            if found is not None:
                z = found
        try:
            hs_s, R_s, report, family = _assemble(items, z, blocks, rng)
        except FactorizationError:
            continue
        labels = [it.label for it in items]
        result = finish(hs_s, R_s, labels, report, family)
        if result.residual > FINAL_TOL:
            continue
        if best is None or result.deg_R < best.deg_R or (result.deg_R == best.deg_R and result.residual < best.residual * 1e-3):
            best = result
        if best.deg_R == 0 or K.shape[1] == 0 and _coprime(blocks, orders[oi]):
            break
    if best is None:
        raise FactorizationError(
            "no factorization of C R was found (no template of the co-factor algorithm solved; "
            f"mrpf = {rf.text()})")
    return best


def _coprime(blocks, rot_primals):
    for x in rot_primals:
        a, b = float(x[0]), float(np.linalg.norm(x[1:4]))
        for M, _ in blocks:
            al, be = alpha_beta(M)
            if abs(a - al) + abs(b - be) <= 1e-6 * (1 + abs(al) + be):
                return False
    return True


def _assemble(items, z, blocks, rng):
    hs, R = [], np.ones(1)
    report = []
    family = None
    for it, zs in zip(items, _split_unknowns(items, z)):
        if it.kind == "rot":
            hs.append(_rotation_from(it, zs))
            continue
        M, k = blocks[it.block]
        E = _E_from(it, zs)
        Ri, hsi, rep = _factor_block(M, k, E, rng)
        R = real_mul(R, Ri)
        hs += hsi
        rep = dict(rep, block=it.label, quadratic=[float(M[0]), float(M[1])], multiplicity=k,
                   rotations=len(hsi))
        if "family" in rep and len(items) == 1:
            family = rep["family"]
        report.append(rep)
    return hs, R, report, family


# ====================================================================== exact certification
def rationalize(x, max_denominator: int = 10**7, tol: float = 1e-9) -> Fraction:
    """The Fraction nearest to x with a bounded denominator; raises ValueError when it is farther
    than tol * max(1, |x|)."""
    f = Fraction(float(x)).limit_denominator(max_denominator)
    if abs(float(f) - float(x)) > tol * max(1.0, abs(float(x))):
        raise ValueError(f"{x!r} is not close to a rational with denominator <= {max_denominator}")
    return f


def exact_product(hs):
    """prod (t - h_i) in exact arithmetic: rows of 8 Fractions, ascending."""
    from synth.algebra.flip import dq_mul_any

    poly = [[Fraction(1)] + [Fraction(0)] * 7]
    for h in hs:
        h = [Fraction(x) for x in h]
        new = [[Fraction(0)] * 8 for _ in range(len(poly) + 1)]
        for k, c in enumerate(poly):
            for a in range(8):
                new[k + 1][a] += c[a]
            ch = dq_mul_any(c, h)
            for a in range(8):
                new[k][a] -= ch[a]
        poly = new
    return poly


def exact_check(C, R, hs) -> bool:
    """True when C R = prod (t - h_i) exactly (all entries Fractions/ints; R ascending real)."""
    C = [[Fraction(x) for x in r] for r in C]
    R = [Fraction(x) for x in R]
    CR = [[Fraction(0)] * 8 for _ in range(len(C) + len(R) - 1)]
    for i, r in enumerate(R):
        for k, c in enumerate(C):
            for a in range(8):
                CR[i + k][a] += r * c[a]
    return exact_product(hs) == CR


def rationalize_factors(hs, max_denominator: int = 10**7):
    return [[rationalize(x, max_denominator) for x in h] for h in hs]


def exact_result(C, result: CofactorResult, max_denominator: int = 10**6):
    """(R, factors) as Fractions when rationalizing ``result`` gives an exact identity C R = prod(t - h)
    for the rational C (rows of ints/Fractions); None otherwise (irrational answer, or not certified)."""
    try:
        R = [rationalize(x, max_denominator) for x in result.R]
        hs = [[rationalize(x, max_denominator) for x in h] for h in result.factors]
    except ValueError:
        return None
    return (R, hs) if exact_check(C, R, hs) else None
