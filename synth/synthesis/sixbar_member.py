"""One member of a 6R family: its 6 factorizations, 9 loops and their scores (issue 4: single-member
speed; used by `synth.synthesis.sixbar.one_member_loops`).

The batched code (`synth.synthesis.cubic.factor_members`, `polish`, `norm_roots`, `loop_geometry`) pays numpy's
per-call overhead on arrays of a few numbers; one member is one cubic, so this module works on 8-tuples
(`synth.algebra.scalar` conventions: a dual quaternion is (p0..p3, q0..q3) meaning p + eps q) where that is
cheaper, and on stacks of the 6 orders where one numpy call replaces many scalar products. It gives up
(returns None) unless the member is clearly generic, leaving every borderline decision to the general
path. Conventions (quadratic order, factorization orders, pairs, score parts) are those of `synth.synthesis.cubic`
and `synth.synthesis.sixbar`.

Factorization (MATH.md section 4): for each norm quadratic M of C the remainder C mod M = r1 t + r0 gives
both outer factors at once, the rightmost h = -r1^-1 r0 (C = Q (t - h)) and the leftmost g = -r0 r1^-1
(C = (t - g) P); the middle factor of the order (i, j, k) follows from the t^2 coefficient,
h2 = -(c2 + g_i + h_k). Every factorization is then polished by Newton's method on the product equations
(as `synth.synthesis.cubic.polish`, same policy), its linear system solved in closed form (`_vnewton`) instead of
as a 16 x 16 system: the multiply-back error drops to ~2e-16.
"""
from __future__ import annotations

import math

import numpy as np

from synth.synthesis.cubic import (EDGES, GENERIC_TOL, JOINTS, LOOP_EDGES, PAIRS, PERMS, PRISMATIC_TOL, STEP_TOL,
                    parameter_separation)
from synth.algebra.dq import _DT_FLAT
from synth.algebra.scalar import FAST_MIN_IMAG, dq_inv, dq_mul, norm_upper_roots

_sqrt = math.sqrt

# The fast path gives up well before the general path would decide otherwise (ok, valid, ordering).
MARGIN = 1e3  # generic-remainder and translation tests: this much clear of the general thresholds
MAX_RESIDUAL = 1e-13  # multiply-back error of a refined factorization above this: general path
ROOT_TOL = 1e-11  # a root's estimated rounding error above this (relative to its gap): general path
EPS = 2.220446049250313e-16
MIN_REAL_GAP = 1e-9  # roots whose real parts are this close (relative) could sort differently: general path


def _outer_factors(C, z, prim):
    """Rightmost h and leftmost g factor for the norm root z (quadratic t^2 + m1 t + m0); None unless the
    remainder's leading coefficient is clearly invertible."""
    m1 = -2.0 * z.real
    m0 = z.real * z.real + z.imag * z.imag
    c0, c1, c2 = C[0], C[1], C[2]
    r1 = (c1[0] - m1 * c2[0] + (m1 * m1 - m0),) + tuple([x - m1 * y for x, y in zip(c1[1:], c2[1:])])
    r0 = (c0[0] - m0 * c2[0] + m1 * m0,) + tuple([x - m0 * y for x, y in zip(c0[1:], c2[1:])])
    if not _sqrt(r1[0] ** 2 + r1[1] ** 2 + r1[2] ** 2 + r1[3] ** 2) > MARGIN * GENERIC_TOL * prim:
        return None
    ir = dq_inv(r1)
    h = tuple([-x for x in dq_mul(ir, r0)])
    g = tuple([-x for x in dq_mul(r0, ir)])
    return h, g


def _study(H):
    """As `synth.synthesis.cubic._study` for one factorization."""
    hs = max(1.0, max([abs(x) for h in H for x in h]))
    return max([abs(h[4]) + abs(h[1] * h[5] + h[2] * h[6] + h[3] * h[7]) / hs for h in H]) / hs


