"""Bennett 4R linkage through three poses (MATH.md section 7).

``bennett(poses)`` takes a (3, 4, 4) array of poses in metres and returns a verified `Linkage`:
branch h = (h1, h2), branch k = (k1, k2) with C = (t-h1)(t-h2) = (t-k1)(t-k2); pose 0 at t = inf
(all angles 0), pose 1 at t = 0, pose 2 at t = 1. By convention h1 (and k2) carry the norm factor
whose root a + ib has the smaller real part a.
"""
from __future__ import annotations

import math
from functools import lru_cache, partial

import numpy as np

from synth.synthesis.assemble import bennett_linkage, two_branch_linkage
from synth.checks import DEFAULT_CHECK_SAMPLES, self_check
from synth.errors import InputError, NotGenericError, SynthesisError
from synth.algebra.factorize import factorize
from synth.synthesis.conic import Conditioning, condition, conic, relative_displacements, to_world
from synth.synthesis.bennett_fast import bennett_core  # = synth.algebra.scalar.bennett_core, fused (bitwise the same)
from synth.algebra.scalar import pair_geometry
from synth.algebra.scalar import cross as scalar_cross
from synth.algebra.scalar import dot as scalar_dot

COINCIDENT_TOL = 1e-9  # relative to the pose spread (translation) and radians (rotation)
ACCEPT_TOL = 1e-8  # largest self-check error accepted, relative (see `_accept`)
ACCURATE = 1e-9  # a self-check error above this (relative) gets a warning
FLOOR_ULPS = 2 ** 17  # rounding floor of the world-frame checks, in ulps of the pose coordinates
SENSITIVITY_EPS = 1e-9  # relative pose perturbation of the condition estimate (`sensitivity`)
SENSITIVE = 1e4  # condition estimate above which a valid result gets a warning
EPS = float(np.finfo(float).eps)


