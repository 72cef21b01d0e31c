"""In-process timing of `mpsynth sixbar` (issue 4): the default synthesis including the scan of both
families, and the 9 loops of one member.

    .venv/bin/python bench/bench_sixbar.py [--sets N] [--repeat R]

Every figure is the *minimum* over R repeats per pose set (wall clock, its median in brackets, and CPU
time of the process), then the median over the sets: the minimum is the least disturbed by other
processes on a busy machine, CPU time excludes waiting for a core. Targets (issue 4):
default synthesis <= 4 ms (100x rational-linkages' 6R pipeline), one member's 9 loops < 1 ms. Reported parts:

  prepare        conditioning, quadric, both families            (synth.synthesis.sixbar.prepare)
  scan           GRID members per family factorized and scored    (synth.synthesis.sixbar.scan)
  build          best candidate -> world-frame Linkage (+ DH)     (synth.synthesis.sixbar.build_linkage, no check)
  self_check     pose reproduction + closure over 200 samples     (synth.checks.self_check)
  sixbar()       all of the above, the self-check at the library's DEFAULT_CHECK_SAMPLES parameters
                 (synth.synthesis.sixbar.sixbar, the default)
  ... 200        the same with the CLI's 200-sample self-check (check_samples=VERIFY_SAMPLES)
  one member     6 factorizations (Newton-polished) + 9 loops + their scores, world frame,
                 poses already prepared: the scan's code on a batch of one member
                 (synth.synthesis.sixbar_member.one_member_loops)
  ... unscored   the same without the scores                      (one_member_loops(score=False))
  ... + prepare  the same from the raw poses                      (one_member_loops(problem=None))
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from synth.checks import self_check  # noqa: E402
from synth.errors import SynthesisError  # noqa: E402
from synth.synthesis.sixbar import build_linkage, prepare, scan, sixbar  # noqa: E402
from synth.synthesis.sixbar_member import one_member_loops  # noqa: E402


def timed(fn, repeat):
    """(min wall ms, median wall ms, min CPU ms) over ``repeat`` calls. CPU time (process_time) does not
    count the time the process waits for a core, so it is the better figure on a busy machine."""
    wall, cpu = [], []
    for _ in range(repeat):
        c = time.process_time()
        t = time.perf_counter()
        fn()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return min(wall) * 1e3, statistics.median(wall) * 1e3, min(cpu) * 1e3


def pose_sets(n, seed=2024):
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    sets = [example()]
    while len(sets) < n:
        T = np.tile(np.eye(4), (4, 1, 1))
        T[:, :3, :3] = Rotation.random(4, random_state=rng).as_matrix()
        T[:, :3, 3] = rng.normal(size=(4, 3))
        try:
            prepare(T)
        except SynthesisError:
            continue  # oval: no 6R
        sets.append(T)
    return sets


def example():
    """MATH.md section 11 E."""
    from synth.algebra.dq import quat_to_matrix

    T = np.tile(np.eye(4), (4, 1, 1))
    for i, (p, q) in enumerate([((0, 0, 0), (1, 0, 0, 0)), ((1, 0, 0.5), (0.6, 0, 0, 0.8)),
                                ((0.25, 1, 0.2), (0.6, 0.8, 0, 0)), ((-1, 0.5, 0), (0.2, 0.4, 0.4, 0.8))]):
        T[i, :3, :3] = quat_to_matrix(np.array(q, float))
        T[i, :3, 3] = p
    return T


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=10, help="pose sets (the first is MATH.md 11 E)")
    ap.add_argument("--repeat", type=int, default=30, help="repeats per measurement")
    args = ap.parse_args(argv)
    rows = {k: [] for k in ("prepare", "scan", "build", "self_check", "sixbar()", "... 200", "one member",
                            "... unscored", "... + prepare")}
    for T in pose_sets(args.sets):
        sixbar(T)  # warm-up (imports, caches)
        pr = prepare(T)
        ranking = scan(pr)
        cand = ranking[0]
        lk = build_linkage(pr, cand)
        rows["prepare"].append(timed(lambda: prepare(T), args.repeat))
        rows["scan"].append(timed(lambda: scan(pr), args.repeat))
        rows["build"].append(timed(lambda: build_linkage(pr, cand, check=False), args.repeat))
        rows["self_check"].append(timed(lambda: self_check(lk, 200), args.repeat))
        rows["sixbar()"].append(timed(lambda: sixbar(T), args.repeat))
        rows["... 200"].append(timed(lambda: sixbar(T, check_samples=200), args.repeat))
        fam, member = cand.family, cand.member
        rows["one member"].append(timed(lambda: one_member_loops(T, fam, member, problem=pr), args.repeat))
        rows["... unscored"].append(timed(lambda: one_member_loops(T, fam, member, problem=pr, score=False),
                                          args.repeat))
        rows["... + prepare"].append(timed(lambda: one_member_loops(T, fam, member), args.repeat))
    print(f"sixbar timings over {args.sets} pose sets, {args.repeat} repeats (ms; median over the sets of the "
          "per-set minimum wall time [median wall time], minimum CPU time; worst set's minimum wall time)")
    for k, v in rows.items():
        mins, meds, cpus = ([x[i] for x in v] for i in range(3))
        print(f"  {k:14} wall {statistics.median(mins):7.3f} [{statistics.median(meds):7.3f}]  "
              f"cpu {statistics.median(cpus):7.3f}   worst set {max(mins):7.3f}")
    print("targets: sixbar() <= 4 ms; one member (poses prepared, scored) < 1 ms")


if __name__ == "__main__":
    main()
