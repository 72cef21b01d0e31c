"""How task fits scale with the number of poses (issue 31): CPU time of a Bennett and a 6R fit of 10, 50, 200
and 1000 noisy poses of known motions, with the 10-pose time as the baseline of the same run.

    .venv/bin/python bench/bench_fit_scale.py [--sizes 10 50 200 1000] [--kinds bennett sixbar] [--order any]

Tasks (seeded): a Bennett motion through three random poses (`bench/bench_fit.py`), or a random 6R
motion (tests/sixbar_motions.py); N poses at parameters spread over the motion (phi uniform in
[0.15, 0.85] pi, pose 0 at phi = 0), positions moved by 1e-4 of the spread, pose 0 exact, tolerance
2e-3 of the spread / 2e-3 rad (Bennett) and 5e-3 / 0.5 deg (6R). Figures: process CPU time of one call of
``bennett_task`` / ``sixbar_task`` (fit, factorization, linkage, self-check; one BLAS thread) and the
ratio to 10 poses: a linear fit scales as N / 10. CPU time, not wall time: the machine is shared.
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
sys.path.insert(0, str(REPO / "bench"))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def bennett_set(n: int, order: str, seed: int = 100):
    """A PoseSet of n noisy poses of a known Bennett motion (`bench_fit.task_sets`)."""
    from dataclasses import replace

    from bench_fit import task_sets
    from synth.task import Order

    return replace(task_sets(n, 1, seed)[0], order=Order(order), source=f"{n} poses")


def sixbar_set(n: int, order: str, seed: int = 100):
    """A PoseSet of n noisy poses of a known 6R motion."""
    from sixbar_motions import poses_at, random_motion
    from synth.task import Order, PoseSet

    rng = np.random.default_rng(seed)
    C, X0 = random_motion(rng)
    phi = np.pi * np.sort(rng.uniform(0.15, 0.85, n - 1))
    T = poses_at(C, X0, np.r_[np.inf, np.cos(phi) / np.sin(phi)])
    return _noisy(T, rng, [5e-3, np.radians(0.5)], order, PoseSet, Order)


def _noisy(T, rng, tol, order, PoseSet, Order):
    n = len(T)
    spread = float(np.sqrt(np.mean(np.sum((T[:, :3, 3] - T[:, :3, 3].mean(0)) ** 2, 1))))
    T = T.copy()
    T[1:, :3, 3] += rng.normal(size=(n - 1, 3)) * 1e-4 * spread
    tols = np.tile([tol[0] * spread, tol[1]], (n, 1))
    tols[0] = 0.0
    return PoseSet(names=[f"p{i}" for i in range(n)], matrices=T, tolerance=tols, order=Order(order),
                   source=f"{n} poses")


def cpu(fn, arg) -> tuple[float, str]:
    """(process CPU seconds of fn(arg), the outcome: max position error / spread or the refusal)."""
    from synth.errors import SynthesisError

    t = time.process_time()
    try:
        lk = fn(arg)[0]
        f = lk.info.fit
        out = f"ok, within tolerance: {f.within_tolerance}"
    except SynthesisError as e:
        out = f"refused: {str(e)[:60]}"
    return time.process_time() - t, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 50, 200, 1000])
    ap.add_argument("--kinds", nargs="+", default=["bennett", "sixbar"])
    ap.add_argument("--order", default="any", choices=["any", "listed"])
    a = ap.parse_args(argv)
    from synth.blas import one_blas_thread
    from synth.synthesis.bennett_fit import bennett_task
    from synth.synthesis.sixbar_task import sixbar_task

    calls = {"bennett": (bennett_task, bennett_set), "sixbar": (sixbar_task, sixbar_set)}
    print(f"{'kind':8} {'poses':>6} {'cpu s':>9} {'x 10 poses':>11}  outcome")
    for kind in a.kinds:
        fn, make = calls[kind]
        with one_blas_thread():
            cpu(fn, make(10, a.order, 99))  # warm imports and caches
            base = None
            for n in a.sizes:
                t, out = cpu(fn, make(n, a.order))
                base = base or t
                print(f"{kind:8} {n:6d} {t:9.3f} {t / base:11.1f}  {out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