def _norm_coefficients(C):
    """N(C) ascending (7 numbers) for the monic cubic C (rows ascending): N_k = sum_{i+j=k} P_i.P_j."""
    P = [r[:4] for r in C]
    N = [0.0] * 7
    for i in range(4):
        a0, a1, a2, a3 = P[i]
        N[2 * i] += a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3
        for j in range(i + 1, 4):
            b0, b1, b2, b3 = P[j]
            N[i + j] += 2.0 * (a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3)
    return N


def _roots(C):
    """The three norm roots (Im z > 0) sorted by real part, or None unless each is determined to about
    ROOT_TOL of its distance to the nearest other root or conjugate (so that `synth.synthesis.cubic.norm_roots`,
    which computes them differently, finds them to ~1e-12 relative, and sorts them alike)."""
    N = _norm_coefficients(C)
    z = norm_upper_roots(N)
    if z is None:
        return None
    z.sort(key=lambda w: w.real)
    for i, w in enumerate(z):
        # first-order rounding error of the root: eps sum |N_k| |w|^k / |N'(w)|
        a = abs(w)
        f, df, bound = 0j, 0j, 0.0
        for c in reversed(N):
            df = df * w + f
            f = f * w + c
            bound = bound * a + abs(c)
        gap = min([2.0 * w.imag] + [abs(w - v) for v in z if v is not w])
        if not (abs(df) * gap * ROOT_TOL > EPS * bound and w.imag > FAST_MIN_IMAG * max(1.0, a)):
            return None
        if i and not w.real - z[i - 1].real > MIN_REAL_GAP * max(1.0, a, abs(z[i - 1])):
            return None
    return z


def factor_member(C):
    """All 6 factorizations of the monic cubic C (4 rows of 8 floats, ascending), polished, with the
    conventions of `synth.synthesis.cubic.factor_members`: (roots, H (6 orders x 3 factors), residual (6,)), or
    None unless C is clearly generic: every factorization then is ok (no translation factor)."""
    flat = [x for r in C for x in r]
    if not math.isfinite(sum(flat)) or C[3] != (1.0,) + (0.0,) * 7:
        return None
    cmax = max(map(abs, flat))
    if not cmax < 1e10:
        return None
    z = _roots(C)
    if z is None:
        return None
    prim = max([_sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]) for r in C])
    outer = [_outer_factors(C, w, prim) for w in z]
    if None in outer:
        return None
    scale = max(1.0, cmax)
    c2 = C[2]
    generic = MARGIN * GENERIC_TOL * prim
    H0 = []
    for i, j, k in PERMS.tolist():
        h1, h3 = outer[i][1], outer[k][0]
        h2 = tuple([-(c + a + b) for c, a, b in zip(c2, h1, h3)])
        # Algorithm 1's second step (synth.synthesis.cubic._step2) needs Q1 - m1_j = -(h1 + h2) - m1_j invertible
        m1 = -2.0 * z[j].real
        s0, s1, s2, s3 = -(h1[0] + h2[0]) - m1, -(h1[1] + h2[1]), -(h1[2] + h2[2]), -(h1[3] + h2[3])
        if not _sqrt(s0 * s0 + s1 * s1 + s2 * s2 + s3 * s3) > generic:
            return None
        H0.append((h1, h2, h3))
    Hp, rm = polish_orders(np.array(C), H0)
    H, res = Hp.tolist(), []
    for F, e in zip(H, rm.tolist()):
        r = max(e / scale, _study(F))
        if not r <= MAX_RESIDUAL:
            return None
        for h in F:
            if not _sqrt(h[1] * h[1] + h[2] * h[2] + h[3] * h[3]) > MARGIN * PRISMATIC_TOL * (1.0 + abs(h[0])):
                return None
        res.append(r)
    return z, H, res


def _line(h):
    """Plücker line (u, m) and the point p = u x m of the axis of t - h (as `synth.synthesis.cubic.lines`)."""
    v1, v2, v3 = h[1], h[2], h[3]
    n = _sqrt(v1 * v1 + v2 * v2 + v3 * v3)
    u1, u2, u3 = -v1 / n, -v2 / n, -v3 / n
    m1, m2, m3 = h[5] / n, h[6] / n, h[7] / n
    return (u1, u2, u3), (u2 * m3 - u3 * m2, u3 * m1 - u1 * m3, u1 * m2 - u2 * m1)


