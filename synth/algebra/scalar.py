"""Pure-Python kernels for *one* small problem (a single Bennett synthesis, a single line pair).

For arrays of 4-8 numbers a numpy call costs 0.5-40 microseconds of overhead, more than the arithmetic;
plain float arithmetic on tuples is 10-50x faster there. These functions use exactly the conventions
(and, where it matters for bitwise-close results, the same formulas) as `synth.algebra.dq`:

- a quaternion is a 4-tuple (w, x, y, z), Hamilton product (ij = k);
- a dual quaternion is an 8-tuple (p0..p3, q0..q3) meaning p + eps q;
- the pose with rotation r (unit quaternion) and translation d is r - (eps/2) d r;
- a Plücker line is (unit direction u, moment m = point x u).

Vectorized (batched) code lives in `synth.synthesis.bennett_batch`; this module is for the single-item path only.
"""
from __future__ import annotations

import cmath
import itertools
import math

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------- quaternions
def qmul(a, b):
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


def dq_mul(a, b):
    """Dual quaternion product (p1 + eps q1)(p2 + eps q2) of 8-tuples."""
    a0, a1, a2, a3, a4, a5, a6, a7 = a
    b0, b1, b2, b3, b4, b5, b6, b7 = b
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
            a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
            a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
            (a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3),
            (a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2),
            (a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1),
            (a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0))


def dq_conj(h):
    return (h[0], -h[1], -h[2], -h[3], h[4], -h[5], -h[6], -h[7])


def dq_inv(h):
    """h~ / N(h), N(h) = a + eps b with 1/(a + eps b) = 1/a - eps b/a^2 (p must be nonzero)."""
    p0, p1, p2, p3, q0, q1, q2, q3 = h
    a = p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3
    b = 2.0 * (p0 * q0 + p1 * q1 + p2 * q2 + p3 * q3)
    ia = 1.0 / a
    f = b / (a * a)
    return (p0 * ia, -p1 * ia, -p2 * ia, -p3 * ia,
            q0 * ia - p0 * f, -q1 * ia + p1 * f, -q2 * ia + p2 * f, -q3 * ia + p3 * f)


def normalize_dq(h):
    """Scale to |p| = 1, p0 >= 0."""
    n = math.sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2] + h[3] * h[3])
    s = (-1.0 if h[0] < 0 else 1.0) / n
    return tuple(x * s for x in h)


def matrix_to_quat(R):
    """Unit quaternion (w >= 0) of a rotation matrix given as nested sequences; the same pivoting
    (Shepperd) and formulas as `synth.algebra.dq.matrix_to_quat`."""
    A, B, C = R[0], R[1], R[2]  # rows; entries beyond the third are ignored (4x4 rows allowed)
    r00, r01, r02 = A[0], A[1], A[2]
    r10, r11, r12 = B[0], B[1], B[2]
    r20, r21, r22 = C[0], C[1], C[2]
    tr = r00 + r11 + r22
    d = (tr, r00, r11, r22)
    k = d.index(max(d))
    if k == 0:
        s = 2 * math.sqrt(1 + tr)
        q = (s / 4, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s)
    elif k == 1:
        s = 2 * math.sqrt(1 + r00 - r11 - r22)
        q = ((r21 - r12) / s, s / 4, (r01 + r10) / s, (r02 + r20) / s)
    elif k == 2:
        s = 2 * math.sqrt(1 + r11 - r00 - r22)
        q = ((r02 - r20) / s, (r01 + r10) / s, s / 4, (r12 + r21) / s)
    else:
        s = 2 * math.sqrt(1 + r22 - r00 - r11)
        q = ((r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, s / 4)
    sg = -1.0 if q[0] < 0 else 1.0
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] * sg / n, q[1] * sg / n, q[2] * sg / n, q[3] * sg / n)


def pose_to_dq(R, d):
    """Unit dual quaternion r - (eps/2) d r of rotation R (3x3 nested) and translation d (3,)."""
    r = matrix_to_quat(R)
    q = qmul((0.0, d[0], d[1], d[2]), r)
    return r + (-0.5 * q[0], -0.5 * q[1], -0.5 * q[2], -0.5 * q[3])


# ----------------------------------------------------------------------------- 3-vectors
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def common_normal_feet(u1, m1, u2, m2):
    """Feet of the common normal of two lines (as `synth.algebra.dq.common_normal_feet`; for parallel lines the
    foot on line 1 is its point closest to the origin)."""
    p1, p2 = cross(u1, m1), cross(u2, m2)
    c = cross(u1, u2)
    s2 = dot(c, c)
    if s2 < 1e-24:
        k = dot((p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]), u2)
        return p1, (p2[0] + k * u2[0], p2[1] + k * u2[1], p2[2] + k * u2[2])
    d = (p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2])
    s1 = dot(cross(d, u2), c) / s2
    s2_ = dot(cross(d, u1), c) / s2
    return ((p1[0] + s1 * u1[0], p1[1] + s1 * u1[1], p1[2] + s1 * u1[2]),
            (p2[0] + s2_ * u2[0], p2[1] + s2_ * u2[1], p2[2] + s2_ * u2[2]))


