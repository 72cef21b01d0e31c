"""Batch jobs on a Dask cluster: `mpsynth batch JOBS --scheduler ADDRESS|local`.

``connect(address)`` gives a ``distributed.Client``: ``"local"`` starts a ``LocalCluster`` on this machine
(one single-threaded worker process per CPU, or ``workers``), anything else is the address of a running
scheduler (``tcp://host:8786``, see README "Sweeps on a Dask cluster"). ``run_jobs_on(client, lines)`` is
`synth.tools.batchjobs.run_jobs` on that cluster: the same (line number, text) items, cut into chunks
(`synth.tools.batchjobs.chunks`), each chunk one Dask task running `synth.tools.batchjobs.run_chunk_lines` on
a worker, at most a few tasks per worker thread in flight (bounded memory on both sides), results
yielded in input order as soon as the chunks before them are done; ``run_chunks_on(client, chunks)`` is
`synth.tools.batchjobs.run_batch` there (`mpsynth batch --scheduler`: raw line bytes in, one text of
result lines out per chunk). The results are the ones of the local run, so the result lines are the same
bytes.

Failures: a job never fails a task (`synth.tools.batchjobs.run_job` turns every error into a result). A
worker that dies (killed, out of memory, its machine gone) loses no job: the scheduler runs its chunks
again on another worker (up to Dask's ``distributed.scheduler.allowed-failures``, default 3); a chunk that
killed that many workers is split and each of its jobs run alone, so that only a job that itself kills
workers gets a result line with exit code 3. Running a job twice is harmless: an ``out`` directory
written by the first attempt is mpsynth's own and is rewritten with the same files, each write atomic
(`synth.io.writer`; a temporary directory of a killed worker is removed by the next write of that OUT on
the same machine). ``out`` paths are resolved under the absolute ``out_dir`` of the client, which must
be the same shared directory on every worker.

Dask is an optional dependency (``pip install 'mpsynth[cluster]'``), imported only here and only when
called; without it `connect` raises an InputError saying how to install it.
"""
from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import functools
import logging
import os
import socket
import sys
import uuid
from typing import Iterator

from synth.errors import InputError, MpsynthError
from synth.io.outputs import Outputs
from synth.tools.batchjobs import ChunkLines, chunks, default_chunksize, numbered, run_chunk_lines, worker_count
from synth.tools.workerpool import keep_freed_pages, worker_boolean_threads
from synth.tools.resultlines import dumps_lines

CONNECT_TIMEOUT = 30.0  # seconds to reach the scheduler
WORKER_TIMEOUT = 60.0  # seconds to wait for a first worker
INSTALL_HINT = "pip install 'mpsynth[cluster]'"


class ClusterError(MpsynthError):
    """The cluster itself failed (the scheduler went away, a task was cancelled). Exit code 2."""

    exit_code = 2


