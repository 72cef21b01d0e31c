"""Linkages whose tool point passes through prescribed points (docs/points.md): five points give a
Bennett 4R linkage, seven points a spatial 6R linkage.

``bennett_points(points)`` / ``sixbar_points(points)`` take (k, 3) points in metres and return the best
verified `Linkage`; ``point_candidates`` returns the ranked designs. Pipeline: validate and condition
the points (origin at their centroid, lengths divided by their RMS spread) -> `synth.synthesis.pointfit.scan`
(one batched linear solve per member, the batched Algorithm 1, the engineering score of every loop) ->
the best distinct candidates built with `synth.synthesis.assemble.two_branch_linkage` (factors polished
by `synth.algebra.algorithm1.polish`), mapped to the world frame and self-checked
(`synth.checks.self_check`, accepted by `synth.synthesis.sixbar.checks_pass`).

Conventions: point 0 is visited at t = inf (all joint angles 0, the reference configuration; the tool
frame there is ``tool_ref``: the given orientation of point 0 when it has one, else the world axes),
points 1..k-1 at -1 = t_1 < t_2 < ... in the order given. Each point is a `PoseRecord` with
``kind = "point"``; its matrix is the tool pose reached there (orientation as the motion gives it,
position as given). Points missing from the task (fewer than 5 or 7) are chosen by the scan and
reported in ``info.synthesis.chosen_points``.
"""
from __future__ import annotations

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.polynomial import pose_at, product_of_linear
from synth.checks import DEFAULT_CHECK_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.info import LinkageInfo, Orders, PointsCandidate
from synth.infoparts import ScoreParts
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett import LOOP_NAMES, bennett_parameters_of, dh_table
from synth.synthesis.conic import Conditioning, to_world
from synth.synthesis.pointfit import PointScan, rereference, scan
from synth.synthesis.sixbar import CHECK_TOL, LOOP, checks_pass
from synth.synthesis.sixbar_loops import SCORE_RULE, root_pairs, score_warnings
from synth.task import MINIMUM, NEEDED, default_name

__all__ = ["bennett_points", "sixbar_points", "point_candidates", "prepare_points", "oriented_item", "PointTask",
           "NEEDED",
           "MINIMUM", "KINDS", "SCORE_RULE"]

KINDS = {2: "bennett", 3: "6r"}
COINCIDENT_TOL = 1e-9  # relative to the points' RMS spread
COLLINEAR_TOL = 1e-9
MAX_ATTEMPTS = 8
DISTINCT = 0.05  # candidates closer than this in parameters (and chosen points, in spreads) are one design


class PointTask:
    """Points prepared for synthesis: world points (k, 3) in metres, names, the degree (2: Bennett,
    3: 6R), the conditioning (centroid, RMS spread) and the conditioned points Y (k, 3). With
    ``rotation`` (3, 3) item ``oriented`` is a full pose (the tool frame's orientation there; ``kinds``):
    the scan then runs on the items in the cyclic order ``order`` that starts with it (its parameter
    is infinity), and the linkage is re-referenced to item 0 (`synth.synthesis.pointfit.rereference`)."""

    def __init__(self, points, names, degree: int, rotation=None, oriented: int = 0):
        self.points = points
        self.names = names
        self.degree = degree
        c = points.mean(axis=0)
        L = float(np.sqrt(np.mean(np.sum((points - c) ** 2, axis=-1))))
        self.cond = Conditioning(centre=c, scale=L)
        self.Y = (points - c) / L
        k = len(points)
        self.oriented = int(oriented) if rotation is not None else 0
        self.order = list(range(self.oriented, k)) + list(range(self.oriented))
        self.ref_pose = np.eye(4)  # tool pose at the scan's first item (world)
        self.ref_pose[:3, 3] = points[self.oriented]
        self.kinds = ["point"] * k
        if rotation is not None:
            self.ref_pose[:3, :3] = rotation
            self.kinds[self.oriented] = "pose"

    @property
    def missing(self) -> int:
        return NEEDED[self.degree] - len(self.points)


