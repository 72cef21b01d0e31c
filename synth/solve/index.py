"""The index documents of ranked solutions (``OUT/index.json`` of ``--top``): the solutions' ids, ranks,
scores, checks and, with designs, their collision reports and sentences. Lengths in metres, angles in
radians (``input_length_unit``/``input_length_scale`` give the task's unit)."""
from __future__ import annotations

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
    if isinstance(linkage.info.get("family"), dict):
        return f"{rank:02d}-{linkage.info['family']['kind']}-c{linkage.info['chain']}"
    return f"{rank:02d}-f{linkage.info['family']}-p{linkage.info['pair']}"


def point_solution_id(rank: int, linkage) -> str:
    """Directory name of a ranked point-task solution: rank, kind and (6R) pair."""
    return f"{rank:02d}-{linkage.kind}" + (f"-p{linkage.info['pair']}" if "pair" in linkage.info else "")


def sixbar_index(linkages, ids, ps) -> dict:
    """index.json of ranked 6R solutions of the task ``ps`` (a `synth.task.PoseSet`)."""
    from synth.synthesis.sixbar import SCORE_RULE

    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        i = lk.info
        sols.append({"id": sid, "rank": rank, "path": f"{sid}/", "family": i["family"], "member": i["member"],
                     "pair": i.get("pair", i.get("chain")), "t3": i["t3"], "score": i["score"],
                     "score_parts": i["score_parts"], "checks": {k: lk.checks[k] for k in SIXBAR_CHECKS}})
    return {"format": SIXBAR_FORMAT, "kind": linkages[0].kind if linkages else "6r", "poses": ps.source,
            "units": dict(UNITS), "input_length_unit": ps.length_unit, "input_length_scale": ps.length_scale,
            "score_rule": SCORE_RULE, "solutions": sols}


def point_index(linkages, ids, ps) -> dict:
    """index.json of ranked point-task solutions of the task ``ps``."""
    from synth.synthesis.points import SCORE_RULE

    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        i = lk.info
        sol = {"id": sid, "rank": rank, "path": f"{sid}/", "parameters": i["parameters"],
               "chosen_points": i["chosen_points"], "score": i["score"], "score_parts": i["score_parts"],
               "checks": {k: lk.checks[k] for k in POINT_CHECKS}}
        if "pair" in i:
            sol["pair"] = i["pair"]
        sols.append(sol)
    return {"format": POINTS_FORMAT, "kind": linkages[0].kind, "task": "points", "poses": ps.source,
            "units": dict(UNITS), "input_length_unit": ps.length_unit, "input_length_scale": ps.length_scale,
            "score_rule": SCORE_RULE, "freedom": linkages[0].info["freedom"], "solutions": sols}


def task_solution_id(rank: int, linkage) -> str:
    """Directory name of a ranked fit: rank and kind."""
    return f"{rank:02d}-{linkage.kind}"


def task_index(linkages, ids, ps) -> dict:
    """index.json of the ranked fits of a task file ``ps`` (docs/fit.md)."""
    sols = [{"id": sid, "rank": r, "path": f"{sid}/", "fit": lk.info["fit"]}
            for r, (sid, lk) in enumerate(zip(ids, linkages), start=1)]
    return {"format": TASK_FORMAT, "kind": linkages[0].kind, "task": "poses", "poses": ps.source,
            "units": dict(UNITS), "solutions": sols}


def fourbar_index(linkages, ids, ps) -> dict:
    """index.json of ranked four-bars of the task ``ps``: lengths, transmission, extent, cost, checks."""
    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        f = lk.info["fourbar"]
        sols.append({"id": sid, "rank": rank, "path": f"{sid}/", "lengths": f["lengths"],
                     "transmission_min_deg": f["transmission_min_deg"], "extent": f["extent"], "cost": f["cost"],
                     "checks": {k: lk.checks[k] for k in ("max_pose_error", "max_closure_error")},
                     **({"fit": lk.info["fit"]} if "fit" in lk.info else {})})
    return {"format": FOURBAR_FORMAT, "kind": "planar_fourbar", "poses": ps.source, "units": dict(UNITS),
            "input_length_unit": ps.length_unit, "input_length_scale": ps.length_scale,
            "score_rule": linkages[0].info["score_rule"], "solutions": sols}


def add_collisions(solutions: list, results, sentence) -> None:
    """Each solution's collision report and ``sentence(result)`` (the input's length unit)."""
    for sol, r in zip(solutions, results):
        sol["collision"] = r.collision.to_dict()
        sol["design_summary"] = sentence(r)
