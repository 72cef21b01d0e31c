"""`mpsynth render OUT --png FILE --gif FILE`: headless pictures of a written linkage (matplotlib, Agg)."""
from __future__ import annotations

import re

import click

from synth.errors import InputError
from synth.io.readback import read_output
from synth.tools.render import render as do_render

from .common import debug_option, echo, json_option, print_json, nonempty_path, run_guarded


def parse_size(value: str) -> tuple[int, int]:
    """'800x600' -> (800, 600); InputError on anything else."""
    m = re.fullmatch(r"\s*(\d{2,5})\s*[xX*]\s*(\d{2,5})\s*", str(value))
    if not m:
        raise InputError(f"--size {value!r}: expected WIDTHxHEIGHT in pixels, e.g. 800x600")
    w, h = int(m.group(1)), int(m.group(2))
    if not (64 <= w <= 8192 and 64 <= h <= 8192):
        raise InputError(f"--size {value!r}: width and height must be between 64 and 8192 pixels")
    return w, h


@click.command(epilog="""\b
Examples:
  mpsynth render out_bennett --png bennett.png
  mpsynth render out_bennett --gif bennett.gif --frames 90 --size 640x480""")
@click.argument("out", metavar="OUT", type=click.Path())
@click.option("--png", type=click.Path(dir_okay=False), callback=nonempty_path, help="Write a picture of the linkage to this PNG file.")
@click.option("--gif", type=click.Path(dir_okay=False), callback=nonempty_path, help="Write an animation of one full cycle to this GIF file.")
@click.option("--frames", type=int, default=60, show_default=True, help="GIF frames over the cycle.")
@click.option("--size", default="800x600", show_default=True, help="Image size WIDTHxHEIGHT in pixels.")
@click.option("--at", "at", help="PNG configuration: a task pose name or a motion parameter t "
                                 "(default: the task pose where the mechanism is most open).")
@click.option("--elev", type=float, help="Camera elevation in degrees (default: chosen to show the linkage).")
@click.option("--azim", type=float, help="Camera azimuth in degrees (default: chosen to show the linkage).")
@click.option("--spacing", type=click.Choice(["angle", "phi"]), default="angle", show_default=True,
              help="GIF frames equally spaced in joint angle, or in phi with t = tan(phi).")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@json_option
@debug_option
@run_guarded
def render(out, png, gif, frames, size, at, elev, azim, spacing, quiet, as_json, debug):
    """Draw the linkage in output directory OUT (written by a synthesis command) without a display:
    the link meshes, the tool frame, the tool path and the task poses as small RGB frames.

    --png writes one picture; --gif an animation of one full cycle of the motion (every joint turns
    once). Needs matplotlib: pip install 'mpsynth[viz]'."""
    if not png and not gif:
        raise InputError("nothing to do: give --png FILE and/or --gif FILE")
    if frames < 2 or frames > 2000:
        raise InputError(f"--frames {frames}: must be between 2 and 2000")
    w, h = parse_size(size)
    rb = read_output(out)
    stats = do_render(rb, png=png, gif=gif, frames=frames, size=(w, h), elev=elev, azim=azim,
                      spacing=spacing, at=at)
    if not quiet:
        if png:
            echo(f"wrote {png} ({w}x{h}) in {stats['png_s']:.2f} s")
        if gif:
            echo(f"wrote {gif} ({w}x{h}, {stats['frames']} frames) in {stats['gif_s']:.2f} s")
    if as_json:
        print_json({"png": png, "gif": gif, "size": [w, h], **{k: v for k, v in stats.items()}})
