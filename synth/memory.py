"""The C allocator's handling of freed memory in a process that runs batches (docs/architecture.md, "Threads").

The batched kernels (the self-check of `synth.checks.check_figures` over many linkages x samples) make
thousands of temporary arrays of a few hundred kB. glibc's malloc hands blocks above its threshold (128 kB,
then adapted) out as fresh pages and gives the top of the heap back to the system once more than a
threshold is free there, so the same pages are mapped, faulted in and given back again and again: on the
README batch jobs the page faults cost more CPU than the arithmetic (groups of 160 linkages: ~75 µs a job
of system time). ``keep_freed_pages()`` sets both thresholds high (blocks up to 32 MB from the heap, up to
128 MB kept free at its top) for the rest of the process: a batch worker's, never the library's own
doing. Without glibc it does nothing. `pages_kept` says whether it is in force (`check_figures` then
takes bigger groups).
"""
from __future__ import annotations

import ctypes
import ctypes.util

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # mallopt's parameters (malloc.h)
MMAP_BYTES = 32 << 20  # glibc's largest mmap threshold on 64-bit systems
TRIM_BYTES = 128 << 20

_kept = False


def keep_freed_pages() -> bool:
    """Keep freed memory in this process (module docstring); True when in force (glibc), else False."""
    global _kept
    if not _kept:
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
            _kept = bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_BYTES)) and bool(libc.mallopt(M_TRIM_THRESHOLD, TRIM_BYTES))
        except (OSError, AttributeError):
            _kept = False
    return _kept


def pages_kept() -> bool:
    """Whether `keep_freed_pages` is in force in this process."""
    return _kept
