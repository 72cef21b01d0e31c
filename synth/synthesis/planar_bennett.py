"""Planar and spherical four-bars through three poses: the conic family (docs/planar.md).

For a planar or spherical pose set (`synth.synthesis.planar.zero_pitch`) every member
``C(t) = t (t - 1) - lambda1 (t - 1) D_1 + lambda2 t D_2`` (``lambda1, lambda2 != 0``) of the plane of
``D_0 = 1, D_1, D_2`` is a quadratic motion through the poses (pose 0 at t = inf, pose 1 at t = 0 with
``C(0) = lambda1 D_1``, pose 2 at t = 1 with ``C(1) = lambda2 D_2``). Its two factorizations
``C = (t - h1)(t - h2) = (t - k1)(t - k2)`` (h1 and k2 carry the norm root with the smaller real part, as
for the Bennett linkage, docs/conic.md) close the loop h1 - h2 - k2 - k1: all axes parallel (planar, an
anti-parallelogram: opposite links equal) or all through one point (spherical).

`scan` factors a batch of members with the one batched Algorithm 1 (`synth.synthesis.bennett_core.solve`'s
steps: `norm_roots`, `quadratics`, `algorithm1`) and scores each like the 6R scan (docs/cubic.md,
section 6): conditioning of the norm roots first, then compactness, with the penalty that fits the
subgroup (`synth.synthesis.planar.axis_penalties`). `candidates` returns the best distinct members
as self-checked linkages; the CLI designs them in turn and keeps the first collision-free one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.algebra.algorithm1 import algorithm1, is_translation, multiply_back, norm_roots, quadratics, root_conditioning
from synth.algebra.geometry import dh_parameters, ring_normals
from synth.algebra.polynomial import norm_poly
from synth.checks import DEFAULT_CHECK_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.info import FamilyMember, LinkageInfo, Member
from synth.infoparts import BennettParameters, DHRow, ScoreParts, StudyForm
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett_core import ACCEPT_TOL, LOOP, acceptance_error, axis_distance, bennett_parameters
from synth.synthesis.conic import TS, Conditioning, conic_member, to_world
from synth.synthesis.planar import (ZeroPitch, axis_penalties, isogram_margin, isogram_penalty, study_forms,
                                    tracks_motion)
from synth.synthesis.sixbar_loops import root_pairs, score_warnings

GRID = 2.0 ** np.linspace(-3, 3, 13)  # |lambda| values of the default scan, each with both signs
ORDERS = np.array([[0, 1], [1, 0]])  # branch h, branch k
RESIDUAL_TOL = 1e-10  # multiply-back error above this: the member is invalid
MAX_BUILT = 12  # members built and checked (and followed by continuation, `tracks_motion`) at most
KAPPA_GOOD, COND_WEIGHT = 0.05, 3.0  # as the 6R score (docs/cubic.md, section 6)
LOOP_NAMES = ["h1", "h2", "k2", "k1"]
MOTION = "C(t) = t (t - 1) - lambda1 (t - 1) D1 + lambda2 t D2 (D_i = T_i T_0^-1; C(0) = lambda1 D1, C(1) = lambda2 D2)"
PART_KEYS = ("conditioning", "root_imag", "root_separation", "extent", "min_twist", "min_offset", "isogram",
             "residual", "penalty_conditioning", "penalty_size", "penalty_parallel", "penalty_intersect",
             "penalty_isogram")


@dataclass
class Scan:
    """Members of the conic family, factored and scored (conditioned frame)."""

    lam: np.ndarray  # (G, 2) lambda1, lambda2
    C: np.ndarray  # (G, 3, 8)
    H: np.ndarray  # (G, 2, 2, 8): branch h (h1, h2), branch k (k1, k2)
    roots: np.ndarray  # (G, 2) norm roots, Re ascending
    parts: dict  # PART_KEYS, each (G,)
    valid: np.ndarray  # (G,)
    score: np.ndarray  # (G,), 0 where invalid


def grid_members() -> np.ndarray:
    """The default scan's members (lambda1, lambda2), shape (G, 2): every sign and |lambda| in GRID."""
    vals = np.concatenate([-GRID[::-1], GRID])
    l1, l2 = np.meshgrid(vals, vals, indexing="ij")
    return np.stack([l1.ravel(), l2.ravel()], -1)


