"""`mpsynth trajectory OUT`: joint angles, velocities and tool pose over time for a motor controller."""
from __future__ import annotations

import sys

import click

from synth.io.readback import read_output
from synth.tools.trajectory import plan, summary, write

from .common import debug_option, echo, nonempty_path, run_guarded


@click.command(epilog="""\b
Examples:
  mpsynth trajectory out_bennett -o motion.csv                      # constant speed, 10 s, 100 Hz
  mpsynth trajectory out_bennett --through-poses --dwell 0.5 --duration 6 -o poses.json
  mpsynth trajectory out_bennett --driver k1 --speed 0.5 --rate 250 > k1.csv

\b
Exit codes: 0 written, 2 bad input or a range outside the collision-free range of linkage.json.""")
@click.argument("out", metavar="OUT", type=click.Path())
@click.option("-o", "--output", type=click.Path(dir_okay=False), callback=nonempty_path,
              help="Write to this .csv or .json file (default: CSV on standard output).")
@click.option("--json", "as_json", is_flag=True, help="JSON on standard output instead of CSV.")
@click.option("--driver", help="The driving joint (default: the first joint of linkage.json).")
@click.option("--rate", type=float, default=100.0, show_default=True, help="Samples per second (Hz).")
@click.option("--duration", type=float, help="Seconds for the whole trajectory (default 10).")
@click.option("--speed", type=float, help="Constant driver speed in rad/s instead of --duration "
                                          "(negative: run the range backwards).")
@click.option("--through-poses", is_flag=True, help="Visit every task pose along the shortest arc that "
                                                    "holds them all, resting --dwell s at each (smooth starts and stops).")
@click.option("--dwell", type=float, default=0.5, show_default=True, help="Rest at each task pose (s).")
@click.option("--range", "span", type=click.Choice(["auto", "full", "task"]), default="auto", show_default=True,
              help="Constant-speed range of the driver: the collision-free range recorded in linkage.json "
                   "(auto), one full turn from the first pose, or the shortest arc through the task poses.")
@click.option("--allow-collisions", is_flag=True,
              help="Drive a range that leaves the collision-free range recorded in linkage.json.")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@debug_option
@run_guarded
def trajectory(out, output, as_json, driver, rate, duration, speed, through_poses, dwell, span,
               allow_collisions, quiet, debug):
    """Sample the motion of the linkage in output directory OUT at --rate Hz: time, every joint's angle
    (rad, continuous, 0 at the first pose as in the URDF) and velocity (rad/s), and the tool frame's
    position (m) and quaternion (w, x, y, z) in the world frame; a 'pose' column names the task pose
    held at a sample. CSV has one header row; JSON (mpsynth.trajectory/1) holds the same columns as
    arrays plus the visiting times of the poses."""
    rb = read_output(out)
    traj = plan(rb, driver=driver, rate=rate, duration=duration, speed=speed, through_poses=through_poses,
                dwell=dwell, span=span, allow_collisions=allow_collisions)
    if output:
        write(traj, output)
    elif as_json:
        import json

        click.echo(json.dumps(traj.to_dict()))
    else:
        sys.stdout.write(traj.csv_text())
    if not quiet:
        for line in summary(traj):
            echo(line)
        if output:
            echo(f"  wrote {output}")
