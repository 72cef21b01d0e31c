"""Multi-loop linkages from one factorization and Bennett flips (docs/exceptional.md, sections 4-5).

Given C' = (t - h_1)...(t - h_N) and one more rotation t - m_0 with a *different* norm, flip N times,
(t - m_{i-1})(t - h_i) = (t - k_i)(t - m_i), so that

    (t - m_0)(t - h_1)...(t - h_N) = (t - k_1)...(t - k_N)(t - m_N).

The "ladder" link graph (links = vertices, joints = edges, "before -> after" in product order):

    A_0 (ground = ``base``): m_0, h_1        m_0: K_0 -> A_0      h_i: A_{i-1} -> A_i
    A_i: h_i, m_i, h_{i+1}                   k_i: K_{i-1} -> K_i  m_i: K_i -> A_i
    A_N (``coupler``, moves by C'): h_N, m_N
    K_0: m_0, k_1;  K_i: k_i, m_i, k_{i+1};  K_N: k_N, m_N

2N + 2 links, 3N + 1 joints, N loops (loop i = m_{i-1}, h_i, m_i, k_i, a Bennett 4R; planar: an
anti-parallelogram). Pose rule: pose(after) = pose(before) @ Rot(axis_j, theta_j(t)), all joints written
at the reference configuration (t = infinity, every angle 0).

URDF tree (docs/conventions.md): spanning tree from ``base`` = the chain of the h_i (base -> link_a1 -> ... ->
coupler) and the chain base -m_0-> link_k0 -k_1-> link_k1 ... -k_N-> link_kN. Every rung m_i
(i = 1..N) is cut: it carries a duplicate ``<A_i>_m<i>`` of A_i as child of K_i, welded to A_i
(``closures``, first the coupler's). A joint traversed against product order (m_0, from A_0 to K_0) gets
the reversed line (direction and moment negated); the angle law is unchanged.
"""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from synth.algebra.dq import factor_lines
from synth.algebra.geometry import line_point, perpendicular_basis, ring_normals
from synth.synthesis.assemble import joint_from_factor
from synth.errors import SynthesisError
from synth.algebra.flip import bennett_flip, flip_residual, is_exact
from synth.info import Ladder, LinkageInfo, Mobility, MultiLoop
from synth.linkage import Joint, Linkage


# ------------------------------------------------------------------ flips
def ladder_factors(hs, m0):
    """(ks, ms): ks[i-1] = k_i (i = 1..N), ms[i] = m_i (i = 0..N) with
    (t - m_{i-1})(t - h_i) = (t - k_i)(t - m_i). Exact when every input is exact (ints/Fractions)."""
    exact = is_exact(m0, *hs)
    m = [Fraction(x) for x in m0] if exact else np.asarray(m0, float)
    ks, ms = [], [m]
    for h in hs:
        h = [Fraction(x) for x in h] if exact else np.asarray(h, float)
        k, m = bennett_flip(m, h)
        ks.append(k)
        ms.append(m)
    return ks, ms


def norm_of(h) -> tuple[float, float]:
    """(a, b) of N(t - h) = (t - a)^2 + b^2."""
    h = np.asarray([float(x) for x in h])
    return float(h[0]), float(np.linalg.norm(h[1:4]))


# ------------------------------------------------------------------ linkage
def _reversed(j: Joint) -> Joint:
    return Joint(name=j.name, parent=j.parent, child=j.child, direction=-np.asarray(j.direction),
                 moment=-np.asarray(j.moment), a=j.a, b=j.b, rate=j.rate)


