"""The worker processes of `mpsynth batch -j N` (`synth.tools.batchjobs.run_batch`): how many, how they start
(`pool_context`), their set-up (`prepare_worker`) and a bounded shutdown (`terminate_pool`)."""
from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
import threading

# what a worker needs, imported by the fork server (a missing optional module is skipped there); without it each
# worker imported them itself: README's 20,000 jobs took longer with -j 2 than with -j 1 on the loaded machine
PRELOAD = ("synth.tools.batchjobs", "synth.synthesis.sixbar")


def worker_count(requested: int, total: int | None) -> int:
    """Worker processes actually used for ``requested`` (0: one per CPU): at most the CPUs this
    process may run on and the number of jobs (when known), at least 1."""
    cpus = len(_cpus())
    n = cpus if requested == 0 else min(requested, cpus)
    if total is not None:
        n = min(n, total)
    return max(1, n)


def pool_context():
    """The multiprocessing context of `run_batch`'s workers: on Linux, when this process runs one thread
    (nothing another thread holds can be copied locked), ``fork``: the workers start at once with what
    this process has imported (README's 20,000 jobs: a fork server first started a new interpreter that
    imported the batch again, ~0.25 s of CPU before any job); else the fork server with `PRELOAD` (POSIX)
    or ``spawn``."""
    if sys.platform.startswith("linux") and threading.active_count() == 1:
        for stream in (sys.stdout, sys.stderr):  # (a worker would write out what the buffers held again)
            with contextlib.suppress(Exception):
                stream.flush()
        return multiprocessing.get_context("fork")
    ctx = multiprocessing.get_context("forkserver" if os.name == "posix" else "spawn")
    if os.name == "posix":  # the fork server imports the batch once; each worker forks with it imported
        ctx.set_forkserver_preload(list(PRELOAD))
    return ctx


TERMINATE_SECONDS = 2.0  # how long a pool's terminate may take before its workers are killed (a shutdown bound)


def terminate_pool(pool, workers) -> bool:
    """``pool.terminate()``, bounded: when the pool still waits for a worker after `TERMINATE_SECONDS`
    (seen once in ~175 stops of a loaded machine here and once in CI: it then waited for good), the
    workers still running are killed (SIGKILL) and the terminate is given as long again. ``workers``:
    the pool's processes. Returns whether the pool is shut down and joined."""
    done = threading.Thread(target=pool.terminate, name="terminate-pool", daemon=True)
    done.start()
    done.join(TERMINATE_SECONDS)
    if done.is_alive():
        for w in workers:
            if w.exitcode is None:
                w.kill()
        done.join(TERMINATE_SECONDS)
    if done.is_alive():
        return False
    pool.join()
    return True


class _QuietWhenOrphaned:
    """A worker's stderr that drops what is written once the batch process is gone (a result sent to a
    dead parent is a BrokenPipeError traceback nobody asked for); else the real stream."""

    def __init__(self, stream, parent: int):
        self.stream, self.parent = stream, parent

    def write(self, text):
        try:
            os.kill(self.parent, 0)
        except ProcessLookupError:
            return len(text)
        except OSError:
            pass
        return self.stream.write(text)

    def __getattr__(self, name):
        return getattr(self.stream, name)


def prepare_worker(parent: int | None = None) -> None:
    """A pool worker's set-up: its stderr goes quiet once the batch process ``parent`` is gone (what a job
    needs beyond the chunk path is imported by its first job: a forked worker importing the 6R synthesis
    here delayed its first chunk), it keeps freed memory (`keep_freed_pages`) and its meshes' booleans run
    on one thread (`worker_boolean_threads`). The command line adds its signal policy (cli/signals.py
    `batch_worker`: ^C ignored, SIGTERM a quiet exit, killed with its parent); the library installs no
    handler."""
    if parent is not None and sys.stderr is not None:
        sys.stderr = _QuietWhenOrphaned(sys.stderr, parent)
    keep_freed_pages()
    worker_boolean_threads()


def worker_boolean_threads(workers: int | None = None) -> None:
    """The output jobs of this worker build their meshes on its own thread (`synth.io.solid.limit_boolean_threads`:
    manifold3d's thread pool is started at one thread by its first boolean; nothing is imported here), or,
    as one of ``workers`` such processes, on its share of the CPUs (CPUs // workers, at least 1). A pool of
    ``-j N`` workers (N >= 2, N capped by the CPUs this process may use: one per CPU by default) or a local
    Dask cluster with a worker per CPU has a process on every CPU: a boolean's second thread there finds no
    idle CPU and only adds CPU time (it spin-waits; bench/RESULTS.md, "Output jobs, fourth pass")."""
    from synth.io.solid import limit_boolean_threads

    limit_boolean_threads(1 if workers is None else max(1, len(_cpus()) // workers))


def _cpus() -> set:
    try:
        return os.sched_getaffinity(0)
    except (AttributeError, OSError):
        return set(range(os.cpu_count() or 1))


# glibc's mallopt parameters (malloc.h) and the values a batch worker uses: a chunk's numpy temporaries (a few
# hundred kB each) come from the heap and its freed pages stay mapped for the next chunk
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3
KEEP_PAGES = {_M_TRIM_THRESHOLD: 256 << 20, _M_TOP_PAD: 16 << 20, _M_MMAP_THRESHOLD: 32 << 20}


def keep_freed_pages() -> bool:
    """This process keeps the memory it frees (glibc only; elsewhere nothing changes): with glibc's defaults
    a chunk of 1,024 README jobs took ~1,500 fresh pages (page faults) in a forked worker, each chunk again,
    as the heap's top was given back and large blocks were mapped and unmapped; kept, ~150 after the first
    chunk. The worker's memory stays at its largest chunk's (tens of MB). Returns whether it applied."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        return all(libc.mallopt(k, v) == 1 for k, v in KEEP_PAGES.items())
    except (OSError, AttributeError):  # not glibc
        return False