def prepare_points(points, names=None, *, degree: int, tool_rotation=None, oriented: int = 0) -> PointTask:
    """Validate points (k, 3) (metres) for a point task of ``degree`` 2 (Bennett) or 3 (6R).
    InputError: wrong shape or count (the message says what is needed), NaN; SynthesisError:
    coincident points, or a full set of collinear points (no linkage moves a point along a line
    through that many points) or of coplanar points (docs/points.md, section 4)."""
    P = np.asarray(points, float)
    kind = "a Bennett linkage" if degree == 2 else "a 6R linkage"
    if P.ndim != 2 or P.shape[-1] != 3:
        raise InputError(f"points must be an array of shape (k, 3), got {P.shape}")
    k, need, least = len(P), NEEDED[degree], MINIMUM[degree]
    if not least <= k <= need:
        raise InputError(f"{kind} through points needs {need} points (or {least} to {need - 1}, the rest chosen "
                         f"by the design search), got {k}")
    if not np.isfinite(P).all():
        raise InputError("the points contain NaN or infinity")
    names = list(names) if names is not None else [default_name(i) for i in range(k)]
    c = P.mean(axis=0)
    L = float(np.sqrt(np.mean(np.sum((P - c) ** 2, axis=-1))))
    i, j = np.triu_indices(k, 1)
    d = np.linalg.norm(P[i] - P[j], axis=-1)
    close = np.nonzero(d <= COINCIDENT_TOL * max(L, 1e-300))[0]
    if len(close):
        a, b = int(i[close[0]]), int(j[close[0]])
        raise SynthesisError(f"points {a} ({names[a]!r}) and {b} ({names[b]!r}) coincide: "
                             f"{kind} needs distinct points")
    sv = np.linalg.svd(P - c, compute_uv=False)
    if k == need and sv[1] <= COLLINEAR_TOL * sv[0]:
        raise SynthesisError(f"the {k} points are collinear: the tool point of {kind} meets a line in at most "
                             f"{2 * degree} points, so no linkage passes through them all")
    if k == need and sv[2] <= COLLINEAR_TOL * sv[0]:
        raise SynthesisError(f"the {k} points are coplanar: the motion through them is then planar (the reflection in "
                             f"their plane maps it to another motion through the same points, and it is unique), so "
                             f"{kind} of revolute joints does not follow it; move a point out of the plane")
    return PointTask(P, names, degree, tool_rotation, oriented)


def oriented_item(matrices, kinds, names) -> tuple[int, np.ndarray | None]:
    """(index, orientation (3, 3)) of the one item of a point task that is a full pose
    (``kinds[i] == "pose"``: the tool frame's orientation there), or (0, None); InputError when more
    than one item has an orientation (each costs three conditions that the point count leaves no room
    for; docs/points.md)."""
    posed = [i for i, kind in enumerate(kinds) if kind == "pose"]
    if len(posed) > 1:
        a, b = posed[:2]
        p = kinds.index("point")
        raise InputError(f"pose {p}: missing orientation (or, as a point task, too many orientations: items {a} "
                         f"({names[a]!r}) and {b} ({names[b]!r}) both have one, a point task takes at most one)")
    return (posed[0], np.asarray(matrices, float)[posed[0], :3, :3]) if posed else (0, None)


def _ranked_entries(sc: PointScan, task: PointTask, base_box=None):
    """Yield (member, loop) of the valid loops, best score first (with ``base_box``, those whose ground
    axes pass through it first: `synth.synthesis.steer.ground_box_distance`), one per design
    (`DISTINCT`), lazily."""
    s, p = np.nonzero(sc.valid)
    order = np.argsort(-sc.score[s, p], kind="stable")
    if base_box is not None:
        from synth.synthesis.steer import conditioned_box, ground_box_distance

        miss = ground_box_distance(sc.H, sc.pairs, conditioned_box(base_box, task.cond))[s, p] > 1e-9
        order = order[np.argsort(miss[order], kind="stable")]
    key = np.concatenate([sc.t, sc.Y[:, len(task.points):].reshape(len(sc.t), -1)], -1)
    kept_keys, kept_loops = np.empty((0, key.shape[1])), np.empty(0, int)
    for si, pi in zip(s[order].tolist(), p[order].tolist()):
        near = np.max(np.abs(kept_keys - key[si]), axis=-1, initial=0.0) < DISTINCT
        if np.any(near & (kept_loops == pi)):
            continue
        kept_keys, kept_loops = np.vstack([kept_keys, key[si]]), np.append(kept_loops, pi)
        yield si, pi