def scan(zp: ZeroPitch, lam) -> Scan:
    """Factor and score the members ``lam`` (G, 2) of the conic family of a three-pose set ``zp``."""
    lam = np.asarray(lam, float).reshape(-1, 2)
    C = conic_member(zp.D[None], lam)
    with np.errstate(all="ignore"):
        z = norm_roots(norm_poly(C))
        im, sep = root_conditioning(z)
        H, ok = algorithm1(C[:, None], quadratics(z)[:, ORDERS])  # (G, 2, 2, 8)
        residual = np.max(multiply_back(C[:, None], H), axis=1)
        F = H.reshape(-1, 4, 8)  # h1 h2 k1 k2
        # the lines of `synth.algebra.dq.factor_lines` with |v| by numpy.linalg.norm: the members of a
        # spherical family tie to the last ulp of their score, and fixtures/bennett_spherical.yaml keeps
        # its member with these roundings
        b = np.linalg.norm(F[..., 1:4], axis=-1)
        U, M = -F[..., 1:4] / b[..., None], F[..., 5:8] / b[..., None]
        geo = ring_normals(U[:, LOOP], M[:, LOOP])
        feet = geo.feet.reshape(len(F), 8, 3)  # conditioned: origin = centroid
        extent = np.max(np.linalg.norm(feet, axis=-1), axis=-1)
        tw = np.abs(geo.twist)
        min_twist = np.min(np.minimum(tw, np.pi - tw), axis=-1)
        min_offset = np.min(geo.distance, axis=-1)
        kappa = np.minimum(im, sep)
        iso = isogram_margin(zp.kind, geo.distance[:, :2], geo.twist[:, :2])
        parts = {"conditioning": kappa, "root_imag": im, "root_separation": sep, "extent": extent,
                 "min_twist": min_twist, "min_offset": min_offset, "isogram": iso, "residual": residual,
                 "penalty_isogram": isogram_penalty(iso),
                 "penalty_conditioning": np.maximum(0.0, np.log10(KAPPA_GOOD / kappa)),
                 "penalty_size": np.log10(extent), **axis_penalties(zp, min_twist, min_offset)}
        cost = (COND_WEIGHT * parts["penalty_conditioning"] + parts["penalty_size"] + parts["penalty_parallel"]
                + parts["penalty_intersect"] + parts["penalty_isogram"])
        valid = (ok.all(axis=1) & ~np.any(is_translation(H), axis=(1, 2)) & (residual <= RESIDUAL_TOL)
                 & np.isfinite(cost) & (kappa > 0) & np.all(lam != 0, axis=1))
        score = np.where(valid, 10.0 ** -cost, 0.0)
    return Scan(lam=lam, C=C, H=H, roots=z, parts=parts, valid=valid, score=np.where(np.isfinite(score), score, 0.0))


def ranked(zp: ZeroPitch, member=None) -> tuple[Scan, list[int]]:
    """The scan and its rows, best first: the given ``member`` (lambda1, lambda2), or the default grid's
    local maxima of the score (each compared with its four grid neighbours: distinct designs, not
    neighbouring grid points of one design)."""
    if member is not None:
        lam = np.asarray(member, float).reshape(1, 2)
        if not np.all(np.isfinite(lam)) or np.any(lam == 0):
            raise InputError(f"--member: lambda1 and lambda2 must be finite and nonzero, got {lam[0].tolist()}")
        sc = scan(zp, lam)
        return sc, [0] if sc.valid[0] else []
    sc = scan(zp, grid_members())
    n = 2 * len(GRID)
    s = sc.score.reshape(n, n)
    pad = np.pad(s, 1)
    keep = (s > 0) & (s >= pad[:-2, 1:-1]) & (s >= pad[2:, 1:-1]) & (s >= pad[1:-1, :-2]) & (s >= pad[1:-1, 2:])
    rows = np.flatnonzero(keep.ravel())
    return sc, rows[np.argsort(-sc.score[rows], kind="stable")].tolist()