def check_distinct(T, names, tol=COINCIDENT_TOL):
    """Refuse coincident poses with a message naming them. (Plain floats: the pairwise differences
    are those of `synth.checks.pose_difference`.)"""
    M = np.asarray(T, float).tolist()
    pos = [(R[0][3], R[1][3], R[2][3]) for R in M]
    n = len(pos)
    cx, cy, cz = (sum([p[k] for p in pos]) / n for k in range(3))
    L = max(math.sqrt(sum([(x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2 for x, y, z in pos]) / n), 1e-300)
    for i in range(n):
        for j in range(i + 1, n):
            dt, dr = _pose_difference(M[i], M[j])
            if dt <= tol * max(L, 1e-300) and dr <= tol or (dt == 0 and dr <= tol):
                raise SynthesisError(f"poses {i} ({names[i]!r}) and {j} ({names[j]!r}) coincide: "
                                     "three distinct poses are needed")


def _pose_difference(A, B):
    """`synth.checks.pose_difference` of two 4x4 nested lists: (|d_A - d_B|, angle of R_A^T R_B)."""
    (a00, a01, a02, a03), (a10, a11, a12, a13), (a20, a21, a22, a23) = A[0], A[1], A[2]
    (b00, b01, b02, b03), (b10, b11, b12, b13), (b20, b21, b22, b23) = B[0], B[1], B[2]
    dt = math.sqrt((a03 - b03) ** 2 + (a13 - b13) ** 2 + (a23 - b23) ** 2)
    # R = R_A^T R_B, R[r][c] = sum_k A[k][r] B[k][c]: only its skew part and trace are needed
    r01 = a00 * b01 + a10 * b11 + a20 * b21
    r02 = a00 * b02 + a10 * b12 + a20 * b22
    r10 = a01 * b00 + a11 * b10 + a21 * b20
    r12 = a01 * b02 + a11 * b12 + a21 * b22
    r20 = a02 * b00 + a12 * b10 + a22 * b20
    r21 = a02 * b01 + a12 * b11 + a22 * b21
    trace = ((a00 * b00 + a10 * b10 + a20 * b20) + (a01 * b01 + a11 * b11 + a21 * b21)
             + (a02 * b02 + a12 * b12 + a22 * b22))
    s = 0.5 * math.sqrt((r21 - r12) ** 2 + (r02 - r20) ** 2 + (r10 - r01) ** 2)
    return dt, math.atan2(s, 0.5 * (trace - 1))


def bennett(poses, names=None, *, check_samples: int = DEFAULT_CHECK_SAMPLES):
    """Synthesize the Bennett linkage whose coupler visits the three poses (shape (3, 4, 4), metres).

    ``check_samples``: number of parameters covering the real line at which the loop closure and the
    motion are verified (``linkage.checks``); the tool frame is always verified at every pose's reported
    joint angles.

    Generic input takes a fast path in plain floats (`synth.algebra.scalar.bennett_core`, in its fused form
    `synth.synthesis.bennett_fast.bennett_core`); anything not clearly generic (nearly degenerate poses, nearly
    real or repeated norm roots, a multiply-back error above 5e-13) goes through the general engine
    (`synth.algebra.factorize.factorize` with its refinements), which also gives every refusal its message. Both
    produce the same linkage up to rounding. On the fast path, ``motion``, ``checks`` and ``info`` are
    computed on first access (`Linkage.defer`); the self-check runs at once, and refuses the result,
    unless `error_estimate` shows that it cannot fail.

    Raises SynthesisError (degenerate or non-real cases, with a plain-language reason)."""
    T = np.asarray(poses, float)
    if T.shape != (3, 4, 4):
        raise InputError(f"a Bennett linkage needs exactly 3 poses (array of shape (3, 4, 4)), got {T.shape}")
    names = list(names) if names is not None else ["p0", "p1", "p2"]
    core = bennett_core(T)  # None for non-finite input, among others
    if core is None:
        if not np.all(np.isfinite(T)):
            raise InputError("the poses contain NaN or infinity")
        return _bennett_general(T, names, check_samples)
    # The self-check and what derives from it (motion, checks, info) are computed on first access,
    # with the values that `_finish` would give now. The refusal cannot wait: unless the error bound
    # shows that the self-check cannot fail, it runs now and decides (`_accept`).
    if len(names) == 3:
        linkage = bennett_linkage(core["H"], core["K"], T, names)
    else:
        linkage = two_branch_linkage("bennett", core["H"], core["K"], None, T, names, _TS)
    linkage.defer(motion=partial(_deferred_motion, core), checks=partial(_deferred_checks, check_samples),
                  info=partial(_deferred_info, core))
    if not error_estimate(core) <= ESTIMATE_TOL:  # (also NaN)
        _accept(linkage, _fast_info(core)[1])
    return linkage


def _fast_info(core):
    """(info, Conditioning) of a fast-path result before the self-check."""
    centre, scale = core["centre"], core["scale"]
    info = {"factorization_residual": core["residual"],
            "study_form": {k: v * scale for k, v in zip(("B01", "B02", "B12"), core["B"])},
            "conditioning": {"centre": list(centre), "scale": scale}}
    return info, Conditioning(centre=np.array(centre), scale=scale)


def _deferred_motion(core, linkage):
    return np.array(core["C"], float)


def _deferred_checks(samples, linkage):
    return self_check(linkage, samples)


def _deferred_info(core, linkage) -> dict:
    info, cond = _fast_info(core)
    return _complete_info(linkage, info, core["B"], cond)


_TS = (np.inf, 0.0, 1.0)


def _finish(linkage, B, cond, check_samples):
    """Self-check the linkage (refusing it when it misses its poses, `_accept`) and complete its info."""
    linkage.checks = self_check(linkage, check_samples)
    linkage.info = _complete_info(linkage, linkage.info, B, cond)
    return linkage


def _complete_info(linkage, info, B, cond) -> dict:
    """``info`` plus the Bennett parameters, DH table, relative self-check error and warnings; raises
    SynthesisError when the self-check (``linkage.checks``) fails (`_accept`)."""
    info = dict(info)
    loop = ["h1", "h2", "k2", "k1"]
    geo = loop_geometry(linkage, loop)
    info["bennett"] = bennett_parameters(linkage, geo)
    info["dh"] = dh_table(linkage, loop, geo)
    info["relative_error"] = _accept(linkage, cond)
    info["warnings"] = _warnings(linkage, B, cond, info)
    return info


# ----------------------------------------------------------------------------- a priori error bound
ESTIMATE_TOL = 1e-9  # error_estimate at or below this: _accept's relative error is far below ACCEPT_TOL
SQRT3 = math.sqrt(3.0)


def error_estimate(core) -> float:
    """A cheap, conservative estimate of `_accept`'s relative self-check error for a fast-path result
    (`synth.algebra.scalar.bennett_core`), from quantities the core already has; no forward kinematics.

    First-order rounding analysis, in the conditioned frame (pose spread 1) where the core works:
    - factorization: the multiply-back error (``residual``, relative to the largest coefficient cmax)
      perturbs C(t) by residual cmax (1 + |t|); the checks compare *normalized* motions, so it is
      amplified by (1 + |t|) / |C(t)|, bounded over all real t with the norm roots x + iy:
      |t - z| >= max(y, |t - x|) gives kappa = (1 + (1 + |x1|) / y1) / y2 (or the same with 1, 2 swapped);
    - interpolation: C(1) = c0 + c1 + 1 = mu2 D2 is formed with cancellation, eps (1 + |mu1| + |mu2|) / |mu|;
    - world coordinates: rounding of eps times the coordinates' size (positions and axes, up to
      pmax + axis distance), amplified like the factorization error (1 + cmax kappa), relative to the
      pose spread plus `_accept`'s floor.
    The constants are calibrated on random sweeps (uniform, extreme scales and offsets, nearly degenerate
    families: tests/test_bennett_lazy.py): the self-check error stayed below 0.25 of this estimate, so
    an estimate <= ESTIMATE_TOL (1e-9) means a relative error <= ~2.5e-10, 40x inside ACCEPT_TOL."""
    B01, B02, B12 = core["B"]
    mu1, mu2 = abs(B02 / B12), abs(B01 / B12)  # |C(0)| = |c0| = |mu1|, |C(1)| = |mu2| (primal parts)
    za, zb = core["roots"]
    y1, y2 = za.imag, zb.imag
    kappa = min((1.0 + (1.0 + abs(za.real)) / y1) / y2, (1.0 + (1.0 + abs(zb.real)) / y2) / y1)
    L = core["scale"]
    cx, cy, cz = core["centre"]
    # bound on the largest coefficient of c0 = -mu1 D1 and c1 = mu1 D1 + mu2 D2 - 1 (conditioned): the
    # relative displacements D have unit primal parts and dual parts -d r / 2 with |d| <= sqrt(6), as
    # the conditioned positions have an RMS distance of 1 from their centroid
    cmax = 1.0 + SQRT3 * (mu1 + mu2)
    # largest distance of an axis from the centroid: |w + c x v| / |v| for the factor t - h, h = (a, v, 0, w)
    size2 = 0.0
    for _, v1, v2, v3, _, w1, w2, w3 in (*core["H"], *core["K"]):
        d1 = w1 + (cy * v3 - cz * v2)
        d2 = w2 + (cz * v1 - cx * v3)
        d3 = w3 + (cx * v2 - cy * v1)
        r = (d1 * d1 + d2 * d2 + d3 * d3) / (v1 * v1 + v2 * v2 + v3 * v3)
        if r > size2:
            size2 = r
    size = max(L, math.sqrt(size2))
    cinf = max(abs(cx), abs(cy), abs(cz))  # pmax (largest |coordinate| of a position) is in [cinf, cinf + sqrt3 L]
    fact = core["residual"] * cmax * kappa
    interp = EPS * (1.0 + mu1 + mu2) / min(mu1, mu2)
    world = EPS * (cinf + SQRT3 * L + size) / (L + FLOOR_ULPS * EPS * cinf / ACCEPT_TOL) * (1.0 + cmax * kappa)
    return 4.0 * fact + 4.0 * interp + 1000.0 * world


def _accept(linkage, cond) -> float:
    """The largest relative self-check error (info's ``relative_error``); refuse a linkage whose own
    self-check fails: near degenerate poses can defeat double precision
    (the conic's coefficients or the factorization lose most digits), and a linkage that misses its
    poses must never be reported as a result. Translation errors are relative to the pose spread (to
    the axes' largest distance from the poses for the closure), plus a floor of FLOOR_ULPS ulps of the
    coordinates' magnitude (~3e-11 of it): a pose 1e6 m from the origin is only known to ~1e-10 m, and
    the checks, evaluated in world coordinates, lose several more digits there. Errors between
    ACCURATE and ACCEPT_TOL are accepted with a warning (`_warnings`)."""
    c = linkage.checks
    spread = float(cond.scale)
    # the linkage's size about the poses: the largest distance of an axis from the poses' centroid
    # (not Linkage.extent(), whose axis points are the ones closest to the world origin)
    size = max(spread, _axis_distance(linkage, cond.centre.tolist()))
    pmax = max(abs(x) for p in linkage.poses for x in p.matrix[:3, 3].tolist())
    floor = FLOOR_ULPS * EPS * pmax
    rel = max(c["max_pose_translation_error"] / (spread + floor / ACCEPT_TOL),
              c["max_pose_rotation_error"],
              c["max_closure_translation_error"] / (size + floor / ACCEPT_TOL),
              c["max_closure_rotation_error"])
    if not rel <= ACCEPT_TOL:  # (also catches NaN)
        T = np.array([p.matrix for p in linkage.poses])
        names = [p.name for p in linkage.poses]
        raise SynthesisError(
            f"the poses are too close to a degenerate configuration{_near_degenerate(T, names, spread)}: the "
            f"linkage computed in double precision misses them by {rel:.1e} (relative; at most {ACCEPT_TOL:g} "
            "is accepted), so no reliable linkage can be given; move the poses further apart")
    return rel


def _axis_distance(linkage, c) -> float:
    """Largest distance of a joint axis from the point c: |moment about c| = |m - c x u|."""
    out = 0.0
    for j in linkage.joints:
        m, cu = j.moment.tolist(), scalar_cross(c, j.direction.tolist())
        out = max(out, math.hypot(m[0] - cu[0], m[1] - cu[1], m[2] - cu[2]))
    return out


def _near_degenerate(T, names, spread) -> str:
    """' (poses i and j ...)' naming the pair of poses closest to a degenerate relation, or ''."""
    found = _near_relations(T, names, spread)
    if sum(1 for k, _ in found if k == 2) == 3:
        return " (the three poses are nearly related by planar motions)"
    return f" ({min(found)[1]})" if found else ""


def _near_relations(T, names, spread) -> list[tuple[int, str]]:
    """(kind, text) for each pair of poses nearly coinciding (0), nearly related by a pure translation
    (1) or by a pure rotation (2), within 1e-3 (relative)."""
    found = []
    for i, j in ((0, 1), (0, 2), (1, 2)):
        R = T[j, :3, :3] @ T[i, :3, :3].T
        d = T[j, :3, 3] - R @ T[i, :3, 3]
        ang = float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        along = abs(float(np.dot(d, w / np.linalg.norm(w)))) if np.linalg.norm(w) > 1e-300 else 0.0
        trans = float(np.linalg.norm(d)) / spread
        if ang < 1e-3 and trans < 1e-3:
            found.append((0, f"poses {i} ({names[i]!r}) and {j} ({names[j]!r}) nearly coincide"))
        elif ang < 1e-3:
            found.append((1, f"poses {i} ({names[i]!r}) and {j} ({names[j]!r}) differ by nearly a pure translation"))
        elif along / spread < 1e-3 * max(ang, 1e-300) or along / spread < 1e-6:
            found.append((2, f"poses {i} ({names[i]!r}) and {j} ({names[j]!r}) differ by nearly a pure rotation"))
    return found


def sensitivity(linkage, eps: float = SENSITIVITY_EPS, trials: int = 2, seed: int = 0) -> float:
    """Condition estimate of the synthesis: the largest change of the joint axes (unit directions,
    and moments about the poses' centroid divided by the pose spread) per unit relative change of
    the poses, over ``trials`` random perturbations of size ``eps`` (rotations of eps radians,
    translations of eps pose spreads). Infinite when a perturbed input has no Bennett linkage.
    Deterministic (fixed seed)."""
    T = np.array([p.matrix for p in linkage.poses])
    c = T[:, :3, 3].mean(axis=0)
    spread = max(float(np.sqrt(np.mean(np.sum((T[:, :3, 3] - c) ** 2, axis=1)))), 1e-300)
    c = c.tolist()

    def line(u, m):
        cu = scalar_cross(c, u)
        return (u[0], u[1], u[2], (m[0] - cu[0]) / spread, (m[1] - cu[1]) / spread, (m[2] - cu[2]) / spread)

    ref = {j.name: line(j.direction.tolist(), j.moment.tolist()) for j in linkage.joints}
    draws = iter(_random_directions(seed, trials))
    worst = 0.0
    for _ in range(trials):
        Tp = T.copy()
        for i in range(3):
            w, nw, v, nv = next(draws)
            Tp[i] = T[i] @ _small_motion(w * (eps / nw), v * (eps * spread / nv))
        try:
            H, K = _factors(Tp, [p.name for p in linkage.poses])
        except SynthesisError:
            return float("inf")
        new = {}
        for prefix, F in (("h", H), ("k", K)):
            for n, h in enumerate(F, 1):
                h = [float(x) for x in h]
                b = math.sqrt(h[1] * h[1] + h[2] * h[2] + h[3] * h[3])
                new[f"{prefix}{n}"] = line((-h[1] / b, -h[2] / b, -h[3] / b), (h[5] / b, h[6] / b, h[7] / b))
        swap = {"h1": "k1", "h2": "k2", "k1": "h1", "k2": "h2"}

        def dev(pairs):
            return max(abs(x - y) for a, b in pairs for x, y in zip(a, b))

        d = min(dev((new[n], ref[n]) for n in ref),  # branches may swap labels
                dev((new[swap[n]], ref[n]) for n in ref))
        worst = max(worst, d / eps)
    return worst


@lru_cache(maxsize=8)
def _random_directions(seed: int, trials: int) -> tuple:
    """`sensitivity`'s random draws, (w, |w|, v, |v|) for each trial and pose (normal 3-vectors, in
    the order drawn). Cached: the seed is fixed, and a new Generator costs more than the rest."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(3 * trials):
        w = rng.normal(size=3)
        v = rng.normal(size=3)
        w.flags.writeable = v.flags.writeable = False
        out.append((w, np.linalg.norm(w), v, np.linalg.norm(v)))
    return tuple(out)


def _small_motion(w, v):
    """4x4 rigid motion: rotation vector w (Rodrigues), translation v."""
    w0, w1, w2 = w.tolist()
    th = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    k0, k1, k2 = w0 / th, w1 / th, w2 / th
    s, c1 = math.sin(th), 1 - math.cos(th)
    # I + sin K + (1 - cos) K^2 with K = [k]x, K^2 = k k^T - I
    return np.array([[1 + c1 * (k0 * k0 - 1), -s * k2 + c1 * k0 * k1, s * k1 + c1 * k0 * k2, v[0]],
                     [s * k2 + c1 * k0 * k1, 1 + c1 * (k1 * k1 - 1), -s * k0 + c1 * k1 * k2, v[1]],
                     [-s * k1 + c1 * k0 * k2, s * k0 + c1 * k1 * k2, 1 + c1 * (k2 * k2 - 1), v[2]],
                     [0.0, 0.0, 0.0, 1.0]])


def _factors(T, names):
    """(H, K): the world-frame factors of both branches (fast path, else the general engine)."""
    core = bennett_core(T)
    if core is not None:
        return core["H"], core["K"]
    H, K, *_ = _general_factors(T, names)
    return H, K


def _bennett_general(T, names, check_samples):
    """The general path: `factorize` with root merging, refinement and every refusal message."""
    H, K, C, con, cond, info = _general_factors(T, names)
    linkage = two_branch_linkage("bennett", H, K, C, T, names, con.ts, info)
    return _finish(linkage, con.B.tolist(), cond, check_samples)


def _general_factors(T, names):
    check_distinct(T, names)
    Tc, cond = condition(T)
    D = relative_displacements(Tc)
    try:
        con = conic(D)
    except SynthesisError as e:
        close = [text for kind, text in _near_relations(T, names, float(cond.scale)) if kind == 0]
        if close:  # the Study form of nearly equal poses vanishes quadratically: say what really happens
            raise SynthesisError(f"{close[0]} (they differ by less than 1e-3, relative): the conic through "
                                 "them is numerically degenerate; give three clearly distinct poses") from e
        raise
    try:
        res = factorize(con.C, validate=False)
    except NotGenericError as e:
        raise SynthesisError(
            "the conic through the poses is degenerate (its motion has a real factor, e.g. a "
            f"circular translation): no Bennett linkage of revolute joints ({e})") from None
    if len(res.factorizations) < 2:
        raise SynthesisError("the conic through the poses has only one factorization (a repeated norm "
                             "factor): the two branches coincide and do not form a movable loop")
    a_roots = -0.5 * res.quadratics[:, 1]
    first = int(np.argmin(a_roots))
    by_order = {f.order: f for f in res.factorizations}
    fh, fk = by_order[(first, 1 - first)], by_order[(1 - first, first)]
    for f in (fh, fk):
        if any(x.kind == "translation" for x in f.classified()):
            raise SynthesisError(
                "the relative screws of the poses have parallel axes: one factor of the motion is a "
                "translation, so the linkage would need a prismatic joint (not supported)")
    H = to_world(fh.factors, cond)
    K = to_world(fk.factors, cond)
    C = to_world(con.C, cond)
    info = {"factorization_residual": max(fh.residual, fk.residual),
            # the Study form is translation invariant and scales with length: report it in metres
            "study_form": {k: float(v * cond.scale) for k, v in zip(("B01", "B02", "B12"), con.B)},
            "conditioning": {"centre": cond.centre.tolist(), "scale": float(cond.scale)}}
    return H, K, C, con, cond, info


def _warnings(linkage, B, cond, info) -> list[str]:
    """Warnings for a valid result: axes far from the poses, and sensitivity to the poses. The condition
    estimate (`sensitivity`, two extra syntheses) runs only when a cheap indicator suggests trouble:
    axes more than 3 pose spreads away, a Study form value |B| < 1e-2 (nearly zero pitch), or norm
    roots that are close or nearly real."""
    out = []
    rel = info.get("relative_error", 0.0)
    if rel > ACCURATE:
        out.append(f"the linkage reproduces the poses less accurately than usual (relative error between "
                   f"{ACCURATE:g} and {ACCEPT_TOL:g}): the poses are close to a degenerate configuration")
    # distance of each axis from the poses' centroid: |moment about the centroid| = |m - c x u|
    far = _axis_distance(linkage, cond.centre.tolist()) / cond.scale
    if far > 1e3:
        out.append(f"joint axes lie {far:.3g} pose spreads away from the poses: the poses are nearly "
                   "related by pure translations, the linkage is valid but impractically large")
    bs = sorted({(round(j.a, 12), round(j.b, 12)) for j in linkage.joints})
    roots_close = len(bs) == 2 and math.dist(*bs) < 1e-2 * max(1.0, *(abs(x) for ab in bs for x in ab))
    nearly_real = min(j.b for j in linkage.joints) < 1e-2 * max(1.0, *(abs(j.a) for j in linkage.joints))
    if far > 3 or min(abs(x) for x in B) < 1e-2 or roots_close or nearly_real:
        kappa = sensitivity(linkage)
        info["condition_estimate"] = kappa
        if kappa > SENSITIVE:
            # orders of magnitude only: the text must not depend on rounding (batch and single paths agree)
            mag = math.floor(math.log10(kappa)) if math.isfinite(kappa) else None
            shown = "infinite (a tiny change makes it degenerate)" if mag is None else f"about 1e{mag}"
            moved = "1" if mag is None or mag >= 9 else f"1e{mag - 9}"
            out.append(f"the result is valid but sensitive to the poses: changing them by 1e-9 (relative) "
                       f"moves the joint axes by up to about {moved} (condition estimate {shown}); small errors "
                       "in the poses give a different linkage")
    return out


def _pair_geometry(j1, j2):
    """(distance, signed twist, foot on j1, foot on j2, unit common normal) between two joint axes.
    The twist is the angle from u1 to u2 about the common normal from j1 to j2."""
    dist, twist, f1, f2, n = pair_geometry(j1.direction.tolist(), j1.moment.tolist(),
                                           j2.direction.tolist(), j2.moment.tolist())
    return dist, twist, np.array(f1), np.array(f2), np.array(n)


def loop_geometry(linkage, loop: list[str]) -> list[tuple]:
    """`pair_geometry` (distance, signed twist, foot on i, foot on i+1, unit normal; plain floats) of
    every consecutive pair of joints around the closed loop ``loop``."""
    L = [(j.direction.tolist(), j.moment.tolist()) for j in (linkage.joint(n) for n in loop)]
    m = len(L)
    return [pair_geometry(*L[i], *L[(i + 1) % m]) for i in range(m)]


def bennett_parameters(linkage, geo=None) -> dict:
    """Link lengths and twists of the loop h1-h2-k2-k1: a, alpha (links h1h2 and k2k1), b, beta
    (coupler h2k2 and base k1h1), and the Bennett condition residual |a/sin(alpha)| - |b/sin(beta)|.
    ``geo``: `loop_geometry(linkage, ["h1", "h2", "k2", "k1"])` if already computed."""
    geo = geo or loop_geometry(linkage, ["h1", "h2", "k2", "k1"])
    (a1, al1, *_), (b1, be1, *_), (a2, al2, *_), (b2, be2, *_) = geo
    ra = a1 / abs(math.sin(al1)) if abs(math.sin(al1)) > 1e-15 else float("inf")
    rb = b1 / abs(math.sin(be1)) if abs(math.sin(be1)) > 1e-15 else float("inf")
    scale = max(a1, b1, 1e-300)
    return {
        "a": a1, "alpha": al1, "b": b1, "beta": be1,
        "opposite_length_mismatch": max(abs(a1 - a2), abs(b1 - b2)) / scale,
        "opposite_twist_mismatch": max(abs(abs(al1) - abs(al2)), abs(abs(be1) - abs(be2))),
        "a_over_sin_alpha": ra, "b_over_sin_beta": rb,
        "bennett_condition_residual": abs(ra - rb) / max(ra, rb, 1e-300) if math.isfinite(ra + rb) else None,
    }


def dh_table(linkage, loop: list[str], geo=None) -> list[dict]:
    """Denavit-Hartenberg parameters around a closed loop of joints at the reference configuration:
    for joint i, ``a``/``alpha`` to the next joint (signed twist about the common normal), ``d`` the
    offset along axis i between the incoming and outgoing common normals, ``theta`` the angle between
    them about axis i. ``geo``: `loop_geometry(linkage, loop)` if already computed."""
    geo = geo or loop_geometry(linkage, loop)
    m = len(loop)
    rows = []
    for i in range(m):
        dist, twist, f_out, _, n_out = geo[i]
        _, _, _, f_in, n_in = geo[i - 1]
        u = linkage.joint(loop[i]).direction.tolist()
        d = scalar_dot((f_out[0] - f_in[0], f_out[1] - f_in[1], f_out[2] - f_in[2]), u)
        theta = math.atan2(scalar_dot(scalar_cross(n_in, n_out), u), scalar_dot(n_in, n_out))
        rows.append({"joint": loop[i], "next": loop[(i + 1) % m], "a": dist, "alpha": twist, "d": d,
                     "theta": theta})
    return rows