def pair_geometry(u1, m1, u2, m2):
    """(distance, signed twist, foot on line 1, foot on line 2, unit common normal) of two lines; the
    twist is the angle from u1 to u2 about the common normal from line 1 to line 2."""
    f1, f2 = common_normal_feet(u1, m1, u2, m2)
    d = (f2[0] - f1[0], f2[1] - f1[1], f2[2] - f1[2])
    dist = norm(d)
    c = cross(u1, u2)
    if dist > 1e-12:
        n = (d[0] / dist, d[1] / dist, d[2] / dist)
    else:
        nc = norm(c)
        n = (c[0] / nc, c[1] / nc, c[2] / nc) if nc > 1e-12 else (0.0, 0.0, 0.0)
    twist = math.atan2(dot(c, n), dot(u1, u2))
    return dist, twist, f1, f2, n


# ----------------------------------------------------------------------------- polynomials
def _cubic_largest_real_root(b, c, d):
    """Largest real root of x^3 + b x^2 + c x + d (trigonometric / Cardano, then Newton)."""
    p = c - b * b / 3.0
    q = 2.0 * b * b * b / 27.0 - b * c / 3.0 + d
    disc = (q / 2.0) ** 2 + (p / 3.0) ** 3
    if disc < 0:  # three real roots
        r = math.sqrt(-p / 3.0)
        arg = max(-1.0, min(1.0, -q / (2.0 * r ** 3)))
        x = 2.0 * r * math.cos(math.acos(arg) / 3.0)
    else:
        s = math.sqrt(disc)
        u = -q / 2.0 + s
        v = -q / 2.0 - s
        x = math.copysign(abs(u) ** (1 / 3), u) + math.copysign(abs(v) ** (1 / 3), v)
    x -= b / 3.0
    for _ in range(3):
        f = ((x + b) * x + c) * x + d
        df = (3.0 * x + 2.0 * b) * x + c
        if df == 0:
            break
        dx = f / df
        x -= dx
        if abs(dx) <= 1e-16 * max(1.0, abs(x)):
            break
    return x


def quartic_roots(a0, a1, a2, a3):
    """The four complex roots of the monic quartic t^4 + a3 t^3 + a2 t^2 + a1 t + a0 (Ferrari, through
    the largest root of the resolvent cubic; unpolished). Returns a list of 4 complex numbers."""
    s = a3 / 4.0
    # depressed: y^4 + p y^2 + q y + r with t = y - s
    p = a2 - 6.0 * s * s
    q = a1 - 2.0 * a2 * s + 8.0 * s ** 3
    r = a0 - a1 * s + a2 * s * s - 3.0 * s ** 4
    # y^4 + p y^2 + q y + r = (y^2 + p/2 + m)^2 - 2m (y - q/(4m))^2 for a root m of the resolvent
    # 8 m^3 + 8 p m^2 + (2 p^2 - 8 r) m - q^2 = 0; the largest root is > 0 unless q = 0 and ...
    m = _cubic_largest_real_root(p, p * p / 4.0 - r, -q * q / 8.0)
    out = []
    if m > 0:
        w = math.sqrt(2.0 * m)
        k = q / (2.0 * w)
        for sgn in (1.0, -1.0):
            # y^2 + p/2 + m = sgn * w * (y - q/(4m))  ->  y^2 - sgn w y + (p/2 + m + sgn k) = 0
            B = -sgn * w
            Cq = p / 2.0 + m + sgn * k
            sq = cmath.sqrt(B * B / 4.0 - Cq)
            out += [-B / 2.0 + sq - s, -B / 2.0 - sq - s]
    else:  # biquadratic (q = 0): y^2 = (-p +- sqrt(p^2 - 4r)) / 2
        sq = cmath.sqrt(p * p / 4.0 - r)
        for y2 in (-p / 2.0 + sq, -p / 2.0 - sq):
            y = cmath.sqrt(y2)
            out += [y - s, -y - s]
    return out


def polish_root(c, z, iterations=3):
    """Newton steps on the real polynomial with ascending coefficients c at the complex point z (as
    `synth.algebra.factorize._polish_roots`)."""
    lead, rest = c[-1], c[-2::-1]  # rest: c[n-1], ..., c[0]
    for _ in range(iterations):
        f = lead
        df = 0.0
        for ck in rest:
            df = df * z + f
            f = f * z + ck
        if df == 0:
            break
        z = z - f / df
    return z