def _edge(a, b):
    """(distance, angle in [0, pi/2], squared distance of the farther common-normal foot from the origin)
    of two lines given as (u, p) (the formulas of `synth.synthesis.cubic._pair_geometry`)."""
    (u1, u2, u3), (p1, p2, p3) = a
    (w1, w2, w3), (q1, q2, q3) = b
    c1, c2, c3 = u2 * w3 - u3 * w2, u3 * w1 - u1 * w3, u1 * w2 - u2 * w1
    s2 = c1 * c1 + c2 * c2 + c3 * c3
    ang = math.atan2(_sqrt(s2), abs(u1 * w1 + u2 * w2 + u3 * w3))
    d1, d2, d3 = q1 - p1, q2 - p2, q3 - p3
    if s2 < 1e-24:
        a1, a2 = 0.0, -d1 * w1 - d2 * w2 - d3 * w3
    else:
        a1 = ((d2 * w3 - d3 * w2) * c1 + (d3 * w1 - d1 * w3) * c2 + (d1 * w2 - d2 * w1) * c3) / s2
        a2 = ((d2 * u3 - d3 * u2) * c1 + (d3 * u1 - d1 * u3) * c2 + (d1 * u2 - d2 * u1) * c3) / s2
    f1, f2, f3 = p1 + a1 * u1, p2 + a1 * u2, p3 + a1 * u3
    g1, g2, g3 = q1 + a2 * w1, q2 + a2 * w2, q3 + a2 * w3
    e1, e2, e3 = g1 - f1, g2 - f2, g3 - f3
    return (_sqrt(e1 * e1 + e2 * e2 + e3 * e3), ang,
            max(f1 * f1 + f2 * f2 + f3 * f3, g1 * g1 + g2 * g2 + g3 * g3))


def loop_geometry(H):
    """`synth.synthesis.cubic.loop_geometry` of one member's factorizations H (6 orders x 3 factors): lists (9,) of
    min_offset, min_twist, extent; each of the 12 joints' axes computed once, each of the 18 edges once."""
    L = [_line(H[p][pos]) for p, pos in JOINTS.tolist()]
    E = [_edge(L[a], L[b]) for a, b in EDGES.tolist()]
    offset, twist, extent = [], [], []
    for loop in LOOP_EDGES.tolist():
        e = [E[i] for i in loop]
        offset.append(min([x[0] for x in e]))
        twist.append(min([x[1] for x in e]))
        extent.append(_sqrt(max([x[2] for x in e])))
    return offset, twist, extent


MIN_GEOMETRY = 1e-6  # a loop with nearly parallel or nearly intersecting consecutive axes: general path


def _root_conditioning(z):
    """`synth.synthesis.cubic.root_conditioning` of three roots: (min Im z / (1 + |z|^2), min |z - z'| / (1 + max|.|^2))."""
    w = [1.0 + abs(x) ** 2 for x in z]
    im = min([abs(x.imag) / v for x, v in zip(z, w)])
    sep = min([abs(z[i] - z[j]) / max(w[i], w[j]) for i, j in ((0, 1), (0, 2), (1, 2))])
    return im, sep


