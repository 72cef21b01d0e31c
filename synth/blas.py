"""numpy's BLAS on one thread for the batched kernels (docs/architecture.md, "Threads").

The batched pipelines multiply many tiny matrices (dual-quaternion structure constants, 8 x 64), which
numpy hands to BLAS as one tall product; a multithreaded BLAS splits it across threads that cost more
than they save. Measured on `synth.bennett_batch` (2 cores, OpenBLAS with 2 threads, N = 20,000): the
same wall-clock time with twice the CPU time when the second core is idle, half the throughput when it
is busy (another process, a parallel test worker or batch job). ``one_blas_thread()`` limits BLAS to one
thread for the duration of a ``with`` block (threadpoolctl, imported on first use) and restores it after;
the limit is process-wide, so other threads of the process that use BLAS meanwhile run on one thread too.
"""
from __future__ import annotations

import contextlib

_controller = None


def one_blas_thread():
    """Context manager: every BLAS library numpy and scipy loaded runs on one thread inside the block."""
    global _controller
    try:
        if _controller is None:
            from threadpoolctl import ThreadpoolController  # ~15 ms: only when a batch needs it

            _controller = ThreadpoolController()
        return _controller.limit(limits=1, user_api="blas")
    except Exception:  # no threadpoolctl, or a BLAS it cannot drive: leave the threads as they are
        return contextlib.nullcontext()
