"""The time targets of issue 31 in one run: task fits next to the exact syntheses, and the CLI on every fit
fixture next to the same run without the STEP file.

    .venv/bin/python bench/bench_fit.py [--sets 5] [--runs 3] [--quick]

Pose sets: seeded, sampled from known Bennett motions (the linkage through 3 random poses) in listed order,
with 1e-4 relative noise on all but the first pose (exact), tolerance 2e-3 of the pose spread / 2e-3 rad;
6R: 8 noisy poses of known 6R motions (`bench_fit_sixbar.fit8_sets`). Figures per task, median over the
sets (and the minimum), wall clock and process CPU time (one BLAS thread, as the CLI runs):

* ``synth.bennett`` on 3 poses (the baseline: the exact synthesis, a batch of one);
* ``synth.synthesis.bennett_fit.bennett_task`` on 10 and 50 poses (targets 20 ms and 100 ms), with the
  ratio to the baseline; ``sixbar_task`` on 8 poses (target 0.5 s) next to ``synth.sixbar`` on 4;
* ``mpsynth bennett|sixbar FIXTURE -o OUT`` in new processes for every fit fixture (``*_fit*.yaml``),
  design search included (targets 2 s and 10 s): wall and CPU (user + system of the child), the median
  of ``--runs``, and the same without linkage.step (gmsh hidden from the process: the output without the
  ``cad`` extra) as the baseline of the same run, interleaved. Bytecode is compiled by a first, untimed
  run of each command. The load average is printed before and after: CPU time is the figure to compare
  on a shared machine.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "bench"))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

TARGETS = {"fit_10": 20e-3, "fit_50": 100e-3, "sixbar_fit_8": 0.5}
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # the first CLI run compiles


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


FIXTURES = [("bennett", "bennett_fit.yaml"), ("bennett", "bennett_fit_mount.yaml"),
            ("bennett", "bennett_points_fit.yaml"), ("sixbar", "sixbar_fit.yaml"), ("sixbar", "sixbar_points_fit.yaml")]
CLI_TARGET = {"bennett": 2.0, "sixbar": 10.0}
NO_STEP = "import sys; sys.modules['gmsh'] = None; from cli.main import main; main()"  # as without the cad extra


def cli(cmd: str, fixture: str, step: bool) -> tuple[float, float]:
    """(wall, CPU) seconds of ``mpsynth CMD fixtures/FIXTURE -o <new dir>`` in a new process (CPU: user +
    system time of the child); ``step`` False: with gmsh hidden (no linkage.step)."""
    head = ["-m", "cli.main"] if step else ["-c", NO_STEP]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        subprocess.run([sys.executable, *head, cmd, f"fixtures/{fixture}", "-o", str(Path(tmp) / "o"), "-q"],
                       cwd=REPO, check=True, capture_output=True, env=ENV)
        wall = time.perf_counter() - t
        if step != (Path(tmp) / "o" / "linkage.step").exists():
            raise RuntimeError(f"{fixture}: linkage.step {'missing' if step else 'written'}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def cli_rows(runs: int) -> list[tuple]:
    """(command, fixture, median wall, median CPU, the same without STEP) per fit fixture, interleaved."""
    rows = []
    for cmd, fixture in FIXTURES:
        cli(cmd, fixture, True)  # bytecode, caches
        got = {True: [], False: []}
        for _ in range(runs):
            for step in (True, False):
                got[step].append(cli(cmd, fixture, step))
        med = {k: [statistics.median(x) for x in zip(*v)] for k, v in got.items()}
        rows.append((cmd, fixture, *med[True], *med[False]))
    return rows


def load() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=5)
    ap.add_argument("--runs", type=int, default=3, help="CLI runs per fixture and variant")
    ap.add_argument("--quick", action="store_true", help="fewer rounds and CLI runs")
    a = ap.parse_args(argv)
    import synth
    from bench_fit_sixbar import fit8_sets
    from synth.blas import one_blas_thread
    from synth.synthesis.bennett import bennett
    from synth.synthesis.bennett_fit import bennett_task
    from synth.synthesis.sixbar_task import sixbar_task

    print(f"load average before: {load()}  ({os.cpu_count()} cores)")
    repeat, runs = (1, 1) if a.quick else (3, a.runs)
    rows = {}
    with one_blas_thread():
        three = [ps.matrices[:3] for ps in task_sets(3, a.sets)]
        bennett(three[0])  # warm imports
        rows["exact_3"] = timed(bennett, three, repeat * 5)
        for n in (10, 50):
            sets = task_sets(n, a.sets)
            bennett_task(sets[0])
            rows[f"fit_{n}"] = timed(bennett_task, sets, repeat)
        six = fit8_sets(a.sets)
        rows["sixbar_4"] = timed(lambda d: synth.sixbar(d[1]), six, repeat)
        rows["sixbar_fit_8"] = timed(lambda d: sixbar_task(d[0], top=1), six, repeat)
    base = rows["exact_3"]["median"]
    print(f"{'figure':12} {'median':>10} {'min':>10} {'cpu':>10} {'x exact_3':>10} {'target':>8}")
    for k, r in rows.items():
        tgt = f"{TARGETS[k] * 1e3:.0f} ms" if k in TARGETS else ""
        print(f"{k:12} {r['median'] * 1e3:8.2f}ms {r['min'] * 1e3:8.2f}ms {r['cpu'] * 1e3:8.2f}ms "
              f"{r['median'] / base:10.1f} {tgt:>8}")
    print(f"load average: {load()}")
    print(f"{'command':8} {'fixture':26} {'wall':>7} {'cpu':>7} {'no STEP: wall':>14} {'cpu':>7} "
          f"{'cpu / no STEP':>14} {'target':>7}")
    for cmd, fixture, wall, cpu, wall0, cpu0 in cli_rows(runs):
        print(f"{cmd:8} {fixture:26} {wall:6.2f}s {cpu:6.2f}s {wall0:13.2f}s {cpu0:6.2f}s {cpu / cpu0:14.2f} "
              f"{CLI_TARGET[cmd]:6.0f}s", flush=True)
    print(f"load average after: {load()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