# the worker's statistical profiler samples the task's stack every 10 ms from the worker's event loop, taking
# the GIL from the task: CPU of a chunk of 1,024 README jobs in a Dask worker against a multiprocessing pool
# worker, same machine, same run (loaded): 0.71-0.92 s against 0.59 s with it, 0.61-0.70 s against
# 0.54-0.62 s without it. A local cluster's workers run without it, and start from a process that has imported
# distributed, numpy and Dask's other packages once instead of each a new interpreter importing them: a
# one-job run with --scheduler local -j 2 took 5.3 s of wall time from a fork server against 7.3 s (load ~19).
# Dask's nannies also start their workers with MALLOC_TRIM_THRESHOLD_=65536 (memory back to the system at once):
# glibc then maps and unmaps a chunk's numpy temporaries again and again; a chunk of 1,024 README jobs took
# ~80,000 page faults and 0.25-0.30 s of CPU (0.15-0.18 s of it system time) in a local worker against 0.06 s
# in the batch process. A local cluster's workers keep glibc's defaults (None unsets the variable).
# On Linux the workers are forked from this process (a method Dask offers: "fork"), which has imported
# distributed and the batch already: the cluster started in 0.26-0.35 s against 1.3-1.6 s from the fork
# server (2 workers, load ~6.5, distributed imported before either).
LOCAL_WORKER_CONFIG = {"distributed.worker.profile.enabled": False,
                       "distributed.worker.multiprocessing-method": "fork" if sys.platform.startswith("linux") else "forkserver",
                       "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}


def dask_config():
    """``dask.config`` (Dask installed: `import_distributed` first)."""
    import dask

    return dask.config


def import_distributed():
    """The ``distributed`` module, or an InputError saying how to install it."""
    try:
        import distributed
    except ImportError as e:
        raise InputError(f"--scheduler needs Dask, which is not installed ({e}); {INSTALL_HINT}") from None
    return distributed


def quiet_logs(level=logging.ERROR) -> None:
    """Dask's own log lines (a worker removed, tasks rescheduled) below ``level`` are not printed: the
    batch reports what matters in its result lines and summary."""
    for name in ("distributed", "distributed.scheduler", "distributed.client", "distributed.worker",
                 "distributed.nanny", "distributed.core", "distributed.comm", "distributed.batched"):
        logging.getLogger(name).setLevel(level)


def connect(address: str, workers: int | None = None, timeout: float = CONNECT_TIMEOUT,
            wait_workers: float = WORKER_TIMEOUT):
    """A ``distributed.Client``: ``address`` "local" starts a LocalCluster of ``workers`` single-threaded
    processes (None or 0: one per CPU, `synth.tools.batchjobs.worker_count`); else it connects to the
    scheduler at ``address`` and waits up to ``wait_workers`` s for a worker. InputError (one line) when
    Dask is missing, the scheduler cannot be reached or has no worker. The caller closes the client
    (and its ``cluster``, for "local": `close`)."""
    distributed = import_distributed()
    quiet_logs()
    if address == "local":
        n = worker_count(workers or 0, None)
        try:
            with dask_config().set(LOCAL_WORKER_CONFIG):  # (handed to the worker processes by their nannies)
                cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                   dashboard_address=None, silence_logs=logging.ERROR)
        except Exception as e:
            raise ClusterError(f"--scheduler local: cannot start a local Dask cluster ({type(e).__name__}: {e})") from None
        client = distributed.Client(cluster)
        # as a pool's workers: they keep the memory they free (`keep_freed_pages`), their booleans run on their
        # share of the CPUs (`worker_boolean_threads`: one thread each with a worker per CPU)
        for setup in (keep_freed_pages, functools.partial(worker_boolean_threads, n)):
            with contextlib.suppress(Exception):
                client.run(setup)
        return client
    if workers:
        raise InputError(f"-j {workers}: the workers of --scheduler {address} are those started there "
                         "(dask worker ADDRESS); -j applies to local runs and --scheduler local")
    _probe(address)
    try:
        client = distributed.Client(address, timeout=timeout)
    except (OSError, TimeoutError, ValueError) as e:
        raise InputError(f"--scheduler {address}: cannot connect to a Dask scheduler there "
                         f"({' '.join(str(e).split()) or type(e).__name__})") from None
    try:
        client.wait_for_workers(1, timeout=wait_workers)
    except (TimeoutError, OSError):
        close(client)
        raise InputError(f"--scheduler {address}: no worker connected within {wait_workers:.0f} s; "
                         f"start some with: dask worker {address}") from None
    return client


def _probe(address: str) -> None:
    """A TCP scheduler address where nothing listens is refused at once (Dask would retry until its
    timeout); other protocols are left to Dask."""
    rest = address[len("tcp://"):] if address.startswith("tcp://") else address
    if "://" in rest:
        return
    host, sep, port = rest.rpartition(":")
    if not sep or not port.isdigit():
        raise InputError(f"--scheduler {address}: not an address (tcp://host:port) or 'local'")
    try:
        socket.create_connection((host.strip("[]") or "127.0.0.1", int(port)), timeout=CONNECT_TIMEOUT).close()
    except OSError as e:
        raise InputError(f"--scheduler {address}: cannot connect to a Dask scheduler there "
                         f"({e.strerror or type(e).__name__})") from None


def close(client) -> None:
    """Close ``client`` and, for a LocalCluster it started, the cluster; never raises."""
    cluster = getattr(client, "cluster", None)
    try:
        client.close()
    except Exception:
        pass
    if cluster is not None:
        try:
            cluster.close()
        except Exception:
            pass


def worker_threads(client) -> int:
    """Worker threads of the cluster now (at least 1)."""
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:
        return 1


