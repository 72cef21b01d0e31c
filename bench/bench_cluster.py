"""`mpsynth batch` on one machine and on a Dask cluster (issue 21): jobs/s and the cost of a chunk.

    python bench/bench_cluster.py [--jobs 100000] [--markdown bench/RESULTS.md]

Needs ``mpsynth[cluster]`` in the running Python. N random Bennett jobs (three poses in mm and degrees,
one JSON line each, as README's batch example) are run as new processes, stdout to a file:

1. ``mpsynth batch JOBS -j 2`` (the multiprocessing pool);
2. ``mpsynth batch JOBS --scheduler local`` (a LocalCluster of one worker per CPU, started by the run:
   its start-up is included and also reported alone, from a run of one job);
3. ``mpsynth batch JOBS --scheduler tcp://127.0.0.1:PORT`` against a scheduler and two single-threaded
   workers started here as separate processes (``dask scheduler``, ``dask worker``): jobs/s, per worker,
   and the workers' CPU seconds per job (psutil).

The three result files must be byte-identical (checked). The overhead per chunk is measured with blank
lines (a job that costs nothing) one per chunk (``--chunksize 1``), on the cluster and on the pool:
wall time / chunks, with two workers. Finally `synth.sweep` (bennett_batch over chunks of arrays, no JSON)
on the same cluster and in-process, for comparison. Wall-clock figures: the machine may be shared, so
the load average before and after is recorded.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MARK_BEGIN, MARK_END = "<!-- bench_cluster begin -->", "<!-- bench_cluster end -->"


def write_jobs(path: Path, n: int, seed: int = 1) -> None:
    rng = np.random.default_rng(seed)
    with open(path, "w") as f:
        for i in range(n):
            pos = rng.uniform(-200, 200, size=(3, 3))
            rpy = rng.uniform(-180, 180, size=(3, 3))
            poses = [{"position": p.tolist(), "rpy": r.tolist()} for p, r in zip(pos, rpy)]
            f.write(json.dumps({"id": i, "kind": "bennett", "units": {"length": "mm", "angle": "deg"},
                                "poses": poses}) + "\n")


def mpsynth(args, out: Path, entry=("-m", "cli.main")) -> tuple[float, None]:
    """Wall seconds of `mpsynth ARGS > out` (a new process; ``entry``: the interpreter's arguments that run the
    command line, e.g. ``("-c", code)`` for a driver that changes something first)."""
    t = time.perf_counter()
    with open(out, "wb") as f:
        p = subprocess.run([sys.executable, *entry, *map(str, args), "-q"], stdout=f,
                           stderr=subprocess.PIPE, cwd=ROOT, env=ENV)
    wall = time.perf_counter() - t
    if p.returncode not in (0, 1):
        sys.exit(f"mpsynth {' '.join(map(str, args))} failed ({p.returncode}): {p.stderr.decode()[-2000:]}")
    return wall, None


ENV = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))


class Cluster:
    def __init__(self, workdir: Path, n_workers: int = 2):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        self.address = f"tcp://127.0.0.1:{port}"
        self.procs = []
        self.workdir = workdir
        self._start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", str(port),
                     "--no-dashboard", "--idle-timeout", "3600"], "scheduler")
        for k in range(n_workers):
            self._start(["distributed.cli.dask_worker", self.address, "--nthreads", "1", "--no-nanny",
                         "--no-dashboard", "--host", "127.0.0.1", "--death-timeout", "60",
                         "--local-directory", str(workdir / f"w{k}")], f"w{k}")
        from distributed import Client

        deadline = time.monotonic() + 120
        while True:
            try:
                self.client = Client(self.address, timeout=5)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        self.client.wait_for_workers(n_workers, timeout=120)

    def _start(self, args, name):
        log = open(self.workdir / f"{name}.log", "wb")
        self.procs.append(subprocess.Popen([sys.executable, "-m", *args], cwd=self.workdir, env=ENV, stdout=log,
                                           stderr=subprocess.STDOUT, start_new_session=True))

    def worker_cpu(self) -> float:
        import psutil

        return sum(sum(psutil.Process(p.pid).cpu_times()[:2]) for p in self.procs[1:])

    def stop(self):
        try:
            self.client.close()
        except Exception:
            pass
        for p in reversed(self.procs):
            try:
                os.killpg(p.pid, signal.SIGTERM)
                p.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                os.killpg(p.pid, signal.SIGKILL)


def ceiling(cl: Cluster, tmp: Path, n: int) -> float:
    """Jobs/s of one client when the jobs cost nothing (malformed lines, chunks of 256): the most a
    single `mpsynth batch --scheduler` can hand out and print, however many workers there are."""
    bad = tmp / "bad.jsonl"
    bad.write_text("{\n" * n)
    wall, _ = mpsynth(["batch", bad, "--scheduler", cl.address, "--chunksize", 256], tmp / "r_bad.jsonl")
    return n / wall


def random_sets(n, seed=2):
    sys.path.insert(0, str(ROOT / "tests"))
    from conftest import random_poses

    rng = np.random.default_rng(seed)
    return np.array([random_poses(rng, 3, scale=0.2) for _ in range(n)])


def print_ceiling(n: int) -> None:
    """Print one client's ceiling (jobs/s) on a fresh cluster."""
    with tempfile.TemporaryDirectory(prefix="bench_cluster-") as tmp:
        cl = Cluster(Path(tmp))
        try:
            print(f"one client's ceiling: {ceiling(cl, Path(tmp), n):,.0f} jobs/s ({n:,} malformed lines)")
        finally:
            cl.stop()


