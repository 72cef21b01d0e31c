"""`mpsynth curve SPEC -o OUT`: a multi-loop revolute linkage that performs a rational motion or whose
`tracer` frame draws a rational curve (docs/exceptional.md)."""
from __future__ import annotations

import math

import click

from synth.io.curvespec import load_spec
from synth.io.posespec import LENGTH_UNITS
from synth.io.writer import check_output_target

from .common import (Output, debug_option, design_option_list, design_options, drive_option_list, drive_options, echo,
                     emit, json_option, nonempty_path, run_guarded)


def _design_flags(func):
    for opt in reversed(design_option_list("--units") + drive_option_list()):
        func = opt(func)
    return func

UNITS = LENGTH_UNITS

EPILOG = """\b
SPEC (YAML or JSON, '-' for stdin), one of:
  curve:                       # the point (x/w, y/w, z/w); w without real zero
    x: "1 - t^2"
    y: "2*2*t"
    z: "0"
    w: "1 + t^2"
  motion:
    expression: "t^2 + 1 + eps*(i + 2*j*t)"
  motion:
    coefficients: [[1,0,0,0, 0,1,0,0], [0,0,0,0, 0,0,2,0], [1,0,0,0, 0,0,0,0]]   # constant term first
Polynomials use t, i, j, k, eps, numbers, + - * / ^ and parentheses (write * explicitly if the
spec is also read by verify_output.py). Lengths are in --units (default m); outputs are in metres.

\b
Examples:
  mpsynth curve fixtures/curve_ellipse.yaml -o out_ellipse      # 10 joints, link 'tracer' draws it
  mpsynth curve fixtures/motion_elliptic.yaml -o out_elliptic   # 13 joints, 'coupler' translates
  mpsynth curve fixtures/motion_circular.yaml -o out_circ       # 4 joints: a parallelogram
  python ../shared/tools/verify_output.py out_ellipse --trace tracer --curve fixtures/curve_ellipse.yaml

\b
Exit codes: 0 linkage written, 1 no revolute linkage (unbounded curve or motion: "needs a
sliding joint"; no factorization), 2 bad input."""


@click.command(epilog=EPILOG)
@click.argument("spec", metavar="SPEC")
@click.option("-o", "--out", "out", type=click.Path(file_okay=False), callback=nonempty_path,
              help="Output directory (linkage.urdf, linkage.json, meshes/). Without it nothing is written.")
@click.option("--units", type=click.Choice(list(UNITS)), default="m", show_default=True,
              help="Length unit of the spec (curve coordinates; dual parts of a motion).")
@click.option("--method", type=click.Choice(["auto", "translation", "rotation"]), default="auto",
              show_default=True,
              help="Curves: 'translation' = the curvilinear translation times a real co-factor; 'rotation' = "
                   "times a rotation about the tracer point (fewer joints for planar curves); 'auto' = fewer joints.")
@click.option("--name", help="Robot name in the URDF (default: the spec file's stem).")
@click.option("--force", is_flag=True, help="Replace OUT even if it holds files not written by mpsynth.")
@_design_flags
@click.option("--package", help="Write mesh paths as package://PACKAGE/meshes/... (ROS).")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@json_option
@debug_option
@run_guarded
def curve(spec, units, method, **params):
    """Synthesize a linkage of revolute joints only (several Bennett loops) whose link `coupler`
    performs the rational motion of SPEC, or whose link `tracer` draws the rational curve of SPEC.

    The motion is factorized after multiplication by a real co-factor (Theorem 2); one extra rotation
    and Bennett flips then close the loops. Writes OUT/linkage.urdf, OUT/linkage.json and
    OUT/meshes/*.stl (millimetres; URDF and JSON in metres) when -o is given; prints a summary with the joint and link counts on
    stderr and, with --json, linkage.json on stdout."""
    from synth.solve import SynthesisOptions, solve_curve

    output = Output.of(params)
    parsed = load_spec(spec)
    options = SynthesisOptions(design=design_options(params), physical=output.physical, method=method,
                               **drive_options(params))

    def ready():
        if output.dir:
            check_output_target(output.dir, output.force)

    result = solve_curve(parsed, options, scale=UNITS[units], unit=units, source=spec, ready=ready)
    for note in result.notes:
        echo(f"  note: {note}")
    emit_multiloop(result, output)


def emit_multiloop(result, output) -> None:
    """Write (when OUT is given) first, then summarize on stderr and print JSON as asked."""
    linkage, scale, unit = result.linkage, result.scale, result.unit

    def details():
        rec = linkage.info.synthesis  # a `synth.info.MultiLoop`
        counts = rec.counts
        echo(f"  counts: {counts.joints} revolute joints, {counts.links} links "
             f"(+{counts.links_with_duplicates - counts.links} welded loop duplicates), "
             f"{counts.loops} loops")
        mot = rec.motion
        if linkage.kind == "curve":
            cur = rec.curve
            echo(f"  curve: x = {cur.x}, y = {cur.y}, z = {cur.z}, w = {cur.w}; drawn by the "
                 f"origin of link 'tracer' (method {cur.method})")
            echo(f"  tracer stays on the curve to {linkage.checks['max_trace_error'] / scale:.2e} {unit}")
        echo(f"  co-factor R = {mot.cofactor_text if mot else '1'} (mrpf = {mot.mrpf_text if mot else '1'}), "
             f"factorization residual {mot.factorization_residual if mot else 0.0:.1e}, "
             f"motion error {linkage.checks.get('max_motion_error', 0.0):.1e}")
        mob = rec.mobility
        if mob:
            echo(f"  mobility: dof {mob.dof} at all sampled t, worst conditioning {mob.conditioning:.1e}")
        choice = rec.darboux.member_choice if rec.darboux else None
        if choice and choice.member is not None:
            m = choice.member
            echo(f"  member: turn {math.degrees(m.turn):.1f} deg of the parallel axes, 3R shift "
                 f"({m.shift[0] / scale:.3g}, {m.shift[1] / scale:.3g}) {unit}: {choice.reason}")
        crossings = (rec.darboux.singular_driver_deg if rec.darboux else None) or ()
        if crossings:
            first = linkage.joints[0].name
            where = ", ".join(f"{d:.0f}" for d in sorted(crossings))
            echo(f"  singular configurations: {first} at {where} deg, where another assembly branch of the "
                 "loop meets the motion; a built linkage can switch branch there (guide it through)")

    emit(result, output, details)
