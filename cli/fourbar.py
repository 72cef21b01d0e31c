"""`mpsynth fourbar POSES -o OUT`: the classical planar four-bar through 3 to 5 coplanar poses, or fitted to more."""
from __future__ import annotations

import math

import click

from synth.design.work import GAPS_PER_SECOND

from .common import (add_collisions, choose_buildable, design_solutions, echo, emit_linkage,
                     fmt_len, mesh_sizes, run_guarded, synthesis_options, write_ranked)

INDEX_FORMAT = "mpsynth.fourbar-index/1"
BUILDABLE_CANDIDATES = 4  # default design: the best-ranked four-bars designed, collision-free first
BUILDABLE_WORK = 4.0 * GAPS_PER_SECOND  # gap evaluations of those design searches (synth.design.work; rank_buildable)


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
def fourbar(poses, top, min_transmission, out, name, force, pin_radius, link_radius, pin_length, clearance,
            hole_clearance, require_collision_free, package, normalize, quiet, as_json, debug):
    """Synthesize a planar four-bar (crank-rocker) whose coupler carries the tool through the poses in
    POSES (YAML or JSON, '-' for stdin): 3, 4 or 5 poses exactly by Burmester theory, more by least squares
    within the task's `tolerance`. The poses may lie in any plane in space (all rotations about one normal,
    all tool origins in one plane perpendicular to it).

    Candidates are ranked as a planar designer does (docs/fourbar.md): a Grashof crank-rocker driven by its
    crank (joint h1), every pose on one assembly branch, the listed order when the task says `order:
    listed`, the transmission angle at least --min-transmission degrees over the task range, then compact
    first; the best (or --top N) is written as linkage.urdf, linkage.json and meshes/*.stl with a layered,
    collision-free design when one is found."""
    import numpy as np

    from synth.errors import InputError, SynthesisError
    from synth.io.poses import load_poses
    from synth.synthesis.fourbar import fourbar_candidates

    ps = load_poses(poses, count=((3, None), "mpsynth fourbar"), normalize=normalize)
    if ps.has_points:
        raise InputError(f"{ps.source}: mpsynth fourbar needs poses (position and orientation), not points")
    if ps.velocity is not None and np.isfinite(ps.velocity).any():
        raise InputError(f"{ps.source}: mpsynth fourbar does not take pose velocities (yet); remove 'velocity' or use "
                         "mpsynth bennett")
    if ps.constraints is not None:
        raise InputError(f"{ps.source}: mpsynth fourbar does not take 'constraints' (yet); remove them")
    sizes = mesh_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                            clearance=clearance, hole_clearance=hole_clearance), ps.length_scale)
    if out:
        from synth.io.writer import check_output_target

        check_output_target(out, force)  # refuse an unusable OUT before doing the work
    design = bool(out or as_json or require_collision_free)
    try:
        linkages = fourbar_candidates(ps.matrices, ps.names, top=top or (BUILDABLE_CANDIDATES if design else 1),
                                      min_transmission_deg=min_transmission, order=ps.order,
                                      tolerance=ps.tolerance, source=ps.source)
    except SynthesisError as e:  # name the file, like every input error
        raise SynthesisError(e.args[0] if str(e).startswith(ps.source) else f"{ps.source}: {e}") from e
    if top is not None:
        return _ranked(ps, linkages, top, sizes=sizes, out=out, name=name, force=force, package=package,
                       quiet=quiet, as_json=as_json, require_free=require_collision_free)
    result = None
    linkage = linkages[0]
    if design and len(linkages) > 1:
        linkage, result = choose_buildable(linkages, ps, sizes, limit=BUILDABLE_CANDIDATES,
                                           work=BUILDABLE_WORK, what="four-bars")
    emit_linkage(linkage, source=ps.source, scale=ps.length_scale, unit=ps.length_unit, out=out, name=name,
                 force=force, package=package, sizes=sizes, quiet=quiet, as_json=as_json,
                 details=lambda: details(linkage, ps),
                 require_free=require_collision_free, result=result)


def design_line(linkage, scale: float, unit: str) -> str:
    """One summary line: the four-bar's links, transmission and task range (and the fit's largest error)."""
    f = linkage.info["fourbar"]
    L = f["lengths"]
    line = (f"  planar four-bar (crank-rocker, driver h1): ground {fmt_len(L['ground'], scale, unit)}, crank "
            f"{fmt_len(L['crank'], scale, unit)}, coupler {fmt_len(L['coupler'], scale, unit)}, rocker "
            f"{fmt_len(L['rocker'], scale, unit)}; transmission >= {f['transmission_min_deg']:.1f} deg over the "
            f"crank's task range {f['task_range_deg'][0]:.1f} .. {f['task_range_deg'][1]:.1f} deg")
    fit = linkage.info.get("fit")
    if fit:
        line += (f"; largest pose error {fmt_len(fit['max_position_error'], scale, unit)}, "
                 f"{math.degrees(fit['max_angle_error']):.3g} deg")
    return line


def details(linkage, ps) -> None:
    """The four-bar's lines of the summary: the design line, and a task's table of errors (`cli.task.print_fit`)."""
    echo(design_line(linkage, ps.length_scale, ps.length_unit))
    if "fit" in linkage.info:
        from .task import print_fit

        print_fit(linkage, ps)


def index_document(linkages, ids, ps) -> dict:
    sols = []
    for rank, (lk, sid) in enumerate(zip(linkages, ids), start=1):
        f = lk.info["fourbar"]
        sols.append({"id": sid, "rank": rank, "path": f"{sid}/", "lengths": f["lengths"],
                     "transmission_min_deg": f["transmission_min_deg"], "extent": f["extent"], "cost": f["cost"],
                     "checks": {k: lk.checks[k] for k in ("max_pose_error", "max_closure_error")}})
    return {"format": INDEX_FORMAT, "kind": "planar_fourbar", "poses": ps.source,
            "units": {"length": "m", "angle": "rad"}, "input_length_unit": ps.length_unit,
            "input_length_scale": ps.length_scale, "score_rule": linkages[0].info["score_rule"], "solutions": sols}


def _ranked(ps, linkages, top, *, sizes, out, name, force, package, quiet, as_json, require_free):
    results = None
    if out or as_json or require_free:  # the physical design of every solution, collision-free first
        linkages, results = design_solutions(linkages, ps, sizes, quiet=quiet, require_free=require_free,
                                             what="four-bars")
    ids = [f"{r:02d}-fourbar" for r in range(1, len(linkages) + 1)]
    doc = index_document(linkages, ids, ps)
    if results is not None:
        add_collisions(doc["solutions"], results, ps)
    if not quiet:
        echo(f"planar four-bars through {len(ps)} poses: the {len(linkages)} best"
             + (f" (asked for {top})" if len(linkages) < top else ""))
        for sol, lk in zip(doc["solutions"], linkages):
            echo(f"  {sol['id']}:" + design_line(lk, ps.length_scale, ps.length_unit)[1:]
                 + (f"; {sol['design_summary']}" if "design_summary" in sol else ""))
    write_ranked(linkages, ids, results, doc, ps, out=out, name=name, force=force, package=package, quiet=quiet,
                 as_json=as_json)
