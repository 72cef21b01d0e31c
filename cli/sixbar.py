"""`mpsynth sixbar POSES -o OUT`: four poses in, ranked spatial 6R linkages out."""
from __future__ import annotations

import click

from synth.design.work import GAPS_PER_SECOND

from .common import (add_collisions, choose_buildable, default_robot_name, design_solutions, echo, mesh_sizes,
                     print_json, run_guarded, synthesis_options)

INDEX_FORMAT = "mpsynth.sixbar-index/1"


@click.command(epilog="""\b
Numbering:
  --family 1|2   family 1 is the family of cubic motions with the larger t3 (parameter of pose 3)
  --member L     the member of the family with C(0) = L * D1 (its weight at pose 1)
  --pair K       1..9: the pairs of factorizations that close a 6R loop, in lexicographic order
Planar or spherical poses (docs/planar.md): a Watt six-bar (7 joints) of a member of the cubic family:
  --member T3,L1,L2,L3   pose 3 at t = T3, C(0) = L1 D1, C(1) = L2 D2, C(T3) = L3 D3
  --pair K       1..6: the chain (the order of branch h)
\b
Examples:
  mpsynth sixbar fixtures/sixbar_example.yaml -o out_sixbar
  mpsynth sixbar fixtures/sixbar_example.yaml --top 5 -o out_designs
  mpsynth sixbar poses.yaml --family 2 --member 0.5 --pair 1 -o out_one
  mpsynth sixbar fixtures/sixbar_points.yaml -o out_points""")
@click.argument("poses", metavar="POSES")
@click.option("--family", type=click.IntRange(1, 2), help="Only this family of cubic motions (1 or 2).")
@click.option("--member", metavar="L", help="Only this member of the family, by its label lambda1 (C(0) = lambda1 D1); "
                                           "planar or spherical poses: T3,L1,L2,L3 (write --member=-1,... for a "
                                           "negative first value).")
@click.option("--pair", type=click.IntRange(1, 9), help="Only this loop pair (1..9) of the member's factorizations.")
@click.option("--top", type=click.IntRange(1, 1000), default=None,
              help="Write the N best designs to OUT/<id>/ with OUT/index.json and print the ranking.")
@click.option("--best-effort", is_flag=True,
              help="Fits: when the tolerances cannot be met, write the best linkage anyway (info.fit.within_tolerance "
                   "false) instead of exiting 1.")
@synthesis_options
@run_guarded
def sixbar(poses, family, member, pair, top, best_effort, out, name, force, pin_radius, link_radius, pin_length,
           clearance, hole_clearance, require_collision_free, package, normalize, quiet, as_json, debug):
    """Synthesize a spatial 6R linkage whose coupler passes through the four poses in POSES (YAML or
    JSON, '-' for stdin; see README for the format). With seven points instead (a `points:` list, or
    poses with a position only; 4 to 6: the rest is chosen) the tool point passes through them
    (docs/points.md).

    By default the best design by the engineering score (well-conditioned factorization first, then a
    compact linkage without nearly parallel or nearly intersecting consecutive axes) over both families
    of cubic motions is written to OUT (linkage.urdf, linkage.json, meshes/*.stl, lengths in metres).
    Exit status 1 when no real 6R linkage exists (e.g. the poses' quadric is oval)."""
    from synth.io.poses import load_poses

    from .points import point_count, run_point_task

    ps = load_poses(poses, count=((2, None), "mpsynth sixbar"), normalize=normalize, points=point_count(3))
    if member is not None and not ps.has_points:
        member = parse_member(member)
    sizes = mesh_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                            clearance=clearance, hole_clearance=hole_clearance), ps.length_scale)
    if ps.has_points:
        if family is not None or member is not None or pair is not None:
            from synth.errors import InputError

            raise InputError("--family, --member and --pair select among the cubics through four poses; a point "
                             "task has no families (use --top to see its ranked designs)")
        return run_point_task(ps, 3, top, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
                              as_json=as_json, require_free=require_collision_free)
    from synth.synthesis.sixbar_task import is_task

    if is_task(ps):  # tolerances, velocities, a listed order or other than four poses (docs/sixbar_fit.md)
        from synth.errors import InputError
        from synth.synthesis.sixbar_task import sixbar_task

        from .task import run_task

        if family is not None or member is not None or pair is not None:
            raise InputError("--family, --member and --pair select among the cubics through four exact poses; a task "
                             "with tolerances, velocities or another count ranks its own designs (use --top)")
        return run_task(ps, top, best_effort, sixbar_task, out=out, name=name, force=force, package=package,
                        sizes=sizes, quiet=quiet, as_json=as_json, require_free=require_collision_free)
    if top is None:
        _single(ps, family, member, pair, out=out, name=name, force=force, package=package, sizes=sizes,
                quiet=quiet, as_json=as_json, require_free=require_collision_free)
    else:
        _ranked(ps, family, member, pair, top, out=out, name=name, force=force, package=package, sizes=sizes,
                quiet=quiet, as_json=as_json, require_free=require_collision_free)


