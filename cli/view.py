"""`mpsynth view OUT -o view.html`: a self-contained offline HTML page that shows and animates a linkage."""
from __future__ import annotations

import click

from synth.errors import InputError
from synth.io.readback import read_output
from synth.tools.viewer import write_viewer

from .common import debug_option, echo, json_option, print_json, nonempty_path, run_guarded


@click.command(epilog="""\b
Example:
  mpsynth view out_bennett -o bennett.html     # then open bennett.html in a browser (no network needed)""")
@click.argument("out", metavar="OUT", type=click.Path())
@click.option("-o", "--output", "output", required=True, type=click.Path(dir_okay=False), callback=nonempty_path,
              help="The HTML file to write.")
@click.option("--frames", type=int, default=120, show_default=True, help="Animation frames over one cycle.")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@json_option
@debug_option
@run_guarded
def view(out, output, frames, quiet, as_json, debug):
    """Write one HTML file that shows the linkage in output directory OUT in 3D (WebGL; drag to rotate,
    wheel to zoom) with its motion: play button and frame slider, the tool frame, the task poses and
    the tool path. Everything is inside the file (meshes, motion, viewer): it works offline."""
    if frames < 2 or frames > 5000:
        raise InputError(f"--frames {frames}: must be between 2 and 5000")
    rb = read_output(out)
    size = write_viewer(rb, output, frames=frames)
    if not quiet:
        echo(f"wrote {output} ({size / 1e3:.0f} kB, {len(rb.mesh_links)} link meshes, {frames} frames); "
             "open it in a browser")
    if as_json:
        print_json({"html": output, "bytes": size, "frames": frames, "links": rb.mesh_links})
