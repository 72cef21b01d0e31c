"""Point tasks of `mpsynth bennett` (5 points) and `mpsynth sixbar` (7 points): the tool point passes
through prescribed points (docs/points.md). Called by cli/bennett.py and cli/sixbar.py when the input
holds points."""
from __future__ import annotations

from synth.design.work import GAPS_PER_SECOND

from .common import (add_collisions, choose_buildable, default_robot_name, design_solutions, echo, emit_linkage,
                     fmt_len, print_json)

INDEX_FORMAT = "mpsynth.points-index/1"
COMMAND = {2: "mpsynth bennett", 3: "mpsynth sixbar"}
BUILDABLE_CANDIDATES = 4  # default design: the best-scored candidates designed, collision-free first
BUILDABLE_WORK = 7.0 * GAPS_PER_SECOND  # gap evaluations (synth.design.work)


def point_count(degree: int):
    """The count spec of a point file for `synth.io.poses.load_poses` (``points=``)."""
    from synth.synthesis.points import MINIMUM, NEEDED

    need, least = NEEDED[degree], MINIMUM[degree]
    return (least, need), COMMAND[degree]


def _design_line(lk) -> str:
    i, p = lk.info, lk.info["score_parts"]
    pair = f", pair {i['pair']}" if "pair" in i else ""
    ts = ", ".join(f"{t:.4g}" for t in i["parameters"][1:] + i["chosen_parameters"])
    return (f"  point design: parameters t = {ts}{pair}; score {i['score']:.3g} (conditioning "
            f"{p['conditioning']:.3g}, extent {p['extent']:.3g} x spread, min twist "
            f"{p['min_twist'] * 57.29577951308232:.1f} deg, min offset {p['min_offset']:.3g} x spread)")


def run_point_task(ps, degree: int, top, *, out, name, force, package, sizes, quiet, as_json, require_free):
    """Synthesize, design, write and summarize a point task (``top``: None = the best design only)."""
    from synth.checks import VERIFY_SAMPLES
    from synth.errors import InputError, SynthesisError
    from synth.synthesis.points import oriented_item, point_candidates

    try:
        oriented, rot = oriented_item(ps.matrices, ps.kinds, ps.names)
    except InputError as e:
        raise InputError(f"{ps.source}: {e}") from e
    want = top or (BUILDABLE_CANDIDATES if (out or as_json or require_free) else 1)
    try:
        linkages = point_candidates(ps.positions, ps.names, degree=degree, top=want, tool_rotation=rot,
                                    oriented=oriented, check_samples=VERIFY_SAMPLES)
    except (SynthesisError, InputError) as e:
        raise type(e)(f"{ps.source}: {e}") from e
    if top is None:
        _single(ps, linkages, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
                as_json=as_json, require_free=require_free)
    else:
        _ranked(ps, linkages, top, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
                as_json=as_json, require_free=require_free)


def _single(ps, linkages, *, out, name, force, package, sizes, quiet, as_json, require_free):
    result = None
    linkage = linkages[0]
    if out or as_json or require_free:
        linkage, result = choose_buildable(linkages, ps, sizes, limit=BUILDABLE_CANDIDATES, work=BUILDABLE_WORK,
                                           what="interpolants")

    def details():
        echo(_design_line(linkage))
        bp = linkage.info.get("bennett")
        if bp:
            scale, unit = ps.length_scale, ps.length_unit
            echo(f"  Bennett: a = {fmt_len(bp['a'], scale, unit)}, alpha = {bp['alpha']:.6f} rad, "
                 f"b = {fmt_len(bp['b'], scale, unit)}, beta = {bp['beta']:.6f} rad")
        if linkage.info["chosen_points"]:
            pts = "; ".join(" ".join(f"{x / ps.length_scale:.6g}" for x in p) for p in linkage.info["chosen_points"])
            echo(f"  chosen points ({ps.length_unit}): {pts}")

    emit_linkage(linkage, source=ps.source, scale=ps.length_scale, unit=ps.length_unit, out=out, name=name,
                 force=force, package=package, sizes=sizes, quiet=quiet, as_json=as_json, details=details,
                 require_free=require_free, result=result)


def solution_id(rank: int, linkage) -> str:
    return f"{rank:02d}-{linkage.kind}" + (f"-p{linkage.info['pair']}" if "pair" in linkage.info else "")


def index_document(ps, linkages, ids, results) -> dict:
    from synth.synthesis.points import SCORE_RULE

    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        c = lk.checks
        sol = {"id": sid, "rank": rank, "path": f"{sid}/", "parameters": lk.info["parameters"],
               "chosen_points": lk.info["chosen_points"], "score": lk.info["score"],
               "score_parts": lk.info["score_parts"],
               "checks": {k: c[k] for k in ("max_pose_error", "max_pose_translation_error", "max_closure_error")}}
        if "pair" in lk.info:
            sol["pair"] = lk.info["pair"]
        sols.append(sol)
    if results is not None:
        add_collisions(sols, results, ps)
    return {"format": INDEX_FORMAT, "kind": linkages[0].kind, "task": "points", "poses": ps.source,
            "units": {"length": "m", "angle": "rad"}, "input_length_unit": ps.length_unit,
            "input_length_scale": ps.length_scale, "score_rule": SCORE_RULE, "freedom": linkages[0].info["freedom"],
            "solutions": sols}


def _ranked(ps, linkages, top, *, out, name, force, package, sizes, quiet, as_json, require_free):
    from synth.io.jsonout import plain
    from synth.io.writer import write_solutions

    results = None
    if out or as_json or require_free:  # the physical design of every solution, collision-free first
        linkages, results = design_solutions(linkages, ps, sizes, quiet=quiet, require_free=require_free,
                                             what="designs")
    ids = [solution_id(r, lk) for r, lk in enumerate(linkages, start=1)]
    doc = index_document(ps, linkages, ids, results)
    if not quiet:
        echo(f"{linkages[0].kind} designs through {len(ps)} points: the {len(linkages)} best of the scan"
             + (f" (asked for {top})" if len(linkages) < top else "") + " (extent and offset in point spreads)")
        for s in doc["solutions"]:
            p = s["score_parts"]
            echo(f"  {s['rank']:>3} {s['id']:14} score {s['score']:.3g}  cond {p['conditioning']:.3g}  extent "
                 f"{p['extent']:.3g}  point err {s['checks']['max_pose_translation_error']:.1e}"
                 + (f"  {s['design_summary']}" if "design_summary" in s else ""))
    if out:
        base = name or default_robot_name(ps.source)
        sols = [(sid, lk, f"{base}_{sid.replace('-', '_')}", r) for lk, sid, r in zip(linkages, ids, results)]
        write_solutions(out, sols, doc, force=force, package=package)
        if not quiet:
            echo(f"  wrote {out}/: index.json and {len(ids)} solution directories")
    if as_json:
        print_json(plain(doc))
