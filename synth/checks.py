"""Self-checks of a linkage: pose reproduction at the reported angles and loop closure over the whole
motion (MATH.md section 12). Errors are translation (metres) and rotation angle (radians).

Forward kinematics is evaluated with unit dual quaternions (a joint at angle theta about the line
(u, m) is ``cos(theta/2) + sin(theta/2) (u - eps m)``), vectorized over all poses and samples at once:
one batched product per joint, whatever the number of samples.
"""
from __future__ import annotations

import math

import numpy as np

from synth.linkage import Linkage


DEFAULT_CHECK_SAMPLES = 4  # synthesis functions check closure and motion at this many parameters
VERIFY_SAMPLES = 200  # the CLI verifies this many before writing anything

def rotation_angle(R):
    """Rotation angle (rad) of rotation matrices (..., 3, 3), accurate for small and large angles."""
    R = np.asarray(R, float)
    s = 0.5 * np.linalg.norm(np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                                       R[..., 1, 0] - R[..., 0, 1]], -1), axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1)
    return np.arctan2(s, c)


def pose_difference(A, B):
    """(translation error, rotation angle) between poses (..., 4, 4)."""
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    dt = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    dr = rotation_angle(np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3])
    return dt, dr


def dq_pose_difference(A, B):
    """(translation error, rotation angle) between the poses of dual quaternions A, B (..., 8) (Study
    condition assumed, any nonzero scale): |d_A - d_B| with d = 2 vec(p q~)/|p|^2, and the angle of
    p_A~ p_B, 2 atan2(|vec|, |scalar|) in [0, pi]."""
    from synth.algebra.dq import qconj, qmul

    A = np.asarray(A, float)
    B = np.asarray(B, float)
    P = np.stack([A[..., :4], B[..., :4]])
    Q = np.stack([A[..., 4:], B[..., 4:]])
    n = np.einsum("...i,...i->...", P, P)
    d = qmul(P, qconj(Q))[..., 1:] * (2.0 / n)[..., None]
    dd = d[0] - d[1]
    dt = np.sqrt(np.einsum("...i,...i->...", dd, dd))
    E = qmul(qconj(P[0]), P[1])
    dr = 2.0 * np.arctan2(np.sqrt(np.einsum("...i,...i->...", E[..., 1:], E[..., 1:])), np.abs(E[..., 0]))
    return dt, dr


def sample_parameters(linkage: Linkage, samples: int = 200) -> np.ndarray:
    """Parameters t covering the real line (t = centre + scale tan(phi)) plus t = infinity."""
    a = [j.a for j in linkage.joints]
    b = [j.b for j in linkage.joints]
    centre, scale = sum(a) / len(a), max(sum(b) / len(b), 1e-12)
    phi = np.linspace(-np.pi / 2, np.pi / 2, samples + 1)[1:]
    t = centre + scale * np.tan(phi[:-1])
    return np.concatenate([t, [np.inf]])


def _pose_dq(T):
    from synth.algebra.scalar import pose_to_dq

    T = np.asarray(T, float).tolist()
    return pose_to_dq([r[:3] for r in T[:3]], [T[0][3], T[1][3], T[2][3]])


def link_displacements(linkage: Linkage, angles) -> dict[str, np.ndarray]:
    """Unit dual quaternions (..., 8) of every link's world displacement from the reference
    configuration for joint angles ``angles`` (J, ...) in the order of ``linkage.joints``."""
    from synth.algebra.dq import dq_mul

    th = 0.5 * np.asarray(angles, float)
    U = np.array([j.direction for j in linkage.joints], float)
    M = np.array([j.moment for j in linkage.joints], float)
    ex = (slice(None),) + (None,) * (th.ndim - 1)
    s = np.sin(th)[..., None]
    G = np.empty(th.shape + (8,))
    G[..., 0] = np.cos(th)
    G[..., 1:4] = s * U[ex]
    G[..., 4] = 0.0
    G[..., 5:8] = -s * M[ex]
    one = np.zeros(8)
    one[0] = 1.0
    out: dict[str, np.ndarray] = {"base": np.broadcast_to(one, th.shape[1:] + (8,))}
    for i, j in enumerate(linkage.joints):
        out[j.child] = G[i] if j.parent == "base" else dq_mul(out[j.parent], G[i])
    return out


