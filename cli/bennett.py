"""`mpsynth bennett POSES -o OUT`: three poses in, a verified Bennett 4R linkage out."""
from __future__ import annotations

import math

import click

from synth.design.work import GAPS_PER_SECOND

from .common import choose_buildable, echo, emit_linkage, fmt_len, mesh_sizes, run_guarded, synthesis_options


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
def bennett(poses, member, top, best_effort, out, name, force, pin_radius, link_radius, pin_length, clearance, hole_clearance,
            require_collision_free, package, normalize, quiet, as_json, debug):
    """Synthesize the spatial Bennett 4R linkage whose coupler passes through the three poses in
    POSES (YAML or JSON, '-' for stdin; see README for the format). With five points instead (a
    `points:` list, or poses with a position only; 3 or 4: the rest is chosen) the tool point passes
    through them (docs/points.md).

    Three planar poses (rotations about parallel axes) or spherical poses (rotations about one point)
    have a two-parameter family of quadratic motions through them: the result is then a planar
    four-bar (parallel axes, an anti-parallelogram) or a spherical four-bar (axes through one point).

    Writes OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl (lengths in metres) when -o is
    given: printable parts of a physical design (bars, hubs with bores, separate pins) and what it
    achieves (collision-free over the full cycle or the task range, or not); prints a summary on stderr
    and, with --json, linkage.json on stdout."""
    from synth.synthesis.bennett import bennett_candidates, verify
    from synth.errors import SynthesisError
    from synth.io.poses import load_poses

    from .points import point_count, run_point_task

    from synth.synthesis.bennett_fit import is_task

    ps = load_poses(poses, count=((2, None), "mpsynth bennett"), normalize=normalize,
                    points=((point_count(2)[0][0], None), "mpsynth bennett"))  # more than 5: fitted
    sizes = mesh_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                            clearance=clearance, hole_clearance=hole_clearance), ps.length_scale)
    if ps.has_points and not is_task(ps):
        if member is not None:
            from synth.errors import InputError

            raise InputError("--member selects among the quadratic motions through planar or spherical poses; a "
                             "point task has no such family (use --top to see its ranked designs)")
        return run_point_task(ps, 2, top, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
                              as_json=as_json, require_free=require_collision_free)
    if is_task(ps):  # tolerances, velocities, an order or other than three poses (docs/fit.md)
        from .task import run_bennett_task

        if out:
            from synth.io.writer import check_output_target

            check_output_target(out, force)
        return run_bennett_task(ps, top, best_effort, out=out, name=name, force=force, package=package, sizes=sizes,
                                quiet=quiet, as_json=as_json, require_free=require_collision_free)
    if top is not None:
        from synth.errors import InputError

        raise InputError("--top applies to point tasks and fits only: three poses give one Bennett linkage")
    if out:
        from synth.io.writer import check_output_target

        check_output_target(out, force)  # refuse an unusable OUT before doing the work
    lam = parse_numbers(member, 2, "--member") if member is not None else None
    result = None
    try:
        design = (out or as_json or require_collision_free) and lam is None
        linkages = bennett_candidates(ps.matrices, ps.names, member=lam, top=BUILDABLE_CANDIDATES if design else 1)
        for lk in linkages:
            verify(lk)  # the self-check at VERIFY_SAMPLES parameters; refuses a failing linkage
    except SynthesisError as e:  # name the file, like every input error
        raise SynthesisError(f"{ps.source}: {e}") from e
    linkage = linkages[0]
    if len(linkages) > 1:  # members of a planar or spherical family: collision-free first
        linkage, result = choose_buildable(linkages, ps, sizes, limit=BUILDABLE_CANDIDATES, work=BUILDABLE_WORK,
                                           what="members")
    emit(linkage, ps, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
         as_json=as_json, require_free=require_collision_free, result=result)


BUILDABLE_CANDIDATES = 4  # planar/spherical default: the best-scored members designed, collision-free first
BUILDABLE_WORK = 4.0 * GAPS_PER_SECOND  # gap evaluations of those design searches (synth.design.work)


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


def emit(linkage, ps, *, out, name, force, package, sizes, quiet, as_json, require_free=False, result=None,
         summary_line: str | None = None):
    """Write, summarize and print a two-branch linkage (bennett, sixbar) read from the pose set ``ps``;
    ``summary_line``: one more line of the summary (printed only when everything succeeded)."""

    def details():
        if summary_line:
            echo(summary_line)
        bp = linkage.info.get("bennett")
        fam = linkage.info.get("family")
        if isinstance(fam, dict) and bp:  # a planar or spherical four-bar (docs/planar.md)
            scale, unit = ps.length_scale, ps.length_unit
            m = linkage.info["member"]
            where = (f"axes parallel to ({', '.join(f'{x:.4f}' for x in fam['normal'])})" if fam["kind"] == "planar" else
                     f"axes through ({', '.join(f'{x / scale:.6g}' for x in fam['centre'])}) {unit}")
            echo(f"  {fam['kind']} four-bar: member lambda1 = {m['lambda1']:.6g}, lambda2 = {m['lambda2']:.6g} of "
                 f"the family of quadratic motions through the poses; {where}; " + (
                 f"links a = {fmt_len(bp['a'], scale, unit)}, b = {fmt_len(bp['b'], scale, unit)}" if fam["kind"] == "planar"
                 else f"link angles alpha = {bp['alpha']:.6f} rad, beta = {bp['beta']:.6f} rad"))
        elif bp:
            scale, unit = ps.length_scale, ps.length_unit
            echo(f"  Bennett: a = {fmt_len(bp['a'], scale, unit)}, alpha = {math.degrees(bp['alpha']):.4f} deg, "
                 f"b = {fmt_len(bp['b'], scale, unit)}, beta = {math.degrees(bp['beta']):.4f} deg, "
                 f"a/sin(alpha) - b/sin(beta) relative {bp['bennett_condition_residual']:.1e}")

    emit_linkage(linkage, source=ps.source, scale=ps.length_scale, unit=ps.length_unit, out=out, name=name,
                 force=force, package=package, sizes=sizes, quiet=quiet, as_json=as_json, details=details,
                 require_free=require_free, result=result)
