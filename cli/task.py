"""Task files with tolerances, velocities, an order or more poses than an exact synthesis takes (docs/fit.md):
`mpsynth bennett` prints and writes the Result of `synth.solve.solve_bennett` for them (the library decides:
`synth.synthesis.bennett_fit.bennett_task`, `synth.synthesis.taskfit`, the choice of design)."""
from __future__ import annotations

from .common import echo, emit, finish_ranked


def emit_task(result, ps, output, top: int | None) -> None:
    """Write, summarize and print the Result of a task file (ranked with --top)."""
    if result.index is not None:
        return _ranked(result, ps, output, top)
    linkage = result.linkage
    emit(result, output, lambda: print_fit(linkage, ps))


def print_fit(linkage, ps) -> None:
    """The fit's lines of the summary: method, visiting order and the table of errors (library rows)."""
    from synth.synthesis.taskfit import error_rows

    f = linkage.info.fit
    seeds = f" from {f.seeds} seeds ({f.refined} refined, {f.iterations} iterations)" if f.seeds else ""
    echo(f"  task: {f.method}{seeds}; order {f.order}, visited {' -> '.join(f.visit_order or [])}"
         + ("" if f.within_tolerance else "; TOLERANCES NOT MET (--best-effort)"))
    rows = [("pose", "position error", "angle error", "tolerance")] + error_rows(linkage, ps)
    widths = [max(len(r[k]) for r in rows) for k in range(4)]
    for r in rows:
        echo("    " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())


def _ranked(result, ps, output, top: int) -> None:
    sols, kind = result.index["solutions"], result.linkage.kind
    if not output.quiet:
        echo(f"{kind} fits of {len(ps)} items: the {len(sols)} best" + (f" (asked for {top})" if len(sols) < top else ""))
        for s in sols:
            f = s["fit"]
            echo(f"  {s['rank']:>3} {s['id']:12} max error {f['max_position_error'] / ps.length_scale:.4g} "
                 f"{ps.length_unit} / {f['max_angle_error'] * 57.29577951308232:.4g} deg"
                 + ("" if f["within_tolerance"] else " (tolerance not met)")
                 + (f"  {s['design_summary']}" if "design_summary" in s else ""))
    finish_ranked(result, output)
