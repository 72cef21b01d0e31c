"""Collision-free rates with parts sized to be built (issue 33), before and after, in one script.

    .venv/bin/python bench/bench_sturdy.py [--bennett 24] [--sixbar 26] [--repo PATH] [--slenderness 25] [--choice]
                                           [--pieces]

The seeded random solvable pose sets of bench/bench_design.py (Bennett: 3 poses, 6R: 4), minus the
near-translational ones whose linkage is over `FAR` metres across (extent; the poses are ~1 m apart).
Each linkage gets the library's design choice, `synth.design.choose.design_for` with its default sizes
(full cycle first, then the task range; thinning, layering, cranks). With ``--choice`` a 6R set is what
``mpsynth sixbar -o`` designs: its best-scored candidates (`synth.solve.tasks.SIXBAR_CHOICE`) chosen
collision-free first (`synth.design.ranking.rank_buildable`), else the best-scored linkage alone. Printed
per kind: sets, certified free over the full cycle, free over the task range (full included), the
slenderness of the bars between joint sites (longest distance / bar diameter, max over sets: the rule
before issue 33's written rule) and of the bars as written (mount -> via points -> mount,
`synth.design.model.bar_polyline`: the rule now), the bore wall (min, mm) and the CPU seconds of the
designs (median, max; process time: the machine is shared). With ``--pieces`` also the parts whose mesh
(`synth.io.meshes.design_solids`) is not one body (trimesh's split, an independent count).

``--repo PATH`` imports ``synth`` from another checkout (e.g. main, for the "before" numbers); the
sets are the same (same seeds, same synthesis there).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

FAR = 100.0  # metres: a linkage this large on poses ~1 m apart is a near-translational set


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bennett", type=int, default=24)
    ap.add_argument("--sixbar", type=int, default=26)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repo", default=str(Path(__file__).resolve().parents[1]))
    ap.add_argument("--slenderness", type=float, default=None, help="design_for's slenderness (when it has one)")
    ap.add_argument("--choice", action="store_true", help="6R: the CLI's choice among the best-scored candidates")
    ap.add_argument("--pieces", action="store_true", help="count the parts not one body (builds the meshes)")
    args = ap.parse_args(argv)
    sys.path.insert(0, args.repo)
    sys.path.insert(0, str(Path(args.repo) / "bench"))  # its bench_design puts its repo first on the path
    import numpy as np
    from bench_design import random_poses, solvable_sets
    from synth.design.choose import design_for

    assert Path(sys.modules["synth"].__file__).resolve().is_relative_to(Path(args.repo).resolve())

    extra = {} if args.slenderness is None else {"slenderness": args.slenderness}

    def design(kind, seed, lk):
        if kind == "bennett" or not args.choice:
            return lk, design_for(lk, **extra)
        from synth.design.ranking import rank_buildable
        from synth.solve.tasks import SIXBAR_CHOICE
        from synth.synthesis.sixbar import sixbar_candidates

        cands = sixbar_candidates(random_poses(np.random.default_rng(seed), 4), top=SIXBAR_CHOICE["limit"], build=True)
        return rank_buildable(cands, lambda c, ranges, full_work, work, effort: design_for(
            c, ranges=ranges, full_work=full_work, work=work, effort=effort, **extra), **SIXBAR_CHOICE)[0]

    for kind, count in (("bennett", args.bennett), ("sixbar", args.sixbar)):
        if not count:
            continue
        full = task = n = 0
        slender, wall, cpu, pieces, written = 0.0, np.inf, [], 0, 0.0
        for seed, lk in solvable_sets(kind, count, args.seed):
            if lk.extent() > FAR:
                continue
            n += 1
            t0 = time.process_time()
            lk, r = design(kind, seed, lk)
            cpu.append(time.process_time() - t0)
            c, d = r.collision, r.design
            full += bool(c.free and c.range == "full")
            task += bool(c.free)
            sites = lk.joint_sites()
            lengths = [np.linalg.norm(sites[b] - sites[a]) for names in lk.links.values()
                       for a, b in zip(names, names[1:])]
            slender = max(slender, max(lengths) / (2 * d.bar_radius))
            wall = min(wall, d.hub_radius - d.pin_radius - d.hole_clearance)
            bars = _written(lk, d)
            written = max(written, bars)
            split = ""
            if args.pieces:
                broken = _pieces(lk, d)
                pieces += len(broken)
                split = f", in pieces: {broken or 'none'}"
            print(f"{kind} seed {seed}: {'full' if c.free and c.range == 'full' else 'task' if c.free else 'none'} "
                  f"bar r {1e3 * d.bar_radius:.1f} mm, slenderness {max(lengths) / (2 * d.bar_radius):.1f}, "
                  f"written 1:{bars:.2f}, cpu {cpu[-1]:.2f} s{split}", flush=True)
        print(f"{kind}{' (choice)' if args.choice and kind == 'sixbar' else ''}: sets {n} (of {count}; over {FAR:g} m "
              f"excluded)  full cycle {full}/{n}  task range {task}/{n}  max slenderness (sites) 1:{slender:.1f}  "
              f"written bars max 1:{written:.2f}  min bore wall {1e3 * wall:.2f} mm  cpu s median "
              f"{statistics.median(cpu):.2f} max {max(cpu):.2f}"
              + (f"  parts in pieces {pieces}" if args.pieces else ""), flush=True)
    return 0


def _pieces(lk, design) -> list[str]:
    """The parts of ``design`` whose mesh is more than one body."""
    from synth.io.meshes import design_solids

    return [n for n, s in design_solids(lk, design).items() if len(s.to_trimesh().split(only_watertight=False)) != 1]


def _written(lk, design) -> float:
    """The largest length / diameter of the bars of ``design`` as written (mount -> via points -> mount):
    `synth.design.sturdy.written_slenderness`, or, in a checkout without it (``--repo``, before), the same
    from `synth.design.model.bar_polyline`."""
    try:
        from synth.design.sturdy import written_slenderness
    except ImportError:
        import numpy as np
        from synth.design.model import bar_polyline

        return max(float(np.linalg.norm(np.diff(np.array(bar_polyline(lk, design, b)), axis=0), axis=-1).sum())
                   for b in design.bars) / (2 * design.bar_radius)
    return written_slenderness(lk, design).ratio


if __name__ == "__main__":
    raise SystemExit(main())
