"""`mpsynth fourbar POSES -o OUT`: the classical planar four-bar through 3 to 5 coplanar poses, or fitted to more."""
from __future__ import annotations

import math

import click

from .common import Output, design_options, echo, emit, finish_ranked, fmt_len, progress, run_guarded, synthesis_options


@click.command(epilog="""\b
Examples:
  mpsynth fourbar fixtures/fourbar_5.yaml -o out_fourbar
  mpsynth fourbar fixtures/fourbar_5.yaml --top 3 -o out_fourbars
  mpsynth fourbar fixtures/fourbar_fit.yaml --min-transmission 45 -o out_fit""")
@click.argument("poses", metavar="POSES")
@click.option("--top", type=click.IntRange(1, 1000), default=None,
              help="Write the N best four-bars to OUT/<id>/ with OUT/index.json and print the ranking.")
@click.option("--min-transmission", type=click.FloatRange(0.0, 90.0), default=40.0, show_default=True,
              help="Smallest transmission angle (degrees, between coupler and rocker) over the task range.")
@synthesis_options
@run_guarded
def fourbar(poses, top, min_transmission, **params):
    """Synthesize a planar four-bar (crank-rocker) whose coupler carries the tool through the poses in
    POSES (YAML or JSON, '-' for stdin): 3, 4 or 5 poses exactly by Burmester theory, more by least squares
    within the task's `tolerance`. The poses may lie in any plane in space (all rotations about one normal,
    all tool origins in one plane perpendicular to it).

    Candidates are ranked as a planar designer does (docs/fourbar.md): a Grashof crank-rocker driven by its
    crank (joint h1), every pose on one assembly branch, the listed order when the task says `order:
    listed`, the transmission angle at least --min-transmission degrees over the task range, then compact
    first; the best (or --top N) is written as linkage.urdf, linkage.json and meshes/*.stl with a layered,
    collision-free design when one is found."""
    from synth.io.poses import load_poses
    from synth.solve import SynthesisOptions, solve_fourbar

    output = Output.of(params)
    ps = load_poses(poses, count=((3, None), "mpsynth fourbar"), normalize=params["normalize"])
    options = SynthesisOptions(design=design_options(params), physical=output.physical, top=top)

    def ready():
        if output.dir:
            from synth.io.writer import check_output_target

            check_output_target(output.dir, output.force)  # refuse an unusable OUT before doing the work

    result = solve_fourbar(ps, options, min_transmission_deg=min_transmission, ready=ready,
                           progress=lambda items, label: progress(items, label, output.quiet))
    if top is not None:
        return _ranked(result, ps, output, top)
    emit(result, output, lambda: details(result.linkage, ps))


def design_line(linkage, scale: float, unit: str) -> str:
    """One summary line: the four-bar's links, transmission and task range (and the fit's largest error)."""
    f = linkage.info.synthesis.fourbar
    L = f.lengths
    line = (f"  planar four-bar (crank-rocker, driver h1): ground {fmt_len(L.ground, scale, unit)}, crank "
            f"{fmt_len(L.crank, scale, unit)}, coupler {fmt_len(L.coupler, scale, unit)}, rocker "
            f"{fmt_len(L.rocker, scale, unit)}; transmission >= {f.transmission_min_deg:.1f} deg over the "
            f"crank's task range {f.task_range_deg[0]:.1f} .. {f.task_range_deg[1]:.1f} deg")
    fit = linkage.info.fit
    if fit:
        line += (f"; largest pose error {fmt_len(fit.max_position_error, scale, unit)}, "
                 f"{math.degrees(fit.max_angle_error):.3g} deg")
    return line


def details(linkage, ps) -> None:
    """The four-bar's lines of the summary: the design line, and a task's table of errors (`cli.task.print_fit`)."""
    echo(design_line(linkage, ps.length_scale, ps.length_unit))
    if linkage.info.fit is not None:
        from .task import print_fit

        print_fit(linkage, ps)


def _ranked(result, ps, output, top: int) -> None:
    doc, ids = result.index, [s.id for s in result.solutions]
    if not output.quiet:
        echo(f"planar four-bars through {len(ps)} poses: the {len(ids)} best"
             + (f" (asked for {top})" if len(ids) < top else ""))
        for sol, s in zip(doc["solutions"], result.solutions):
            echo(f"  {sol['id']}:" + design_line(s.linkage, ps.length_scale, ps.length_unit)[1:]
                 + (f"; {sol['design_summary']}" if "design_summary" in sol else ""))
    finish_ranked(result, output)