def local_rows(phases, jobs: Path, tmp: Path, n: int) -> list[tuple]:
    """The rows of the runs on this machine: ``batch -j 2`` (pool) and ``--scheduler local``."""
    rows = []
    if "pool" in phases:
        wall, _ = mpsynth(["batch", jobs, "-j", 2], tmp / "r_pool.jsonl")
        rows.append((f"`-j 2` (multiprocessing pool), {n:,} jobs", wall, n / wall, "-", None))
    if "local" in phases:
        with open(jobs) as f:
            (tmp / "one.jsonl").write_text(f.readline())
        w1, _ = mpsynth(["batch", tmp / "one.jsonl", "--scheduler", "local"], tmp / "r_one.jsonl")
        wall, _ = mpsynth(["batch", jobs, "--scheduler", "local"], tmp / "r_local.jsonl")
        rows.append((f"`--scheduler local` (LocalCluster, 2 workers; start-up {w1:.1f} s included)", wall,
                     n / wall, "-", None))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=100_000)
    ap.add_argument("--chunks", type=int, default=2000, help="blank-line chunks for the overhead figure")
    ap.add_argument("--markdown", type=Path, help="write the section into this file (between markers)")
    ap.add_argument("--ceiling-only", action="store_true", help="only the client's ceiling (jobs/s)")
    ap.add_argument("--phases", default="pool,local,cluster",
                    help="comma-separated runs to make: pool (-j 2), local (LocalCluster), cluster (scheduler + 2 "
                         "workers, with the overhead, sweep and ceiling figures)")
    a = ap.parse_args()
    phases = set(a.phases.split(","))
    if a.ceiling_only:
        print_ceiling(a.jobs)
        return
    rows = []
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_cluster-") as tmp:
        tmp = Path(tmp)
        jobs = tmp / "jobs.jsonl"
        write_jobs(jobs, a.jobs)
        n = a.jobs

        sys.path.insert(0, str(ROOT))
        from synth.tools.batchjobs import run_jobs
        from synth.tools.cluster import run_jobs_on
        from synth.tools.sweep import sweep

        with open(jobs) as f:
            first = [f.readline() for _ in range(min(n, 2000))]
        t = time.process_time()
        list(run_jobs(first))
        cpu_job = (time.process_time() - t) / len(first)

        rows += local_rows(phases, jobs, tmp, n)
        if "cluster" not in phases:
            cl = None
            print("\n".join(f"{r[0]}: {r[1]:.1f} s, {r[2]:,.0f} jobs/s" for r in rows))
            return

        cl = Cluster(tmp)
        try:
            c0 = cl.worker_cpu()
            wall, _ = mpsynth(["batch", jobs, "--scheduler", cl.address], tmp / "r_cluster.jsonl")
            wcpu = cl.worker_cpu() - c0
            rows.append((f"`--scheduler tcp://...` (scheduler + 2 worker processes), {n:,} jobs", wall, n / wall,
                         n / wall / 2, wcpu / n))
            blank = ["" for _ in range(a.chunks)]
            t = time.perf_counter()
            assert len(list(run_jobs_on(cl.client, blank, chunksize=1))) == a.chunks
            ow = time.perf_counter() - t
            t = time.perf_counter()
            assert len(list(run_jobs(blank, jobs=2, chunksize=1))) == a.chunks
            pw = time.perf_counter() - t
            # synth.sweep: bennett_batch over chunks of arrays
            P = random_sets(min(n, 100_000))
            t = time.perf_counter()
            S = sweep(P, client=cl.client, chunksize=5000)
            sw = time.perf_counter() - t
            t = time.perf_counter()
            H = sweep(P, chunksize=5000)
            hw = time.perf_counter() - t
            assert S.ok.sum() == H.ok.sum()
            top = ceiling(cl, tmp, n)
        finally:
            cl.stop()
        files = [tmp / f for f in ("r_pool.jsonl", "r_local.jsonl", "r_cluster.jsonl") if (tmp / f).exists()]
        same = all(f.read_bytes() == files[0].read_bytes() for f in files)
        assert same, "the result files differ"
        ok = sum('"ok":true' in s for s in open(files[0]))
    fig = {"n": n, "ok": ok, "first": len(first), "cpu_job": cpu_job, "chunks": a.chunks, "overhead": ow,
           "pool": pw, "ceiling": top, "sets": len(P), "sweep_cluster": sw, "sweep_here": hw, "load0": load0,
           "load1": os.getloadavg()}
    text = report(rows, fig)
    print(text)
    if a.markdown:
        save_section(a.markdown, text)


