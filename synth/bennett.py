"""Bennett 4R linkage through three poses (MATH.md section 7).

``bennett(poses)`` takes a (3, 4, 4) array of poses in metres and returns a verified `Linkage`:
branch h = (h1, h2), branch k = (k1, k2) with C = (t-h1)(t-h2) = (t-k1)(t-k2); pose 0 at t = inf
(all angles 0), pose 1 at t = 0, pose 2 at t = 1. By convention h1 (and k2) carry the norm factor
whose root a + ib has the smaller real part a.
"""
from __future__ import annotations

import numpy as np

from .assemble import two_branch_linkage
from .checks import pose_difference, self_check
from .dq import common_normal_feet
from .errors import InputError, NotGenericError, SynthesisError
from .factor import factorize
from .interpolate import condition, conic, relative_displacements, to_world

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

    Raises SynthesisError (degenerate or non-real cases, with a plain-language reason)."""
    T = np.asarray(poses, float)
    if T.shape != (3, 4, 4):
        raise InputError(f"a Bennett linkage needs exactly 3 poses (array of shape (3, 4, 4)), got {T.shape}")
    names = list(names) if names is not None else [f"p{i}" for i in range(3)]
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
    linkage.info["bennett"] = bennett_parameters(linkage)
    linkage.info["dh"] = dh_table(linkage, ["h1", "h2", "k2", "k1"])
    linkage.info["warnings"] = _warnings(linkage, con, cond)
    linkage.checks = self_check(linkage, check_samples)
    return linkage


def _warnings(linkage, con, cond) -> list[str]:
    out = []
    far = max(np.linalg.norm(j.point - cond.centre) for j in linkage.joints) / cond.scale
    if far > 1e3:
        out.append(f"joint axes lie {far:.3g} pose spreads away from the poses: the poses are nearly "
                   "related by pure translations, the linkage is valid but impractically large")
    if np.min(np.abs(con.B)) < 1e-3:
        out.append("some relative displacement has nearly zero pitch: the result is valid but "
                   "sensitive to small changes of the poses")
    return out


def _pair_geometry(j1, j2):
    """(distance, signed twist, foot on j1, foot on j2, unit common normal) between two joint axes.
    The twist is the angle from u1 to u2 about the common normal from j1 to j2."""
    f1, f2 = common_normal_feet(j1.direction, j1.moment, j2.direction, j2.moment)
    d = f2 - f1
    dist = float(np.linalg.norm(d))
    c = np.cross(j1.direction, j2.direction)
    if dist > 1e-12:
        n = d / dist
    elif np.linalg.norm(c) > 1e-12:
        n = c / np.linalg.norm(c)
    else:
        n = np.zeros(3)
    twist = float(np.arctan2(np.dot(np.cross(j1.direction, j2.direction), n), np.dot(j1.direction, j2.direction)))
    return dist, twist, f1, f2, n


def bennett_parameters(linkage) -> dict:
    """Link lengths and twists of the loop h1-h2-k2-k1: a, alpha (links h1h2 and k2k1), b, beta
    (coupler h2k2 and base k1h1), and the Bennett condition residual |a/sin(alpha)| - |b/sin(beta)|."""
    J = {j.name: j for j in linkage.joints}
    a1, al1, *_ = _pair_geometry(J["h1"], J["h2"])
    b1, be1, *_ = _pair_geometry(J["h2"], J["k2"])
    a2, al2, *_ = _pair_geometry(J["k2"], J["k1"])
    b2, be2, *_ = _pair_geometry(J["k1"], J["h1"])
    ra = a1 / abs(np.sin(al1)) if abs(np.sin(al1)) > 1e-15 else float("inf")
    rb = b1 / abs(np.sin(be1)) if abs(np.sin(be1)) > 1e-15 else float("inf")
    scale = max(a1, b1, 1e-300)
    return {
        "a": a1, "alpha": al1, "b": b1, "beta": be1,
        "opposite_length_mismatch": max(abs(a1 - a2), abs(b1 - b2)) / scale,
        "opposite_twist_mismatch": max(abs(abs(al1) - abs(al2)), abs(abs(be1) - abs(be2))),
        "a_over_sin_alpha": ra, "b_over_sin_beta": rb,
        "bennett_condition_residual": abs(ra - rb) / max(ra, rb, 1e-300) if np.isfinite(ra + rb) else None,
    }


def dh_table(linkage, loop: list[str]) -> list[dict]:
    """Denavit-Hartenberg parameters around a closed loop of joints at the reference configuration:
    for joint i, ``a``/``alpha`` to the next joint (signed twist about the common normal), ``d`` the
    offset along axis i between the incoming and outgoing common normals, ``theta`` the angle between
    them about axis i."""
    J = [linkage.joint(n) for n in loop]
    m = len(J)
    geo = [_pair_geometry(J[i], J[(i + 1) % m]) for i in range(m)]
    rows = []
    for i in range(m):
        dist, twist, f_out, _, n_out = geo[i]
        _, _, _, f_in, n_in = geo[i - 1]
        u = J[i].direction
        d = float(np.dot(f_out - f_in, u))
        theta = float(np.arctan2(np.dot(np.cross(n_in, n_out), u), np.dot(n_in, n_out)))
        rows.append({"joint": loop[i], "next": loop[(i + 1) % m], "a": dist, "alpha": twist, "d": d,
                     "theta": theta})
    return rows
