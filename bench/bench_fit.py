"""Time of a Bennett task fit (docs/fit.md) next to the exact 3-pose synthesis in the same run.

    .venv/bin/python bench/bench_fit.py [--sets 5] [--quick]

Pose sets: seeded, sampled from known Bennett motions (the linkage through 3 random poses) in listed order,
with 1e-4 relative noise on all but the first pose (exact), tolerance 2e-3 of the pose spread / 2e-3 rad.
Figures per task, median over the sets (and the minimum), wall clock and process CPU time:

* ``synth.bennett`` on 3 poses (the baseline: the exact synthesis, a batch of one);
* ``synth.synthesis.bennett_fit.bennett_task`` on 10 and 50 poses (targets 20 ms and 100 ms), with the
  ratio to the baseline;
* ``mpsynth bennett fixtures/bennett_fit.yaml -o OUT`` in a new process, design search included
  (target 2 s), next to ``mpsynth bennett fixtures/bennett_mm_deg.yaml -o OUT`` (3 poses).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

TARGETS = {"fit_10": 20e-3, "fit_50": 100e-3, "cli_fit": 2.0}


def task_sets(n: int, sets: int, first_seed: int = 100):
    """``sets`` tasks of n poses each (PoseSet), seeded (``first_seed`` on)."""
    from synth.algebra.dq import dq_mul, dq_to_pose, normalize_dq, pose_to_dq
    from synth.errors import SynthesisError
    from synth.synthesis.bennett import bennett
    from synth.synthesis.fit import homogeneous
    from synth.task import Order, PoseSet
    from tests.conftest import random_poses

    out = []
    for s in range(sets):
        rng = np.random.default_rng(first_seed + s)
        while True:  # a linkage the synthesis accepts (its transmission)
            try:
                L = bennett(random_poses(rng, 3))
                break
            except SynthesisError:
                continue
        phi = np.pi * (1 - np.r_[0.0, np.sort(rng.uniform(0.15, 0.85, n - 1))])
        T = dq_to_pose(normalize_dq(dq_mul(homogeneous(L.motion[:2][None], phi[None])[0], pose_to_dq(L.tool_ref))))
        spread = float(np.sqrt(np.mean(np.sum((T[:, :3, 3] - T[:, :3, 3].mean(0)) ** 2, 1))))
        T[1:, :3, 3] += rng.normal(size=(n - 1, 3)) * 1e-4 * spread
        tol = np.tile([2e-3 * spread, 2e-3], (n, 1))
        tol[0] = 0.0
        out.append(PoseSet(names=[f"p{i}" for i in range(n)], matrices=T, tolerance=tol, order=Order.LISTED))
    return out


def timed(fn, args, repeat: int) -> dict:
    """Median and minimum wall time and the mean CPU time per call of fn(a) over args, ``repeat`` rounds."""
    walls, cpu0 = [], time.process_time()
    for _ in range(repeat):
        for a in args:
            t = time.perf_counter()
            fn(a)
            walls.append(time.perf_counter() - t)
    return {"median": statistics.median(walls), "min": min(walls),
            "cpu": (time.process_time() - cpu0) / (repeat * len(args))}


def cli(args, runs: int) -> float:
    """Median wall time of ``mpsynth ARGS -o <new dir>`` in new processes."""
    walls = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "cli.main", *args, "-o", str(Path(tmp) / "o"), "-q"], cwd=REPO,
                           check=True, capture_output=True)
            walls.append(time.perf_counter() - t)
    return statistics.median(walls)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="fewer rounds and CLI runs")
    a = ap.parse_args(argv)
    from synth.synthesis.bennett import bennett
    from synth.synthesis.bennett_fit import bennett_task

    repeat, runs = (1, 1) if a.quick else (3, 3)
    rows = {}
    three = [ps.matrices[:3] for ps in task_sets(3, a.sets)]
    bennett(three[0])  # warm imports
    rows["exact_3"] = timed(bennett, three, repeat * 5)
    for n in (10, 50):
        sets = task_sets(n, a.sets)
        bennett_task(sets[0])
        rows[f"fit_{n}"] = timed(bennett_task, sets, repeat)
    base = rows["exact_3"]["median"]
    print(f"{'figure':10} {'median':>10} {'min':>10} {'cpu':>10} {'x exact_3':>10} {'target':>8}")
    for k, r in rows.items():
        tgt = f"{TARGETS[k] * 1e3:.0f} ms" if k in TARGETS else ""
        print(f"{k:10} {r['median'] * 1e3:8.2f}ms {r['min'] * 1e3:8.2f}ms {r['cpu'] * 1e3:8.2f}ms "
              f"{r['median'] / base:10.1f} {tgt:>8}")
    c3 = cli(["bennett", "fixtures/bennett_mm_deg.yaml"], runs)
    cf = cli(["bennett", "fixtures/bennett_fit.yaml"], runs)
    print(f"{'cli_3':10} {c3:9.2f}s")
    print(f"{'cli_fit':10} {cf:9.2f}s {'':>10} {'':>10} {cf / c3:10.2f} {TARGETS['cli_fit']:7.0f}s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