def ladder_linkage(hs, m0, *, kind: str = "motion", motion=None, coupler: str = "coupler",
                   tool_ref=None, info: MultiLoop | None = None) -> Linkage:
    """The ladder linkage of C' = prod (t - h_i) with the extra rotation t - m0 (section 7).

    ``hs`` (N, 8), ``m0`` (8,): floats, or Fractions for exact flips (the Linkage itself is float).
    ``motion``: the coupler's motion polynomial (default: prod (t - h_i)). Raises SynthesisError when a
    flip does not exist or m0 shares its norm with some h_i. ``info``: the multi-loop record (curve, motion)
    the ladder is added to (`synth.info.MultiLoop`)."""
    from synth.algebra.polynomial import product_of_linear

    N = len(hs)
    if N < 1:
        raise SynthesisError("a multi-loop linkage needs at least one factor")
    a0, b0 = norm_of(m0)
    for i, h in enumerate(hs):
        a, b = norm_of(h)
        if abs(a - a0) + abs(b - b0) <= 1e-9 * (1 + abs(a) + b):
            raise SynthesisError(f"m0 has the same norm as h{i + 1}: the flips would not give new joints")
    ks, ms = ladder_factors(hs, m0)
    Hf = np.array([[float(x) for x in h] for h in hs])
    Kf = np.array([[float(x) for x in k] for k in ks])
    Mf = np.array([[float(x) for x in m] for m in ms])

    A = ["base"] + [f"link_a{i}" for i in range(1, N)] + [coupler]
    K = [f"link_k{i}" for i in range(N + 1)]
    joints: list[Joint] = []
    for i in range(1, N + 1):  # the h chain
        joints.append(joint_from_factor(f"h{i}", A[i - 1], A[i], Hf[i - 1]))
    joints.append(_reversed(joint_from_factor("m0", "base", K[0], Mf[0])))  # A_0 -> K_0 against order
    for i in range(1, N + 1):  # the k chain
        joints.append(joint_from_factor(f"k{i}", K[i - 1], K[i], Kf[i - 1]))
    closures = []
    for i in range(N, 0, -1):  # rungs m_i: K_i -> duplicate of A_i
        dup = f"{A[i]}_m{i}"
        joints.append(joint_from_factor(f"m{i}", K[i], dup, Mf[i]))
        closures.append((A[i], dup))

    links = {"base": ["m0", "h1"]}
    for i in range(1, N):
        links[A[i]] = [f"h{i}", f"m{i}", f"h{i + 1}"]
    links[A[N]] = [f"h{N}", f"m{N}"]
    links[K[0]] = ["m0", "k1"]
    for i in range(1, N):
        links[K[i]] = [f"k{i}", f"m{i}", f"k{i + 1}"]
    links[K[N]] = [f"k{N}", f"m{N}"]
    for _, dup in closures:
        links[dup] = []

    C = product_of_linear(Hf) if motion is None else np.asarray(motion, float)
    flip_res = max(flip_residual(m, h, k, n) for m, h, k, n in zip(Mf[:-1], Hf, Kf, Mf[1:]))
    linkage = Linkage(
        kind=kind,
        joints=joints,
        links=links,
        branches=[[f"h{i}" for i in range(1, N + 1)], ["m0"] + [f"k{i}" for i in range(1, N + 1)] + [f"m{N}"]],
        closures=closures,
        tool_ref=np.eye(4) if tool_ref is None else np.asarray(tool_ref, float),
        motion=C,
        tool_link=coupler,
    )
    ladder = Ladder(N=N, loops=N, joints=3 * N + 1, links=2 * N + 2, h=Hf, k=Kf, m=Mf, flip_residual=flip_res,
                    loop_joints=tuple((f"m{i - 1}", f"h{i}", f"m{i}", f"k{i}") for i in range(1, N + 1)))
    linkage.info = LinkageInfo(synthesis=(info or MultiLoop()).replace(ladder=ladder))
    return linkage


# ------------------------------------------------------------------ analysis
def joint_twists(linkage: Linkage, angles, disp: dict | None = None) -> dict:
    """World twists (omega, v) (..., 6) of every joint at the given angles (scalars or arrays of one
    shape; v = velocity of the point at the origin); ``disp``: ``linkage.displacements(angles)`` when the
    caller has them already."""
    disp = linkage.displacements(angles) if disp is None else disp
    out = {}
    for j in linkage.joints:
        T = disp[j.parent]
        R, p = T[..., :3, :3], T[..., :3, 3]
        u = R @ j.direction
        m = R @ j.moment + np.cross(p, u)
        out[j.name] = np.concatenate([u, m], axis=-1)
    return out


