"""Factoring the primary translations of the co-factor algorithm (docs/exceptional.md): T = M^k + eps E
(M a real monic quadratic, E vectorial of degree < 2k) into rotations after multiplying by a real
factor R_i of T's motion.

- k = 1 circular (|F|^2 = 0 mod M): two rotations, R_i = 1 (`factor_circular`, the min-norm member);
- k = 1 otherwise: T M = (M + eps F1)(M + eps F2) with circular F1 + F2 = F (`ellipse_split`, R_i = M);
- k >= 2 planar: patterns x+^k x-^k, x-^k x+^k (R_i = 1) or x+^k x-^2k x+^k (R_i = M^k);
- k >= 2 non-planar: the nested chain [a.., ~a.., b.., ~b..] by Levenberg-Marquardt over the directions
  (R_i = M^k), last resort two planar halves.

`circular_kernel_search` moves a template solution inside its affine family so that chosen k = 1
blocks become circular (each saves a factor M of R). Works in floating point.
"""
from __future__ import annotations

import numpy as np

from synth.algebra.dualsystem import (as_qpoly, dual_matrix, perp_basis, qp_mul, rot_item, rotation_dq,
                                      rotation_from, solve_items, split_unknowns, unit)
from synth.algebra.realpoly import divide_real, mod_real, quad, quadratic_roots, real_mul, real_pow
from synth.errors import NoFactorizationError

TEMPLATE_TOL = 1e-8  # relative least-squares residual of the template split
CIRCULAR_TOL = 1e-10  # relative circularity residual |F|^2 mod M


class FactorizationError(NoFactorizationError):
    """No template of the co-factor algorithm produced a factorization."""


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
    alpha, beta = quadratic_roots(M)
    v, u = np.asarray(E[0], float), np.asarray(E[1], float)
    uu = u @ u
    vec_y = np.cross(u, v) / uu
    n = unit(vec_y)
    d2 = -u / 2
    d2 = d2 - (d2 @ n) * n
    d1 = -u - d2
    d1 = d1 - (d1 @ n) * n
    h1 = rotation_dq(alpha, -beta, n, d1)
    h2 = rotation_dq(alpha, beta, n, d2)
    e1, e2 = perp_basis(n)
    family = {"h1": h1.tolist(), "h2": h2.tolist(),
              "directions": [e1.tolist(), e2.tolist()],
              "note": "h1 - eps(f e1 + g e2), h2 + eps(f e1 + g e2) for all real f, g"}
    return [h1, h2], family


def factor_real(M, axis=(0.0, 0.0, 1.0)):
    """M = (t - ~x)(t - x) with x = alpha + beta axis (a coaxial pair through the origin)."""
    alpha, beta = quadratic_roots(M)
    n = unit(axis)
    return [rotation_dq(alpha, -beta, n, np.zeros(3)), rotation_dq(alpha, beta, n, np.zeros(3))]


def ellipse_split(M, E):
    """F = F1 + F2 with both M + eps Fi circular (section 5 step 4): returns (F1, F2) as (2, 3) arrays."""
    alpha, beta = quadratic_roots(M)
    v, u = np.asarray(E[0], float), np.asarray(E[1], float)
    vp = (v + alpha * u) / beta
    c = np.cross(u, vp)
    scale = max(np.linalg.norm(u), np.linalg.norm(vp), 1e-300)
    if np.linalg.norm(c) > 1e-12 * scale * scale:
        n = unit(c)
    else:  # u ∥ v': any unit n ⊥ u and ⊥ v'
        ref = u if np.linalg.norm(u) >= np.linalg.norm(vp) else vp
        n = perp_basis(ref)[0] if np.linalg.norm(ref) > 0 else np.array([0.0, 0, 1])
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
        return perp_basis(ref)[0], rank
    if rank == 2:
        return Vt[2], rank
    return None, rank


def _solve_chain(primals, target_dual, n):
    """Duals d_j ⊥ vec x_j with prod(t - x_j - eps d_j) having dual part target (n, 4). Returns (rotations,
    relative residual)."""
    items = [rot_item(x) for x in primals]
    z0, _, res = solve_items(items, target_dual, n)
    hs = [rotation_from(it, zs) for it, zs in zip(items, split_unknowns(items, z0))]
    return hs, res


def _factor_planar(M, k, E, n_vec):
    alpha, beta = quadratic_roots(M)
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
        target = qp_mul(as_qpoly(Rk), Ed) if kr else Ed
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

    alpha, beta = quadratic_roots(M)
    Mq = quad(M)
    Rk = real_pow(Mq, k)
    Ed = np.zeros((2 * k, 4))
    Ed[:, 1:] = E
    target = qp_mul(as_qpoly(Rk), Ed)
    nn = 4 * k
    tgt = np.zeros((nn, 4))
    tgt[:target.shape[0]] = target[:nn]
    b = tgt.reshape(-1)
    bscale = max(float(np.max(np.abs(b))), 1e-300)

    def resid(p):
        items = [rot_item(x) for x in _nested_primals(p, alpha, beta, k)]
        A, _ = dual_matrix(items, nn)
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


def factor_block(M, k, E, rng):
    """Factor the primary translation M^k + eps E (E (2k, 3)) after multiplying by R_i.
    Returns (R_i, rotations, report)."""
    E = np.asarray(E, float)
    Mq = quad(M)
    # strip real factors M | E
    stripped = 0
    while k >= 1:
        if np.max(np.abs(E)) == 0 or np.max(np.abs(mod_real(E, Mq))) <= 1e-10 * np.max(np.abs(E)):
            if np.max(np.abs(E)) == 0:
                stripped += k
                k = 0
                break
            E = divide_real(E, Mq)[: 2 * (k - 1)]
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


def circular_kernel_search(items, z0, K, blocks, target_blocks, rng, starts=12):
    """Find s with z0 + K s making the k = 1 translation blocks in ``target_blocks`` circular.
    Returns z or None."""
    if K.shape[1] == 0 or not target_blocks:
        return None
    sl = split_unknowns(items, np.arange(len(z0)))
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
