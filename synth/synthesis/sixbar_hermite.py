"""6R linkages through two poses with the tool's velocity prescribed at each (Hermite interpolation,
docs/sixbar_fit.md).

In the kinematic image space (conditioned frame, displacements relative to pose 0) the two poses are
the points 1 and D1 of the Study quadric S and the velocities give the tangents W0 = Xi0 (the twist at
pose 0 as a dual quaternion, Xi = w/2 - eps (v - w x d)/2) and W1 = Xi1 D1. Their span
V = <1, W0, D1, W1> plays the role of the 3-space of four poses (`synth.synthesis.cubic`): a monic
cubic through 1 at t = inf with tangent W0 there and through D1 at t = 0 with tangent W1 is

    C(t) = t^3 + (alpha + W0) t^2 + (mu D1 + nu W1) t + lam D1

(the scale of t fixed by the weight 1 of W0). C lies on S for every t iff x(t)^T A x(t) = 0, A the Gram
matrix of the Study form on V: the coefficients of t^6, t^5, t^1, t^0 vanish by construction and t^4,
t^3, t^2 give

    mu = -(A22 + 2 A14 nu) / (2 A13),   lam = (alpha A22 - K) / (2 A13),   K = 2 A23 mu + 2 A24 nu,
    A22 A13 alpha^2 + (A22 A23 - K A13) alpha + A13 A44 nu^2 - K A23 = 0,

a quadratic in alpha: for every nu two members, the two families of cubics of a ruled section (no real
member: the section is oval). The members are scanned over nu = tan(phi) and factored and scored like
the 6R scan (`synth.synthesis.sixbar_loops`).
"""
from __future__ import annotations

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.dq import dq_mul, study_form
from synth.checks import DEFAULT_CHECK_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.info import LinkageInfo, Orders, SixbarCandidate
from synth.infoparts import ScoreParts
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.conic import Conditioning, condition, relative_displacements, to_world
from synth.synthesis.cubic import PAIRS, PERMS
from synth.synthesis.sixbar import LOOP, MAX_ATTEMPTS, checks_pass, loop_dh
from synth.synthesis.sixbar_loops import factor_members, member_geometry, root_pairs, score_loops, score_warnings

__all__ = ["twist_dq", "hermite_members", "hermite_candidates", "GRID"]

GRID = 48  # members per family in the scan (nu = tan(phi), phi uniform)
TANGENT_TOL = 1e-9  # relative: A13 (the Study form of the two poses) must not vanish


def twist_dq(velocity, position) -> np.ndarray:
    """The twist (N, 6) [w, v] (v: velocity of the tool origin at ``position`` (N, 3)) as dual
    quaternions Xi (N, 8) with dT/dtime = Xi T for the pose T (layout of `synth.algebra.dq`)."""
    velocity = np.asarray(velocity, float)
    w, v = velocity[:, :3], velocity[:, 3:]
    out = np.zeros((len(w), 8))
    out[:, 1:4] = 0.5 * w
    out[:, 5:8] = -0.5 * (v - np.cross(w, np.asarray(position, float)))
    return out


def hermite_members(Tc, velocity, grid: int = GRID):
    """The scanned members (G, 4, 8) (monic, conditioned frame, relative to pose 0) through the two
    conditioned poses Tc (2, 4, 4) with the conditioned twists ``velocity`` (2, 6), and their labels
    (G, 2): (family 0|1, nu). SynthesisError when the poses coincide in the Study form (A13 = 0) or no
    member is real."""
    D1 = relative_displacements(Tc)[1]
    Xi = twist_dq(velocity, Tc[:, :3, 3])
    W0, W1 = Xi[0], dq_mul(Xi[1], D1)
    basis = np.stack([np.eye(8)[0], W0, D1, W1])
    A = study_form(basis[:, None], basis[None])
    scale = np.abs(A).max()
    if abs(A[0, 2]) <= TANGENT_TOL * scale:
        raise SynthesisError("the two poses differ by a displacement of zero pitch (a pure rotation, a pure "
                             "translation or a planar motion): no spatial cubic 6R motion interpolates them with "
                             "the given velocities")
    nu = np.tan((np.arange(grid) + 0.5) * np.pi / grid - np.pi / 2)
    mu = -(A[1, 1] + 2 * A[0, 3] * nu) / (2 * A[0, 2])
    K = 2 * A[1, 2] * mu + 2 * A[1, 3] * nu
    a, b, c = A[1, 1] * A[0, 2], A[1, 1] * A[1, 2] - K * A[0, 2], A[0, 2] * A[3, 3] * nu ** 2 - K * A[1, 2]
    disc = b * b - 4 * a * c
    real = disc >= 0
    root = np.sqrt(np.where(real, disc, 0.0))
    with np.errstate(all="ignore"):
        alpha = np.stack([(-b + root) / (2 * a), (-b - root) / (2 * a)])  # (2, G)
    lam = (alpha * A[1, 1] - K) / (2 * A[0, 2])
    C = np.zeros((2, grid, 4, 8))
    C[..., 0, :] = lam[..., None] * D1
    C[..., 1, :] = mu[:, None] * D1 + nu[:, None] * W1
    C[..., 2, :] = alpha[..., None] * np.eye(8)[0] + W0
    C[..., 3, 0] = 1.0
    ok = np.broadcast_to(real, (2, grid)) & np.isfinite(C).all((-2, -1))
    if not ok.any():
        raise SynthesisError("no real cubic motion interpolates the two poses with their velocities: the "
                             "quadric through their tangent space is oval (change a velocity or a pose)")
    fam = np.repeat(np.arange(2)[:, None], grid, 1)
    labels = np.stack([fam, np.broadcast_to(nu, (2, grid))], -1)
    return C[ok], labels[ok]


