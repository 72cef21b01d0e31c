"""How many five-point subsets a Bennett point fit needs (docs/fit.md, "Seeds"): success and CPU time of
``bennett_task`` on held-out noisy point tasks against ``bennett_fit.MAX_SUBSETS``.

    .venv/bin/python bench/bench_point_subsets.py [--tasks 30] [--sizes 8 12 20] [--subsets 10 20 40 80 160]

Tasks: positions of known Bennett motions (tests/test_bennett_fit.py `sampled`, seeds 500 on: not those of
the tests), point 0 exact, the others moved by 1e-4 of the spread, tolerance 2e-3 of the spread. A task
counts as solved when the fit returns a linkage within every tolerance. CPU time: process time per call.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def point_task(seed: int, n: int):
    """A PoseSet of n noisy points of a known Bennett motion (point 0 exact)."""
    from test_bennett_fit import sampled, spread_of
    from synth.task import PoseSet

    T, _ = sampled(seed, n, noise=1e-4, exact=(0,))
    pts = T.copy()
    pts[:, :3, :3] = np.eye(3)
    tol = np.tile([2e-3 * spread_of(T), np.inf], (n, 1))
    tol[0] = 0.0
    return PoseSet(names=[f"q{i}" for i in range(n)], matrices=pts, kinds=["point"] * n, tolerance=tol)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", type=int, default=30)
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 12, 20])
    ap.add_argument("--subsets", type=int, nargs="+", default=[10, 20, 40, 80, 160])
    a = ap.parse_args(argv)
    from synth.blas import one_blas_thread
    from synth.errors import SynthesisError
    from synth.synthesis import bennett_fit

    print(f"{'points':>6} {'subsets':>7} {'solved':>8} {'cpu ms':>8}")
    for n in a.sizes:
        tasks = [point_task(500 + s, n) for s in range(a.tasks)]
        for k in a.subsets:
            bennett_fit.MAX_SUBSETS = k
            solved, t = 0, time.process_time()
            with one_blas_thread():
                for ps in tasks:
                    try:
                        solved += bennett_fit.bennett_task(ps)[0].info.fit.within_tolerance
                    except SynthesisError:
                        pass
            cpu = (time.process_time() - t) / len(tasks)
            print(f"{n:6d} {k:7d} {solved:4d}/{len(tasks):<3d} {cpu * 1e3:8.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
