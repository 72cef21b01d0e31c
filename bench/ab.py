"""A/B of `synth.bennett` against a baseline checkout, in one run (issue 30: "speed within 5%").

    .venv/bin/python bench/ab.py BASELINE [--rounds 5] [--sets 20] [--instructions]

BASELINE is another checkout of mpsynth (e.g. ``git worktree add /tmp/base <rev>``); both trees run with
this interpreter, one child process per tree and round, the trees interleaved (A B A B ...), so that a
change of the machine's load hits both. The figure per tree and round is the median over the pose sets
of the smallest CPU time (process_time) of ``--calls`` calls; the ratio B/A is printed per round and as
the median over rounds.

``--instructions`` counts instead the instructions of the same calls with valgrind's callgrind (the
count of a run with the calls less that of a run without them): repeatable whatever else the machine
is doing, the steadier figure on a loaded machine (instructions are not time: memory stalls are not in
it). Exit code 0; the verdict is printed, not enforced.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHILD = r'''
import sys, time
import numpy as np
import synth
rng = np.random.default_rng(7)
def pose():
    q = rng.normal(size=4); q /= np.linalg.norm(q); w, x, y, z = q
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                 [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                 [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = rng.normal(size=3)
    return T
sets, calls, mode = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
ok = []
for _ in range(sets):
    P = np.array([pose() for _ in range(3)])
    try:
        synth.bennett(P)
        ok.append(P)
    except Exception:
        pass
if mode == "time":
    best = []
    for P in ok:
        b = float("inf")
        for _ in range(calls):
            t = time.process_time_ns(); synth.bennett(P); b = min(b, time.process_time_ns() - t)
        best.append(b)
    print(float(np.median(best)) * 1e-9, len(ok))
else:
    for _ in range(calls if mode == "count" else 0):
        for P in ok:
            synth.bennett(P)
    print(len(ok))
'''


def child(tree: Path, *args: str, prefix=()) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1")
    return subprocess.run([*prefix, sys.executable, "-c", CHILD, *args], env=env, capture_output=True,
                          text=True, check=True, cwd=tree)


def seconds(tree: Path, sets: int, calls: int) -> float:
    return float(child(tree, str(sets), str(calls), "time").stdout.split()[0])


def instructions(tree: Path, sets: int, calls: int) -> float:
    """Instructions per call (callgrind): the run with ``calls`` rounds less the run with none."""
    counts = []
    for mode in ("none", "count"):
        r = child(tree, str(sets), str(calls), mode,
                  prefix=("valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null"))
        counts.append(int(re.search(r"Collected : (\d+)", r.stderr).group(1)))
        n = int(r.stdout.split()[0])
    return (counts[1] - counts[0]) / (calls * n)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("baseline", type=Path, help="another checkout of mpsynth (A); this tree is B")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--sets", type=int, default=20)
    ap.add_argument("--calls", type=int, default=60, help="calls per set (time) or rounds (instructions)")
    ap.add_argument("--instructions", action="store_true", help="count instructions with callgrind")
    a = ap.parse_args()
    trees = {"A (baseline)": a.baseline.resolve(), "B (this tree)": REPO}
    if a.instructions:
        if not shutil.which("valgrind"):
            print("valgrind is not installed: --instructions needs it")
            return 0
        calls = min(a.calls, 10)
        per = {k: instructions(t, a.sets, calls) for k, t in trees.items()}
        ratio = per["B (this tree)"] / per["A (baseline)"]
        for k, v in per.items():
            print(f"{k:14s} {v / 1e6:8.3f} M instructions per synth.bennett call")
        print(f"B / A = {ratio:.4f} ({(ratio - 1) * 100:+.1f}%)")
        return 0
    ratios = []
    for r in range(a.rounds):
        figs = {k: seconds(t, a.sets, a.calls) for k, t in trees.items()}
        ratios.append(figs["B (this tree)"] / figs["A (baseline)"])
        print(f"round {r + 1}: " + ", ".join(f"{k} {v * 1e6:.1f} us" for k, v in figs.items())
              + f", B / A = {ratios[-1]:.4f}")
    med = statistics.median(ratios)
    print(f"median B / A over {a.rounds} rounds = {med:.4f} ({(med - 1) * 100:+.1f}%); load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
