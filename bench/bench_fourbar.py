"""In-process timing of `mpsynth fourbar`'s library part (issue 32): five exact poses and an eight-pose fit.

    .venv/bin/python bench/bench_fourbar.py [--sets N] [--repeat R]

Each pose set comes from the coupler of a random crank-rocker (seeded, tests/fourbar_tasks.py) in a tilted
plane; the fit's poses carry in-plane noise (0.02 mm, 0.011 deg at 0.2 m) and a tolerance of 0.1 mm and
0.057 deg. Figures: the minimum wall time over R repeats per set (least disturbed on a busy machine; CPU time
in brackets), then the median over the sets. Targets (issue 32): five poses <= 50 ms, eight-pose fit <= 0.5 s,
for `synth.synthesis.fourbar.fourbar_candidates(..., top=1)` with the CLI's 200-sample self-check.

Baseline, timed in the same run on the same sets: the textbook numerical route without the batched algebra:
five poses by scipy.optimize.fsolve on the four dyad equations from a 6 x 6 grid of fixed pivots (one start at
a time; the Burmester points found are then ranked by the same code), and the fit by
scipy.optimize.least_squares on each dyad seed in turn (as many seeds). The ratio baseline / library (wall and
CPU time) says what the batched formulation buys; the dyad step alone is timed for both.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from fourbar_tasks import coupler_poses, noisy, random_crank_rocker  # noqa: E402
from synth.checks import VERIFY_SAMPLES  # noqa: E402
from synth.synthesis import fourbar_dyads as fd  # noqa: E402
from synth.synthesis.fourbar import fourbar_candidates  # noqa: E402
from synth.synthesis.fourbar_plane import plane_of_motion  # noqa: E402

NAMES = [f"p{i}" for i in range(8)]
TOL = np.tile([1e-4, 1e-3], (8, 1))


def timed(fn, repeat):
    """(min wall ms, min CPU ms) over ``repeat`` calls."""
    wall, cpu = [], []
    for _ in range(repeat):
        c, t = time.process_time(), time.perf_counter()
        fn()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return min(wall) * 1e3, min(cpu) * 1e3


def task_sets(n, seed=32):
    rng = np.random.default_rng(seed)
    five, fit = [], []
    for i in range(n):
        L = random_crank_rocker(rng)
        five.append(coupler_poses(L, np.linspace(0.3, 0.3 + math.radians(220), 5), plane_seed=i)[0])
        T = coupler_poses(L, np.linspace(0.3, 0.3 + math.radians(250), 8), plane_seed=i)[0]
        fit.append(noisy(T, rng, 2e-5, 2e-4))
    return five, fit


def baseline_burmester(task):
    """Burmester dyads by fsolve from a 6 x 6 grid of fixed pivots, one start at a time."""
    from scipy.optimize import fsolve

    def f(x):
        F, _ = fd.dyad_equations(task, x[None])
        return F[0]

    found = []
    for u in np.linspace(-3, 3, 6):
        for v in np.linspace(-3, 3, 6):
            G = np.array([u, v])
            w, _ = fd.null_circle_points(fd.rows_in_w(task, G))
            x, _, ok, _ = fsolve(f, np.concatenate([G, w]), full_output=True)
            if ok == 1 and np.max(np.abs(f(x))) < fd.EXACT_TOL:
                found.append(x)
    return found


def baseline_fit(task):
    """Least-squares dyads by scipy least_squares on each of the library's seeds in turn."""
    from scipy.optimize import least_squares

    w = fd.circle_point_grid(task, fd.FIT_GRID)
    G, err = fd.algebraic_circles(task, w, np.ones(len(task.theta)))
    out = []
    for n in np.argsort(err, kind="stable")[:fd.FIT_SEEDS + len(task.theta) - 1]:
        def res(x):
            d = np.linalg.norm(fd.moving_points(task, x[2:4]) - x[:2], axis=-1)
            return d - x[4]
        r, _ = fd.circle_figures(task, G[n], w[n])
        out.append(least_squares(res, np.concatenate([G[n], w[n], [r]]), method="lm", max_nfev=200).x)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    five, fit = task_sets(args.sets)
    fourbar_candidates(five[0], NAMES[:5])  # imports (scipy.linalg) and caches outside the timings
    rows = {}
    for label, sets, call in (
            ("five poses: fourbar_candidates", five,
             lambda T: fourbar_candidates(T, NAMES[:5], check_samples=VERIFY_SAMPLES)),
            ("five poses: Burmester dyads only", five, lambda T: fd.burmester_points(plane_of_motion(T, NAMES))),
            ("  baseline: fsolve from 36 starts", five, lambda T: baseline_burmester(plane_of_motion(T, NAMES))),
            ("eight-pose fit: fourbar_candidates", fit,
             lambda T: fourbar_candidates(T, NAMES, tolerance=TOL, check_samples=VERIFY_SAMPLES)),
            ("eight-pose fit: least-squares dyads only", fit,
             lambda T: fd.least_squares_dyads(plane_of_motion(T, NAMES))),
            ("  baseline: scipy least_squares per seed", fit, lambda T: baseline_fit(plane_of_motion(T, NAMES)))):
        figs = [timed(lambda: call(T), args.repeat) for T in sets]
        rows[label] = (statistics.median(w for w, _ in figs), statistics.median(c for _, c in figs))
    print(f"mpsynth fourbar library timings: median over {args.sets} sets of the minimum of {args.repeat} runs")
    print(f"| {'figure':42} | wall ms | CPU ms | target |")
    print(f"|{'-' * 44}|---------|--------|--------|")
    targets = {"five poses: fourbar_candidates": 50.0, "eight-pose fit: fourbar_candidates": 500.0}
    for label, (w, c) in rows.items():
        t = targets.get(label)
        print(f"| {label:42} | {w:7.2f} | {c:6.2f} | {f'<= {t:g} ms ({t / w:.1f}x)' if t else ''} |")
    for k, what in ((0, "wall"), (1, "CPU")):
        b5 = rows["  baseline: fsolve from 36 starts"][k] / rows["five poses: Burmester dyads only"][k]
        bf = rows["  baseline: scipy least_squares per seed"][k] / rows["eight-pose fit: least-squares dyads only"][k]
        print(f"baseline / library, dyad step ({what} time): five poses {b5:.1f}x, eight-pose fit {bf:.1f}x")


if __name__ == "__main__":
    main()
