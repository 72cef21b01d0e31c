"""The index documents of ranked solutions (``OUT/index.json`` of ``--top``): the solutions' ids, ranks,
scores, checks and, with designs, their collision reports and sentences. Lengths in metres, angles in
radians (``input_length_unit``/``input_length_scale`` give the task's unit)."""
from __future__ import annotations

from synth.info import FamilyMember, PointsCandidate
from synth.infoparts import document

SIXBAR_FORMAT = "mpsynth.sixbar-index/1"
POINTS_FORMAT = "mpsynth.points-index/1"
TASK_FORMAT = "mpsynth.task-index/1"
FOURBAR_FORMAT = "mpsynth.fourbar-index/1"
SIXBAR_CHECKS = ("max_pose_error", "max_pose_translation_error", "max_pose_rotation_error", "max_closure_error",
                 "max_closure_translation_error", "max_closure_rotation_error", "max_motion_error")
POINT_CHECKS = ("max_pose_error", "max_pose_translation_error", "max_closure_error")
UNITS = {"length": "m", "angle": "rad"}


def sixbar_solution_id(rank: int, linkage) -> str:
    """Directory name of a ranked 6R solution: rank, family and pair (planar or spherical: the chain)."""
    s = linkage.info.synthesis
    if isinstance(s, FamilyMember):
        return f"{rank:02d}-{s.family.kind}-c{s.chain}"
    return f"{rank:02d}-f{s.family}-p{s.pair}"


def point_solution_id(rank: int, linkage) -> str:
    """Directory name of a ranked point-task solution: rank, kind and (6R) pair."""
    pair = linkage.info.synthesis.pair
    return f"{rank:02d}-{linkage.kind}" + (f"-p{pair}" if pair is not None else "")


def sixbar_index(linkages, ids, ps) -> dict:
    """index.json of ranked 6R solutions of the task ``ps`` (a `synth.task.PoseSet`)."""
    from synth.synthesis.sixbar import SCORE_RULE

    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        s = lk.info.synthesis
        sols.append({"id": sid, "rank": rank, "path": f"{sid}/", "family": document(s.family),
                     "member": document(s.member), "pair": s.chain if isinstance(s, FamilyMember) else s.pair,
                     "t3": s.t3, "score": s.score, "score_parts": document(s.score_parts),
                     "checks": {k: lk.checks[k] for k in SIXBAR_CHECKS}})
    return {"format": SIXBAR_FORMAT, "kind": linkages[0].kind if linkages else "6r", "poses": ps.source,
            "units": dict(UNITS), "input_length_unit": ps.length_unit, "input_length_scale": ps.length_scale,
            "score_rule": SCORE_RULE, "solutions": sols}


def point_index(linkages, ids, ps) -> dict:
    """index.json of ranked point-task solutions of the task ``ps``."""
    from synth.synthesis.points import SCORE_RULE

    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        s: PointsCandidate = lk.info.synthesis
        sol = {"id": sid, "rank": rank, "path": f"{sid}/", "parameters": document(s.parameters),
               "chosen_points": document(s.chosen_points), "score": s.score, "score_parts": document(s.score_parts),
               "checks": {k: lk.checks[k] for k in POINT_CHECKS}}
        if s.pair is not None:
            sol["pair"] = s.pair
        sols.append(sol)
    return {"format": POINTS_FORMAT, "kind": linkages[0].kind, "task": "points", "poses": ps.source,
            "units": dict(UNITS), "input_length_unit": ps.length_unit, "input_length_scale": ps.length_scale,
            "score_rule": SCORE_RULE, "freedom": linkages[0].info.synthesis.freedom, "solutions": sols}


def task_solution_id(rank: int, linkage) -> str:
    """Directory name of a ranked fit: rank and kind."""
    return f"{rank:02d}-{linkage.kind}"


def task_index(linkages, ids, ps) -> dict:
    """index.json of the ranked fits of a task file ``ps`` (docs/fit.md)."""
    sols = [{"id": sid, "rank": r, "path": f"{sid}/", "fit": document(lk.info.fit)}
            for r, (sid, lk) in enumerate(zip(ids, linkages), start=1)]
    return {"format": TASK_FORMAT, "kind": linkages[0].kind, "task": "poses", "poses": ps.source,
            "units": dict(UNITS), "solutions": sols}


def fourbar_index(linkages, ids, ps) -> dict:
    """index.json of ranked four-bars of the task ``ps``: lengths, transmission, extent, cost, checks."""
    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        f = lk.info.synthesis.fourbar
        sols.append({"id": sid, "rank": rank, "path": f"{sid}/", "lengths": document(f.lengths),
                     "transmission_min_deg": f.transmission_min_deg, "extent": f.extent, "cost": f.cost,
                     "checks": {k: lk.checks[k] for k in ("max_pose_error", "max_closure_error")},
                     **({"fit": document(lk.info.fit)} if lk.info.fit is not None else {})})
    return {"format": FOURBAR_FORMAT, "kind": "planar_fourbar", "poses": ps.source, "units": dict(UNITS),
            "input_length_unit": ps.length_unit, "input_length_scale": ps.length_scale,
            "score_rule": linkages[0].info.synthesis.score_rule, "solutions": sols}


def add_collisions(solutions: list, results, sentence) -> None:
    """Each solution's collision report and ``sentence(result)`` (the input's length unit)."""
    for sol, r in zip(solutions, results):
        sol["collision"] = r.collision.to_dict()
        sol["design_summary"] = sentence(r)
