"""`mpsynth batch --scheduler`, `--results` and `synth.sweep` on a real Dask cluster: a scheduler and two
workers started here as separate processes on 127.0.0.1 (free ports, bounded start-up, always stopped)."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
pq = pytest.importorskip("pyarrow.parquet")

from synth.tools.batchjobs import run_jobs  # noqa: E402
from synth.tools.cluster import quiet_logs, run_jobs_on  # noqa: E402
from synth.tools.sweep import sixbar_chunk, sweep  # noqa: E402

from conftest import REPO, random_poses, run  # noqa: E402
from test_batchjobs import make_jobs, matrix_specs  # noqa: E402

START_TIMEOUT = 90.0  # seconds for the scheduler and the workers to come up (a loaded 2-CPU machine)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A scheduler and workers, each its own process group; `stop` kills them all."""

    def __init__(self, workdir):
        self.workdir = workdir
        self.procs: dict[str, subprocess.Popen] = {}
        self.address = f"tcp://127.0.0.1:{free_port()}"
        self.env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))

    def _start(self, name, args):
        log = open(self.workdir / f"{name}.log", "wb")
        self.procs[name] = subprocess.Popen([sys.executable, "-m", *args], cwd=self.workdir, env=self.env,
                                            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                            start_new_session=True)
        log.close()

    def start_scheduler(self):
        port = self.address.rsplit(":", 1)[1]
        # --idle-timeout: a scheduler this test failed to stop goes away by itself
        self._start("scheduler", ["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", port,
                                  "--no-dashboard", "--idle-timeout", "600"])

    def start_worker(self, name):
        # no nanny: killing the process kills the worker (a nanny would restart it); --death-timeout: it
        # exits by itself when the scheduler is gone
        self._start(name, ["distributed.cli.dask_worker", self.address, "--name", name, "--nthreads", "1",
                           "--no-nanny", "--no-dashboard", "--host", "127.0.0.1", "--death-timeout", "60",
                           "--local-directory", str(self.workdir / name)])

    def wait(self, client, n):
        try:
            client.wait_for_workers(n, timeout=START_TIMEOUT)
        except TimeoutError:
            logs = {p.name: p.read_text()[-2000:] for p in self.workdir.glob("*.log")}
            pytest.fail(f"the Dask workers did not start within {START_TIMEOUT} s: {logs}")

    def worker_address(self, client, name):
        return next(a for a, w in client.scheduler_info()["workers"].items() if w["name"] == name)

    def kill(self, name, sig=signal.SIGKILL):
        p = self.procs.pop(name)
        try:
            os.killpg(p.pid, sig)
        except ProcessLookupError:
            pass
        p.wait(timeout=30)

    def stop(self):
        for name in [n for n in self.procs if n != "scheduler"] + ["scheduler"]:
            p = self.procs.get(name)
            if p is None:
                continue
            try:
                os.killpg(p.pid, signal.SIGTERM)
                p.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                p.wait(timeout=10)
            del self.procs[name]


@pytest.fixture(scope="module")
def cluster(tmp_path_factory, request):
    quiet_logs()
    c = Cluster(tmp_path_factory.mktemp("dask"))
    request.addfinalizer(c.stop)
    c.start_scheduler()
    c.start_worker("w1")
    c.start_worker("w2")
    deadline = time.monotonic() + START_TIMEOUT
    while True:  # the scheduler's port opens within a few seconds
        try:
            client = distributed.Client(c.address, timeout=5)
            break
        except (OSError, TimeoutError):
            if time.monotonic() > deadline or c.procs["scheduler"].poll() is not None:
                pytest.fail(f"no Dask scheduler at {c.address}: {(c.workdir / 'scheduler.log').read_text()[-2000:]}")
            time.sleep(0.5)
    request.addfinalizer(client.close)
    c.wait(client, 2)
    c.client = client
    return c


@pytest.fixture(scope="module")
def mixed_jobs(tmp_path_factory):
    """300 job lines (good Bennett and 6R, no-linkage, malformed JSON, bad poses, unknown kinds and keys)
    and a blank line, with the result lines of the local run."""
    lines, _ = make_jobs(300, seed=21)
    path = tmp_path_factory.mktemp("jobs") / "jobs.jsonl"
    path.write_text("\n".join(lines[:150]) + "\n  \n" + "\n".join(lines[150:]) + "\n")
    local = run("batch", path, "-q")
    assert local.exit_code == 1 and local.stdout.count("\n") == 301
    return path, local.stdout


