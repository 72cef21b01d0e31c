"""Issue #36, fifth pass: `mpsynth batch`'s start-up. The command imports the chunk path only (the per-job
path's modules, the design search, the writers and Dask come with the first job or option that needs
them), and `-j N`'s workers are forked from the batch process when it runs one thread (no second
interpreter importing the batch again)."""
from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import threading

import pytest

from synth.tools import workerpool as batchjobs

from conftest import REPO
from test_batch_chunks import readme_job

# modules the chunk path of README's Bennett jobs does not need (each was imported at start-up before)
NOT_AT_START = ("synth.solve.tasks", "synth.design.constraints", "synth.design.search", "synth.io.writer",
                "synth.io.poses", "synth.synthesis.bennett", "synth.linkage", "synth.tools.cluster",
                "synth.tools.resultstable", "distributed", "pyarrow", "scipy", "sympy", "trimesh",
                "yaml")  # (PyYAML: ~11 ms, for YAML documents only: `synth.io.yamlload`)


def test_the_batch_command_imports_the_chunk_path_only():
    code = ("import sys, cli.batch, synth.tools.batchjobs; "
            f"print(sorted(m for m in {NOT_AT_START!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_the_per_job_path_imports_what_it_needs_when_it_runs():
    job = json.dumps({**readme_job(random.Random(1), 0), "name": "r0"})  # (a name: the per-job path)
    code = ("import sys; from synth.tools.batchjobs import run_job; r = run_job((1, sys.argv[1])); "
            "print(r['ok'], 'synth.solve.tasks' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code, job], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True"], out.stdout + out.stderr


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork is the Linux choice")
def test_workers_fork_from_a_single_threaded_process_only():
    if threading.active_count() == 1:
        assert batchjobs.pool_context().get_start_method() == "fork"
    done = threading.Event()
    other = threading.Thread(target=done.wait)
    other.start()
    try:
        assert batchjobs.pool_context().get_start_method() == "forkserver"
    finally:
        done.set()
        other.join()


def test_the_collector_is_off_only_while_the_programs_modules_load():
    code = ("import sys, gc; sys.argv[0] = sys.argv[1]; import cli; off = not gc.isenabled(); "
            "from cli.main import mpsynth; from click.testing import CliRunner; "
            "CliRunner().invoke(mpsynth, ['batch', '--help']); print(off, gc.isenabled())")
    for argv0, off in (("/venv/bin/mpsynth", "True"), ("notebook.py", "False")):
        out = subprocess.run([sys.executable, "-c", code, argv0], cwd=REPO, capture_output=True, text=True, check=True)
        assert out.stdout.split() == [off, "True"], out.stdout + out.stderr


def test_a_worker_keeps_freed_pages_and_its_results_do_not_change():
    """`keep_freed_pages` (glibc's mallopt) applies on glibc and leaves the chunk path's result lines as they were."""
    import platform

    from synth.tools.batchjobs import run_chunk_lines

    lines = [json.dumps(readme_job(random.Random(3), i)).encode() for i in range(40)]
    before = run_chunk_lines((1, lines), False, None).text
    applied = batchjobs.keep_freed_pages()
    assert applied == (sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc")
    assert run_chunk_lines((1, lines), False, None).text == before


# a worker process (`workerpool.prepare_worker`, or no set-up) runs a boolean of two crossing bars as a link's
# (manifold3d), then prints its threads (/proc/self/task) and a digest of the mesh
_THREADS_AFTER_A_BOOLEAN = """
import hashlib, multiprocessing, os, sys
from synth.io.solid import boolean, capsule
from synth.tools.workerpool import prepare_worker

def job(_):
    mesh = boolean([capsule((0, 0, 0), (1, 0.2, 0), 0.1, 32), capsule((0.5, -0.5, 0), (0.6, 0.5, 0.05), 0.08, 32)],
                   [capsule((0, 0, -1), (0, 0, 1), 0.03, 48)])
    digest = hashlib.sha256(mesh.vertices.tobytes() + mesh.faces.tobytes()).hexdigest()
    return len(os.listdir("/proc/self/task")), digest

setup = prepare_worker if sys.argv[1] == "worker" else None
with multiprocessing.get_context("fork").Pool(1, initializer=setup, initargs=(os.getpid(),) if setup else ()) as pool:
    for threads, digest in pool.map(job, range(3), chunksize=1):
        print(threads, digest)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                    reason="a thread count from /proc on a machine with 2 or more CPUs")
def test_a_pool_worker_runs_its_booleans_on_its_own_thread_with_the_same_meshes():
    """manifold3d (TBB) starts a thread per CPU at its first boolean in a plain process; in a worker set up by
    `prepare_worker` none (`synth.io.solid.limit_boolean_threads`), and the meshes are the same."""
    def run(kind):
        out = subprocess.run([sys.executable, "-c", _THREADS_AFTER_A_BOOLEAN, kind], cwd=REPO, capture_output=True,
                             text=True, check=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
        return [(int(t), d) for t, d in (line.split() for line in out.stdout.splitlines())]

    plain, worker = run("plain"), run("worker")
    assert all(t > 1 for t, _ in plain), plain  # (the check below can fail: the pool's threads are there)
    assert all(t == 1 for t, _ in worker), worker
    assert {d for _, d in plain} == {d for _, d in worker} and len({d for _, d in worker}) == 1
