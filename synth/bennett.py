"""Bennett 4R linkage through three poses (MATH.md section 7).

``bennett(poses)`` takes a (3, 4, 4) array of poses in metres and returns a verified `Linkage`:
branch h = (h1, h2), branch k = (k1, k2) with C = (t-h1)(t-h2) = (t-k1)(t-k2); pose 0 at t = inf
(all angles 0), pose 1 at t = 0, pose 2 at t = 1. By convention h1 (and k2) carry the norm factor
whose root a + ib has the smaller real part a.
"""
from __future__ import annotations

import math

import numpy as np

from .assemble import two_branch_linkage
from .checks import pose_difference, self_check
from .errors import InputError, NotGenericError, SynthesisError
from .factor import factorize
from .interpolate import Conditioning, condition, conic, relative_displacements, to_world
from .scalar import bennett_core, pair_geometry
from .scalar import cross as scalar_cross
from .scalar import dot as scalar_dot

COINCIDENT_TOL = 1e-9  # relative to the pose spread (translation) and radians (rotation)


def check_distinct(T, names, tol=COINCIDENT_TOL):
    """Refuse coincident poses with a message naming them."""
    T = np.asarray(T, float)
    pos = T[:, :3, 3]
    L = max(float(np.sqrt(np.mean(np.sum((pos - pos.mean(0)) ** 2, axis=1)))), 1e-300)
    for i in range(len(T)):
        for j in range(i + 1, len(T)):
            dt, dr = pose_difference(T[i], T[j])
            if dt <= tol * max(L, 1e-300) and dr <= tol or (dt == 0 and dr <= tol):
                raise SynthesisError(f"poses {i} ({names[i]!r}) and {j} ({names[j]!r}) coincide: "
                                     "three distinct poses are needed")


def bennett(poses, names=None, *, check_samples: int = 200):
    """Synthesize the Bennett linkage whose coupler visits the three poses (shape (3, 4, 4), metres).

    ``check_samples``: number of parameters covering the real line at which the loop closure and the
    motion are verified (``linkage.checks``); the tool frame is always verified at every pose's reported
    joint angles.

    Generic input takes a fast path in plain floats (`synth.scalar.bennett_core`); anything not clearly
    generic (nearly degenerate poses, nearly real or repeated norm roots, a multiply-back error above
    1e-14) goes through the general engine (`synth.factor.factorize` with its refinements), which also
    gives every refusal its message. Both produce the same linkage up to rounding.

    Raises SynthesisError (degenerate or non-real cases, with a plain-language reason)."""
    T = np.asarray(poses, float)
    if T.shape != (3, 4, 4):
        raise InputError(f"a Bennett linkage needs exactly 3 poses (array of shape (3, 4, 4)), got {T.shape}")
    if not math.isfinite(float(T.sum())) and not np.all(np.isfinite(T)):
        raise InputError("the poses contain NaN or infinity")
    names = list(names) if names is not None else [f"p{i}" for i in range(3)]
    core = bennett_core(T)
    if core is None:
        return _bennett_general(T, names, check_samples)
    cond = Conditioning(centre=np.array(core["centre"]), scale=core["scale"])
    info = {"factorization_residual": core["residual"],
            "study_form": {k: v * cond.scale for k, v in zip(("B01", "B02", "B12"), core["B"])},
            "conditioning": {"centre": list(core["centre"]), "scale": cond.scale}}
    linkage = two_branch_linkage("bennett", core["H"], core["K"], core["C"], T, names, _TS, info)
    return _finish(linkage, core["B"], cond, check_samples)


_TS = (np.inf, 0.0, 1.0)


def _finish(linkage, B, cond, check_samples):
    loop = ["h1", "h2", "k2", "k1"]
    geo = loop_geometry(linkage, loop)
    linkage.info["bennett"] = bennett_parameters(linkage, geo)
    linkage.info["dh"] = dh_table(linkage, loop, geo)
    linkage.info["warnings"] = _warnings(linkage, B, cond)
    linkage.checks = self_check(linkage, check_samples)
    return linkage


def _bennett_general(T, names, check_samples):
    """The general path: `factorize` with root merging, refinement and every refusal message."""
    check_distinct(T, names)
    Tc, cond = condition(T)
    D = relative_displacements(Tc)
    con = conic(D)
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
    linkage = two_branch_linkage("bennett", H, K, C, T, names, con.ts, info)
    return _finish(linkage, con.B.tolist(), cond, check_samples)


def _warnings(linkage, B, cond) -> list[str]:
    out = []
    c = cond.centre.tolist()
    far = max(math.dist(scalar_cross(j.direction.tolist(), j.moment.tolist()), c) for j in linkage.joints) / cond.scale
    if far > 1e3:
        out.append(f"joint axes lie {far:.3g} pose spreads away from the poses: the poses are nearly "
                   "related by pure translations, the linkage is valid but impractically large")
    if min(abs(x) for x in B) < 1e-3:
        out.append("some relative displacement has nearly zero pitch: the result is valid but "
                   "sensitive to small changes of the poses")
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
