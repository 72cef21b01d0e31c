"""`mpsynth check OUT [--poses POSES]`: verify an output directory (`synth.tools.check.verify`)."""
from __future__ import annotations

import sys

import click

from synth.errors import InputError
from synth.io.poses import load_poses
from synth.tools.check.verify import check_tree

from .common import debug_option, echo, json_option, print_json, run_guarded


@click.command(epilog="""\b
Example:
  mpsynth bennett fixtures/bennett_quat.yaml -o out_b && mpsynth check out_b --poses fixtures/bennett_quat.yaml
  mpsynth check out_b --json | jq .figures.continuation""")
@click.argument("out", metavar="OUT")
@click.option("--poses", "poses", metavar="POSES",
              help="Pose file the output was made from: the tool frame must reach these poses too.")
@click.option("--tol", type=float, default=1e-8, show_default=True,
              help="Relative tolerance (lengths times the linkage's size; angles in radians).")
@click.option("--steps", type=click.IntRange(12, 100000), default=360, show_default=True,
              help="Largest step of the mobility sweep: a full turn / STEPS.")
@click.option("--no-meshes", is_flag=True, help="Skip the mesh checks (faster).")
@click.option("-q", "--quiet", is_flag=True, help="Print only the problems, no summary.")
@json_option
@debug_option
@run_guarded
def check(out, poses, tol, steps, no_meshes, quiet, as_json, debug):
    """Verify the output directory OUT of a synthesis command: structure (root base, one parent per link,
    loop-closure welds matching linkage.json, tool link), meshes (relative paths, binary STL, watertight,
    positive volume, plausible size), the tool frame at every pose's joint angles (and at the poses of
    POSES), closed loops there, and the whole cycle: the angle laws of linkage.json keep every loop
    closed over a full turn, and an independent continuation that drives the first joint through a full
    turn (the other joints solved for closure) completes it and agrees with the laws.

    Exit 0 when everything holds, 1 with one line per problem on stderr, 2 when OUT cannot be read.
    A multi-solution OUT (index.json) is checked solution by solution."""
    if not (tol > 0 and tol < 1):
        raise InputError(f"--tol must be in (0, 1), got {tol}")
    ps = None
    if poses:
        ps = load_poses(poses, points=(1, None))  # a point file: positions only are compared
    result = check_tree(out, ps, rtol=tol, steps=steps, meshes=not no_meshes)
    for p in result["problems"]:
        echo(f"FAIL {p}")
    if not quiet:
        echo(summary_line(out, result))
    if as_json:
        print_json(result)
    sys.exit(0 if result["ok"] else 1)


def summary_line(out, result) -> str:
    figs = result["figures"]
    sols = [("", figs)] if "length_scale" in figs else list(figs.items())
    parts = []
    for sid, f in sols:
        pe = f.get("pose_error", {})
        ce = f.get("law_closure_error", {})
        cont = f.get("continuation", {})
        m = f.get("meshes", {})
        bits = []
        if pe:
            bits.append(f"pose {pe['translation']:.1e} m/{pe['rotation']:.1e} rad")
        if ce:
            bits.append(f"closure {ce['translation']:.1e} m/{ce['rotation']:.1e} rad")
        if cont:
            bits.append(f"turn by {cont['driver']} {100 * cont['followed']:.0f}%")
            if "max_deviation_from_laws" in cont:
                bits.append(f"vs laws {cont['max_deviation_from_laws']:.1e} rad")
            if cont.get("branch_crossings_deg"):
                at = ", ".join(f"{d:.0f}" for d in cont["branch_crossings_deg"])
                bits.append(f"branch crossing(s) passed on the laws' motion at {cont['driver']} = {at} deg")
        if m:
            bits.append(f"meshes {m['good']}/{m['referenced']}")
        parts.append((f"{sid}: " if sid else "") + ", ".join(bits))
    status = "OK" if result["ok"] else f"FAILED ({len(result['problems'])} problem(s))"
    return f"check {out}: {status}: " + "; ".join(parts)
