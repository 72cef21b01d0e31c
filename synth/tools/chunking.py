"""Jobs in chunks for `mpsynth batch` (`synth.tools.batchjobs`): numbering the lines, cutting them into chunks
(`chunks`, `default_chunksize`), and moving a chunk to a forked worker and its result lines back through memory
both share (`SharedSlots`, `run_in_slot`).

Shared slots: the batch process maps one anonymous shared region before its workers fork (they inherit it);
a chunk in flight owns a slot of it: the batch process puts the chunk's job lines there, the worker reads them
and puts the chunk's result lines in the slot's second part, and the pool's pipes carry only the slot's number,
the sizes and the exit codes. Through the pipes (pickled line lists in, one pickled text out), README's 20,000
jobs (10 MB in, 12 MB out) cost the batch process ~0.04 s of CPU in and ~0.035 s out (a pool of 2 forked
workers with the same sizes and no work; `bench/RESULTS.md`, issue 36). A chunk that does not fit its slot
(a line over the limit, a long line, a large result, `--full`) goes through the pipes as before.
"""
from __future__ import annotations

import mmap
from typing import Iterable, Iterator

MAX_CHUNK = 1024  # jobs per chunk at most (`default_chunksize`)
PIPE_CHUNK = 256  # jobs per chunk from a pipe (an unknown count: some chunks for every worker)


def numbered_lines(lines: Iterable[str]) -> Iterator[tuple[int, str]]:
    """(1-based line number, text) of every line of an iterable of text lines."""
    return enumerate(lines, 1)


def numbered(lines) -> Iterator[tuple[int, str]]:
    """(line number, text) pairs from (line number, text) pairs or plain text lines."""
    return (it if isinstance(it, tuple) else (n, it) for n, it in enumerate(lines, 1))


def chunks(items, size: int, max_bytes: int = 1 << 20):
    """Lists of at most ``size`` items of ``items`` ((line number, text) pairs) and about ``max_bytes``
    of job text."""
    chunk, nbytes = [], 0
    for item in items:
        chunk.append(item)
        nbytes += len(item[1] or "")
        if len(chunk) >= size or nbytes >= max_bytes:
            yield chunk
            chunk, nbytes = [], 0
    if chunk:
        yield chunk


def default_chunksize(workers: int, total: int | None) -> int:
    """Jobs per chunk: for a known job count, equal chunks of at most MAX_CHUNK (a chunk's Bennett jobs run as
    one batch: bigger chunks vectorize better), at least 8 per worker and their number a multiple of the
    workers, so that the last ones run side by side (README's 20,000 jobs on 2 workers: 20 of 1,000, not
    19 of 1,024 and one of 544 run by one worker while the other waits); PIPE_CHUNK for an unknown count (a
    pipe: `synth.io.docload.read_chunks` answers what was read whenever the pipe is idle)."""
    if total is None:
        return PIPE_CHUNK
    workers = max(workers, 1)
    count = max(8 * workers, -(-total // MAX_CHUNK))
    count = -(-count // workers) * workers
    return max(1, -(-total // count))


IN_BYTES = 2 << 20  # a slot's room for a chunk's job lines (`synth.io.docload.read_chunks`: about 1 MB a chunk)
OUT_BYTES = 4 << 20  # and for its result lines (README's: ~1.2 times its job lines)
_SHARED: list = []  # the batch process's mapping while its pool runs, inherited by the forked workers


class SharedSlots:
    """``count`` slots of shared memory for the chunks in flight (module docstring): made in the batch process
    before its workers fork (they must fork after it: ``multiprocessing``'s "fork" method), closed by `close`."""

    def __init__(self, count: int):
        self.map = mmap.mmap(-1, count * (IN_BYTES + OUT_BYTES))  # (anonymous: MAP_SHARED)
        self.free = list(range(count - 1, -1, -1))
        _SHARED[:] = [self.map]

    def put(self, chunk) -> tuple | None:
        """(slot, first line number, bytes) of a chunk (first line number, [line bytes]) put in a free slot, or
        None (no free slot, a line over the limit, more than IN_BYTES)."""
        first, raw = chunk
        if not self.free or None in raw:
            return None
        data = b"\n".join(raw)
        if len(data) > IN_BYTES or not raw:
            return None
        slot = self.free.pop()
        base = slot * (IN_BYTES + OUT_BYTES)
        self.map[base : base + len(data)] = data
        return slot, first, len(data)

    def answer(self, slot: int, got):
        """The text of result lines a worker put in ``slot`` (``got`` = (bytes, exit codes): `run_in_slot`) as
        (text, codes), or ``got`` itself when it came through the pipe; the slot is free again."""
        self.free.append(slot)
        if type(got) is not tuple:
            return got
        base = slot * (IN_BYTES + OUT_BYTES) + IN_BYTES
        return self.map[base : base + got[0]].decode("utf-8"), got[1]

    def close(self) -> None:
        _SHARED[:] = []
        self.map.close()


def run_in_slot(run, slot: int, first: int, nbytes: int, *args):
    """In a forked worker: ``run((first, [line bytes]), *args)`` (`synth.tools.batchjobs.run_chunk_lines`) of the
    chunk in ``slot``, its result lines put back there: (bytes, exit codes); or run's answer itself when they do
    not fit (OUT_BYTES)."""
    shared = _SHARED[0]
    base = slot * (IN_BYTES + OUT_BYTES)
    data = shared[base : base + nbytes]
    if data.isascii():  # (the usual job lines: decoded at once, not line by line)
        out = run(list(enumerate(data.decode("ascii").split("\n"), first)), *args)
    else:
        out = run((first, data.split(b"\n")), *args)
    data = out.text.encode("utf-8")
    if len(data) > OUT_BYTES:
        return out
    shared[base + IN_BYTES : base + IN_BYTES + len(data)] = data
    return len(data), out.codes