def _evaluate(linkage: Linkage, samples: int):
    """All check figures from one forward-kinematics pass over the poses' reported angles and the
    sampled parameters."""
    from synth.algebra.dq import dq_mul
    from synth.algebra.polynomial import evaluate

    joints = linkage.joints
    P = len(linkage.poses)
    t = sample_parameters(linkage, samples)
    a = np.array([j.a for j in joints])[:, None]
    b = np.array([j.b for j in joints])[:, None]
    th_s = 2.0 * np.arctan2(b, t[None, :] - a)  # 0 at t = inf
    th_p = np.array([[rec.joint_angles[j.name] for rec in linkage.poses] for j in joints], float).reshape(len(joints), P)
    disp = link_displacements(linkage, np.concatenate([th_p, th_s], axis=1))
    tool = disp[linkage.tool_link]
    # stack every comparison: poses (tool frame), closures (samples), motion polynomial (samples)
    lhs, rhs = [], []
    if P:
        lhs.append(dq_mul(tool[:P], np.array(_pose_dq(linkage.tool_ref))))
        rhs.append(np.array([_pose_dq(rec.matrix) for rec in linkage.poses]))
    for x, y in linkage.closures:
        lhs.append(disp[x][P:])
        rhs.append(disp[y][P:])
    lhs.append(tool[P:])
    rhs.append(evaluate(linkage.motion, t))
    dt, dr = dq_pose_difference(np.concatenate(lhs), np.concatenate(rhs))
    S, nc = len(t), len(linkage.closures)
    pose = (float(dt[:P].max(initial=0.0)), float(dr[:P].max(initial=0.0)))
    clo = (float(dt[P:P + nc * S].max(initial=0.0)), float(dr[P:P + nc * S].max(initial=0.0)))
    motion = float(np.max(dt[P + nc * S:] + dr[P + nc * S:], initial=0.0))
    return pose, clo, motion


def pose_errors(linkage: Linkage) -> tuple[float, float]:
    """Largest (translation, rotation) error of the tool frame at every pose's joint angles."""
    return _evaluate(linkage, 2)[0]


def closure_errors(linkage: Linkage, samples: int = 200) -> tuple[float, float]:
    """Largest (translation, rotation) mismatch of every welded pair over the sampled motion."""
    return _evaluate(linkage, samples)[1]


def motion_error(linkage: Linkage, samples: int = 200) -> float:
    """Largest deviation (translation + rotation, over the sample) of the tool link's displacement from
    the motion polynomial C(t)."""
    return _evaluate(linkage, samples)[2]


def extent(linkage: Linkage) -> float:
    """`Linkage.extent` in plain floats (no numpy call per joint): RMS distance of the joint sites
    (`Linkage.joint_sites`: mean of the common-normal feet along the links carrying the joint, else the
    axis point nearest the poses' centre) and the tool positions from their centroid, at least 1e-9.
    tests/test_fastpaths.py checks that both agree."""
    from synth.algebra.scalar import common_normal_feet, cross, dot

    lines = {j.name: (j.direction.tolist(), j.moment.tolist()) for j in linkage.joints}
    acc = {name: [0.0, 0.0, 0.0, 0] for name in lines}  # sum of feet, count
    for names in linkage.links.values():
        js = [n for n in names if n in lines]
        for n1, n2 in zip(js, js[1:]):
            (u1, m1), (u2, m2) = lines[n1], lines[n2]
            c = cross(u1, u2)
            if math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) < 1e-9:
                # parallel: the normal through the midpoint of the points nearest the origin (pair_feet)
                p1, p2 = cross(u1, m1), cross(u2, m2)
                k1 = ((p2[0] - p1[0]) * u1[0] + (p2[1] - p1[1]) * u1[1] + (p2[2] - p1[2]) * u1[2]) / 2
                f1 = (p1[0] + k1 * u1[0], p1[1] + k1 * u1[1], p1[2] + k1 * u1[2])
                k2 = dot((f1[0] - p2[0], f1[1] - p2[1], f1[2] - p2[2]), u2)
                f2 = (p2[0] + k2 * u2[0], p2[1] + k2 * u2[1], p2[2] + k2 * u2[2])
            else:
                f1, f2 = common_normal_feet(u1, m1, u2, m2)
            for name, f in ((n1, f1), (n2, f2)):
                a = acc[name]
                a[0] += f[0]
                a[1] += f[1]
                a[2] += f[2]
                a[3] += 1
    tools = [p.matrix[:3, 3].tolist() for p in linkage.poses] + [linkage.tool_ref[:3, 3].tolist()]
    nt = len(tools)
    cx = sum([p[0] for p in tools]) / nt
    cy = sum([p[1] for p in tools]) / nt
    cz = sum([p[2] for p in tools]) / nt
    pts = list(tools)
    for name, (u, m) in lines.items():
        a = acc[name]
        if a[3]:
            pts.append((a[0] / a[3], a[1] / a[3], a[2] / a[3]))
        else:  # the axis point nearest the poses' centre
            p = cross(u, m)
            k = (cx - p[0]) * u[0] + (cy - p[1]) * u[1] + (cz - p[2]) * u[2]
            pts.append((p[0] + k * u[0], p[1] + k * u[1], p[2] + k * u[2]))
    n = len(pts)
    mx = sum([p[0] for p in pts]) / n
    my = sum([p[1] for p in pts]) / n
    mz = sum([p[2] for p in pts]) / n
    ms = sum([(p[0] - mx) ** 2 + (p[1] - my) ** 2 + (p[2] - mz) ** 2 for p in pts]) / n
    return float(max(ms ** 0.5, 1e-9))