# ----------------------------------------------------------------------------- Bennett (MATH.md 6-7)
# The fast path gives up (returns None) well before the general path would refuse or refine, so that
# every refusal, warning and refinement stays with the general code (synth.synthesis.bennett._bennett_general).
FAST_MIN_B = 1e-6  # |B_ij| (conditioned) at or below this: degenerate or nearly so -> general path
FAST_MIN_IMAG = 1e-5  # Im z <= tol * max(1, |z|): nearly real norm root -> general path
FAST_MIN_SEPARATION = 1e-5  # |z1 - z2| <= tol * max(1, |z|): nearly repeated norm root -> general path
FAST_MAX_RESIDUAL = 5e-13  # multiply-back error above this: the general path refines (= factor.REFINE_TRIGGER)


def bennett_core(T):
    """The numeric core of `synth.synthesis.bennett.bennett` for one (3, 4, 4) pose array, in plain floats.

    Returns None when the input is not clearly generic (non-finite numbers, a Study form |B| <=
    FAST_MIN_B, nearly real or nearly repeated norm roots, a large multiply-back error, a translation
    factor). Otherwise a dict with (world frame, metres) ``H`` = (h1, h2), ``K`` = (k1, k2) factors
    (8-tuples), ``C`` (3 rows, ascending), conditioned-frame ``B`` = (B01, B02, B12), ``centre``,
    ``scale`` and ``residual`` (largest multiply-back error of the two factorizations, conditioned)."""
    if not math.isfinite(float(T.sum())):
        return None
    (R0, R1, R2) = rows = T.tolist()
    x0, y0, z0 = R0[0][3], R0[1][3], R0[2][3]
    x1, y1, z1 = R1[0][3], R1[1][3], R1[2][3]
    x2, y2, z2 = R2[0][3], R2[1][3], R2[2][3]
    c = (cx, cy, cz) = ((x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, (z0 + z1 + z2) / 3.0)
    L = math.sqrt(((x0 - cx) ** 2 + (y0 - cy) ** 2 + (z0 - cz) ** 2 + (x1 - cx) ** 2 + (y1 - cy) ** 2
                   + (z1 - cz) ** 2 + (x2 - cx) ** 2 + (y2 - cy) ** 2 + (z2 - cz) ** 2) / 3.0)
    if not L > 0:
        L = 1.0
    H = [pose_to_dq((r[0], r[1], r[2]), ((r[0][3] - cx) / L, (r[1][3] - cy) / L, (r[2][3] - cz) / L))
         for r in rows]
    H0c = dq_conj(H[0])
    D1 = normalize_dq(dq_mul(H[1], H0c))
    D2 = normalize_dq(dq_mul(H[2], H0c))
    B01 = D1[4] / 2
    B02 = D2[4] / 2
    B12 = 0.5 * ((D1[0] * D2[4] + D1[1] * D2[5] + D1[2] * D2[6] + D1[3] * D2[7])
                 + (D2[0] * D1[4] + D2[1] * D1[5] + D2[2] * D1[6] + D2[3] * D1[7]))
    if min(abs(B01), abs(B02), abs(B12)) <= FAST_MIN_B:
        return None
    mu1 = -B02 / B12
    mu2 = B01 / B12
    c1 = [mu1 * x + mu2 * y for x, y in zip(D1, D2)]
    c1[0] += -1.0
    c1 = tuple(c1)
    c0 = tuple([-mu1 * x for x in D1])
    # norm polynomial N = |P(t)|^2 (P2 = 1)
    a0, a1, a2, a3 = c0[:4]
    b0, b1, b2, b3 = c1[:4]
    n0 = a0 * a0 + a1 * a1 + a2 * a2 + a3 * a3
    n1 = 2.0 * (a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3)
    nb = b0 * b0 + b1 * b1 + b2 * b2 + b3 * b3
    n2 = 2.0 * a0 + nb
    n3 = 2.0 * b0
    N = (n0, n1, n2, n3, 1.0)
    up = [z for z in quartic_roots(n0, n1, n2, n3) if z.imag > 0]
    if len(up) != 2:
        return None
    z = sorted((polish_root(N, up[0]), polish_root(N, up[1])), key=lambda w: (w.real, w.imag))
    za, zb = z
    if not (za.imag > FAST_MIN_IMAG * max(1.0, abs(za)) and zb.imag > FAST_MIN_IMAG * max(1.0, abs(zb))
            and abs(za - zb) > FAST_MIN_SEPARATION * max(1.0, abs(za), abs(zb))):
        return None
    quads = ((za.real * za.real + za.imag * za.imag, -2.0 * za.real),
             (zb.real * zb.real + zb.imag * zb.imag, -2.0 * zb.real))
    prim_scale = max(math.sqrt(n0), math.sqrt(nb), 1.0)
    cmax = max(1.0, max(map(abs, c0)), max(map(abs, c1)))
    facts = []
    for right in (1, 0):  # branch h: h2 from the larger-real-part quadratic; branch k: k2 from the other
        m0, m1 = quads[right]
        r1 = (c1[0] - m1,) + c1[1:]
        r0 = (c0[0] - m0,) + c0[1:]
        if not math.sqrt(r1[0] ** 2 + r1[1] ** 2 + r1[2] ** 2 + r1[3] ** 2) > 1e-9 * prim_scale:
            return None
        g = dq_mul(dq_inv(r1), r0)
        h2 = (-g[0], -g[1], -g[2], -g[3], -g[4], -g[5], -g[6], -g[7])
        h1 = tuple([-(a + b) for a, b in zip(c1, h2)])
        # multiply back: (t - h1)(t - h2) = t^2 - (h1 + h2) t + h1 h2
        p0 = dq_mul(h1, h2)
        res = max(max(map(abs, map(float.__sub__, p0, c0))),
                  max([abs((-a - b) - e) for a, b, e in zip(h1, h2, c1)])) / cmax
        if not res <= FAST_MAX_RESIDUAL:
            return None
        if (math.sqrt(h1[1] ** 2 + h1[2] ** 2 + h1[3] ** 2) <= 1e-7 * (1 + abs(h1[0]))
                or math.sqrt(h2[1] ** 2 + h2[2] ** 2 + h2[3] ** 2) <= 1e-7 * (1 + abs(h2[0]))):
            return None
        facts.append((h1, h2, res))
    (h1, h2, rh), (k1, k2, rk) = facts

    def world(h):
        p1, p2, p3 = h[1], h[2], h[3]
        return (h[0], p1, p2, p3, h[4] * L,
                h[5] * L + (p2 * cz - p3 * cy),
                h[6] * L + (p3 * cx - p1 * cz),
                h[7] * L + (p1 * cy - p2 * cx))

    return {"H": (world(h1), world(h2)), "K": (world(k1), world(k2)),
            "C": (world(c0), world(c1), (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)), "B": (B01, B02, B12),
            "centre": c, "scale": L, "residual": max(rh, rk), "norm": N, "roots": (za, zb)}


# ----------------------------------------------------------------------------- checks
def dq_translation(h):
    """Translation d = 2 vec(p q~) / |p|^2 of a dual quaternion (Study condition assumed)."""
    p0, p1, p2, p3, q0, q1, q2, q3 = h
    n = 2.0 / (p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3)
    # vec(p q~) with q~ = (q0, -q1, -q2, -q3)
    return ((-p0 * q1 + p1 * q0 - p2 * q3 + p3 * q2) * n,
            (-p0 * q2 + p1 * q3 + p2 * q0 - p3 * q1) * n,
            (-p0 * q3 - p1 * q2 + p2 * q1 + p3 * q0) * n)


def dq_pose_difference(A, B):
    """(translation error, rotation angle in [0, pi]) between the poses of two dual quaternions."""
    dA, dB = dq_translation(A), dq_translation(B)
    dt = math.sqrt((dA[0] - dB[0]) ** 2 + (dA[1] - dB[1]) ** 2 + (dA[2] - dB[2]) ** 2)
    E = qmul((A[0], -A[1], -A[2], -A[3]), B[:4])
    dr = 2.0 * math.atan2(math.sqrt(E[1] * E[1] + E[2] * E[2] + E[3] * E[3]), abs(E[0]))
    return dt, dr


def rotation_dq(u, m, c, s):
    """cos(theta/2) + sin(theta/2) (u - eps m): rotation by theta about the line (u, m)."""
    return (c, s * u[0], s * u[1], s * u[2], 0.0, -s * m[0], -s * m[1], -s * m[2])


# ----------------------------------------------------------------------------- Algorithm 1 (MATH.md 4)
FAST_STUDY_TOL = 1e-9  # as synth.algebra.factorize.check_motion_polynomial
FAST_REAL_FACTOR_TOL = 1e-6  # |P(z)| <= tol * ref at a norm root: real factor (as synth.algebra.factorize.real_factor_roots)
FAST_MIN_REMAINDER = 1e-9  # |primal r1| <= tol * max |primal C_k|: not generic (as synth.algebra.factorize.GENERIC_TOL)
_ONE = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def _poly_norm_and_study(rows):
    """(N ascending, Study residual) of a dual-quaternion polynomial: N_k = sum_{i+j=k} P_i.P_j and the
    dual scalar part of C C~, sum_{i+j=k} (P_i.Q_j + Q_i.P_j), relative to the largest coefficient (the
    vector parts of C C~ vanish identically)."""
    n1 = len(rows)
    N = [0.0] * (2 * n1 - 1)
    S = [0.0] * (2 * n1 - 1)
    for i, a in enumerate(rows):
        a0, a1, a2, a3, a4, a5, a6, a7 = a
        for j in range(i, n1):  # (i, j) and (j, i) contribute alike
            b0, b1, b2, b3, b4, b5, b6, b7 = rows[j]
            f = 1.0 if i == j else 2.0
            N[i + j] += f * (a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3)
            S[i + j] += f * ((a0 * b4 + a1 * b5 + a2 * b6 + a3 * b7) + (a4 * b0 + a5 * b1 + a6 * b2 + a7 * b3))
    scale = max(max(map(abs, N)), max(map(abs, S)))
    return N, (max(map(abs, S)) / scale if scale > 0 else 0.0)


def _dq_neg(h):
    return (-h[0], -h[1], -h[2], -h[3], -h[4], -h[5], -h[6], -h[7])


_SUBDIAGONAL = {}  # 2n -> companion matrix template (ones below the diagonal)


def _eigvals_function():
    """numpy's LAPACK eigenvalue kernel without the checks of `numpy.linalg.eigvals` (a third of its
    cost for a 6x6 matrix; our matrix is finite and real); that function itself if the kernel moved."""
    import numpy as np

    try:
        from numpy.linalg import _umath_linalg

        kernel = _umath_linalg.eigvals
        kernel(np.eye(2), signature="d->D")
    except Exception:  # pragma: no cover - other numpy layouts
        return np.linalg.eigvals

    def eigvals(a):
        with np.errstate(all="ignore"):  # no convergence: NaN, then the general path decides
            return kernel(a, signature="d->D")

    return eigvals


_EIGVALS = None  # eigenvalue function, chosen on first use


def _companion_eigenvalues(N):
    """Roots of the real polynomial N (ascending, N[-1] > 0) as the eigenvalues of its companion matrix
    (LAPACK through numpy; the only numpy call of the fast path)."""
    global _EIGVALS
    m = len(N) - 1
    base = _SUBDIAGONAL.get(m)
    if base is None:
        import numpy as np

        base = _SUBDIAGONAL[m] = np.eye(m, k=-1)
    if _EIGVALS is None:
        _EIGVALS = _eigvals_function()
    comp = base.copy()
    lead = N[-1]
    comp[0] = [-x / lead for x in N[-2::-1]]
    return _EIGVALS(comp).tolist()


def norm_upper_roots(N):
    """The n roots with Im z > 0 of a real polynomial N of degree 2n <= 6 (ascending, N[-1] > 0): closed
    form for n <= 2 (Ferrari), companion eigenvalues for n = 3; each polished by 3 Newton steps on N
    (as `synth.algebra.factorize.norm_quadratics`) and sorted by (Re z, Im z). None unless there are exactly n."""
    n = (len(N) - 1) // 2
    lead = N[-1]
    if n == 1:
        a, b = N[1] / lead, N[0] / lead
        up = [complex(-a / 2, math.sqrt(b - a * a / 4))] if b - a * a / 4 > 0 else []
    elif n == 2:
        up = [z for z in quartic_roots(*(x / lead for x in N[:4])) if z.imag > 0]
    else:
        up = [z for z in _companion_eigenvalues(N) if z.imag > 0]
    if len(up) != n:
        return None
    return sorted((polish_root(N, w) for w in up), key=lambda w: (w.real, w.imag))


def _clearly_separated(z):
    """Every root clearly non-real (FAST_MIN_IMAG) and every two clearly apart (FAST_MIN_SEPARATION)."""
    for i, w in enumerate(z):
        if not w.imag > FAST_MIN_IMAG * max(1.0, abs(w)):
            return False
        for v in z[:i]:
            if not abs(w - v) > FAST_MIN_SEPARATION * max(1.0, abs(w), abs(v)):
                return False
    return True


def remainder_mod_quadratic(rows, c0, c1):
    """(r1, r0) with C = Q (t^2 + c1 t + c0) + r1 t + r0 (rows ascending, 8 numbers each; the same steps
    as `synth.algebra.polynomial.divide_real_quadratic`, where a coefficient exactly 1 is not multiplied)."""
    R = list(rows)
    for k in range(len(R) - 1, 1, -1):
        top = R[k]
        if top == _ONE:
            a, b = R[k - 1], R[k - 2]
            R[k - 1] = (a[0] - c1,) + tuple(a[1:])
            R[k - 2] = (b[0] - c0,) + tuple(b[1:])
        else:
            R[k - 1] = [x - c1 * y for x, y in zip(R[k - 1], top)]
            R[k - 2] = [x - c0 * y for x, y in zip(R[k - 2], top)]
    return R[1], R[0]


def _outer_factors(rows, z, prim, pscale, left):
    """For the norm root z (quadratic M = t^2 - 2 Re z t + |z|^2): the rightmost factor h with
    C = C' (t - h), and when ``left`` the leftmost k with C = (t - k) C'', both from the remainder
    r1 t + r0 of C mod M: h = -r1^-1 r0, and k = conj of the rightmost factor of conj(C), whose
    remainder is conj(r1) t + conj(r0). None when C is not clearly generic at z: the primal part of r1
    is (nearly) zero, or P(z) = primal(r1) z + primal(r0) (nearly) vanishes, i.e. the primal part has
    the real factor M (as `synth.algebra.factorize.real_factor_roots`)."""
    x, y = z.real, z.imag
    r1, r0 = remainder_mod_quadratic(rows, x * x + y * y, -2.0 * x)
    p0, p1, p2, p3 = r1[:4]
    if not math.sqrt(p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3) > FAST_MIN_REMAINDER * prim:
        return None
    az = abs(z)
    ref = 1.0  # sum of |z|^k, k = 0..n
    for _ in range(len(rows) - 1):
        ref = ref * az + 1.0
    u0, u1, u2, u3 = p0 * x + r0[0], p1 * x + r0[1], p2 * x + r0[2], p3 * x + r0[3]
    if (math.sqrt(u0 * u0 + u1 * u1 + u2 * u2 + u3 * u3 + (p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3) * (y * y))
            <= FAST_REAL_FACTOR_TOL * pscale * ref):
        return None
    inv = dq_inv(r1)
    if left:
        return _outer_pair(inv, r0)
    return _dq_neg(dq_mul(inv, r0)), None


def _outer_pair(a, b):
    """(-(a b), -conj(conj(a) conj(b))) of 8-tuples: for a = r1^-1, b = r0 the right factor h = -r1^-1 r0 and
    the left factor k (the rightmost factor of conj(C), conjugated), with the formulas of `dq_mul` (bitwise
    equal to composing dq_mul, dq_conj and negation)."""
    a0, a1, a2, a3, a4, a5, a6, a7 = a
    b0, b1, b2, b3, b4, b5, b6, b7 = b
    na1, na2, na3, na5, na6, na7 = -a1, -a2, -a3, -a5, -a6, -a7
    nb1, nb2, nb3, nb5, nb6, nb7 = -b1, -b2, -b3, -b5, -b6, -b7
    h = (-(a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3),
         -(a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2),
         -(a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1),
         -(a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0),
         -((a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3)),
         -((a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2)),
         -((a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1)),
         -((a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0)))
    k = (-(a0 * b0 - na1 * nb1 - na2 * nb2 - na3 * nb3),
         a0 * nb1 + na1 * b0 + na2 * nb3 - na3 * nb2,
         a0 * nb2 - na1 * nb3 + na2 * b0 + na3 * nb1,
         a0 * nb3 + na1 * nb2 - na2 * nb1 + na3 * b0,
         -((a0 * b4 - na1 * nb5 - na2 * nb6 - na3 * nb7) + (a4 * b0 - na5 * nb1 - na6 * nb2 - na7 * nb3)),
         (a0 * nb5 + na1 * b4 + na2 * nb7 - na3 * nb6) + (a4 * nb1 + na5 * b0 + na6 * nb3 - na7 * nb2),
         (a0 * nb6 - na1 * nb7 + na2 * b4 + na3 * nb5) + (a4 * nb2 - na5 * nb3 + na6 * b0 + na7 * nb1),
         (a0 * nb7 + na1 * nb6 - na2 * nb5 + na3 * b4) + (a4 * nb3 + na5 * nb2 - na6 * nb1 + na7 * b0))
    return h, k


def _dq_mul_add_error(a, b, c, d):
    """max_k |(a b + c - d)_k| for 8-tuples, the product with the formulas of `dq_mul` (bitwise equal)."""
    a0, a1, a2, a3, a4, a5, a6, a7 = a
    b0, b1, b2, b3, b4, b5, b6, b7 = b
    c0, c1, c2, c3, c4, c5, c6, c7 = c
    d0, d1, d2, d3, d4, d5, d6, d7 = d
    return max(abs((a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3) + c0 - d0),
               abs((a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2) + c1 - d1),
               abs((a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1) + c2 - d2),
               abs((a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0) + c3 - d3),
               abs(((a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3)) + c4 - d4),
               abs(((a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2)) + c5 - d5),
               abs(((a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1)) + c6 - d6),
               abs(((a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0)) + c7 - d7))


_ZERO = (0.0,) * 8


def _multiply_back_error(H, rows):
    """max |(t - h_1)...(t - h_n) - C| over all coefficients, for n <= 3 and monic C (rows ascending);
    the same floating-point steps as `synth.algebra.polynomial.product_of_linear`, with the signs folded in (exact)."""
    if len(H) == 1:
        return max([abs(a + c) for a, c in zip(H[0], rows[0])])
    h1, h2 = H[0], H[1]
    if len(H) == 2:  # (t - h1)(t - h2) = t^2 - (h1 + h2) t + h1 h2
        return max(_dq_mul_add_error(h1, h2, _ZERO, rows[0]),
                   max([abs((a + b) + c) for a, b, c in zip(h1, h2, rows[1])]))
    h3 = H[2]  # (t^2 - s t + A)(t - h3) = t^3 - (s + h3) t^2 + (A + s h3) t - A h3
    A = dq_mul(h1, h2)
    s = [a + b for a, b in zip(h1, h2)]
    return max(_dq_mul_add_error(A, h3, rows[0], _ZERO),
               _dq_mul_add_error(s, h3, A, rows[1]),
               max([abs((a + b) + c) for a, b, c in zip(s, h3, rows[2])]))


def _cubic_order(h1, h3, c0, c1, c2):
    """For a monic cubic C = c0 + c1 t + c2 t^2 + t^3 with outer factors h1, h3: the middle factor
    h2 = -(c2 + h1 + h3) and max |(t - h1)(t - h2)(t - h3) - C|; `_multiply_back_error` unrolled (the same
    floating-point steps: A = h1 h2, s = h1 + h2, rows A h3 + c0, (A + s h3) - c1, (s + h3) + c2).
    The error is inf unless every number is finite."""
    a0, a1, a2, a3, a4, a5, a6, a7 = h1
    d0, d1, d2, d3, d4, d5, d6, d7 = h3
    h2 = (-((c2[0] + a0) + d0), -((c2[1] + a1) + d1), -((c2[2] + a2) + d2), -((c2[3] + a3) + d3),
          -((c2[4] + a4) + d4), -((c2[5] + a5) + d5), -((c2[6] + a6) + d6), -((c2[7] + a7) + d7))
    b0, b1, b2, b3, b4, b5, b6, b7 = h2
    A0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
    A1 = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
    A2 = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
    A3 = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
    A4 = (a0 * b4 - a1 * b5 - a2 * b6 - a3 * b7) + (a4 * b0 - a5 * b1 - a6 * b2 - a7 * b3)
    A5 = (a0 * b5 + a1 * b4 + a2 * b7 - a3 * b6) + (a4 * b1 + a5 * b0 + a6 * b3 - a7 * b2)
    A6 = (a0 * b6 - a1 * b7 + a2 * b4 + a3 * b5) + (a4 * b2 - a5 * b3 + a6 * b0 + a7 * b1)
    A7 = (a0 * b7 + a1 * b6 - a2 * b5 + a3 * b4) + (a4 * b3 + a5 * b2 - a6 * b1 + a7 * b0)
    s0, s1, s2, s3, s4, s5, s6, s7 = a0 + b0, a1 + b1, a2 + b2, a3 + b3, a4 + b4, a5 + b5, a6 + b6, a7 + b7
    e = (
        (A0 * d0 - A1 * d1 - A2 * d2 - A3 * d3) + c0[0],
        (A0 * d1 + A1 * d0 + A2 * d3 - A3 * d2) + c0[1],
        (A0 * d2 - A1 * d3 + A2 * d0 + A3 * d1) + c0[2],
        (A0 * d3 + A1 * d2 - A2 * d1 + A3 * d0) + c0[3],
        ((A0 * d4 - A1 * d5 - A2 * d6 - A3 * d7) + (A4 * d0 - A5 * d1 - A6 * d2 - A7 * d3)) + c0[4],
        ((A0 * d5 + A1 * d4 + A2 * d7 - A3 * d6) + (A4 * d1 + A5 * d0 + A6 * d3 - A7 * d2)) + c0[5],
        ((A0 * d6 - A1 * d7 + A2 * d4 + A3 * d5) + (A4 * d2 - A5 * d3 + A6 * d0 + A7 * d1)) + c0[6],
        ((A0 * d7 + A1 * d6 - A2 * d5 + A3 * d4) + (A4 * d3 + A5 * d2 - A6 * d1 + A7 * d0)) + c0[7],
        ((s0 * d0 - s1 * d1 - s2 * d2 - s3 * d3) + A0) - c1[0],
        ((s0 * d1 + s1 * d0 + s2 * d3 - s3 * d2) + A1) - c1[1],
        ((s0 * d2 - s1 * d3 + s2 * d0 + s3 * d1) + A2) - c1[2],
        ((s0 * d3 + s1 * d2 - s2 * d1 + s3 * d0) + A3) - c1[3],
        (((s0 * d4 - s1 * d5 - s2 * d6 - s3 * d7) + (s4 * d0 - s5 * d1 - s6 * d2 - s7 * d3)) + A4) - c1[4],
        (((s0 * d5 + s1 * d4 + s2 * d7 - s3 * d6) + (s4 * d1 + s5 * d0 + s6 * d3 - s7 * d2)) + A5) - c1[5],
        (((s0 * d6 - s1 * d7 + s2 * d4 + s3 * d5) + (s4 * d2 - s5 * d3 + s6 * d0 + s7 * d1)) + A6) - c1[6],
        (((s0 * d7 + s1 * d6 - s2 * d5 + s3 * d4) + (s4 * d3 + s5 * d2 - s6 * d1 + s7 * d0)) + A7) - c1[7],
        (s0 + d0) + c2[0],
        (s1 + d1) + c2[1],
        (s2 + d2) + c2[2],
        (s3 + d3) + c2[3],
        (s4 + d4) + c2[4],
        (s5 + d5) + c2[5],
        (s6 + d6) + c2[6],
        (s7 + d7) + c2[7],
    )
    err = max(max(e), -min(e))
    return h2, (err if math.isfinite(sum(e)) else math.inf)


def factorize_generic(C, validate=True):
    """All factorizations of a monic motion polynomial C ((n+1, 8) ndarray, degree n <= 3) in plain
    floats, for *generic* input only: returns None unless C is valid (when ``validate``), the roots of N(C) are
    non-real and well separated (FAST_MIN_IMAG, FAST_MIN_SEPARATION), the primal part has no real factor,
    every Algorithm-1 step is generic with an exact division, and every factorization multiplies back
    to within FAST_MAX_RESIDUAL. `synth.algebra.factorize.factorize` then handles everything else (validation
    errors, repeated or real roots, refinement). Otherwise returns (N, roots (sorted by real, imag part),
    quadratics, orders, factor lists, residuals) with the same conventions and results as the general code."""
    rows = [tuple(r) for r in C.tolist()]
    n = len(rows) - 1
    if not 1 <= n <= 3 or len(rows[0]) != 8:
        return None
    if rows[-1] != _ONE:  # the shortcuts below need an exactly monic C (so it is valid as to that)
        return None
    flat = [x for r in rows for x in r]
    if not math.isfinite(sum(flat)):
        return None
    N, study = _poly_norm_and_study(rows)
    if validate and not study <= FAST_STUDY_TOL:
        return None
    z = norm_upper_roots(N)
    if z is None or not _clearly_separated(z):
        return None
    quads = [(w.real * w.real + w.imag * w.imag, -2.0 * w.real) for w in z]
    prim = max([math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]) for r in rows])
    pscale = max([abs(x) for r in rows for x in r[:4]])
    # the rightmost factor depends only on its norm quadratic, and so does the leftmost one; the middle
    # one of a cubic follows from the t^2 coefficient, c2 = -(h1 + h2 + h3). Every factorization is
    # multiplied back below.
    outer = [_outer_factors(rows, w, prim, pscale, n == 3) for w in z]
    if None in outer:
        return None
    right = [o[0] for o in outer]
    cmax = max(1.0, max(map(abs, flat)))
    c_top = rows[n - 1]
    orders = _PERMUTATIONS[n]
    factors, residuals = [], []
    for order in orders:
        hn = right[order[-1]]
        if n == 1:
            H = [hn]
            res = _multiply_back_error(H, rows) / cmax
        elif n == 2:
            H = [tuple([-(a + b) for a, b in zip(c_top, hn)]), hn]
            res = _multiply_back_error(H, rows) / cmax
        else:
            h1 = outer[order[0]][1]
            h2, err = _cubic_order(h1, hn, rows[0], rows[1], c_top)
            H = [h1, h2, hn]
            res = err / cmax
        if not res <= FAST_MAX_RESIDUAL:
            return None
        factors.append(H)
        residuals.append(res)
    return N, z, quads, orders, factors, residuals


_PERMUTATIONS = {n: list(itertools.permutations(range(n))) for n in (1, 2, 3)}