def _checked(poses, velocity):
    T = np.asarray(poses, float)
    V = np.asarray(velocity, float)
    if T.shape != (2, 4, 4) or V.shape != (2, 6):
        raise InputError(f"Hermite 6R synthesis needs 2 poses and a full twist [angular, linear] at each, got "
                         f"poses {T.shape} and velocities {V.shape}")
    if not np.all(np.isfinite(V)):
        raise InputError("Hermite 6R synthesis needs both the angular and the linear velocity at both poses")
    for i in range(2):
        if not np.any(V[i]):
            raise InputError(f"pose {i}: the velocity is zero (only its direction counts, so it must not vanish)")
    return T, V


def hermite_candidates(poses, velocity, names=None, *, top: int | None = None, grid: int = GRID,
                       check_samples: int = DEFAULT_CHECK_SAMPLES):
    """Built, self-checked 6R linkages (best engineering score first, at most ``top``) whose tool passes
    pose 0 (t = inf) and pose 1 (t = 0) of ``poses`` (2, 4, 4) (metres) with its twist parallel to
    ``velocity`` (2, 6) [rad/s, m/s of the tool origin] there. SynthesisError with the reason when none."""
    T, V = _checked(poses, velocity)
    names = list(names) if names is not None else ["p0", "p1"]
    Tc, cond = condition(T)
    Vc = V.copy()
    Vc[:, 3:] /= cond.scale
    C, labels = hermite_members(Tc, Vc, grid)
    with np.errstate(all="ignore"):
        mf = factor_members(C, polish=True)
        im, sep = a1.root_conditioning(mf.roots)
        geo = member_geometry(mf)
        parts, valid, score = score_loops(im, sep, ("parameter_separation", np.ones(len(C))), geo, mf.residual,
                                          mf.ok, np.isfinite(C).all((-2, -1)), PAIRS)
    g, k = np.nonzero(valid)
    if not len(g):
        raise SynthesisError("every cubic motion through the two poses with their velocities has a nearly real or "
                             "repeated norm factor or a translation factor: no 6R linkage interpolates them")
    order = np.argsort(-score[g, k], kind="stable")
    out, tried = [], 0
    for gi, ki in zip(g[order].tolist(), k[order].tolist()):
        lk = _build(C[gi], mf.H[gi], mf.roots[gi], ki, parts, score, gi, labels[gi], cond, T, names, check_samples)
        tried += 1
        if checks_pass(lk, float(cond.scale)):
            out.append(lk)
            if top and len(out) >= top:
                break
        elif tried >= MAX_ATTEMPTS and not out:
            break
    if not out:
        raise SynthesisError("the best Hermite 6R candidates do not pass the self-check: the task is numerically "
                             "degenerate")
    return out


def _build(C, H, roots, k, parts, score, g, label, cond, T, names, check_samples):
    oh, ok_ = PAIRS[k]
    HK, _ = a1.polish(C, np.stack([H[oh], H[ok_]]))
    res = float(np.max(np.maximum(a1.multiply_back(C, HK), a1.study_violation(HK))))
    W = to_world(np.concatenate([HK[0], HK[1], C]), cond)
    p = {key: float(v[g, k]) for key, v in parts.items()}
    record = SixbarCandidate(
        task="hermite", family=int(label[0]) + 1, member=float(label[1]), pair=int(k + 1), score=float(score[g, k]),
        score_parts=ScoreParts.of(p), orders=Orders(h=tuple(PERMS[oh].tolist()), k=tuple(PERMS[ok_].tolist())),
        norm_roots=root_pairs(roots), factorization_residual=res,
        conditioning=Conditioning(cond.centre, float(cond.scale)))
    lk = two_branch_linkage("6r", W[:3], W[3:6], W[6:], T, names, (np.inf, 0.0), LinkageInfo(synthesis=record))
    lk.info = lk.info.replace(dh=loop_dh(lk, LOOP), warnings=score_warnings(p, "motion"))
    lk.checks = self_check(lk, check_samples)
    return lk