def parse_member(text: str):
    """--member: one number (lambda1 of a spatial family) or four (T3,L1,L2,L3 of a planar or spherical one)."""
    import math

    from synth.errors import InputError

    try:
        vals = [float(x) for x in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (1, 4) or not all(math.isfinite(v) for v in vals):
        raise InputError(f"--member needs one finite number (lambda1) or four (T3,L1,L2,L3), got {text!r}")
    return vals[0] if len(vals) == 1 else vals


def _design_line(info) -> str:
    p = info["score_parts"]
    if isinstance(info.get("family"), dict):  # a planar or spherical Watt six-bar (docs/planar.md)
        m = info["member"]
        return (f"  {info['family']['kind']} Watt six-bar (7 joints): member t3 = {m['t3']:.6g}, lambda = "
                f"({m['lambda1']:.6g}, {m['lambda2']:.6g}, {m['lambda3']:.6g}), chain {info['chain']}; score "
                f"{info['score']:.3g} (conditioning {p['conditioning']:.3g}, extent {p['extent']:.3g} x spread)")
    return (f"  6R design: family {info['family']} (t3 = {info['t3']:.6g}), member lambda1 = {info['member']:.6g}, "
            f"pair {info['pair']}; score {info['score']:.3g} (conditioning {p['conditioning']:.3g}, "
            f"extent {p['extent']:.3g} x spread, min twist {p['min_twist'] * 57.29577951308232:.1f} deg, "
            f"min offset {p['min_offset']:.3g} x spread)")


BUILDABLE_CANDIDATES = 8  # default design: the best-scored candidates searched, collision-free first
BUILDABLE_WORK = 7.0 * GAPS_PER_SECOND  # gap evaluations of those design searches (synth.design.work; rank_buildable)


def _single(ps, family, member, pair, *, out, name, force, package, sizes, quiet, as_json, require_free):
    """The default design: with a physical design to make (files, --json, --require-collision-free) and no
    explicit --family/--member/--pair, the best-scored candidates are designed in turn and the first
    collision-free one (full cycle, then task range) wins (`synth.design.search.rank_buildable`); else the
    best-scored linkage."""
    from synth.checks import VERIFY_SAMPLES
    from synth.synthesis.sixbar import sixbar as synth_sixbar
    from synth.synthesis.sixbar import sixbar_candidates

    from .bennett import emit

    result = None
    if (out or as_json or require_free) and family is None and member is None and pair is None:
        candidates = sixbar_candidates(ps.matrices, ps.names, top=BUILDABLE_CANDIDATES, build=True,
                                       check_samples=VERIFY_SAMPLES)
        linkage, result = choose_buildable(candidates, ps, sizes, limit=BUILDABLE_CANDIDATES,
                                           work=BUILDABLE_WORK, what="6R linkages")
    else:
        linkage = synth_sixbar(ps.matrices, ps.names, family=family, member=member, pair=pair,
                               check_samples=VERIFY_SAMPLES)
    emit(linkage, ps, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
         as_json=as_json, require_free=require_free, result=result, summary_line=_design_line(linkage.info))


def solution_id(rank: int, linkage) -> str:
    """Directory name of a ranked solution: rank, family and pair (the member is in index.json)."""
    if isinstance(linkage.info.get("family"), dict):  # planar or spherical: the chain
        return f"{rank:02d}-{linkage.info['family']['kind']}-c{linkage.info['chain']}"
    return f"{rank:02d}-f{linkage.info['family']}-p{linkage.info['pair']}"


def index_document(linkages, ids, source: str, length_scale: float, length_unit: str) -> dict:
    from synth.synthesis.sixbar import SCORE_RULE

    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        c = lk.checks
        sols.append({
            "id": sid, "rank": rank, "path": f"{sid}/", "family": lk.info["family"], "member": lk.info["member"],
            "pair": lk.info.get("pair", lk.info.get("chain")), "t3": lk.info["t3"], "score": lk.info["score"],
            "score_parts": lk.info["score_parts"],
            "checks": {k: c[k] for k in ("max_pose_error", "max_pose_translation_error", "max_pose_rotation_error",
                                         "max_closure_error", "max_closure_translation_error",
                                         "max_closure_rotation_error", "max_motion_error")},
        })
    return {"format": INDEX_FORMAT, "kind": linkages[0].kind if linkages else "6r", "poses": source, "units": {"length": "m", "angle": "rad"},
            "input_length_unit": length_unit, "input_length_scale": length_scale,
            "score_rule": SCORE_RULE, "solutions": sols}


def ranking_table(doc) -> list[str]:
    head = (f"  {'rank':>4} {'id':12} {'fam':>3} {'member':>12} {'pair':>4} {'score':>9} {'cond':>8} {'extent':>7} "
            f"{'twist':>6} {'offset':>7} {'pose err':>9} {'closure':>9}")
    rows = [head]
    for s in doc["solutions"]:
        p = s["score_parts"]
        fam, mem = s["family"], s["member"]
        if isinstance(fam, dict):  # planar or spherical: the kind's initial and the member's four numbers
            fam, mem = fam["kind"][0], ",".join(f"{v:.3g}" for v in mem.values())
        else:
            mem = f"{mem:.6g}"
        rows.append(f"  {s['rank']:>4} {s['id']:12} {fam:>3} {mem:>12} {s['pair']:>4} "
                    f"{s['score']:>9.3g} {p['conditioning']:>8.3g} {p['extent']:>7.3g} "
                    f"{p['min_twist'] * 57.29577951308232:>6.1f} {p['min_offset']:>7.3g} "
                    f"{s['checks']['max_pose_error']:>9.1e} {s['checks']['max_closure_error']:>9.1e}")
    return rows


def _ranked(ps, family, member, pair, top, *, out, name, force, package, sizes, quiet, as_json, require_free):
    from synth.checks import VERIFY_SAMPLES
    from synth.synthesis.sixbar import sixbar_candidates

    linkages = sixbar_candidates(ps.matrices, ps.names, family=family, member=member, pair=pair, top=top,
                                 build=True, check_samples=VERIFY_SAMPLES)
    results = None
    if out or as_json or require_free:  # the physical design of every solution, collision-free first
        linkages, results = design_solutions(linkages, ps, sizes, quiet=quiet, require_free=require_free,
                                             what="6R designs")
    ids = [solution_id(r, lk) for r, lk in enumerate(linkages, start=1)]
    doc = index_document(linkages, ids, ps.source, ps.length_scale, ps.length_unit)
    if results is not None:
        add_collisions(doc["solutions"], results, ps)
    if not quiet:
        echo(f"6r designs through {len(ps)} poses: the {len(linkages)} best of the scan"
             + (f" (asked for {top})" if len(linkages) < top else "")
             + " (extent and offset in pose spreads, twist in degrees, errors in m + rad)")
        for row in ranking_table(doc):
            echo(row)
        for sol in doc["solutions"] if results is not None else ():
            echo(f"  {sol['id']}: {sol['design_summary']}")
    if out:
        from synth.io.writer import write_solutions

        base = name or default_robot_name(ps.source)
        write_solutions(out, [(sid, lk, f"{base}_{sid.replace('-', '_')}", r) for lk, sid, r in zip(linkages, ids, results)],
                        doc, force=force, package=package)
        if not quiet:
            echo(f"  wrote {out}/: index.json and {len(ids)} solution directories ({', '.join(ids)})")
    elif not quiet and not as_json:
        echo("  no files written (give -o OUT to write every design's URDF, STL and JSON)")
    if as_json:
        from synth.io.jsonout import plain

        print_json(plain(doc))
