"""`mpsynth collide OUT`: self-collision of the written link meshes along the motion (the claimed range)."""
from __future__ import annotations

import sys

import click

from synth.errors import InputError
from synth.io.readback import read_output
from synth.tools.collide import collide as do_collide
from synth.tools.collide import summary_lines

from .common import debug_option, echo, json_option, print_json, run_guarded


@click.command(epilog="""\b
Examples:
  mpsynth collide out_bennett
  mpsynth collide out_bennett --steps 1440 --json | jq '.collisions[].links'

\b
Exit codes: 0 no collision, 1 some pair of links collides, 2 bad input or python-fcl missing.""")
@click.argument("out", metavar="OUT", type=click.Path())
@click.option("--steps", type=int, default=360, show_default=True,
              help="Configurations checked over one full cycle (evenly spaced in joint angle).")
@click.option("--range", "span", type=click.Choice(["task", "full"]), default=None,
              help="Check the arc of the driver through the task poses, or the full cycle (default: the range "
                   "linkage.json's design claims to be collision-free over).")
@click.option("--no-clearance", is_flag=True, help="Skip the smallest-distance figure of the pairs that never collide.")
@click.option("-q", "--quiet", is_flag=True, help="No report on stderr.")
@json_option
@debug_option
@run_guarded
def collide(out, steps, span, no_clearance, quiet, as_json, debug):
    """Check the link meshes of output directory OUT for self-collision at STEPS configurations of the
    range its design claims (or --range). Links that share a joint, and the welded copies of a loop closure (coupler and
    coupler_k), touch by design and are not checked. Reports every colliding pair with the ranges of
    the driver's angle (degrees, in the direction it turns) and of the motion parameter t where it collides.

    Needs python-fcl: pip install 'mpsynth[collide]'."""
    if steps < 8 or steps > 1_000_000:
        raise InputError(f"--steps {steps}: must be between 8 and 1000000")
    rb = read_output(out)
    report = do_collide(rb, steps=steps, clearance=not no_clearance, span=span or "claim")
    if not quiet:
        for line in summary_lines(report):
            echo(line)
    if as_json:
        print_json(report)
    sys.exit(1 if report["colliding"] else 0)
