"""`mpsynth batch` against the library's own rate (issue 36), in one run.

    python bench/bench_batch.py [--jobs 20000] [--design-jobs 200] [--runs j1,j2,local,design,nodesign]

N random Bennett jobs from README's generator ("Batch and shell pipelines": three poses in mm and
degrees, ``random.seed(1)``) are run as new processes, stdout to a file:

1. ``mpsynth batch JOBS -j 1``, ``-j 2`` and ``--scheduler local`` (a LocalCluster, start-up included;
   skipped when dask is not installed): jobs/s; the three result files must be byte-identical (checked);
2. `synth.bennett_batch` on the same pose sets (parsed once, in this process): linkages/s, the
   baseline of the ratios printed;
3. writing outputs (each job with ``"out"``) on the first ``--design-jobs`` jobs: with the design search
   (URDF + STL + linkage.json, collision-free search) and with ``--no-design`` (kinematic outputs only).

Targets (issue 36): ``-j 2`` >= 10,000 jobs/s and >= 25% of bennett_batch's rate; outputs with the design
search >= 10 jobs/s; ``--scheduler local`` within 20% of ``-j 2``. Wall-clock figures on a machine that
may be shared: the load average before and after is printed.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))


def readme_jobs(n: int, seed: int = 1) -> list[str]:
    """N job lines exactly as README's generator prints them (for n = 1000, its jobs.jsonl)."""
    random.seed(seed)
    out = []
    for i in range(n):
        poses = [{"position": [random.uniform(-200, 200) for _ in range(3)],
                  "rpy": [random.uniform(-180, 180) for _ in range(3)]} for _ in range(3)]
        out.append(json.dumps({"id": i, "kind": "bennett", "units": {"length": "mm", "angle": "deg"}, "poses": poses}))
    return out


def mpsynth(args, out: Path, cwd: Path = ROOT) -> float:
    """Wall seconds of `mpsynth ARGS -q > out` (a new process; exit 0 or 1 expected)."""
    t = time.perf_counter()
    with open(out, "wb") as f:
        p = subprocess.run([sys.executable, "-m", "cli.main", *map(str, args), "-q"], stdout=f,
                           stderr=subprocess.PIPE, cwd=cwd, env=ENV)
    wall = time.perf_counter() - t
    if p.returncode not in (0, 1):
        sys.exit(f"mpsynth {' '.join(map(str, args))} failed ({p.returncode}): {p.stderr.decode()[-2000:]}")
    return wall


def library_rate(lines: list[str], repeats: int = 3) -> float:
    """Linkages/s of `synth.bennett_batch` on the jobs' pose sets (best of ``repeats``; parsing excluded)."""
    sys.path.insert(0, str(ROOT))
    from synth import bennett_batch
    from synth.io.poses import parse_pose_document

    docs = [{k: v for k, v in json.loads(s).items() if k in ("poses", "units")} for s in lines]
    T = np.stack([parse_pose_document(d, count=3).matrices for d in docs])
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        bennett_batch(T)
        best = min(best, time.perf_counter() - t)
    return len(T) / best


def has_dask() -> bool:
    return subprocess.run([sys.executable, "-c", "import distributed"], capture_output=True).returncode == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=20_000)
    ap.add_argument("--design-jobs", type=int, default=200, help="jobs with 'out' for the output runs")
    ap.add_argument("--runs", default="j1,j2,local,design,nodesign", help="comma-separated runs to make")
    a = ap.parse_args()
    runs = set(a.runs.split(","))
    load0 = os.getloadavg()
    rows = []  # (name, seconds, jobs)
    with tempfile.TemporaryDirectory(prefix="bench_batch-") as tmp:
        tmp = Path(tmp)
        lines = readme_jobs(a.jobs)
        jobs = tmp / "jobs.jsonl"
        jobs.write_text("\n".join(lines) + "\n")
        lib = library_rate(lines)
        results = {}
        for name, args in (("j1", ["-j", 1]), ("j2", ["-j", 2]), ("local", ["--scheduler", "local", "-j", 2])):
            if name not in runs or (name == "local" and not has_dask()):
                continue
            results[name] = tmp / f"r_{name}.jsonl"
            rows.append((f"batch {' '.join(map(str, args))}", mpsynth(["batch", jobs, *args], results[name]), a.jobs))
        same = len({p.read_bytes() for p in results.values()}) <= 1
        if "local" in results:  # the LocalCluster's start-up, from a run of one job
            (tmp / "one.jsonl").write_text(lines[0] + "\n")
            startup = mpsynth(["batch", tmp / "one.jsonl", "--scheduler", "local", "-j", 2], tmp / "r_one.jsonl")
            wall = rows[-1][1]
            rows.append(("batch --scheduler local, less its start-up", max(wall - startup, 1e-9), a.jobs))
        for name, extra in (("design", []), ("nodesign", ["--no-design"])):
            if name not in runs:
                continue
            out = tmp / f"out_{name}"
            out.mkdir()
            wjobs = tmp / f"jobs_{name}.jsonl"
            wjobs.write_text("".join(json.dumps({**json.loads(s), "out": f"o{i}"}) + "\n"
                                     for i, s in enumerate(lines[: a.design_jobs])))
            wall = mpsynth(["batch", wjobs, "-j", 2, "--out-dir", out, *extra], tmp / f"r_{name}.jsonl")
            rows.append((f"batch -j 2, outputs {'with the design search' if not extra else '--no-design'}", wall,
                         a.design_jobs))
    load1 = os.getloadavg()
    rate = {r[0]: r[2] / r[1] for r in rows}
    print(f"{a.jobs:,} README jobs; nproc {os.cpu_count()}; load {load0[0]:.1f} -> {load1[0]:.1f}")
    print(f"{'run':48s} {'seconds':>8s} {'jobs/s':>10s} {'/ bennett_batch':>16s}")
    print(f"{'synth.bennett_batch (in process, best of 3)':48s} {a.jobs / lib:8.2f} {lib:10,.0f} {1:16.4f}")
    for name, wall, n in rows:
        print(f"{name:48s} {wall:8.2f} {n / wall:10,.1f} {n / wall / lib:16.4f}")
    j2 = rate.get("batch -j 2")
    if j2:
        print(f"targets: -j 2 {j2:,.0f} jobs/s (>= 10,000: {j2 / 10_000:.3f}x); {j2 / lib:.1%} of bennett_batch "
              f"(>= 25%)")
    if j2 and "batch --scheduler local -j 2" in rate:
        print(f"--scheduler local / -j 2 = {rate['batch --scheduler local -j 2'] / j2:.2f} (>= 0.8); less the "
              f"LocalCluster's start-up: {rate['batch --scheduler local, less its start-up'] / j2:.2f}")
    d = rate.get("batch -j 2, outputs with the design search")
    if d:
        print(f"outputs with the design search: {d:.2f} jobs/s (>= 10: {d / 10:.3f}x)")
    if results:
        print(f"result files of {', '.join(results)} byte-identical: {same}")
        if not same:
            sys.exit(1)


if __name__ == "__main__":
    main()
