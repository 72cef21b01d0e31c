"""`mpsynth batch` against the library's own rate (issue 36), in one run.

    python bench/bench_batch.py [--jobs 20000] [--design-jobs 200] [--runs cpu,j1,j2,nocheck,local,design,nostep,nodesign]

N random Bennett jobs from README's generator ("Batch and shell pipelines": three poses in mm and
degrees, ``random.seed(1)``) are run as new processes, stdout to a file:

1. ``mpsynth batch JOBS -j 1``, ``-j 2`` and ``--scheduler local`` (a LocalCluster, start-up included;
   skipped when dask is not installed): jobs/s; the three result files must be byte-identical (checked);
2. `synth.bennett_batch` on the same pose sets (parsed once, in this process): linkages/s, the
   baseline of the ratios printed;
3. CPU time per job in this process, per-job path against chunk path (steadier than wall time), and by
   stage of the chunk path (reading, `solve_bennett_many`, result lines);
4. writing outputs (each job with ``"out"``) on the first ``--design-jobs`` jobs: with the design search
   (URDF + STL + linkage.json + linkage.step, collision-free search), with ``--no-step`` (the same but
   linkage.step) and with ``--no-design`` (kinematic outputs only);
5. what-if (``--runs`` ``nocheck``): ``-j 2`` with the 200-sample self-check (`synth.solve.many`'s
   VERIFY_SAMPLES figures, which the result lines print) switched off in a driver process: what the rate
   would be without it (its result lines are not the batch's and are not compared).

Targets (issue 36): ``-j 2`` >= 10,000 jobs/s and >= 25% of bennett_batch's rate; outputs with the design
search >= 10 jobs/s; ``--scheduler local`` within 20% of ``-j 2``. Wall-clock figures on a machine that
may be shared: the load average before and after is printed.

The package's modules are compiled to bytecode first (``compileall``, as a pip install does): in a checkout
run with PYTHONDONTWRITEBYTECODE=1 every process compiled them again (~0.1 s of each start-up). The start-up
of one job (``-j 1``, and ``--scheduler local``) is measured as a run of its own.
"""
from __future__ import annotations

import argparse
import compileall
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_cluster import ROOT, mpsynth as run_cli  # noqa: E402 (this folder is on the path of a script)


def readme_jobs(n: int, seed: int = 1) -> list[str]:
    """N job lines exactly as README's generator prints them (for n = 1000, its jobs.jsonl)."""
    random.seed(seed)
    out = []
    for i in range(n):
        poses = [{"position": [random.uniform(-200, 200) for _ in range(3)],
                  "rpy": [random.uniform(-180, 180) for _ in range(3)]} for _ in range(3)]
        out.append(json.dumps({"id": i, "kind": "bennett", "units": {"length": "mm", "angle": "deg"}, "poses": poses}))
    return out


def mpsynth(args, out: Path) -> float:
    """Wall seconds of `mpsynth ARGS -q > out` (a new process; exit 0 or 1 expected)."""
    return run_cli(args, out)[0]


def mpsynth_unchecked(args, out: Path) -> float:
    """Wall seconds of `mpsynth ARGS -q > out` with `synth.solve.many`'s 200-sample self-check switched off
    (a what-if: the figures become 0 and its acceptance gate sees none; a new process, as `mpsynth`)."""
    code = ("import sys, cli, synth.solve.many as m; m.VERIFY_SAMPLES = 0; from cli.main import main; "
            "sys.exit(main(sys.argv[1:]))")
    return run_cli(args, out, entry=("-c", code))[0]


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


def cpu_per_job(lines: list[str], n: int = 1000) -> tuple[float, float]:
    """CPU µs per job (process time, steadier than wall time on a shared machine) of the first n jobs, in
    this process: the per-job path (`run_job` each) and the chunk path (`run_chunk`, chunks of 1024),
    result lines (`dumps`) included."""
    from synth.tools.batchjobs import dumps, run_chunk, run_job

    items = list(enumerate(lines[:n], 1))
    run_chunk(items[:8], False, None)  # (imports, caches)
    t = time.process_time()
    [dumps(run_job(it)) for it in items]
    single = (time.process_time() - t) / len(items) * 1e6
    t = time.process_time()
    [dumps(r) for k in range(0, len(items), 1024) for r in run_chunk(items[k : k + 1024], False, None)]
    return single, (time.process_time() - t) / len(items) * 1e6


