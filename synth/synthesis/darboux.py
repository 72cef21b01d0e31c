"""The 7R linkage of a general Darboux motion (docs/exceptional.md, section 6, "The 7R linkage").

A cubic motion polynomial C (monic) whose primal part is ``M (t - p)``, M = (t - alpha)^2 + beta^2 real
and N(t - p) = M, is ``C = Q_w (t - h_w)`` for every rotation h_w = p + eps w (w perpendicular to vec p):
``Q_w = C (t - h_w~) / M = M + eps (A_w + B_w t)`` is a translation, and A_w, B_w are affine in w. Two
choices of w give the two branches:

* the **3R chain**: w with Q_w a circular translation (``|A + B t|^2`` divisible by M, two affine
  equations), then Q_w = (t - h1)(t - h2), two parallel axes along (A x B)/|A x B|;
* the **4R chain**: w with A_w, B_w parallel (Q_w a segment translation along d, two affine equations
  across vec p), then ``Q_w M = (t - g1)(t - g2)^2 (t - g3)``: three axes perpendicular to d, the middle
  one of rate 2 (it turns by 2 theta), and ``C M = (t - g1)(t - g2)^2 (t - g3)(t - g4)``.

The dual parts of both chains, for their primal parts, solve one linear system each
(`synth.algebra.dualsystem`). The two chains close a 7R loop with one degree of freedom. The construction
fails (returns None) for the vertical Darboux motion (the circular equations are singular) and for planar
motions (A, B perpendicular to vec p: the segment equations are singular). Lengths in the units of C.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from synth.algebra.dq import dq_conj
from synth.algebra.dualsystem import dual_matrix, perp_basis, rot_item, rotation_from, unit
from synth.algebra.polynomial import divide_real_quadratic, poly_mul, product_of_linear
from synth.algebra.realpoly import quad
from synth.checks import self_check
from synth.info import Darboux, DarbouxMember, LinkageInfo, MultiLoop
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.multiloop import constraint_jacobian, score_linkage

DARBOUX_JOINTS = 7
TOL = 1e-9  # relative residual of the structure and of the factorizations


def darboux_structure(C) -> dict | None:
    """For a monic cubic C (4, 8): {"M": [c0, c1], "p": (4,) the rotation's primal part} when the primal
    part is M (t - p) with N(t - p) = M (M without real roots), else None."""
    C = np.asarray(C, float)
    if C.shape != (4, 8) or np.abs(C[3] - np.eye(8)[0]).max() > TOL:
        return None
    P0, P1, P2 = C[0, :4], C[1, :4], C[2, :4]
    r = -P2[1:]
    rr = float(r @ r)
    scale = 1.0 + float(np.abs(C[:, :4]).max())
    if rr <= (TOL * scale) ** 2:
        return None
    m1 = -float(P1[1:] @ r) / rr
    m0 = -float(P0[1:] @ r) / rr
    p0 = m1 - P2[0]
    p = np.array([p0, *r])
    # P = M (t - p): every coefficient, and N(t - p) = M
    res = [P1[1:] + m1 * r, P0[1:] + m0 * r, P1[0] - (m0 - m1 * p0), P0[0] + m0 * p0,
           np.array([-2 * p0 - m1, p0 * p0 + rr - m0])]
    if max(float(np.abs(x).max()) for x in res) > TOL * scale ** 3 or m1 * m1 >= 4 * m0:
        return None
    return {"M": np.array([m0, m1]), "p": p}


def translation_part(C, M, p, w) -> tuple[np.ndarray, np.ndarray, float]:
    """(A, B, remainder): C (t - h~) = M Q + remainder, Q = M + eps (A + B t), h = p + eps w."""
    h = np.concatenate([p, [0.0], w])
    lin = np.zeros((2, 8))
    lin[0] = -dq_conj(h)
    lin[1, 0] = 1.0
    Q, r1, r0 = divide_real_quadratic(poly_mul(np.asarray(C, float), lin), M)
    rem = float(max(np.abs(r1).max(), np.abs(r0).max(), np.abs(Q[:, 4]).max(), np.abs(Q[2:, 4:]).max(initial=0.0),
                    np.abs(Q[:, :4] - quad(M)[:, None] * np.eye(4)[0]).max()))
    return Q[0, 5:8].copy(), Q[1, 5:8].copy(), rem


def _affine_root(fun, e1, e2):
    """w = x e1 + y e2 with fun(w) = 0 for a map fun: R^3 -> R^2 affine in (x, y) (the quadratic terms
    cancel, module docstring); None when its 2x2 matrix is singular."""
    f0 = fun(np.zeros(3))
    J = np.stack([fun(e1) - f0, fun(e2) - f0], axis=1)
    sv = np.linalg.svd(J, compute_uv=False)
    if sv[0] == 0 or sv[1] <= 1e-9 * max(sv[0], float(np.abs(f0).max())):
        return None
    x = np.linalg.solve(J, -f0)
    return x[0] * e1 + x[1] * e2


def _solve(prims, target, shared=()):
    """Duals of the rotations t - x_j - eps d_j (x_j in ``prims``, d_j ⊥ vec x_j) whose product has dual
    part ``target`` (n, 4); ``shared``: index pairs (i, j) of factors with one common dual (a repeated
    factor). Returns (factors (len(prims), 8), kernel (L, dim), relative residual)."""
    items = [rot_item(x) for x in prims]
    A, _ = dual_matrix(items, len(target))
    cols = [A[:, 2 * i: 2 * i + 2] for i in range(len(items))]
    keep = list(range(len(items)))
    for i, j in shared:
        cols[i] = cols[i] + cols[j]
        keep.remove(j)
    A = np.concatenate([cols[i] for i in keep], axis=1)
    b = np.asarray(target, float).reshape(-1)
    z, *_ = np.linalg.lstsq(A, b, rcond=None)
    _, sv, Vt = np.linalg.svd(A)
    K = Vt[int(np.sum(sv > 1e-10 * sv[0])):].T
    full = dict(zip(keep, np.split(z, len(keep))))
    for i, j in shared:
        full[j] = full[i]
    zs = [full[i] for i in range(len(items))]
    H = np.array([rotation_from(it, zz) for it, zz in zip(items, zs)])
    res = float(np.abs(A @ z - b).max()) / max(float(np.abs(b).max()), 1e-300)
    return H, K, res


def three_joint_chain(C, st) -> np.ndarray | None:
    """C = (t - h1)(t - h2)(t - h3) (3, 8), h3 = p + eps w the rotation with Q_w circular, h1, h2 the
    minimum-norm member of the circular translation's family; None for a vertical Darboux motion."""
    M, p = st["M"], st["p"]
    e1, e2 = perp_basis(p[1:])
    c0, c1 = M

    def circ(w):
        A, B, _ = translation_part(C, M, p, w)
        return np.array([2 * A @ B - (B @ B) * c1, A @ A - (B @ B) * c0])

    w = _affine_root(circ, e1, e2)
    if w is None:
        return None
    A, B, rem = translation_part(C, M, p, w)
    n = np.cross(A, B)
    if rem > TOL * (1 + np.abs(C).max()) or np.linalg.norm(n) <= TOL * (A @ A + B @ B):
        return None
    target = np.asarray(C, float)[:3, 4:]
    best = None
    for sign in (1.0, -1.0):
        H, _, res = _solve([*_norm_roots(M, sign * unit(n)), p], target)
        if best is None or res < best[1]:
            best = (H, res)
    return best[0] if best[1] <= TOL else None


def four_joint_chain(C, st, turn: float = 0.0) -> np.ndarray | None:
    """[g1, g2, g3, g4] (4, 8) with C M = (t - g1)(t - g2)^2 (t - g3)(t - g4): g4 = p + eps w the rotation
    with Q_w a segment translation along d, g1, g2, g3 parallel axes along u ⊥ d (u = d x vec p turned by
    ``turn`` rad about d), the minimum-norm solution; None for a planar motion."""
    M, p = st["M"], st["p"]
    r = unit(p[1:])
    e1, e2 = perp_basis(r)

    def par(w):
        A, B, _ = translation_part(C, M, p, w)
        x = np.cross(A, B)
        return np.array([x @ e1, x @ e2])

    w = _affine_root(par, e1, e2)
    if w is None:
        return None
    A, B, rem = translation_part(C, M, p, w)
    d = A if A @ A >= B @ B else B
    if rem > TOL * (1 + np.abs(C).max()) or np.linalg.norm(d) <= TOL * (1 + np.abs(C).max()):
        return None
    d = unit(d)
    u0 = np.cross(d, r)
    u0 = unit(u0) if np.linalg.norm(u0) > 1e-6 else perp_basis(d)[0]
    u = np.cos(turn) * u0 + np.sin(turn) * np.cross(d, u0)
    xp, xm = _norm_roots(M, u)
    CM = poly_mul(np.asarray(C, float), _real(quad(M)))
    G, _, res = _solve([xp, xm, xm, xp, p], CM[:5, 4:], shared=[(1, 2)])
    if res > TOL:
        return None
    return G[[0, 1, 3, 4]]


def _norm_roots(M, u) -> tuple[np.ndarray, np.ndarray]:
    """The primal parts alpha +- beta u of the two rotations about direction u whose norm is
    M = [c0, c1] (t^2 + c1 t + c0 = (t - alpha)^2 + beta^2)."""
    c0, c1 = M
    alpha, beta = -c1 / 2, float(np.sqrt(c0 - c1 * c1 / 4))
    return np.array([alpha, *(beta * u)]), np.array([alpha, *(-beta * u)])


def _real(m):
    out = np.zeros((len(m), 8))
    out[:, 0] = m
    return out


def chains(C, turn: float = 0.0, shift=(0.0, 0.0)) -> tuple[np.ndarray, np.ndarray] | None:
    """(H (3, 8), G (4, 8)) of a monic cubic Darboux motion C, or None when C is not one whose 7R this
    construction builds (module docstring). ``turn``: of the parallel axes of G about d (`four_joint_chain`);
    ``shift`` (f, g): the member h1 - eps s, h2 + eps s of the 3R family, s = f e1 + g e2 (e1, e2 =
    `perp_basis` of the axis of h1), in the units of C."""
    st = darboux_structure(C)
    if st is None:
        return None
    H = three_joint_chain(C, st)
    G = four_joint_chain(C, st, turn) if H is not None else None
    if G is None:
        return None
    e1, e2 = perp_basis(H[0, 1:4])
    s = shift[0] * e1 + shift[1] * e2
    H = H.copy()
    H[0, 5:8] -= s
    H[1, 5:8] += s
    return H, G


def chain_residuals(C, H, G) -> tuple[float, float]:
    """Relative multiply-back residuals of C = prod (t - h) and C M = (t - g1)(t - g2)^2 (t - g3)(t - g4)."""
    st = darboux_structure(C)
    CM = poly_mul(np.asarray(C, float), _real(quad(st["M"])))
    rh = np.abs(product_of_linear(H) - C).max() / np.abs(C).max()
    rg = np.abs(product_of_linear(G[[0, 1, 1, 2, 3]]) - CM).max() / np.abs(CM).max()
    return float(rh), float(rg)


def darboux_linkage(C, *, kind: str = "motion", tool_ref=None, info: MultiLoop | None = None, check_samples: int = 200,
                    turn: float = 0.0, shift=(0.0, 0.0), singular: bool = True):
    """The 7R loop of a monic cubic Darboux motion C (world frame, metres), or None when `chains` does
    not apply (or, for this ``turn``, the loop has more than one degree of freedom): branch h = h1 h2 h3 (C),
    branch k = k1 k2 k3 k4 = g1 g2 g3 g4 (C M, k2 of rate 2), welded at the coupler (docs/conventions.md,
    section 6). ``turn``, ``shift``: the member (`chains`). ``info`` (a multi-loop record) becomes
    ``linkage.info.synthesis`` with its ``darboux`` added (with the singular parameters unless ``singular`` is false: `singular_parameters`);
    ``checks`` holds the sampled self-check (`synth.checks.self_check`; the certified bound does not apply
    to a joint of rate 2)."""
    C = np.asarray(C, float)
    got = chains(C, turn, shift)
    if got is None:
        return None
    H, G = got
    rh, rg = chain_residuals(C, H, G)
    T = np.eye(4) if tool_ref is None else np.asarray(tool_ref, float)
    lk = two_branch_linkage(kind, H, G, C, [T], [], [], rates=[1, 1, 1, 1, 2, 1, 1])
    darboux = Darboux(h=H, g=G, rates={"k2": 2},
                      products="C = (t - h1)(t - h2)(t - h3),  C M = (t - g1)(t - g2)^2 (t - g3)(t - g4)",
                      M=darboux_structure(C)["M"], residuals={"h": rh, "g": rg},
                      member=DarbouxMember(turn=float(turn), shift=tuple(float(x) for x in shift)))
    mobility = score_linkage(lk)
    lk.info = LinkageInfo(synthesis=(info or MultiLoop()).replace(darboux=darboux, mobility=mobility))
    if mobility.dof != 1:
        return None
    if singular:
        add_singular(lk)
    lk.info = lk.info.with_synthesis(counts=lk.counts())
    lk.checks = self_check(lk, check_samples)
    return lk


def darboux_member(linkage, turn: float, shift=(0.0, 0.0), *, singular: bool = True, check_samples: int = 200):
    """Another member (`chains`: ``turn`` rad, ``shift`` metres) of the 7R of the Darboux motion of
    ``linkage`` (a `darboux_linkage`), with the same motion, tool frame and info (but its own ``darboux``,
    ``mobility`` and ``counts``); None where `darboux_linkage` refuses it."""
    info = linkage.info.synthesis.replace(darboux=None, mobility=None, counts=None)
    return darboux_linkage(linkage.motion, kind=linkage.kind, tool_ref=linkage.tool_ref, info=info,
                           check_samples=check_samples, turn=turn, shift=shift, singular=singular)


def add_singular(linkage) -> None:
    """Record the singular parameters (`singular_parameters`) and the driver h1's angles there in
    ``linkage.info.synthesis.darboux``."""
    sing = singular_parameters(linkage)
    deg = tuple(float(np.degrees(linkage.joints[0].angle(t))) for t in sing)
    darboux = linkage.info.synthesis.darboux.replace(singular_t=tuple(sing), singular_driver_deg=deg)
    linkage.info = linkage.info.with_synthesis(darboux=darboux)


def singular_parameters(linkage, grid: int = 720, tol: float = 1e-8) -> list[float]:
    """Parameters t where the loop Jacobian of ``linkage`` loses rank (smallest kept singular value below
    ``tol`` times the largest): minima of that ratio on ``grid`` values of phi (t = centre + scale tan phi),
    refined by a bounded scalar minimization. At these configurations other branches of the configuration
    curve can cross the motion (docs/exceptional.md, section 6)."""
    a = np.mean([j.a for j in linkage.joints])
    b = max(np.mean([j.b for j in linkage.joints]), 1e-12)
    rank = 6 * len(linkage.closures) - 1

    def cond(phi):
        t = a + b * np.tan(np.atleast_1d(phi))
        sv = np.linalg.svd(constraint_jacobian(linkage, linkage.angles_at(t)), compute_uv=False)
        return sv[:, rank] / sv[:, 0]

    phis = np.linspace(-np.pi / 2, np.pi / 2, grid + 1)[1:-1]
    c = cond(phis)
    out = []
    for i in np.flatnonzero((c[1:-1] <= c[:-2]) & (c[1:-1] <= c[2:])) + 1:
        r = minimize_scalar(lambda x: float(cond(x)[0]), bounds=(phis[i - 1], phis[i + 1]), method="bounded",
                            options={"xatol": 1e-12})
        if r.fun <= tol:
            out.append(float(a + b * np.tan(r.x)))
    return out
