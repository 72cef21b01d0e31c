"""Benchmark: complete factorization of random motion polynomials (all n! factorizations).

Run on demand (not part of pytest):

    .venv/bin/python bench/bench_factor.py                     # degrees 2..6, 20 polynomials each
    .venv/bin/python bench/bench_factor.py --degrees 3 --repeat 200

For every degree: ``--count`` random products of revolute factors (seeded), each timed ``--repeat``
times round-robin after a warm-up, ``synth.algebra.factorize.factorize(C)`` with validation. Reports the median
and minimum in-process wall time per call and the mean CPU time per call (``time.process_time``; on a
shared machine CPU time and the minimum are the steadier figures). Target for the cubic: 200 us.
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

from synth.algebra.factorize import factorize  # noqa: E402
from synth.algebra.polynomial import product_of_linear, relative_error  # noqa: E402

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


def bench(polys, repeat, warmup):
    """(median wall, min wall, mean CPU) per call in seconds over ``repeat`` rounds of all polys."""
    for _ in range(warmup):
        for C in polys:
            factorize(C)
    walls = []
    clock = time.perf_counter
    c0 = time.process_time()
    for _ in range(repeat):
        for C in polys:
            t0 = clock()
            factorize(C)
            walls.append(clock() - t0)
    cpu = (time.process_time() - c0) / (repeat * len(polys))
    return statistics.median(walls), min(walls), cpu


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=20, help="random polynomials per degree")
    ap.add_argument("--repeat", type=int, default=50, help="timed rounds (degrees >= 5: a fifth, at least 2)")
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--degrees", type=int, nargs="+", default=[2, 3, 4, 5, 6])
    ap.add_argument("--seed", type=int, default=12345)
    args = ap.parse_args(argv)

    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; {args.count} polynomials x "
          f"{args.repeat} rounds after {args.warmup} warm-up")
    for n in args.degrees:
        polys = [random_polynomial(n, args.seed + 1000 * n + i) for i in range(args.count)]
        results = [factorize(C) for C in polys]
        count = min(len(r.factorizations) for r in results)
        worst = max(float(np.max(relative_error(product_of_linear(np.stack([f.factors for f in r.factorizations])), C)))
                    for r, C in zip(results, polys))
        repeat = args.repeat if n <= 4 else max(2, args.repeat // 5)
        med, lo, cpu = bench(polys, repeat, args.warmup)
        line = (f"degree {n}: >= {count}/{math.factorial(n)} factorizations, max multiply-back {worst:.1e}; "
                f"median {med * 1e6:8.1f} us, min {lo * 1e6:8.1f} us, CPU {cpu * 1e6:8.1f} us per call")
        if n == 3:
            verdict = "meets" if med * 1e6 <= TARGET_CUBIC_US else "MISSES"
            line += f"  target {TARGET_CUBIC_US:.0f} us: {verdict}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