def test_scheduler_gives_the_local_result_lines_byte_for_byte(cluster, mixed_jobs, tmp_path):
    path, expected = mixed_jobs
    table = tmp_path / "results.parquet"
    r = run("batch", path, "--scheduler", cluster.address, "--chunksize", 8, "--results", table)
    assert r.exit_code == 1, r.stderr
    assert r.stdout == expected
    assert "300 jobs" in r.stderr and "2 Dask workers" in r.stderr
    # the Parquet table: one row per job (not for the blank line), the same figures as the lines
    results = [json.loads(s) for s in expected.splitlines() if "skipped" not in s]
    t = pq.read_table(table).to_pylist()
    assert len(t) == len(results) == 300
    for row, res in zip(t, results):
        assert row["line"] == res["line"] and row["ok"] is res["ok"]
        assert row["id"] == (res["id"] if res["id"] is None or isinstance(res["id"], str) else json.dumps(res["id"]))
        if res["ok"]:
            assert row["status"] == "ok" and row["exit_code"] == 0 and row["error"] is None
            assert row["kind"] == res["kind"] and row["extent"] == res["extent"]
            assert row["max_pose_error"] == res["checks"]["max_pose_error"]
            assert row["a"] == res.get("bennett", {}).get("a")
        else:
            assert row["exit_code"] == res["exit_code"] and row["error"] == res["error"]
            assert row["status"] == {1: "no linkage", 2: "bad input", 3: "internal error"}[res["exit_code"]]
            assert row["extent"] is None and row["kind"] is None
    assert not [p for p in tmp_path.iterdir() if p.name != "results.parquet"]  # no temporary left


def out_jobs(n_out, n_plain, seed):
    """Bennett jobs, the first ``n_out`` writing their linkage to o/<i>."""
    rng = np.random.default_rng(seed)
    jobs = []
    for i in range(n_out + n_plain):
        job = {"id": i, "kind": "bennett", "poses": matrix_specs(random_poses(rng, 3))}
        if i < n_out:
            job["out"] = f"o/{i}"
        jobs.append(json.dumps(job))
    return jobs


def kill_mid_run(cluster, lines, out_dir, chunksize):
    """Run ``lines`` on the cluster with a third worker, killed (SIGKILL) by a watcher thread as soon as it
    is running a chunk; the results, and the chunks the worker held when it was killed."""
    client = cluster.client
    cluster.start_worker("w3")
    cluster.wait(client, 3)
    w3 = cluster.worker_address(client, "w3")
    held: list = []
    stop = threading.Event()

    def watch():
        deadline = time.monotonic() + 60
        while not stop.is_set() and time.monotonic() < deadline:
            keys = client.processing(workers=[w3]).get(w3, ())
            if keys:
                held.extend(keys)
                cluster.kill("w3")
                return
            time.sleep(0.005)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        results = list(run_jobs_on(client, lines, chunksize=chunksize, out_dir=out_dir, window=9))
    finally:
        stop.set()
        watcher.join(timeout=60)
        if "w3" in cluster.procs:
            cluster.kill("w3")
    return results, held


def _check_kill(cluster, tmp_path, n_out, n_plain, chunksize, seed):
    lines = out_jobs(n_out, n_plain, seed)
    (tmp_path / "local").mkdir()
    (tmp_path / "dask").mkdir()
    expected = list(run_jobs(lines, out_dir=tmp_path / "local"))
    results, held = kill_mid_run(cluster, lines, tmp_path / "dask", chunksize)
    assert held, "the killed worker held no chunk"
    assert results == expected  # every job, once, in order, with the same figures
    assert [json.dumps(r) for r in results] == [json.dumps(r) for r in expected]
    for i in range(n_out):  # every output written completely, no temporary directory left behind
        doc = json.loads((tmp_path / "dask" / "o" / str(i) / "linkage.json").read_text())
        ref = json.loads((tmp_path / "local" / "o" / str(i) / "linkage.json").read_text())
        assert doc["joints"] == ref["joints"]
    assert sorted(os.listdir(tmp_path / "dask" / "o")) == sorted(str(i) for i in range(n_out))


def test_a_killed_worker_loses_no_job(cluster, tmp_path):
    _check_kill(cluster, tmp_path, n_out=4, n_plain=120, chunksize=4, seed=4)


@pytest.mark.slow
def test_a_killed_worker_loses_no_job_long(cluster, tmp_path):
    _check_kill(cluster, tmp_path, n_out=40, n_plain=2000, chunksize=10, seed=5)


def test_sweep_on_the_cluster_equals_the_local_sweep(cluster):
    rng = np.random.default_rng(8)
    P = np.array([random_poses(rng, 3) for _ in range(300)])
    P[7, 2] = P[7, 1]  # no linkage: coincident poses
    here = sweep(P, chunksize=64)
    there = sweep(P, client=cluster.client, chunksize=64)
    assert there.chunks == 5 and len(there) == 300 and here.ok.sum() == 299 and not there.ok[7]
    assert "coincide" in there.status[7]
    for k, v in here.arrays.items():
        if v.dtype.kind in "US":
            assert (there[k] == v).all(), k
        else:
            np.testing.assert_array_equal(there[k], v, err_msg=k)
    L = there.linkage(3)
    np.testing.assert_allclose(L.joints[0].direction, there["lines"][3, 0, 0], atol=1e-9)
    six = sweep(np.array([random_poses(rng, 4) for _ in range(3)]), sixbar_chunk, client=cluster.client, chunksize=2)
    assert len(six) == 3 and six["lines"].shape == (3, 6, 2, 3)
    assert all((s == "") == ok for s, ok in zip(six.status, six.ok))


