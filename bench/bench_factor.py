"""Benchmark: complete factorization of random motion polynomials (all n! factorizations).

Run on demand (not part of pytest):

    .venv/bin/python bench/bench_factor.py            # n = 2, 3, 4; 2000 timed runs each
    .venv/bin/python bench/bench_factor.py --runs 500 --degrees 3

Reports the median in-process wall time of ``synth.factor.factorize(C)`` (validation included) after a
warm-up, for one fixed random polynomial per degree (seeded). Target for the cubic: 200 microseconds.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from synth.factor import factorize  # noqa: E402
from synth.motion import product_of_linear  # noqa: E402

TARGET_CUBIC_US = 200.0


def random_revolute(rng):
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    a = rng.uniform(-2, 2)
    b = rng.uniform(0.3, 2)
    c = rng.uniform(-2, 2, size=3)
    return np.concatenate([[a], -b * u, [0.0], b * np.cross(c, u)])


def random_polynomial(n, seed):
    rng = np.random.default_rng(seed)
    return product_of_linear(np.stack([random_revolute(rng) for _ in range(n)]))


def bench(C, runs, warmup):
    for _ in range(warmup):
        factorize(C)
    times = []
    clock = time.perf_counter
    for _ in range(runs):
        t0 = clock()
        factorize(C)
        times.append(clock() - t0)
    return times


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--warmup", type=int, default=100)
    ap.add_argument("--degrees", type=int, nargs="+", default=[2, 3, 4])
    ap.add_argument("--seed", type=int, default=12345)
    args = ap.parse_args(argv)

    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; {args.runs} runs after {args.warmup} warm-up")
    for n in args.degrees:
        C = random_polynomial(n, args.seed + n)
        r = factorize(C)
        count = len(r.factorizations)
        worst = max(f.residual for f in r.factorizations)
        times = bench(C, args.runs, args.warmup)
        med = statistics.median(times) * 1e6
        p10, p90 = (np.percentile(times, [10, 90]) * 1e6).tolist()
        line = (f"degree {n}: {count}/{math.factorial(n)} factorizations, max residual {worst:.1e}, "
                f"median {med:8.1f} us  (p10 {p10:.1f}, p90 {p90:.1f})")
        if n == 3:
            verdict = "meets" if med <= TARGET_CUBIC_US else "MISSES"
            line += f"  target {TARGET_CUBIC_US:.0f} us: {verdict}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
