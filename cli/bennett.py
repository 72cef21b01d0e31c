"""`mpsynth bennett POSES -o OUT`: three poses in, a verified Bennett 4R linkage out."""
from __future__ import annotations

import click

from .common import echo, emit_linkage, fmt_len, mesh_sizes, run_guarded, synthesis_options


@click.command(epilog="""\b
Example:
  mpsynth bennett fixtures/bennett_mm_deg.yaml -o out_bennett
  cat poses.yaml | mpsynth bennett - --json | jq .checks
  mpsynth bennett fixtures/bennett_points.yaml --top 3 -o out_points""")
@click.argument("poses", metavar="POSES")
@click.option("--top", type=click.IntRange(1, 1000), default=None,
              help="Point tasks: write the N best designs to OUT/<id>/ with OUT/index.json and print the ranking.")
@synthesis_options
@run_guarded
def bennett(poses, top, out, name, force, pin_radius, link_radius, pin_length, clearance, hole_clearance,
            require_collision_free, package, normalize, quiet, as_json, debug):
    """Synthesize the spatial Bennett 4R linkage whose coupler passes through the three poses in
    POSES (YAML or JSON, '-' for stdin; see README for the format). With five points instead (a
    `points:` list, or poses with a position only; 3 or 4: the rest is chosen) the tool point passes
    through them (docs/points.md).

    Writes OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl (lengths in metres) when -o is
    given: printable parts of a physical design (bars, hubs with bores, separate pins) and what it
    achieves (collision-free over the full cycle or the task range, or not); prints a summary on stderr
    and, with --json, linkage.json on stdout."""
    from synth.synthesis.bennett import bennett as synth_bennett
    from synth.synthesis.bennett import verify
    from synth.errors import SynthesisError
    from synth.io.poses import load_poses

    from .points import point_count, run_point_task

    ps = load_poses(poses, count=(3, "mpsynth bennett"), normalize=normalize, points=point_count(2))
    sizes = mesh_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                            clearance=clearance, hole_clearance=hole_clearance), ps.length_scale)
    if ps.has_points:
        return run_point_task(ps, 2, top, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
                              as_json=as_json, require_free=require_collision_free)
    if top is not None:
        from synth.errors import InputError

        raise InputError("--top applies to point tasks only: three poses give one Bennett linkage")
    if out:
        from synth.io.writer import check_output_target

        check_output_target(out, force)  # refuse an unusable OUT before doing the work
    try:
        linkage = synth_bennett(ps.matrices, ps.names)
        verify(linkage)  # the self-check at VERIFY_SAMPLES parameters; refuses a failing linkage
    except SynthesisError as e:  # name the file, like every input error
        raise SynthesisError(f"{ps.source}: {e}") from e
    emit(linkage, ps, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
         as_json=as_json, require_free=require_collision_free)


def emit(linkage, ps, *, out, name, force, package, sizes, quiet, as_json, require_free=False, result=None,
         summary_line: str | None = None):
    """Write, summarize and print a two-branch linkage (bennett, sixbar) read from the pose set ``ps``;
    ``summary_line``: one more line of the summary (printed only when everything succeeded)."""

    def details():
        if summary_line:
            echo(summary_line)
        bp = linkage.info.get("bennett")
        if bp:
            scale, unit = ps.length_scale, ps.length_unit
            echo(f"  Bennett: a = {fmt_len(bp['a'], scale, unit)}, alpha = {bp['alpha']:.6f} rad, "
                 f"b = {fmt_len(bp['b'], scale, unit)}, beta = {bp['beta']:.6f} rad, "
                 f"a/sin(alpha) - b/sin(beta) relative {bp['bennett_condition_residual']:.1e}")

    emit_linkage(linkage, source=ps.source, scale=ps.length_scale, unit=ps.length_unit, out=out, name=name,
                 force=force, package=package, sizes=sizes, quiet=quiet, as_json=as_json, details=details,
                 require_free=require_free, result=result)