def score_loops(z, t3, H, residual):
    """Score parts (PART_KEYS of `synth.synthesis.sixbar`, each a list of 9) and scores of the 9 loops, or None when
    some loop is nearly degenerate (MIN_GEOMETRY) and the general path should decide."""
    from synth.synthesis.sixbar import COND_WEIGHT, KAPPA_GOOD, OFFSET_GOOD, RESIDUAL_TOL, TWIST_GOOD

    offset, twist, extent = loop_geometry(H)
    if not min(min(offset), min(twist)) > MIN_GEOMETRY:
        return None
    im, sep = _root_conditioning(z)
    t3s = parameter_separation(t3)
    kappa = min(min(im, sep), t3s)
    log10 = math.log10
    pc = max(0.0, log10(KAPPA_GOOD / kappa))
    sin_good = math.sin(TWIST_GOOD)
    parts = {k: [] for k in ("residual", "penalty_size", "penalty_parallel", "penalty_intersect")}
    score = []
    for (a, b), off, tw, ext in zip(PAIRS.tolist(), offset, twist, extent):
        res = max(residual[a], residual[b])
        ps = log10(ext)
        pp = max(0.0, log10(sin_good / math.sin(tw)))
        pi = max(0.0, log10(OFFSET_GOOD / off))
        cost = COND_WEIGHT * pc + ps + pp + pi
        if not (res <= RESIDUAL_TOL and math.isfinite(cost) and kappa > 0):
            return None
        parts["residual"].append(res)
        parts["penalty_size"].append(ps)
        parts["penalty_parallel"].append(pp)
        parts["penalty_intersect"].append(pi)
        score.append(10.0 ** -cost)
    parts.update(conditioning=[kappa] * 9, root_imag=[im] * 9, root_separation=[sep] * 9, t3_separation=[t3s] * 9,
                 extent=extent, min_twist=twist, min_offset=offset, penalty_conditioning=[pc] * 9)
    return parts, score


# ============================================================================ polish, batched over the 6 orders
# The Newton step above in numpy over all orders at once (each stage's products in one matmul): on a
# member's 6 factorizations a numpy call costs less than the ~20 scalar products per order it replaces.
_TL = _DT_FLAT  # a -> L(a) with a b = b @ L(a)
_CONJ8 = np.array([1.0, -1, -1, -1, 1, -1, -1, -1])


def _vmul(a, b):
    """Products a_n b_n of stacks (n, 8)."""
    return (b[:, None, :] @ (a @ _TL).reshape(-1, 8, 8))[:, 0, :]


def _vdual(x, y):
    """(x0 + eps x4) y for stacks: the dual scalar part of x times y."""
    out = x[:, :1] * y
    out[:, 4:] += x[:, 4:5] * y[:, :4]
    return out


def _vnorm_plus(x, y):
    """y + N(x) (the dual number N(x) = x x~ added to the scalar parts of y), stacks."""
    p, q = x[:, :4], x[:, 4:]
    out = y.copy()
    out[:, 0] += np.einsum("ni,ni->n", p, p)
    out[:, 4] += 2.0 * np.einsum("ni,ni->n", p, q)
    return out


def _vinv(h):
    """Inverses of a stack of dual quaternions (nonzero primal parts): h~ / (n + eps d)."""
    p, q = h[:, :4], h[:, 4:]
    n = np.einsum("ni,ni->n", p, p)[:, None]
    d = 2.0 * np.einsum("ni,ni->n", p, q)[:, None]
    c = h * _CONJ8
    out = c / n
    out[:, 4:] -= c[:, :4] * (d / (n * n))
    return out


def _vresidual(C, h1, h2, h3):
    """(r (3, n, 8) coefficient errors of (t - h1)(t - h2)(t - h3) - C for t^0, t^1, t^2, h1 h2)."""
    n = len(h1)
    X = _vmul(h1, h2)
    s = h1 + h2
    P = _vmul(np.concatenate([X, s]), np.concatenate([h3, h3]))
    r = np.empty((3, n, 8))
    r[0] = -P[:n] - C[0]
    r[1] = X + P[n:] - C[1]
    r[2] = -(s + h3) - C[2]
    return r, X