def cpu_stages(lines: list[str], n: int = 4096) -> dict:
    """CPU µs per job of the chunk path's stages on the first n jobs, in this process (chunks of 1024):
    reading (the full reader job by job, and `read_common_bennett` a chunk at once), `solve_bennett_many`
    (of which `bennett_batch`'s core), and the result lines (`run_chunk_lines` less the rest)."""
    from synth import bennett_batch
    from synth.solve.many import solve_bennett_many
    from synth.tools.batchjobs import _read_job, run_chunk_lines
    from synth.tools.jobspec import read_common_bennett

    parts = [lines[k : k + 1024] for k in range(0, min(n, len(lines)), 1024)]
    count = sum(map(len, parts))

    def cpu(f):
        t = time.process_time()
        out = [f(p) for p in parts]
        return out, (time.process_time() - t) / count * 1e6

    _, full = cpu(lambda p: [_read_job((i, s), None) for i, s in enumerate(p, 1)])
    read, fast = cpu(read_common_bennett)
    _, solve = cpu(lambda p: solve_bennett_many(read[parts.index(p)].poses))
    _, core = cpu(lambda p: bennett_batch(read[parts.index(p)].poses))
    _, whole = cpu(lambda p: run_chunk_lines((1, [s.encode() for s in p]), False, None))
    return {"full reader": full, "fast reader": fast, "solve_bennett_many": solve, "bennett_batch": core,
            "result lines and the rest": whole - fast - solve, "run_chunk_lines": whole}


def children_cpu() -> float:
    """CPU seconds of this process's reaped children: linkage.step is built in a forked child
    (`synth.io.bounded`), whose time `time.process_time` does not see."""
    t = os.times()
    return t.children_user + t.children_system


def cpu_outputs(lines: list[str], tmp: Path, n: int = 10) -> tuple[float, ...]:
    """CPU ms per job writing OUT, in this process and its children (linkage.step's build) (`run_job`, n
    jobs): with the design search, with ``--no-step`` and with ``--no-design``."""
    from synth.io.outputs import Outputs
    from synth.tools.batchjobs import run_job

    out = []
    for outputs in (Outputs.FULL, Outputs.NO_STEP, Outputs.KINEMATIC):
        items = [(i + 1, json.dumps({**json.loads(s), "out": f"cpu_{outputs.value}_{i}"})) for i, s in enumerate(lines[:n])]
        t, c = time.process_time(), children_cpu()
        for it in items:
            run_job(it, out_dir=tmp, outputs=outputs)
        out.append((time.process_time() - t + children_cpu() - c) / n * 1e3)
    return tuple(out)


