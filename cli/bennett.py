"""`mpsynth bennett POSES -o OUT`: three poses in, a verified Bennett 4R linkage out."""
from __future__ import annotations

import math

import click

from .common import Output, design_options, drive_options, echo, emit, fmt_len, progress, run_guarded, synthesis_options


@click.command(epilog="""\b
Example:
  mpsynth bennett fixtures/bennett_mm_deg.yaml -o out_bennett
  cat poses.yaml | mpsynth bennett - --json | jq .checks
  mpsynth bennett fixtures/bennett_planar.yaml -o out_planar
  mpsynth bennett fixtures/bennett_planar.yaml --member=-0.5,2 -o out_planar
  mpsynth bennett fixtures/bennett_points.yaml --top 3 -o out_points""")
@click.argument("poses", metavar="POSES")
@click.option("--member", metavar="L1,L2",
              help="Planar or spherical poses only: the member C(t) = t(t-1) - L1 (t-1) D1 + L2 t D2 of the family "
                   "of quadratic motions through them (L1, L2 nonzero; default: the best-scored, collision-free "
                   "first). Write a negative first value as --member=-0.5,2.")
@click.option("--top", type=click.IntRange(1, 1000), default=None,
              help="Point tasks and fits: write the N best designs to OUT/<id>/ with OUT/index.json and print the "
                   "ranking.")
@click.option("--best-effort", is_flag=True,
              help="Fits: when the tolerances cannot be met, write the best linkage anyway (info.fit.within_tolerance "
                   "false) instead of exiting 1.")
@synthesis_options
@run_guarded
def bennett(poses, member, top, best_effort, **params):
    """Synthesize the spatial Bennett 4R linkage whose coupler passes through the three poses in
    POSES (YAML or JSON, '-' for stdin; see README for the format). With five points instead (a
    `points:` list, or poses with a position only; 3 or 4: the rest is chosen) the tool point passes
    through them (docs/points.md).

    Three planar poses (rotations about parallel axes) or spherical poses (rotations about one point)
    have a two-parameter family of quadratic motions through them: the result is then a planar
    four-bar (parallel axes, an anti-parallelogram) or a spherical four-bar (axes through one point).

    Writes OUT/linkage.urdf and OUT/linkage.json (lengths in metres) and OUT/meshes/*.stl (millimetres) when -o is
    given: printable parts of a physical design (bars, hubs with bores, separate pins) and what it
    achieves (collision-free over the full cycle or the task range, or not); prints a summary on stderr
    and, with --json, linkage.json on stdout."""
    from synth.io.poses import load_poses
    from synth.solve import SynthesisOptions, solve_bennett

    from synth.synthesis.bennett_fit import is_task

    from .points import emit_points, point_count
    from .task import emit_task

    output = Output.of(params)
    ps = load_poses(poses, count=((2, None), "mpsynth bennett"), normalize=params["normalize"],
                    points=((point_count(2)[0][0], None), "mpsynth bennett"))  # more than 5 points: fitted
    task = is_task(ps)
    lam = parse_numbers(member, 2, "--member") if member is not None and not ps.has_points and not task else member
    options = SynthesisOptions(design=design_options(params), physical=output.physical, top=top, member=lam,
                               best_effort=best_effort, **drive_options(params))

    def ready():
        if output.dir:
            from synth.io.writer import check_output_target

            check_output_target(output.dir, output.force)  # refuse an unusable OUT before doing the work

    result = solve_bennett(ps, options, ready=ready, progress=lambda items, label: progress(items, label, output.quiet))
    if task:
        return emit_task(result, ps, output, top)
    if ps.has_points:
        return emit_points(result, ps, output, top)
    emit_two_branch(result, ps, output)


def parse_numbers(text: str, count: int, option: str) -> list[float]:
    """``count`` comma-separated finite numbers of an option (InputError naming the option otherwise)."""
    import math

    from synth.errors import InputError

    try:
        vals = [float(x) for x in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{option} needs {count} comma-separated finite numbers, got {text!r}")
    return vals


def emit_two_branch(result, ps, output, summary_line: str | None = None):
    """Write, summarize and print a two-branch linkage (bennett, sixbar) read from the pose set ``ps``;
    ``summary_line``: one more line of the summary (printed only when everything succeeded)."""
    linkage = result.linkage

    def details():
        if summary_line:
            echo(summary_line)
        from synth.info import FamilyMember

        bp, s = linkage.info.bennett, linkage.info.synthesis
        if isinstance(s, FamilyMember) and bp:  # a planar or spherical four-bar (docs/planar.md)
            scale, unit = ps.length_scale, ps.length_unit
            fam, m = s.family, s.member
            where = (f"axes parallel to ({', '.join(f'{x:.4f}' for x in fam.normal)})" if fam.kind == "planar" else
                     f"axes through ({', '.join(f'{x / scale:.6g}' for x in fam.centre)}) {unit}")
            echo(f"  {fam.kind} four-bar: member lambda1 = {m.lambda1:.6g}, lambda2 = {m.lambda2:.6g} of "
                 f"the family of quadratic motions through the poses; {where}; " + (
                 f"links a = {fmt_len(bp.a, scale, unit)}, b = {fmt_len(bp.b, scale, unit)}" if fam.kind == "planar"
                 else f"link angles alpha = {math.degrees(bp.alpha):.4f} deg, beta = {math.degrees(bp.beta):.4f} deg"))
        elif bp:
            scale, unit = ps.length_scale, ps.length_unit
            echo(f"  Bennett: a = {fmt_len(bp.a, scale, unit)}, alpha = {math.degrees(bp.alpha):.4f} deg, "
                 f"b = {fmt_len(bp.b, scale, unit)}, beta = {math.degrees(bp.beta):.4f} deg, "
                 f"a/sin(alpha) - b/sin(beta) relative {bp.bennett_condition_residual:.1e}")

    emit(result, output, details)
