"""Point tasks of `mpsynth bennett` (5 points) and `mpsynth sixbar` (7 points): the tool point passes
through prescribed points (docs/points.md). The synthesis and the choice of design are
`synth.solve.solve_points`'s; this module prints and writes its Result."""
from __future__ import annotations

import math

from synth.solve.tasks import point_count

from .common import echo, emit, fmt_len, finish_ranked

__all__ = ["point_count", "emit_points"]


def _design_line(lk) -> str:
    s = lk.info.synthesis
    p = s.score_parts
    pair = f", pair {s.pair}" if s.pair is not None else ""
    ts = ", ".join(f"{t:.4g}" for t in s.parameters[1:] + s.chosen_parameters)
    return (f"  point design: parameters t = {ts}{pair}; score {s.score:.3g} (conditioning "
            f"{p.conditioning:.3g}, extent {p.extent:.3g} x spread, min twist "
            f"{p.min_twist * 57.29577951308232:.1f} deg, min offset {p.min_offset:.3g} x spread)")


def emit_points(result, ps, output, top: int | None) -> None:
    """Write, summarize and print the Result of a point task (ranked with --top)."""
    if result.index is not None:
        return _ranked(result, ps, output, top)
    linkage = result.linkage

    def details():
        echo(_design_line(linkage))
        bp = linkage.info.bennett
        if bp:
            scale, unit = ps.length_scale, ps.length_unit
            echo(f"  Bennett: a = {fmt_len(bp.a, scale, unit)}, alpha = {math.degrees(bp.alpha):.4f} deg, "
                 f"b = {fmt_len(bp.b, scale, unit)}, beta = {math.degrees(bp.beta):.4f} deg")
        chosen = linkage.info.synthesis.chosen_points
        if chosen:
            pts = "; ".join(" ".join(f"{x / ps.length_scale:.6g}" for x in p) for p in chosen)
            echo(f"  chosen points ({ps.length_unit}): {pts}")

    emit(result, output, details)


def _ranked(result, ps, output, top: int) -> None:
    doc, sols = result.index, result.solutions
    kind = result.linkage.kind
    if not output.quiet:
        echo(f"{kind} designs through {len(ps)} points: the {len(sols)} best of the scan"
             + (f" (asked for {top})" if len(sols) < top else "") + " (extent and offset in point spreads)")
        for s in doc["solutions"]:
            p = s["score_parts"]
            echo(f"  {s['rank']:>3} {s['id']:14} score {s['score']:.3g}  cond {p['conditioning']:.3g}  extent "
                 f"{p['extent']:.3g}  point err {s['checks']['max_pose_translation_error']:.1e}"
                 + (f"  {s['design_summary']}" if "design_summary" in s else ""))
    finish_ranked(result, output)