def _vnewton(h1, h2, h3, r, X):
    """Newton correction (d1, d2, d3) of the product equations (t - h1)(t - h2)(t - h3) = C for stacks
    (n, 8), given the residual r = product - C (t^0, t^1, t^2) and X = h1 h2:
    d1 (t - h2)(t - h3) + (t - h1) d2 (t - h3) + (t - h1)(t - h2) d3 = r. Its right value at h3 leaves
    alpha d3 h3 + beta d3 = r(h3) with (t - h1)(t - h2) = N(t - h3) + alpha t + beta (N(t - h3) has
    central coefficients and vanishes at h3); its left value at h1 leaves h1 d1 alpha' + d1 beta' = r(h1)
    with (t - h2)(t - h3) = N(t - h1) + alpha' t + beta'; the t^2 coefficient gives d2 = r2 - d1 - d3.
    Both are Sylvester equations a x - x b = c, solved by (a^2 - 2 Re(b) a + N(b)) x = a c - c b~ (Re, N
    dual numbers). Generically equivalent to the 16 x 16 system of `synth.synthesis.cubic._newton_step`."""
    n = len(h1)
    r0, r1, r2 = r
    A = _vmul(np.concatenate([r2, h1, h2]), np.concatenate([h3, r2, h3]))  # r2 h3, h1 r2, h2 h3
    Y = A[2 * n:]
    B = _vmul(np.concatenate([r1 + A[:n], h1]), np.concatenate([h3, r1 + A[n:2 * n]]))
    rr, rl = r0 + B[:n], r0 + B[n:]  # right value of r at h3, left value at h1
    two_re3, two_re1 = 2.0 * h3 * _RE, 2.0 * h1 * _RE
    alpha = np.concatenate([two_re3 - h1 - h2, two_re1 - h2 - h3])
    beta = np.concatenate([-_vnorm_plus(h3, -X), -_vnorm_plus(h1, -Y)])  # X - N(h3), Y - N(h1)
    ia = _vinv(alpha)
    # right: a3 = ia beta, c3 = ia rr; left: b1 = beta ia, c1 = rl ia
    M = _vmul(np.concatenate([ia[:n], ia[:n], beta[n:], rl]), np.concatenate([beta[:n], rr, ia[n:], ia[n:]]))
    a3, c3, b1, c1 = M[:n], M[n:2 * n], M[2 * n:3 * n], M[3 * n:]
    # a X - X b = c: (a^2 - 2 Re(b) a + N(b)) X = a c - c b~; right: a = a3, b = -h3; left: a = h1, b = -b1
    S = _vmul(np.concatenate([a3, a3, c3, h1, h1, c1]),
              np.concatenate([a3, c3, h3 * _CONJ8, h1, c1, b1 * _CONJ8]))
    lhs = np.concatenate([_vnorm_plus(h3, S[:n] + _vdual(two_re3, a3)),
                          _vnorm_plus(b1, S[3 * n:4 * n] + _vdual(2.0 * b1 * _RE, h1))])
    rhs = np.concatenate([S[n:2 * n] + S[2 * n:3 * n], S[4 * n:5 * n] + S[5 * n:]])
    d = _vmul(_vinv(lhs), rhs)
    d3, d1 = d[:n], d[n:]
    return d1, r2 - d1 - d3, d3


_RE = np.array([1.0, 0, 0, 0, 1, 0, 0, 0])  # the dual scalar part of a dual quaternion


def polish_orders(C, H):
    """`synth.synthesis.cubic.polish` (same policy: at most 2 Newton steps, a step kept only where it lowers the
    residual, none after a step of at most STEP_TOL relative) of factorizations H (n, 3, 8) of one cubic
    C (4, 8), with the closed-form Newton step. Returns (H, largest absolute coefficient error (n,))."""
    H = np.array(H, float)
    tiny = 2e-16 * max(1.0, float(np.abs(C).max()))
    r, X = _vresidual(C, H[:, 0], H[:, 1], H[:, 2])
    rm = np.abs(r).max((0, 2))
    for _ in range(2):
        if not (rm > tiny).any():
            break
        D = np.stack(_vnewton(H[:, 0], H[:, 1], H[:, 2], r, X), 1)
        Hn = H + D
        rn, Xn = _vresidual(C, Hn[:, 0], Hn[:, 1], Hn[:, 2])
        rmn = np.abs(rn).max((0, 2))
        better = rmn < rm
        if better.all():
            H, r, X, rm = Hn, rn, Xn, rmn
        else:
            H = np.where(better[:, None, None], Hn, H)
            r = np.where(better[None, :, None], rn, r)
            X = np.where(better[:, None], Xn, X)
            rm = np.where(better, rmn, rm)
        big = np.abs(D).max((1, 2)) > STEP_TOL * np.maximum(1.0, np.abs(H).max((1, 2)))
        if not (better & big).any():
            break
    return H, rm
