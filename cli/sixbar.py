"""`mpsynth sixbar POSES -o OUT`: four poses in, ranked spatial 6R linkages out."""
from __future__ import annotations

import click

from .common import Output, design_options, drive_options, echo, finish_ranked, progress, run_guarded, synthesis_options


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
def sixbar(poses, family, member, pair, top, best_effort, **params):
    """Synthesize a spatial 6R linkage whose coupler passes through the four poses in POSES (YAML or
    JSON, '-' for stdin; see README for the format). With seven points instead (a `points:` list, or
    poses with a position only; 4 to 6: the rest is chosen) the tool point passes through them
    (docs/points.md); more points are fitted (docs/sixbar_fit.md).

    By default the best design by the engineering score (well-conditioned factorization first, then a
    compact linkage without nearly parallel or nearly intersecting consecutive axes) over both families
    of cubic motions is written to OUT (linkage.urdf and linkage.json in metres, meshes/*.stl in millimetres).
    Exit status 1 when no real 6R linkage exists (e.g. the poses' quadric is oval)."""
    from synth.io.poses import load_poses
    from synth.solve import SynthesisOptions, solve_sixbar

    from synth.synthesis.sixbar_task import is_sixbar_task

    from .points import emit_points, point_count
    from .task import emit_task

    output = Output.of(params)
    ps = load_poses(poses, count=((2, None), "mpsynth sixbar"), normalize=params["normalize"],
                    points=((point_count(3)[0][0], None), "mpsynth sixbar"))  # more than 7 points: fitted
    task = is_sixbar_task(ps)  # tolerances, velocities, an order, other counts (docs/sixbar_fit.md)
    if member is not None and not ps.has_points and not task:
        member = parse_member(member)
    options = SynthesisOptions(design=design_options(params), physical=output.physical, top=top, member=member,
                               family=family, pair=pair, best_effort=best_effort, **drive_options(params))
    result = solve_sixbar(ps, options, progress=lambda items, label: progress(items, label, output.quiet))
    if task:
        return emit_task(result, ps, output, top)
    if ps.has_points:
        return emit_points(result, ps, output, top)
    if top is None:
        from .bennett import emit_two_branch

        return emit_two_branch(result, ps, output, summary_line=_design_line(result.linkage.info.synthesis))
    _ranked(result, ps, output, top)


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


def _design_line(s) -> str:
    """The design line of a 6R (`synth.info.SixbarCandidate`) or Watt six-bar (`synth.info.FamilyMember`)."""
    from synth.info import FamilyMember

    p = s.score_parts
    if isinstance(s, FamilyMember):  # a planar or spherical Watt six-bar (docs/planar.md)
        m = s.member
        return (f"  {s.family.kind} Watt six-bar (7 joints): member t3 = {m.t3:.6g}, lambda = "
                f"({m.lambda1:.6g}, {m.lambda2:.6g}, {m.lambda3:.6g}), chain {s.chain}; score "
                f"{s.score:.3g} (conditioning {p.conditioning:.3g}, extent {p.extent:.3g} x spread)")
    return (f"  6R design: family {s.family} (t3 = {s.t3:.6g}), member lambda1 = {s.member:.6g}, "
            f"pair {s.pair}; score {s.score:.3g} (conditioning {p.conditioning:.3g}, "
            f"extent {p.extent:.3g} x spread, min twist {p.min_twist * 57.29577951308232:.1f} deg, "
            f"min offset {p.min_offset:.3g} x spread)")


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


def _ranked(result, ps, output, top: int) -> None:
    doc, ids = result.index, [s.id for s in result.solutions]
    designed = bool(result.solutions) and result.solutions[0].design is not None
    if not output.quiet:
        echo(f"6r designs through {len(ps)} poses: the {len(ids)} best of the scan"
             + (f" (asked for {top})" if len(ids) < top else "")
             + " (extent and offset in pose spreads, twist in degrees, errors in m + rad)")
        for row in ranking_table(doc):
            echo(row)
        for sol in doc["solutions"] if designed else ():
            echo(f"  {sol['id']}: {sol['design_summary']}")
    finish_ranked(result, output)