def _path(linkage: Linkage, link: str) -> list[str]:
    parent = {j.child: j for j in linkage.joints}
    out = []
    while link in parent:
        j = parent[link]
        out.append(j.name)
        link = j.parent
    return out[::-1]


def constraint_jacobian(linkage: Linkage, angles, disp: dict | None = None) -> np.ndarray:
    """(..., 6 * closures, joints): for every weld (Y, Y'), twist(path to Y) - twist(path to Y');
    ``disp``: as `joint_twists`."""
    tw = joint_twists(linkage, angles, disp)
    names = [j.name for j in linkage.joints]
    col = {n: i for i, n in enumerate(names)}
    batch = np.broadcast_shapes(*[np.shape(v)[:-1] for v in tw.values()])
    J = np.zeros(batch + (6 * len(linkage.closures), len(names)))
    for c, (y, y2) in enumerate(linkage.closures):
        for n in _path(linkage, y):
            J[..., 6 * c:6 * c + 6, col[n]] += tw[n]
        for n in _path(linkage, y2):
            J[..., 6 * c:6 * c + 6, col[n]] -= tw[n]
    return J


def mobility(linkage: Linkage, ts, tol: float = 1e-9) -> tuple[list[int], float]:
    """(dof at each t, worst conditioning): dof = joints - rank of the constraint Jacobian (relative
    tolerance ``tol``); conditioning = min over t of the smallest kept singular value / the largest."""
    ts = np.atleast_1d(np.asarray(ts, float))
    J = constraint_jacobian(linkage, linkage.angles_at(ts))
    sv = np.linalg.svd(J, compute_uv=False)  # (T, k)
    dofs, worst = [], np.inf
    for row in sv:
        if row.size == 0 or row[0] == 0:
            dofs.append(len(linkage.joints))
            continue
        rank = int(np.sum(row > tol * row[0]))
        dofs.append(len(linkage.joints) - rank)
        worst = min(worst, float(row[rank - 1] / row[0]))
    return dofs, float(worst)


def loop_sides(linkage: Linkage) -> list[list[float]]:
    """Per loop (m_{i-1}, h_i, m_i, k_i): distances of the sides m-h and h-m' (opposite sides equal)."""
    out = []
    for loop in linkage.info.synthesis.ladder.loop_joints:
        J = [linkage.joint(n) for n in loop]
        U = np.array([j.direction for j in J], float)
        M = np.array([j.moment for j in J], float)
        out.append([float(d) for d in ring_normals(U, M).distance])
    return out


# ------------------------------------------------------------------ choosing m0
def _common_direction(hs):
    U = np.array([-np.asarray(h[1:4], float) / np.linalg.norm(h[1:4]) for h in hs])
    n = U[0]
    if all(np.linalg.norm(np.cross(n, u)) <= 1e-9 for u in U):
        return n
    return None


def _leading_direction(hs):
    """The common axis direction of the leading factors h_1, h_2, ... when at least two share one (and
    not all do): an m0 of that direction makes their loops planar (the flip of two parallel rotations is
    parallel), and planar loops can be layered (docs/design.md)."""
    U = np.array([-np.asarray(h[1:4], float) / np.linalg.norm(h[1:4]) for h in hs])
    run = 1
    while run < len(U) and np.linalg.norm(np.cross(U[0], U[run])) <= 1e-9:
        run += 1
    return U[0] if 2 <= run < len(U) else None


def _axis_points(hs):
    L = factor_lines(np.asarray(hs, float))[0]
    return line_point(L[..., 0, :], L[..., 1, :])


def make_rotation(a: float, b: float, direction, point) -> np.ndarray:
    """The dual quaternion m with t - m a rotation about the line through ``point`` with ``direction``
    (right-hand rule) and norm (t - a)^2 + b^2 (b > 0)."""
    u = np.asarray(direction, float)
    u = u / np.linalg.norm(u)
    v = -b * u
    w = b * np.cross(np.asarray(point, float), u)
    return np.array([a, *v, 0.0, *w])


