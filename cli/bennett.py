"""`mpsynth bennett POSES -o OUT`: three poses in, a verified Bennett 4R linkage out."""
from __future__ import annotations

import click

from .common import (check_mesh_sizes, default_robot_name, echo, fmt_len, mesh_sizes, print_json,
                     print_linkage_summary, run_guarded, synthesis_options)


@click.command(epilog="""\b
Example:
  mpsynth bennett fixtures/bennett_mm_deg.yaml -o out_bennett
  cat poses.yaml | mpsynth bennett - --json | jq .checks""")
@click.argument("poses", metavar="POSES")
@synthesis_options
@run_guarded
def bennett(poses, out, name, force, pin_radius, link_radius, pin_length, package, normalize, quiet,
            as_json, debug):
    """Synthesize the spatial Bennett 4R linkage whose coupler passes through the three poses in
    POSES (YAML or JSON, '-' for stdin; see README for the format).

    Writes OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl (lengths in metres) when -o is
    given; prints a summary on stderr and, with --json, linkage.json on stdout."""
    from synth.bennett import bennett as synth_bennett
    from synth.errors import SynthesisError
    from synth.poses import load_poses

    ps = load_poses(poses, count=(3, "mpsynth bennett"), normalize=normalize)
    sizes = mesh_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length),
                       ps.length_scale)
    if out:
        from synth.export.writer import check_output_target

        check_output_target(out, force)  # refuse an unusable OUT before doing the work
    try:
        linkage = synth_bennett(ps.matrices, ps.names)
    except SynthesisError as e:  # name the file, like every input error
        raise SynthesisError(f"{ps.source}: {e}") from e
    emit(linkage, ps, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
         as_json=as_json)


def emit(linkage, ps, *, out, name, force, package, sizes, quiet, as_json):
    """Write (when OUT is given), summarize on stderr and print JSON as asked. Writing comes first, so
    that a failure to write is the only line on stderr."""
    from synth.export import linkage_document, write_output

    unit, scale = ps.length_unit, ps.length_scale
    files = None
    if out:
        check_mesh_sizes(sizes, linkage.extent(), scale, unit)
        files = write_output(linkage, out, robot_name=name or default_robot_name(ps.source), force=force,
                             package=package, **sizes)
    if not quiet:
        print_linkage_summary(linkage, scale, unit)
        b = linkage.info.get("bennett")
        if b:
            echo(f"  Bennett: a = {fmt_len(b['a'], scale, unit)}, alpha = {b['alpha']:.6f} rad, "
                 f"b = {fmt_len(b['b'], scale, unit)}, beta = {b['beta']:.6f} rad, "
                 f"a/sin(alpha) - b/sin(beta) relative {b['bennett_condition_residual']:.1e}")
    if files is not None:
        if not quiet:
            n_mesh = sum(1 for f in files if str(f).endswith(".stl"))
            echo(f"  wrote {out}/: linkage.urdf, linkage.json, {n_mesh} meshes in meshes/")
    elif not quiet and not as_json:
        echo("  no files written (give -o OUT to write URDF, STL and JSON)")
    if as_json:
        print_json(linkage_document(linkage))