def has_dask() -> bool:
    return subprocess.run([sys.executable, "-c", "import distributed"], capture_output=True).returncode == 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=20_000)
    ap.add_argument("--design-jobs", type=int, default=200, help="jobs with 'out' for the output runs")
    ap.add_argument("--runs", default="cpu,j1,j2,nocheck,local,design,nostep,nodesign", help="comma-separated runs to make")
    a = ap.parse_args()
    runs = set(a.runs.split(","))
    for part in ("synth", "cli"):  # (bytecode, as installed: see the module docstring)
        compileall.compile_dir(str(ROOT / part), quiet=1)
    load0 = os.getloadavg()
    rows = []  # (name, seconds, jobs)
    with tempfile.TemporaryDirectory(prefix="bench_batch-") as tmp:
        tmp = Path(tmp)
        lines = readme_jobs(a.jobs)
        jobs = tmp / "jobs.jsonl"
        jobs.write_text("\n".join(lines) + "\n")
        lib = library_rate(lines)
        cpu = cpu_per_job(lines) if "cpu" in runs else None
        cpu_out = cpu_outputs(lines, tmp) if "cpu" in runs else None
        stages = cpu_stages(lines) if "cpu" in runs else None
        results = {}
        if runs & {"j1", "j2"}:  # the start-up: one job
            (tmp / "one.jsonl").write_text(lines[0] + "\n")
            rows.append(("batch -j 1, one job (start-up)", mpsynth(["batch", tmp / "one.jsonl"], tmp / "r_one1.jsonl"), 1))
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
        if "nocheck" in runs:
            rows.append(("batch -j 2, no 200-sample self-check (what-if)",
                         mpsynth_unchecked(["batch", jobs, "-j", 2], tmp / "r_nocheck.jsonl"), a.jobs))
        for name, extra in (("design", []), ("nostep", ["--no-step"]), ("nodesign", ["--no-design"])):
            if name not in runs:
                continue
            out = tmp / f"out_{name}"
            out.mkdir()
            wjobs = tmp / f"jobs_{name}.jsonl"
            wjobs.write_text("".join(json.dumps({**json.loads(s), "out": f"o{i}"}) + "\n"
                                     for i, s in enumerate(lines[: a.design_jobs])))
            wall = mpsynth(["batch", wjobs, "-j", 2, "--out-dir", out, *extra], tmp / f"r_{name}.jsonl")
            rows.append((f"batch -j 2, outputs {' '.join(extra) or 'with the design search'}", wall, a.design_jobs))
    load1 = os.getloadavg()
    rate = {r[0]: r[2] / r[1] for r in rows}
    print(f"{a.jobs:,} README jobs; nproc {os.cpu_count()}; load {load0[0]:.1f} -> {load1[0]:.1f}")
    print(f"{'run':48s} {'seconds':>8s} {'jobs/s':>10s} {'/ bennett_batch':>16s}")
    print(f"{'synth.bennett_batch (in process, best of 3)':48s} {a.jobs / lib:8.2f} {lib:10,.0f} {1:16.4f}")
    for name, wall, n in rows:
        print(f"{name:48s} {wall:8.2f} {n / wall:10,.1f} {n / wall / lib:16.4f}")
    if cpu:
        print(f"CPU per job in process ({min(len(lines), 1000):,} jobs): per-job path {cpu[0]:,.0f} µs, chunk path {cpu[1]:,.0f} µs "
              f"({cpu[0] / cpu[1]:.1f}x); bennett_batch {1e6 / lib:,.0f} µs wall per set")
    if stages:
        print("CPU per job by stage, in process (µs): " + ", ".join(f"{k} {v:,.1f}" for k, v in stages.items()))
    if cpu_out:
        print(f"CPU per job writing OUT in process and its children (10 jobs): with the design search {cpu_out[0]:,.0f} ms, "
              f"--no-step {cpu_out[1]:,.0f} ms, --no-design {cpu_out[2]:,.0f} ms")
    j2 = rate.get("batch -j 2")
    if j2:
        print(f"targets: -j 2 {j2:,.0f} jobs/s (>= 10,000: {j2 / 10_000:.3f}x); {j2 / lib:.1%} of bennett_batch "
              f"(>= 25%)")
    if j2 and (u := rate.get("batch -j 2, no 200-sample self-check (what-if)")):
        print(f"what-if: -j 2 without the 200-sample self-check {u / lib:.1%} of bennett_batch; the check costs "
              f"{a.jobs / j2 - a.jobs / u:.2f} s of the -j 2 run's {a.jobs / j2:.2f} s")
    if j2 and "batch --scheduler local -j 2" in rate:
        print(f"--scheduler local / -j 2 = {rate['batch --scheduler local -j 2'] / j2:.2f} (>= 0.8); less the "
              f"LocalCluster's start-up: {rate['batch --scheduler local, less its start-up'] / j2:.2f}")
    for label in ("with the design search", "--no-step"):
        if (d := rate.get(f"batch -j 2, outputs {label}")):
            print(f"outputs {label}: {d:.2f} jobs/s (>= 10: {d / 10:.3f}x)")
    if results:
        print(f"result files of {', '.join(results)} byte-identical: {same}")
        if not same:
            sys.exit(1)


if __name__ == "__main__":
    main()
