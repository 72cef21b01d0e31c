"""`mpsynth export OUT --step`: add linkage.step to an existing output (`synth.tools.cadexport`)."""
from __future__ import annotations

import click

from synth.errors import InputError
from synth.tools.cadexport import export_step

from .common import debug_option, echo, json_option, print_json, run_guarded


@click.command(epilog="""\b
Examples:
  pip install 'mpsynth[cad]'
  mpsynth export out_bennett --step""")
@click.argument("out", metavar="OUT", type=click.Path())
@click.option("--step", is_flag=True, help="Write linkage.step (B-rep solids in mm, one per link and pin).")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@json_option
@debug_option
@run_guarded
def export(out, step, quiet, as_json, debug):
    """Write further formats of the linkage in output directory OUT (written by a synthesis command).

    --step writes linkage.step: an assembly of B-rep solids in millimetres at the home configuration,
    one per link and pin, named as in the URDF, for CAD programs. Needs gmsh: pip install 'mpsynth[cad]'
    (with it installed, every synthesis command writes linkage.step itself)."""
    if not step:
        raise InputError("nothing to do: give --step")
    paths = export_step(out)
    if as_json:
        print_json({"written": [str(p) for p in paths]})
    elif not quiet:
        for p in paths:
            echo(f"wrote {p}")