def report(rows, f: dict) -> str:
    """The Markdown section of the results: the runs' table and the overhead, ceiling and sweep figures."""
    load0, load1, n = f["load0"], f["load1"], f["n"]
    lines = [f"## Dask cluster: `bench/bench_cluster.py` (issue 21)", "",
             f"- {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs; Python {platform.python_version()}, "
             f"numpy {np.__version__}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}",
             f"- Load average (1/5/15 min) before {load0[0]:.2f}, {load0[1]:.2f}, {load0[2]:.2f}, after "
             f"{load1[0]:.2f}, {load1[1]:.2f}, {load1[2]:.2f}",
             f"- {n:,} random Bennett jobs (JSON lines, mm/deg, {f['ok']:,} ok); the result files of the runs are "
             "byte-identical", "",
             "| run | wall | jobs/s | jobs/s per worker | CPU per job |", "|---|---|---|---|---|"]
    for name, wall, rate, per, cpu in rows:
        lines.append(f"| {name} | {wall:.1f} s | {rate:,.0f} | {per if per == '-' else f'{per:,.0f}'} | "
                     f"{'-' if cpu is None else f'{cpu * 1e3:.2f} ms'} |")
    chunks = f["chunks"]
    lines += ["", f"CPU per job in one process (`run_jobs`, {f['first']:,} of the jobs): {f['cpu_job'] * 1e3:.2f} ms.", "",
              "| overhead | per chunk |", "|---|---|",
              f"| Dask scheduler + 2 workers, {chunks:,} chunks of one blank line (`run_jobs_on`, connected client) "
              f"| {f['overhead'] / chunks * 1e3:.2f} ms |",
              f"| multiprocessing pool (`run_jobs(jobs=2)`, pool start included), the same | {f['pool'] / chunks * 1e3:.2f} ms |", "",
              f"| one client's ceiling: {n:,} malformed lines (no work), chunks of 256, on the cluster | {f['ceiling']:,.0f} jobs/s |",
              "", "| `synth.sweep` (bennett_batch over chunks of 5,000 pose arrays) | sets/s |", "|---|---|",
              f"| on the cluster (2 workers), {f['sets']:,} sets | {f['sets'] / f['sweep_cluster']:,.0f} |",
              f"| in this process | {f['sets'] / f['sweep_here']:,.0f} |"]
    return "\n".join(lines) + "\n"


def save_section(path: Path, text: str) -> None:
    """Write ``text`` into ``path`` between the markers (replacing the previous section), or append it."""
    old = path.read_text() if path.exists() else ""
    block = f"{MARK_BEGIN}\n{text}{MARK_END}\n"
    if MARK_BEGIN in old and MARK_END in old:
        new = old[:old.index(MARK_BEGIN)] + block + old[old.index(MARK_END) + len(MARK_END) + 1:]
    else:
        new = old.rstrip("\n") + "\n\n" + block
    path.write_text(new)

if __name__ == "__main__":
    main()