def m0_candidates(hs, count: int = 24, seed: int = 0):
    """Deterministic candidates for m0: planar factors keep the common axis direction, factors whose
    leading ones share a direction take that one (`_leading_direction`: those loops are planar); the
    point is around the centroid of the axes, at 0.5-1.5 times their spread; the norm differs from every h."""
    hs = np.asarray(hs, float)
    rng = np.random.default_rng(seed)
    pts = _axis_points(hs)
    c = pts.mean(axis=0)
    # the RMS spread of `synth.algebra.geometry.spread`, summed point by point: this rounding keeps the
    # candidates (and fixtures/motion_darboux.yaml's design search, which follows them) as they were
    size = np.sqrt(np.mean(np.sum((pts - c) ** 2, axis=1)))
    ab = np.array([norm_of(h) for h in hs])
    a_mean, b_mean = float(ab[:, 0].mean()), float(ab[:, 1].mean())
    scale = float(size) if size > 0 else max(1.0, float(np.max(np.abs(hs[:, 5:]))))
    n = _common_direction(hs)
    if n is None:
        n = _leading_direction(hs)
    out = []
    norms = [(a_mean + 2 * b_mean, 1.5 * b_mean), (a_mean - 2 * b_mean, 1.5 * b_mean),
             (a_mean + 1.5 * b_mean, b_mean), (a_mean - 1.5 * b_mean, 0.75 * b_mean),
             (a_mean + 3 * b_mean, 2 * b_mean), (a_mean + b_mean, 0.5 * b_mean)]
    for i in range(count):
        a, b = norms[i % len(norms)]
        if n is not None:
            d = n
            e1, e2 = perpendicular_basis(n)
            phi = 2 * np.pi * ((i * 0.381966) % 1.0) - np.pi / 2
            r = scale * (0.75 + 0.5 * ((i * 0.618034) % 1.0))
            p = c + r * (np.cos(phi) * e1 + np.sin(phi) * e2)
        else:
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            p = c + scale * rng.normal(size=3) * 0.75
        if any(abs(a - x) + abs(b - y) <= 1e-6 * (1 + abs(x) + y) for x, y in ab):
            b *= 1.37
        out.append(make_rotation(a, b, d, p))
    return out


def score_linkage(linkage: Linkage, samples: int = 48) -> Mobility:
    """Figures used to rank m0 candidates: worst conditioning of the loop equations over the motion,
    dof at the samples, and the size of the linkage relative to the factors' axes."""
    phi = np.linspace(-np.pi / 2, np.pi / 2, samples + 1)[1:]
    a = np.array([j.a for j in linkage.joints])
    b = np.array([j.b for j in linkage.joints])
    ts = float(np.mean(a)) + float(np.mean(b)) * np.tan(phi[:-1] + 1e-3)
    ts = np.concatenate([ts, [np.inf]])
    dofs, cond = mobility(linkage, ts)
    pts = np.array([j.point for j in linkage.joints])
    size = float(np.max(np.linalg.norm(pts - pts.mean(axis=0), axis=1)))
    return Mobility(dof=max(dofs), dof_min=min(dofs), conditioning=cond, size=size)


def choose_m0(hs, *, count: int = 24, seed: int = 0, build=None):
    """The m0 candidate whose ladder scores best (dof = 1 everywhere, then largest conditioning per
    size). ``build(m0) -> Linkage`` defaults to ``ladder_linkage(hs, m0)``. Returns (m0, linkage, score)."""
    build = build or (lambda m: ladder_linkage(hs, m))
    base_pts = _axis_points(np.asarray(hs, float))
    ref = max(float(np.sqrt(np.mean(np.sum((base_pts - base_pts.mean(0)) ** 2, axis=1)))), 1e-9)
    best = None
    for m in m0_candidates(hs, count, seed):
        try:
            lk = build(m)
        except SynthesisError:
            continue
        sc = score_linkage(lk)
        ok = sc.dof == 1 and sc.dof_min == 1
        value = (ok, sc.conditioning / max(sc.size / ref, 1.0))
        if best is None or value > best[0]:
            best = (value, m, lk, sc)
    if best is None:
        raise SynthesisError("no extra rotation m0 gave a valid multi-loop linkage")
    return best[1], best[2], best[3]
