"""Time per point task (docs/points.md): mpsynth next to rational-linkages on the same points.

    .venv/bin/python bench/bench_points.py [--sets 5] [--rl-python /tmp/rlvenv/bin/python] [--markdown FILE]

Point sets: seeded, taken from the tool origin of known linkages (a Bennett linkage through 3 random
poses, 5 points; a 6R linkage through 4 random poses, 7 points), so a solution exists. Figures per task,
median over the sets (and the minimum), wall clock plus process CPU time:

* mpsynth ``point_motion`` (one member: the interpolation alone, a batch of one);
* mpsynth ``bennett_points`` / ``sixbar_points`` (the whole task: scan of 136 / 400 members, batched
  factorization and score, the best distinct candidates built and self-checked);
* rational-linkages ``interpolate_points_quadratic`` / ``interpolate_points_cubic`` (one motion with
  its fixed parameters) and the same followed by ``RationalCurve.factorize`` (its factorizations: the
  joints of one linkage), run with ``--rl-python`` in its own environment (not a dependency of mpsynth).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

RL_SCRIPT = r"""
import json, sys, time
import numpy as np
from rational_linkages import MotionInterpolation, PointHomogeneous, RationalCurve
sets = json.load(sys.stdin)
out = {"interp": [], "interp_cpu": [], "task": [], "task_cpu": []}
for P in sets:
    pts = [PointHomogeneous([1.0, *p]) for p in P]
    MI = MotionInterpolation
    f = MI.interpolate_points_quadratic if len(P) == 5 else MI.interpolate_points_cubic
    f(pts, return_numeric=True)
    w, c = time.perf_counter(), time.process_time()
    for _ in range(20):
        coeffs = f(pts, return_numeric=True)
    out["interp"].append((time.perf_counter() - w) / 20)
    out["interp_cpu"].append((time.process_time() - c) / 20)
    w, c = time.perf_counter(), time.process_time()
    coeffs = f(pts, return_numeric=True)
    RationalCurve.from_coeffs(coeffs).factorize()
    out["task"].append(time.perf_counter() - w)
    out["task_cpu"].append(time.process_time() - c)
print(json.dumps(out))
"""


def point_sets(kind: str, count: int, seed: int = 0) -> list[np.ndarray]:
    """``count`` seeded point sets (metres) from known linkages: 5 points of a Bennett linkage's tool
    origin, or 7 of a 6R linkage's (pose sets without a 6R linkage are skipped)."""
    import synth
    from synth.errors import SynthesisError

    rng = np.random.default_rng(seed)
    out = []
    while len(out) < count:
        n = 3 if kind == "bennett" else 4
        T = np.tile(np.eye(4), (n, 1, 1))
        for i in range(n):
            q = rng.normal(size=4)
            from synth.algebra.dq import quat_to_matrix

            T[i, :3, :3] = quat_to_matrix(q / np.linalg.norm(q))
            T[i, :3, 3] = rng.normal(size=3) * 0.3
        try:
            L = synth.bennett(T) if kind == "bennett" else synth.sixbar(T)
        except SynthesisError:
            continue
        k = 5 if kind == "bennett" else 7
        ts = np.concatenate([[np.inf], np.sort(rng.normal(size=k - 1))])
        out.append(np.array([L.tool_pose({a: float(b) for a, b in L.angles_at(t).items()})[:3, 3] for t in ts]))
    return out


def timed(f, reps: int):
    f()
    w, c = time.perf_counter(), time.process_time()
    for _ in range(reps):
        f()
    return (time.perf_counter() - w) / reps, (time.process_time() - c) / reps


def mpsynth_figures(sets, degree: int) -> dict:
    from synth.synthesis.pointfit import parameter_samples, point_motion
    from synth.synthesis.points import bennett_points, sixbar_points

    task = bennett_points if degree == 2 else sixbar_points
    t = parameter_samples(1, 2 * degree - 2)
    out = {"interp": [], "interp_cpu": [], "task": [], "task_cpu": []}
    for P in sets:
        X = (P[1:] - P[0])[None]
        w, c = timed(lambda: point_motion(X, t, degree), 200)
        out["interp"].append(w)
        out["interp_cpu"].append(c)
        w, c = timed(lambda: task(P), 5)
        out["task"].append(w)
        out["task_cpu"].append(c)
    return out


def rl_figures(python: str, sets) -> dict | None:
    r = subprocess.run([python, "-c", RL_SCRIPT], input=json.dumps([P.tolist() for P in sets]), capture_output=True,
                       text=True, timeout=3600, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    if r.returncode != 0:
        print(f"rational-linkages run failed: {r.stderr.strip().splitlines()[-1:]}", file=sys.stderr)
        return None
    return json.loads(r.stdout.strip().splitlines()[-1])


def fmt(x: float) -> str:
    return f"{x * 1e6:.0f} µs" if x < 1e-3 else (f"{x * 1e3:.1f} ms" if x < 1 else f"{x:.2f} s")


def row(name: str, figs: dict, key: str) -> str:
    v, c = figs[key], figs[key + "_cpu"]
    return f"| {name} | {fmt(statistics.median(v))} | {fmt(min(v))} | {fmt(statistics.median(c))} |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=5)
    ap.add_argument("--rl-python", help="a Python interpreter in which rational_linkages is importable")
    ap.add_argument("--markdown", help="also write the table to this file")
    args = ap.parse_args(argv)
    load = os.getloadavg()[0]
    lines = [f"Point tasks, {args.sets} seeded point sets each (from known linkages); nproc {os.cpu_count()}, "
             f"load average {load:.1f} at the start (a loaded machine: compare the CPU column).", "",
             "| figure | median wall | min wall | median CPU |", "|---|---|---|---|"]
    for kind, degree in (("bennett", 2), ("sixbar", 3)):
        sets = point_sets(kind, args.sets, seed=degree)
        mine = mpsynth_figures(sets, degree)
        k = len(sets[0])
        lines.append(row(f"mpsynth `point_motion`, {k} points (one member)", mine, "interp"))
        lines.append(row(f"mpsynth `{kind}_points`, {k} points (scan, rank, build, self-check)", mine, "task"))
        if args.rl_python:
            rl = rl_figures(args.rl_python, sets)
            if rl:
                name = "quadratic" if degree == 2 else "cubic"
                lines.append(row(f"rational-linkages `interpolate_points_{name}` (one motion)", rl, "interp"))
                lines.append(row("rational-linkages interpolation + `RationalCurve.factorize`", rl, "task"))
    lines.append(f"\nload average at the end {os.getloadavg()[0]:.1f}")
    text = "\n".join(lines)
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