def build(zp: ZeroPitch, sc: Scan, g: int, *, check_samples: int = DEFAULT_CHECK_SAMPLES, choice: str = ""):
    """The world-frame Linkage of scan row ``g`` with its info and checks (`self_check`)."""
    cond = zp.cond
    W = to_world(np.concatenate([sc.H[g].reshape(4, 8), sc.C[g]]), cond)
    H, K, C = W[:2], W[2:4], W[4:]
    l1, l2 = (float(x) for x in sc.lam[g])
    kind = f"{zp.kind}_4r"
    parts = {k: float(v[g]) for k, v in sc.parts.items()}
    record = FamilyMember(
        family=zp.describe(3, ("lambda1", "lambda2"), MOTION), member=Member(lambda1=l1, lambda2=l2),
        member_choice=choice or "given (--member)", score=float(sc.score[g]),
        score_parts=ScoreParts.of(parts), norm_roots=root_pairs(sc.roots[g]),
        factorization_residual=float(sc.parts["residual"][g]), study_form=StudyForm.of(study_forms(zp.D) * cond.scale),
        conditioning=Conditioning(cond.centre, float(cond.scale)))
    linkage = two_branch_linkage(kind, H, K, C, zp.poses, zp.names, TS, LinkageInfo(synthesis=record))
    linkage.checks = self_check(linkage, check_samples)
    U = np.array([linkage.joint(n).direction for n in LOOP_NAMES])[None]
    M = np.array([linkage.joint(n).moment for n in LOOP_NAMES])[None]
    geo = ring_normals(U, M)
    linkage.info = linkage.info.replace(
        bennett=BennettParameters.of_row(bennett_parameters(geo), 0, finite=True),
        dh=DHRow.table(dh_parameters(U, normals=geo).table(LOOP_NAMES, 0)),
        relative_error=accepted_error(linkage, zp.poses, zp.cond), warnings=score_warnings(parts))
    return linkage


def accepted_error(linkage, T, cond) -> float:
    """The relative self-check error of `synth.synthesis.bennett_core.acceptance_error` (translations to the
    pose spread, closure to the axes' distance) of a linkage through the poses T with conditioning
    ``cond``; a value above ACCEPT_TOL is not accepted (returned as is: the caller decides)."""
    c = linkage.checks
    U = np.array([j.direction for j in linkage.joints])[None]
    M = np.array([j.moment for j in linkage.joints])[None]
    far = axis_distance(U, M, np.asarray(cond.centre, float)[None])
    errors = {"pose_translation": np.array([c["max_pose_translation_error"]]),
              "pose_rotation": np.array([c["max_pose_rotation_error"]]),
              "closure_translation": np.array([c["max_closure_translation_error"]]),
              "closure_rotation": np.array([c["max_closure_rotation_error"]])}
    return float(acceptance_error(np.asarray(T, float)[None], np.array([float(cond.scale)]), far, errors)[0])


def candidates(zp: ZeroPitch, member=None, *, top: int = 1, check_samples: int = DEFAULT_CHECK_SAMPLES) -> list:
    """Up to ``top`` self-checked linkages of the conic family, best score first (the given ``member``
    (lambda1, lambda2) alone when given). Raises SynthesisError when none passes."""
    sc, rows = ranked(zp, member)
    if member is None:
        choice = (f"the best-scored of {len(sc.lam)} members (|lambda| from {GRID[0]:g} to {GRID[-1]:g}, both signs)"
                  "; score as the 6R scan (conditioning, extent, link lengths or angles)")
    else:
        choice = ""
    built = (build(zp, sc, g, check_samples=check_samples, choice=choice) for g in rows[:MAX_BUILT])
    out = select_tracked(built, member is not None, top, ACCEPT_TOL)
    if not out:
        raise _refusal(zp, member)
    return out


def select_tracked(built, explicit: bool, top: int, tol: float) -> list:
    """Up to ``top`` of the linkages ``built`` (an iterable, best first, consumed lazily) whose relative
    self-check error is at most ``tol``: those that follow their motion under continuation
    (`tracks_motion`) first, then the others with SWITCH_WARNING. An ``explicit`` member is kept either way."""
    out, switching = [], []
    for linkage in built:
        if linkage.info.relative_error > tol:
            continue
        tracked = tracks_motion(linkage)
        if not tracked and explicit:
            linkage.info = linkage.info.replace(warnings=linkage.info.warnings + (SWITCH_WARNING,))
        (out if tracked or explicit else switching).append(linkage)
        if len(out) >= top:
            return out
    for linkage in switching[: max(0, top - len(out))]:
        linkage.info = linkage.info.replace(warnings=linkage.info.warnings + (SWITCH_WARNING,))
        out.append(linkage)
    return out


SWITCH_WARNING = ("driven by h1 in 2-degree steps, a continuation can switch to the other branch at a flat "
                  "(change-point) configuration of a loop: pass those positions slowly or guide the mechanism there")


def _refusal(zp, member) -> SynthesisError:
    if member is not None:
        return SynthesisError(
            f"member lambda1 = {member[0]:g}, lambda2 = {member[1]:g} of the {zp.kind} family gives no valid "
            "four-bar (its norm polynomial has a real or repeated root, or the factorization is inaccurate); "
            "choose another member or omit --member")
    return SynthesisError(f"no member of the {zp.kind} family of quadratic motions through the poses gives an "
                          "accurate four-bar: the pose set is numerically degenerate")