def test_cluster_errors_are_one_line(tmp_path):
    jobs = tmp_path / "jobs.jsonl"
    jobs.write_text("{}\n")
    r = run("batch", jobs, "--scheduler", f"tcp://127.0.0.1:{free_port()}")
    assert r.exit_code == 2 and r.stdout == ""
    assert r.stderr.startswith("mpsynth: --scheduler tcp://127.0.0.1:") and "cannot connect" in r.stderr
    assert r.stderr.count("\n") == 1
    r = run("batch", jobs, "--scheduler", "tcp://127.0.0.1:1", "-j", 2)
    assert r.exit_code == 2 and "-j 2" in r.stderr
    r = run("batch", jobs, "--results", tmp_path)
    assert r.exit_code == 2 and "--results" in r.stderr
    r = run("batch", jobs, "--results", jobs)
    assert r.exit_code == 2 and "is the jobs file" in r.stderr and jobs.read_text() == "{}\n"


def test_results_file_without_a_cluster_and_nothing_partial(tmp_path):
    jobs = tmp_path / "jobs.jsonl"
    rng = np.random.default_rng(2)
    jobs.write_text(json.dumps({"id": 7, "kind": "bennett", "poses": matrix_specs(random_poses(rng, 3))}) + "\n"
                    + "{bad\n")
    r = run("batch", jobs, "-q", "--results", tmp_path / "r.parquet")
    assert r.exit_code == 1
    t = pq.read_table(tmp_path / "r.parquet")
    assert t.column("id").to_pylist() == ["7", None] and t.column("ok").to_pylist() == [True, False]
    assert t.column("status").to_pylist() == ["ok", "bad input"]
    # an unreadable jobs file: no results file at all
    r = run("batch", tmp_path / "nope.jsonl", "--results", tmp_path / "n.parquet")
    assert r.exit_code == 2 and not (tmp_path / "n.parquet").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.jsonl", "r.parquet"]


def test_help_stays_fast_and_dask_free():
    code = "import sys, cli.main; import synth.tools.cluster, synth.tools.sweep; print('distributed' in sys.modules)"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=60,
                       env=dict(os.environ, PYTHONPATH=str(REPO)))
    assert p.returncode == 0 and p.stdout.strip() == "False", p.stderr


class _Future:
    def __init__(self, fn, args, kills):
        self.fn, self.args, self.kills = fn, args, kills

    def done(self):
        return True

    def result(self):
        if self.kills(self.args[0]):
            raise distributed.KilledWorker("task", "worker", 3)
        return self.fn(*self.args)


class _Client:
    """Runs tasks here; a task whose chunk holds line 3 "kills its worker" (KilledWorker)."""

    def __init__(self):
        self.submitted = []

    def submit(self, fn, *args, pure=True, key=None):
        self.submitted.append([n for n, _ in args[0]])
        return _Future(fn, args, lambda chunk: any(n == 3 for n, _ in chunk))

    def nthreads(self):
        return {"w": 1}

    def cancel(self, futures):
        pass


def test_a_chunk_that_kills_workers_is_split_and_only_its_killer_fails():
    client = _Client()
    rng = np.random.default_rng(3)
    lines = [json.dumps({"id": i, "kind": "bennett", "poses": matrix_specs(random_poses(rng, 3))}) for i in range(6)]
    res = list(run_jobs_on(client, lines, chunksize=4))
    assert [r["line"] for r in res] == [1, 2, 3, 4, 5, 6]
    assert [r["ok"] for r in res] == [True, True, False, True, True, True]
    assert res[2]["exit_code"] == 3 and "killed every Dask worker" in res[2]["error"]
    assert res[:2] + res[3:] == [r for r in run_jobs(lines) if r["line"] != 3]
    assert client.submitted == [[1, 2, 3, 4], [1], [2], [3], [4], [5, 6]]  # the chunk of line 3, split


def _boolean_threads() -> int | None:
    from synth.io.solid import _THREADS

    return _THREADS["limit"]


def test_a_local_clusters_workers_run_their_booleans_on_their_share_of_the_cpus():
    """`connect("local")`'s workers, one per CPU, are set up as a pool's (`worker_boolean_threads`: the thread
    test is tests/test_batch_startup.py's); this process is not."""
    from synth.tools.cluster import close, connect

    client = connect("local", 2)
    try:
        workers = len(client.scheduler_info()["workers"])
        limits = client.run(_boolean_threads)
    finally:
        close(client)
    assert sorted(limits.values()) == [max(1, len(os.sched_getaffinity(0)) // workers)] * workers
    assert _boolean_threads() is None
