"""`mpsynth parts OUT`: print plates and an assembly sheet for a written linkage (`synth.tools.plates`)."""
from __future__ import annotations

import click

from synth.errors import InputError
from synth.tools.plates import write_parts

from .common import debug_option, echo, json_option, print_json, run_guarded


@click.command(epilog="""\b
Examples:
  mpsynth parts out_bennett
  mpsynth parts out_bennett --bed 250 210 220
  mpsynth parts out_bennett --format 3mf""")
@click.argument("out", metavar="OUT", type=click.Path())
@click.option("--bed", nargs=3, type=float, default=(220.0, 220.0, 250.0), show_default=True,
              help="The printer's build volume X Y Z in mm.")
@click.option("--format", "fmt", type=click.Choice(["stl", "3mf"]), default="stl", show_default=True,
              help="Plate files: one STL per plate, or one 3MF per plate with every part a named object.")
@click.option("-q", "--quiet", is_flag=True, help="No summary on stderr.")
@json_option
@debug_option
@run_guarded
def parts(out, bed, fmt, quiet, as_json, debug):
    """Lay the printable parts of output directory OUT (links and pins, in their print orientation; the base
    on its mounting face) out on print plates, OUT/plates/plate_<k>.stl or .3mf (mm), and write
    OUT/plates/assembly.html: which pin goes through which bores in which order, with an exploded view
    (needs matplotlib: 'mpsynth[viz]')."""
    if not all(10.0 <= b <= 10000.0 for b in bed):
        raise InputError(f"--bed {' '.join(f'{b:g}' for b in bed)}: each side must be between 10 and 10000 mm")
    layout, paths = write_parts(out, tuple(bed), fmt)
    if as_json:
        print_json({"plates": layout.plates, "written": [str(p) for p in paths],
                    "parts": [{"name": p.name, "plate": p.plate + 1, "offset": list(p.offset),
                               "extents": list(p.extents)} for p in layout.placements],
                    "too_large": layout.too_large})
    elif not quiet:
        echo(f"{len(layout.placements)} parts on {layout.plates} plate(s): " + ", ".join(str(p) for p in paths))
        for name, s in layout.too_large.items():
            echo(f"  {name} does not fit the bed: it fits at scale {s:.3g}")
