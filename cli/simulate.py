"""`mpsynth simulate OUT --engine pybullet|mujoco`: drive the linkage in a physics engine (synth/sim)."""
from __future__ import annotations

import sys

import click

from synth.tools.sim.run import advice
from synth.tools.sim.run import simulate as run_sim

from .common import debug_option, echo, json_option, print_json, nonempty_path, run_guarded


@click.command(epilog="""\b
Example:
  mpsynth bennett fixtures/bennett_quat.yaml -o out_b
  mpsynth simulate out_b --engine mujoco --export-mjcf out_b/linkage.mjcf.xml
  mpsynth simulate out_b --engine pybullet --json | jq .max_joint_deviation""")
@click.argument("out", metavar="OUT")
@click.option("--engine", type=click.Choice(["pybullet", "mujoco"]), default="mujoco", show_default=True,
              help="Physics engine.")
@click.option("--seconds", type=float, default=None,
              help="Simulated time for the driver's full turn (default: 2 s for one loop, 4 s per loop "
                   "for several: welds in series give way with speed).")
@click.option("--timestep", type=float, default=None,
              help="Engine time step in seconds (default: pybullet 1 ms, mujoco 0.5 ms).")
@click.option("--gravity", is_flag=True, help="Gravity -9.81 m/s^2 along the base's -z (default: off).")
@click.option("--tol", type=float, default=1e-3, show_default=True,
              help="Exit 1 when a joint deviates from the exact motion by more than TOL radians (outside a "
                   "near-singular passage, which is reported on its own).")
@click.option("--export-mjcf", "export_mjcf", type=click.Path(dir_okay=False), callback=nonempty_path,
              help="Also write the MuJoCo model (MJCF; mesh paths relative to it) to this file.")
@click.option("--contacts", is_flag=True,
              help="Contacts between bodies that share no joint (convex hulls of the meshes); reports the steps "
                   "with a contact and the largest contact force.")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@json_option
@debug_option
@run_guarded
def simulate(out, engine, seconds, timestep, gravity, tol, export_mjcf, contacts, quiet, as_json, debug):
    """Load OUT/linkage.urdf into PyBullet or MuJoCo, close each loop the engine's way (PyBullet: a
    JOINT_FIXED constraint between coupler and coupler_k; MuJoCo: an equality weld), drive the first
    joint through one full turn (a driver with URDF limits, from its design's task range: from the lower to
    the upper limit) with a position motor (all other joints free, no self-contacts unless --contacts) and
    report the worst deviation of the joints from the exact motion of linkage.json's angle laws (the
    configuration's distance from the motion's curve, every joint; not read at the driver's angle alone,
    which multiplies the driver's slip by the speed ratio), and the worst gap of the welds.

    When the first joint nearly stops somewhere (another joint turns over 10 times as fast), the joint whose
    worst speed ratio is smallest is driven instead if it stays within 10; when none does (a near-singular
    passage of the loop), the deviation in that stretch is reported on its own and --tol holds elsewhere.

    Exit 0 when every joint stays within --tol of the exact motion, 1 when not or when the engine fails,
    2 for unreadable input or an engine that is not installed (pip install 'mpsynth[sim]')."""
    res = run_sim(out, engine, seconds=seconds, timestep=timestep, gravity=gravity, export_mjcf=export_mjcf,
                  contacts=contacts, tol=tol)
    ok = res["ok"]
    if not quiet:
        lo, hi = res["drive_range"]
        sweep = "" if (lo, hi) == (0.0, 6.283185307179586) else (
            f" over its limits {lo * 57.29577951308232:.1f} to {hi * 57.29577951308232:.1f} deg (the task range)")
        echo(f"simulate {out} with {engine}: {res['steps']} steps of {res['timestep']:.3g} s ({res['seconds']:g} s), "
             f"driver {res['driver']}"
             f"{sweep}, gravity {'on' if gravity else 'off'}")
        echo(f"  worst joint deviation from the exact motion {res['max_joint_deviation']:.3e} rad "
             f"({res['worst_joint']}), worst closure gap {res['max_closure_gap']:.3e} m / "
             f"{res['max_closure_angle']:.3e} rad, {res['wall_time']:.2f} s wall time")
        if "unsteady" in res:
            u = res["unsteady"]
            echo(f"  near-singular passage: {res['driver']} nearly stops from {u['driver_deg'][0]:.1f} to "
                 f"{u['driver_deg'][1]:.1f} deg ({u['fastest']} turns {u['speed_ratio']:.3g} times as fast at "
                 f"{u['at_deg']:.1f} deg) and no joint drives it steadily: the joints deviate up to "
                 f"{u['max_joint_deviation']:.3e} rad there (the welds' give magnified by the loop), "
                 f"{res['max_joint_deviation_steady']:.3e} rad elsewhere (held against --tol)")
        if "driver_choice" in res:
            echo(f"  {res['driver_choice']}")
        if "retried" in res:
            r = res["retried"]
            echo(f"  (the default {r['seconds']:g} s turn deviated {r['max_joint_deviation']:.2e} rad: "
                 + ("retried" if res["retries"] == 1 else f"retried {res['retries']} times, the last")
                 + f" at {res['seconds']:.3g} s" + (", tighter solver)" if engine == "pybullet" else ")"))
        if contacts:
            echo(f"  contacts between bodies that share no joint: {res['contact_steps']} of {res['steps']} steps, "
                 f"largest contact force {res['max_contact_force']:.3g} N")
        if export_mjcf:
            echo(f"  wrote {export_mjcf}")
        if not ok:
            echo(f"  FAIL: deviation above --tol {tol:g} rad: "
                 + advice(res, engine, tol, res["seconds"], res["loops"]))
    if as_json:
        print_json(res)
    sys.exit(0 if ok else 1)