def build_point_linkage(task: PointTask, sc: PointScan, member: int, loop: int, *,
                        check_samples: int = DEFAULT_CHECK_SAMPLES):
    """The world-frame, self-checked Linkage of loop ``loop`` of scan member ``member``."""
    n = task.degree
    oh, ok_ = sc.pairs[loop]
    C = sc.C[member]
    HK, _ = a1.polish(C, np.stack([sc.H[member, oh], sc.H[member, ok_]]))
    res = float(np.max(np.maximum(a1.multiply_back(C, HK), a1.study_violation(HK))))
    W = to_world(np.concatenate([HK[0], HK[1], C]), task.cond)
    H, K, Cw = W[:n], W[n:2 * n], W[2 * n:]
    k = len(task.points)
    params = np.concatenate([[np.inf], sc.t[member]])  # of the scan's items (task.order, then the chosen)
    where = np.argsort(task.order)  # scan position of each item
    tool_ref = task.ref_pose
    if task.oriented:  # the reference configuration back at item 0
        t0 = float(params[where[0]])
        tool_ref = pose_at(Cw, t0) @ task.ref_pose
        tool_ref[:3, 3] = task.points[0]
        H, K = rereference(H, t0), rereference(K, t0)
        Cw = product_of_linear(H)
        with np.errstate(divide="ignore"):
            params = np.where(np.isinf(params), 0.0, 1.0 / (t0 - params))
        params[where[0]] = np.inf
    ts = params[where]
    T = pose_at(Cw, ts) @ tool_ref
    T[:, :3, 3] = task.points
    T[0] = tool_ref
    if task.kinds[task.oriented] == "pose":
        T[task.oriented] = task.ref_pose
    parts = {key: float(v[member, loop]) for key, v in sc.parts.items()}
    chosen = (sc.Y[member, k:] * task.cond.scale + task.cond.centre).tolist()
    record = PointsCandidate(
        points=k, parameters=tuple(None if np.isinf(x) else float(x) for x in ts), score=float(sc.score[member, loop]),
        score_parts=ScoreParts.of(parts), orders=Orders(h=tuple(sc.orders[oh].tolist()), k=tuple(sc.orders[ok_].tolist())),
        norm_roots=root_pairs(sc.roots[member]), factorization_residual=res,
        chosen_points=tuple(tuple(p) for p in chosen), chosen_parameters=tuple(params[k:].tolist()),
        conditioning=Conditioning(task.cond.centre, float(task.cond.scale)), freedom=freedom_text(task, len(sc.t)),
        pair=int(loop + 1) if n == 3 else None)
    linkage = two_branch_linkage(KINDS[n], H, K, Cw, T, task.names, ts, LinkageInfo(synthesis=record))
    for rec, kind in zip(linkage.poses, task.kinds):
        rec.kind = kind
    linkage.info = linkage.info.replace(
        bennett=bennett_parameters_of(linkage) if n == 2 else None,
        dh=dh_table(linkage, LOOP_NAMES if n == 2 else LOOP), warnings=score_warnings(parts, "motion", "points"))
    linkage.checks = self_check(linkage, check_samples)
    return linkage


def freedom_text(task: PointTask, samples: int) -> str:
    """How the free design parameters were chosen, in words (``info.synthesis.freedom``)."""
    n = task.degree
    free = 2 * n - 2
    text = (f"{len(task.points)} points given; point 0 at t = inf, the others at -1 = t1 < ... < t{2 * n} = 1; "
            f"the {free} interior parameters")
    if task.missing:
        text += (f" and the {task.missing} missing point{'s' if task.missing > 1 else ''} (appended after the given "
                 "ones, reported in chosen_points; give them as points to fix them)")
    return text + f" chosen by the engineering score over {samples} seeded samples (score_rule)"


def point_candidates(points, names=None, *, degree: int, top: int | None = None, samples: int | None = None,
                     seed: int = 0, tool_rotation=None, oriented: int = 0,
                     check_samples: int = DEFAULT_CHECK_SAMPLES, base_box=None):
    """The best distinct verified linkages through the points (k, 3) (metres), best score first, at
    most ``top`` (default all that pass; the first MAX_ATTEMPTS failures stop the search). With
    ``tool_rotation`` item ``oriented`` is a full pose (`PointTask`). ``base_box`` (`synth.task.Box`): a
    scan `synth.synthesis.steer.BOX_SCAN` times as large, the designs whose ground axes pass through the
    box first. SynthesisError when none passes."""
    task = prepare_points(points, names, degree=degree, tool_rotation=tool_rotation, oriented=oriented)
    if base_box is not None:
        from synth.synthesis.pointfit import SAMPLES
        from synth.synthesis.steer import BOX_SCAN

        samples = samples or BOX_SCAN * SAMPLES[degree]
    sc = scan(task.Y[task.order], degree, samples=samples, seed=seed)
    entries = _ranked_entries(sc, task, base_box)
    if not sc.valid.any():
        raise SynthesisError(f"no member of the {len(sc.t)} scanned motions through the points gives a real "
                             f"{KINDS[degree]} linkage (every one has a nearly real or repeated norm factor or a "
                             "translation factor): the points are close to a degenerate configuration")
    out, failed, first = [], 0, None
    for s, p in entries:
        linkage = build_point_linkage(task, sc, s, p, check_samples=check_samples)
        first = first or linkage
        if checks_pass(linkage, task.cond.scale):
            out.append(linkage)
            if top and len(out) >= top:
                break
        else:
            failed += 1
            if failed >= MAX_ATTEMPTS and not out:
                break
    if not out:
        c = first.checks
        raise SynthesisError(f"the best {KINDS[degree]} candidates through the points do not pass the self-check at "
                             f"{CHECK_TOL:g} relative (point error {c['max_pose_translation_error']:.2g} m, closure "
                             f"error {c['max_closure_error']:.2g}): the points are numerically degenerate")
    return out


def bennett_points(points, names=None, **kw):
    """The best Bennett linkage whose tool point visits the points (k, 3), k = 5 (3 or 4: the rest chosen);
    keyword arguments as `point_candidates`."""
    return point_candidates(points, names, degree=2, top=1, **kw)[0]


def sixbar_points(points, names=None, **kw):
    """The best 6R linkage whose tool point visits the points (k, 3), k = 7 (4 to 6: the rest chosen);
    keyword arguments as `point_candidates`."""
    return point_candidates(points, names, degree=3, top=1, **kw)[0]

