"""Task files with tolerances, velocities, an order or more poses than an exact synthesis takes (docs/fit.md):
`mpsynth bennett` hands them here. The library decides (`synth.synthesis.bennett_fit.bennett_task`,
`synth.synthesis.taskfit`); this module designs, writes and prints."""
from __future__ import annotations

from synth.design.work import GAPS_PER_SECOND

from .common import (add_collisions, choose_buildable, default_robot_name, design_solutions, echo, emit_linkage,
                     print_json)

BUILDABLE_CANDIDATES = 3  # default design: the best fits designed, collision-free first (within tolerance)
BUILDABLE_WORK = 4.0 * GAPS_PER_SECOND  # gap evaluations of those design searches (synth.design.work)
INDEX_FORMAT = "mpsynth.task-index/1"


def run_bennett_task(ps, top, best_effort, **kw):
    """Synthesize (exact, Hermite or fit), design, write and summarize a Bennett task."""
    from synth.synthesis.bennett_fit import bennett_task

    return run_task(ps, top, best_effort, bennett_task, **kw)


def run_task(ps, top, best_effort, synthesize, *, out, name, force, package, sizes, quiet, as_json, require_free):
    """Synthesize a task with the library entry ``synthesize(ps, top=, best_effort=)`` (`bennett_task`,
    `sixbar_task`), design, write and summarize it."""
    design = bool(out or as_json or require_free)
    if out:
        from synth.io.writer import check_output_target

        check_output_target(out, force)
    linkages = synthesize(ps, top=top or (BUILDABLE_CANDIDATES if design else 1), best_effort=best_effort)
    if top is not None:
        return _ranked(ps, linkages, top, out=out, name=name, force=force, package=package, sizes=sizes, quiet=quiet,
                       as_json=as_json, require_free=require_free)
    linkage, result = linkages[0], None
    within = [lk for lk in linkages if lk.info["fit"]["within_tolerance"]] or linkages
    if design and len(within) > 1:
        linkage, result = choose_buildable(within, ps, sizes, limit=BUILDABLE_CANDIDATES, work=BUILDABLE_WORK,
                                           what="fits")
    emit_linkage(linkage, source=ps.source, scale=ps.length_scale, unit=ps.length_unit, out=out, name=name,
                 force=force, package=package, sizes=sizes, quiet=quiet, as_json=as_json,
                 details=lambda: print_fit(linkage, ps), require_free=require_free, result=result)


def print_fit(linkage, ps) -> None:
    """The fit's lines of the summary: method, visiting order and the table of errors (library rows)."""
    from synth.synthesis.taskfit import error_rows

    f = linkage.info["fit"]
    seeds = f" from {f['seeds']} seeds ({f['refined']} refined, {f['iterations']} iterations)" if f["seeds"] else ""
    echo(f"  task: {f['method']}{seeds}; order {f['order']}, visited {' -> '.join(f['visit_order'] or [])}"
         + ("" if f["within_tolerance"] else "; TOLERANCES NOT MET (--best-effort)"))
    rows = [("pose", "position error", "angle error", "tolerance")] + error_rows(linkage, ps)
    widths = [max(len(r[k]) for r in rows) for k in range(4)]
    for r in rows:
        echo("    " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())


def _ranked(ps, linkages, top, *, out, name, force, package, sizes, quiet, as_json, require_free):
    from synth.io.jsonout import plain
    from synth.io.writer import write_solutions

    results = [None] * len(linkages)
    if out or as_json or require_free:
        linkages, results = design_solutions(linkages, ps, sizes, quiet=quiet, require_free=require_free,
                                             what="fits")
    ids = [f"{r:02d}-{lk.kind}" for r, lk in enumerate(linkages, start=1)]
    sols = [{"id": sid, "rank": r, "path": f"{sid}/", "fit": lk.info["fit"]}
            for r, (sid, lk) in enumerate(zip(ids, linkages), start=1)]
    if results[0] is not None:
        add_collisions(sols, results, ps)
    doc = {"format": INDEX_FORMAT, "kind": linkages[0].kind, "task": "poses", "poses": ps.source,
           "units": {"length": "m", "angle": "rad"}, "solutions": sols}
    if not quiet:
        echo(f"{linkages[0].kind} fits of {len(ps)} items: the {len(linkages)} best"
             + (f" (asked for {top})" if len(linkages) < top else ""))
        for s in sols:
            f = s["fit"]
            echo(f"  {s['rank']:>3} {s['id']:12} max error {f['max_position_error'] / ps.length_scale:.4g} "
                 f"{ps.length_unit} / {f['max_angle_error'] * 57.29577951308232:.4g} deg"
                 + ("" if f["within_tolerance"] else " (tolerance not met)")
                 + (f"  {s['design_summary']}" if "design_summary" in s else ""))
    if out:
        base = name or default_robot_name(ps.source)
        write_solutions(out, [(sid, lk, f"{base}_{sid.replace('-', '_')}", r)
                              for lk, sid, r in zip(linkages, ids, results)], plain(doc), force=force, package=package)
        if not quiet:
            echo(f"  wrote {out}/: index.json and {len(ids)} solution directories")
    if as_json:
        print_json(plain(doc))
