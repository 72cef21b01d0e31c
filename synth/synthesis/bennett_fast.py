"""`synth.algebra.scalar.bennett_core` with its small helpers fused in (issue 7: single-call speed).

The same floating-point operations in the same order, so the results are bitwise those of
`synth.algebra.scalar.bennett_core` (tests/test_bennett_lazy.py compares them on random and nearly degenerate
input); what is gone is the overhead of ~40 tiny function calls (pose_to_dq, matrix_to_quat, qmul, dq_mul,
dq_inv, normalize_dq, world, sorted with a key) per synthesis. Conventions and thresholds are those of
`synth.algebra.scalar` (imported from there, not repeated). Keep the two in step: a change to the algorithm
belongs in `synth.algebra.scalar.bennett_core` first.
"""
from __future__ import annotations

import math

from synth.algebra.scalar import (FAST_MAX_RESIDUAL, FAST_MIN_B, FAST_MIN_IMAG, FAST_MIN_SEPARATION, polish_root,
                     quartic_roots)

_sqrt = math.sqrt


def _pose_dq(R, cx, cy, cz, L):
    """pose_to_dq of the rows R of a 4x4 pose with the translation (d - c) / L (matrix_to_quat, qmul)."""
    A, B, C = R[0], R[1], R[2]
    d0, d1, d2 = (A[3] - cx) / L, (B[3] - cy) / L, (C[3] - cz) / L
    r00, r01, r02 = A[0], A[1], A[2]
    r10, r11, r12 = B[0], B[1], B[2]
    r20, r21, r22 = C[0], C[1], C[2]
    tr = r00 + r11 + r22
    d = (tr, r00, r11, r22)
    k = d.index(max(d))
    if k == 0:
        s = 2 * _sqrt(1 + tr)
        q0, q1, q2, q3 = (s / 4, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s)
    elif k == 1:
        s = 2 * _sqrt(1 + r00 - r11 - r22)
        q0, q1, q2, q3 = ((r21 - r12) / s, s / 4, (r01 + r10) / s, (r02 + r20) / s)
    elif k == 2:
        s = 2 * _sqrt(1 + r11 - r00 - r22)
        q0, q1, q2, q3 = ((r02 - r20) / s, (r01 + r10) / s, s / 4, (r12 + r21) / s)
    else:
        s = 2 * _sqrt(1 + r22 - r00 - r11)
        q0, q1, q2, q3 = ((r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, s / 4)
    sg = -1.0 if q0 < 0 else 1.0
    n = _sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    b0, b1, b2, b3 = q0 * sg / n, q1 * sg / n, q2 * sg / n, q3 * sg / n
    # qmul((0, d), r)
    e0 = 0.0 * b0 - d0 * b1 - d1 * b2 - d2 * b3
    e1 = 0.0 * b1 + d0 * b0 + d1 * b3 - d2 * b2
    e2 = 0.0 * b2 - d0 * b3 + d1 * b0 + d2 * b1
    e3 = 0.0 * b3 + d0 * b2 - d1 * b1 + d2 * b0
    return (b0, b1, b2, b3, -0.5 * e0, -0.5 * e1, -0.5 * e2, -0.5 * e3)


def _relative(a, b):
    """normalize_dq(dq_mul(a, b))."""
    a0, a1, a2, a3, a4, a5, a6, a7 = a
    b0, b1, b2, b3, b4, b5, b6, b7 = b
    h0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    h1 = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    h2 = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
    h3 = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
    h4 = (a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3)
    h5 = (a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2)
    h6 = (a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1)
    h7 = (a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0)
    n = _sqrt(h0 * h0 + h1 * h1 + h2 * h2 + h3 * h3)
    s = (-1.0 if h0 < 0 else 1.0) / n
    return (h0 * s, h1 * s, h2 * s, h3 * s, h4 * s, h5 * s, h6 * s, h7 * s)


def _right_factor(c0, c1, m0, m1, prim_scale):
    """Branch factors (h1, h2, residual) with t - h2 right-dividing C modulo the quadratic
    t^2 + m1 t + m0; None if not generic (as the loop body of `synth.algebra.scalar.bennett_core`)."""
    p0, p1, p2, p3, q0, q1, q2, q3 = (c1[0] - m1,) + c1[1:]
    if not _sqrt(p0 ** 2 + p1 ** 2 + p2 ** 2 + p3 ** 2) > 1e-9 * prim_scale:
        return None
    # dq_inv(r1)
    a = p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3
    b = 2.0 * (p0 * q0 + p1 * q1 + p2 * q2 + p3 * q3)
    ia = 1.0 / a
    f = b / (a * a)
    a0, a1, a2, a3 = p0 * ia, -p1 * ia, -p2 * ia, -p3 * ia
    a4, a5, a6, a7 = q0 * ia - p0 * f, -q1 * ia + p1 * f, -q2 * ia + p2 * f, -q3 * ia + p3 * f
    # g = dq_inv(r1) r0, h2 = -g
    b0, b1, b2, b3, b4, b5, b6, b7 = (c0[0] - m0,) + c0[1:]
    g0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    g1 = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    g2 = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
    g3 = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
    g4 = (a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3)
    g5 = (a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2)
    g6 = (a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1)
    g7 = (a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0)
    b0, b1, b2, b3, b4, b5, b6, b7 = h2 = (-g0, -g1, -g2, -g3, -g4, -g5, -g6, -g7)
    k0, k1, k2, k3, k4, k5, k6, k7 = c1
    a0, a1, a2, a3, a4, a5, a6, a7 = h1 = (-(k0 + b0), -(k1 + b1), -(k2 + b2), -(k3 + b3), -(k4 + b4), -(k5 + b5),
                                           -(k6 + b6), -(k7 + b7))
    # multiply back: (t - h1)(t - h2) = t^2 - (h1 + h2) t + h1 h2
    o0, o1, o2, o3, o4, o5, o6, o7 = c0
    res = max(max(abs((a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3) - o0),
                  abs((a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2) - o1),
                  abs((a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1) - o2),
                  abs((a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0) - o3),
                  abs(((a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3)) - o4),
                  abs(((a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2)) - o5),
                  abs(((a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1)) - o6),
                  abs(((a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0)) - o7)),
              max(abs((-a0 - b0) - k0), abs((-a1 - b1) - k1), abs((-a2 - b2) - k2), abs((-a3 - b3) - k3),
                  abs((-a4 - b4) - k4), abs((-a5 - b5) - k5), abs((-a6 - b6) - k6), abs((-a7 - b7) - k7)))
    return h1, h2, res


def bennett_core(T):
    """`synth.algebra.scalar.bennett_core` (same contract, bitwise the same results)."""
    if not math.isfinite(float(T.sum())):
        return None
    rows = T.tolist()
    R0, R1, R2 = rows
    x0, y0, z0 = R0[0][3], R0[1][3], R0[2][3]
    x1, y1, z1 = R1[0][3], R1[1][3], R1[2][3]
    x2, y2, z2 = R2[0][3], R2[1][3], R2[2][3]
    c = (cx, cy, cz) = ((x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, (z0 + z1 + z2) / 3.0)
    L = math.sqrt(((x0 - cx) ** 2 + (y0 - cy) ** 2 + (z0 - cz) ** 2 + (x1 - cx) ** 2 + (y1 - cy) ** 2
                   + (z1 - cz) ** 2 + (x2 - cx) ** 2 + (y2 - cy) ** 2 + (z2 - cz) ** 2) / 3.0)
    if not L > 0:
        L = 1.0
    H0 = _pose_dq(R0, cx, cy, cz, L)
    H0c = (H0[0], -H0[1], -H0[2], -H0[3], H0[4], -H0[5], -H0[6], -H0[7])
    D1 = _relative(_pose_dq(R1, cx, cy, cz, L), H0c)
    D2 = _relative(_pose_dq(R2, cx, cy, cz, L), H0c)
    B01 = D1[4] / 2
    B02 = D2[4] / 2
    B12 = 0.5 * ((D1[0] * D2[4] + D1[1] * D2[5] + D1[2] * D2[6] + D1[3] * D2[7])
                 + (D2[0] * D1[4] + D2[1] * D1[5] + D2[2] * D1[6] + D2[3] * D1[7]))
    if min(abs(B01), abs(B02), abs(B12)) <= FAST_MIN_B:
        return None
    mu1 = -B02 / B12
    mu2 = B01 / B12
    d0, d1, d2, d3, d4, d5, d6, d7 = D1
    e0, e1, e2, e3, e4, e5, e6, e7 = D2
    b0, b1, b2, b3 = mu1 * d0 + mu2 * e0 + -1.0, mu1 * d1 + mu2 * e1, mu1 * d2 + mu2 * e2, mu1 * d3 + mu2 * e3
    c1 = (b0, b1, b2, b3, mu1 * d4 + mu2 * e4, mu1 * d5 + mu2 * e5, mu1 * d6 + mu2 * e6, mu1 * d7 + mu2 * e7)
    m = -mu1
    a0, a1, a2, a3 = m * d0, m * d1, m * d2, m * d3
    c0 = (a0, a1, a2, a3, m * d4, m * d5, m * d6, m * d7)
    # norm polynomial N = |P(t)|^2 (P2 = 1)
    n0 = a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3
    n1 = 2.0 * (a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3)
    nb = b0 * b0 + b1 * b1 + b2 * b2 + b3 * b3
    n2 = 2.0 * a0 + nb
    n3 = 2.0 * b0
    N = (n0, n1, n2, n3, 1.0)
    up = [z for z in quartic_roots(n0, n1, n2, n3) if z.imag > 0]
    if len(up) != 2:
        return None
    za, zb = polish_root(N, up[0]), polish_root(N, up[1])
    if (zb.real, zb.imag) < (za.real, za.imag):  # sorted by (real, imag)
        za, zb = zb, za
    if not (za.imag > FAST_MIN_IMAG * max(1.0, abs(za)) and zb.imag > FAST_MIN_IMAG * max(1.0, abs(zb))
            and abs(za - zb) > FAST_MIN_SEPARATION * max(1.0, abs(za), abs(zb))):
        return None
    prim_scale = max(math.sqrt(n0), math.sqrt(nb), 1.0)
    cmax = max(1.0, max(map(abs, c0)), max(map(abs, c1)))
    facts = []
    for z in (zb, za):  # branch h: h2 from the larger-real-part quadratic; branch k: k2 from the other
        f = _right_factor(c0, c1, z.real * z.real + z.imag * z.imag, -2.0 * z.real, prim_scale)
        if f is None:
            return None
        h1, h2, res = f
        res /= cmax
        if not res <= FAST_MAX_RESIDUAL:
            return None
        if (math.sqrt(h1[1] ** 2 + h1[2] ** 2 + h1[3] ** 2) <= 1e-7 * (1 + abs(h1[0]))
                or math.sqrt(h2[1] ** 2 + h2[2] ** 2 + h2[3] ** 2) <= 1e-7 * (1 + abs(h2[0]))):
            return None
        facts.append((h1, h2, res))
    (h1, h2, rh), (k1, k2, rk) = facts
    world = [(h0, p1, p2, p3, q0 * L, q1 * L + (p2 * cz - p3 * cy), q2 * L + (p3 * cx - p1 * cz),
              q3 * L + (p1 * cy - p2 * cx)) for h0, p1, p2, p3, q0, q1, q2, q3 in (h1, h2, k1, k2, c0, c1)]
    return {"H": (world[0], world[1]), "K": (world[2], world[3]),
            "C": (world[4], world[5], (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)), "B": (B01, B02, B12),
            "centre": c, "scale": L, "residual": max(rh, rk), "norm": N, "roots": (za, zb)}