def run_jobs_on(client, lines, chunksize: int | None = None, full: bool = False, total: int | None = None,
                out_dir=None, window: int | None = None, outputs: Outputs = Outputs.FULL) -> Iterator[dict]:
    """Results of the jobs in ``lines`` ((line number, text) pairs or text lines) computed on the Dask
    cluster of ``client``, in input order, streamed; the same dictionaries as
    `synth.tools.batchjobs.run_jobs` (`run_chunks_on`)."""
    if chunksize is None:
        chunksize = default_chunksize(worker_threads(client), total)
    with contextlib.closing(run_chunks_on(client, chunks(numbered(lines), chunksize), full, out_dir, window, outputs,
                                          keep=True)) as answers:
        for answer in answers:
            yield from answer.results


def run_chunks_on(client, chunks, full: bool = False, out_dir=None, window: int | None = None, outputs: Outputs = Outputs.FULL,
                  keep: bool = False) -> Iterator[ChunkLines]:
    """`synth.tools.batchjobs.run_batch` on the Dask cluster of ``client``: `ChunkLines` of ``chunks``
    (`synth.io.docload.read_chunks`, None: the input is idle) in input order, streamed, each chunk one
    task (`run_chunk_lines`: line bytes in, one text of result lines out). ``window``: tasks in flight
    (default 3 per worker thread, at least 4). Pending tasks are cancelled when the generator is closed
    early."""
    threads = worker_threads(client)
    base = os.path.abspath(os.fspath(out_dir) if out_dir is not None else os.curdir)
    window = window or max(4, 3 * threads)
    token = uuid.uuid4().hex[:12]
    pending: collections.deque = collections.deque()  # (future, chunk) in input order
    try:
        for chunk in chunks:
            if chunk is not None:
                fut = client.submit(run_chunk_lines, chunk, full, base, outputs, keep, pure=False,
                                    key=f"mpsynth-batch-{token}-{_first(chunk)}")
                pending.append((fut, chunk))
            while len(pending) >= window:
                yield _collect(client, *pending.popleft(), full, base, outputs, keep)
            while pending and pending[0][0].done():
                yield _collect(client, *pending.popleft(), full, base, outputs, keep)
        while pending:
            yield _collect(client, *pending.popleft(), full, base, outputs, keep)
    finally:
        if pending:
            try:
                client.cancel([f for f, _ in pending])
            except Exception:
                pass


def _first(chunk) -> int:
    """The number of the first line of ``chunk`` (either form `run_chunk_lines` takes)."""
    return chunk[0] if isinstance(chunk, tuple) else chunk[0][0]


def _singles(chunk) -> list:
    """The one-line chunks of ``chunk`` (either form `run_chunk_lines` takes)."""
    if isinstance(chunk, tuple):
        return [(chunk[0] + i, [b]) for i, b in enumerate(chunk[1])]
    return [[item] for item in chunk]


def _collect(client, fut, chunk, full, base, outputs=Outputs.FULL, keep=False) -> ChunkLines:
    """The answer to one submitted chunk; a chunk that killed workers is run job by job."""
    distributed = import_distributed()
    try:
        return fut.result()
    except distributed.KilledWorker:
        singles = _singles(chunk)
        if len(singles) == 1:
            res = {"id": None, "line": _first(chunk), "ok": False, "exit_code": 3,
                   "error": "internal error: this job killed every Dask worker that ran it "
                            "(out of memory, a crash); it was not completed"}
            return ChunkLines(dumps_lines([res]), [3], [res] if keep else None)
        futures = [client.submit(run_chunk_lines, one, full, base, outputs, keep, pure=False) for one in singles]
        parts = [_collect(client, f, one, full, base, outputs, keep) for f, one in zip(futures, singles)]
        return ChunkLines("".join(p.text for p in parts), [c for p in parts for c in p.codes],
                          [r for p in parts for r in p.results] if keep else None)
    except ImportError as e:  # the worker's Python has no (or another) mpsynth
        raise ClusterError(f"a Dask worker cannot run mpsynth's jobs ({type(e).__name__}: {e}); install "
                           f"the same mpsynth on every worker ({INSTALL_HINT})") from None
    except (concurrent.futures.CancelledError, OSError, TimeoutError) as e:
        raise ClusterError(f"the Dask cluster failed while running the jobs from line {_first(chunk)} on "
                           f"({type(e).__name__}: {' '.join(str(e).split())}); the results before them are complete") from None