def self_check(linkage: Linkage, samples: int = 200) -> dict[str, float]:
    """All self-check figures (metres / radians) for linkage.json's ``checks``: pose errors at the
    reported angles of every pose, closure and motion errors at ``samples`` parameters covering R."""
    evaluate = _evaluate_small if samples <= SMALL_SAMPLES else _evaluate
    (pt, pr), (ct, cr), me = evaluate(linkage, samples)
    return {
        "max_pose_error": pt + pr,
        "max_pose_translation_error": pt,
        "max_pose_rotation_error": pr,
        "max_closure_error": ct + cr,
        "max_closure_translation_error": ct,
        "max_closure_rotation_error": cr,
        "max_motion_error": me,
        "length_scale": extent(linkage),
        "samples": samples,
    }


# ----------------------------------------------------------------------------- small samples
SMALL_SAMPLES = 32  # up to this many samples the checks run in plain floats (faster than numpy)


def _evaluate_small(linkage: Linkage, samples: int):
    """`_evaluate` in plain floats, for few samples: the same figures, no numpy call per joint."""
    import math

    from synth.algebra.scalar import dq_mul, dq_translation

    joints = linkage.joints
    U = [j.direction.tolist() for j in joints]
    M = [j.moment.tolist() for j in joints]
    slot = {"base": 0}  # link -> index into the displacement list
    for j in joints:
        slot.setdefault(j.child, len(slot))
    chain = [(slot[j.parent], slot[j.child], u, m) for j, u, m in zip(joints, U, M)]
    nlinks = len(slot)
    identity = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def fk(cs):
        disp = [identity] * nlinks
        for (p, ch, u, m), (c, s) in zip(chain, cs):
            G = (c, s * u[0], s * u[1], s * u[2], 0.0, -s * m[0], -s * m[1], -s * m[2])
            disp[ch] = G if p == 0 else dq_mul(disp[p], G)
        return disp

    def diff(A, dA, B):
        dB = dq_translation(B)
        dt = math.sqrt((dA[0] - dB[0]) ** 2 + (dA[1] - dB[1]) ** 2 + (dA[2] - dB[2]) ** 2)
        # angle of pA~ pB: scalar and vector part of the quaternion product
        a0, a1, a2, a3 = A[0], -A[1], -A[2], -A[3]
        b0, b1, b2, b3 = B[0], B[1], B[2], B[3]
        e0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
        e1 = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
        e2 = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
        e3 = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
        return dt, 2.0 * math.atan2(math.sqrt(e1 * e1 + e2 * e2 + e3 * e3), abs(e0))

    tool = slot[linkage.tool_link]
    closures = [(slot[x], slot[y]) for x, y in linkage.closures]
    pt = pr = 0.0
    if linkage.poses:
        Href = _pose_dq(linkage.tool_ref)
        names = [j.name for j in joints]
        for rec in linkage.poses:
            cs = []
            for name in names:
                h = 0.5 * rec.joint_angles[name]
                cs.append((math.cos(h), math.sin(h)))
            P = _pose_dq(rec.matrix)
            if P == Href and all(c == 1.0 and s == 0.0 for c, s in cs):
                continue  # every joint at rest and the pose is tool_ref: an error of exactly 0
            T = dq_mul(fk(cs)[tool], Href)
            dt, dr = diff(T, dq_translation(T), P)
            pt, pr = max(pt, dt), max(pr, dr)
    a = [j.a for j in joints]
    b = [j.b for j in joints]
    centre, scale = sum(a) / len(a), max(sum(b) / len(b), 1e-12)
    ts = [centre + scale * math.tan(-math.pi / 2 + math.pi * (k + 1) / samples) for k in range(samples - 1)]
    C = linkage.motion.tolist()
    ct = cr = me = 0.0
    laws = list(zip(a, b))
    # at t = inf every link is at rest (the identity): the closures agree exactly, and so does the motion
    # when C is exactly monic; only a non-monic C needs that sample
    for t in ts if C[-1] == [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0] else ts + [math.inf]:
        if t == math.inf:
            cs = [(1.0, 0.0)] * len(joints)
            Ct = C[-1]
        else:
            cs = []
            for aj, bj in laws:
                e = t - aj
                r = math.hypot(e, bj)
                cs.append((e / r, bj / r))
            Ct = C[-1]
            for row in C[-2::-1]:
                Ct = [x * t + y for x, y in zip(Ct, row)]
        disp = fk(cs)
        for x, y in closures:
            dt, dr = diff(disp[x], dq_translation(disp[x]), disp[y])
            ct, cr = max(ct, dt), max(cr, dr)
        dt, dr = diff(disp[tool], dq_translation(disp[tool]), Ct)
        me = max(me, dt + dr)
    return (pt, pr), (ct, cr), me
