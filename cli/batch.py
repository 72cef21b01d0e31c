"""`mpsynth batch JOBS.jsonl [-j N]`: many synthesis jobs from JSON lines, results as JSON lines."""
from __future__ import annotations

import contextlib
import os
import select
import sys
import time

import click

from synth.errors import InputError, OutputError
from synth.io.docload import open_lines, read_chunks
from synth.io.outputs import Outputs
from synth.tools.batchjobs import IDLE_SECONDS, Stopped, default_chunksize, run_batch, worker_count

from . import signals
from .common import debug_option, echo, nonempty_path, run_guarded
from .streams import WRITING, silence_stdout, terminate_as_exit


class Progress:
    """A one-line progress display on stderr (only used when stderr is a terminal)."""

    WIDTH = 28

    def __init__(self, total: int | None, stream=None):
        self.total = total
        self.stream = stream or sys.stderr
        self.start = time.monotonic()
        self.last = 0.0
        self.done = self.failed = 0

    def update(self, ok: bool, force: bool = False) -> None:
        self.done += 1
        self.failed += 0 if ok else 1
        now = time.monotonic()
        if not force and now - self.last < 0.1:
            return
        self.last = now
        rate = self.done / max(now - self.start, 1e-9)
        if self.total:
            frac = min(self.done / self.total, 1.0)
            fill = int(round(frac * self.WIDTH))
            bar = "#" * fill + "." * (self.WIDTH - fill)
            eta = (self.total - self.done) / rate if rate > 0 else 0
            text = f"[{bar}] {self.done}/{self.total} jobs, {self.failed} failed, {rate:.1f}/s, eta {eta:.0f} s"
        else:
            text = f"{self.done} jobs, {self.failed} failed, {rate:.1f}/s"
        self.stream.write("\r" + text + "\x1b[K")
        self.stream.flush()

    def close(self) -> None:
        self.stream.write("\r\x1b[K")
        self.stream.flush()


def _read(lines, source):
    """``lines``, with a read error (EIO, a vanished device) as a one-line InputError."""
    try:
        yield from lines
    except OSError as e:
        name = "<stdin>" if source == "-" else source
        raise InputError(f"{name}: cannot read: {e.strerror or e}") from None


def _write(text: str, whole: bool = False) -> None:
    """Result lines on stdout, flushed; a full disk or closed stdout is an OutputError. ``whole``: no signal
    handler can raise meanwhile (`signals.StopOnSignal` only records), so the text goes out at once
    (`_write_bytes`: one write call for a chunk's lines instead of one per line, which with an unbuffered
    stdout (PYTHONUNBUFFERED) was one system call per line: ~3 µs of the batch process's CPU a job)."""
    try:
        with WRITING:  # a forced exit after a signal (`cli.streams.exit_after_cleanup`) never cuts a line
            buffer = getattr(sys.stdout, "buffer", None) if whole else None
            if buffer is not None:
                sys.stdout.flush()
                _write_bytes(buffer, text.encode(sys.stdout.encoding or "utf-8", sys.stdout.errors or "strict"))
                return
            # whole lines, at most PIPE_BUF bytes a write: a signal's exception inside a write of the whole text
            # lost the rest of a line; stdout's buffer takes such a piece whole or not at all (what it holds is
            # flushed at exit), and an unbuffered stdout (PYTHONUNBUFFERED) writes it to a pipe in one atomic
            # system call (line by line, that was one call a line: ~3 µs of CPU a job)
            piece, size = [], 0
            for line in text.splitlines(keepends=True):
                n = len(line) if line.isascii() else select.PIPE_BUF
                if piece and size + n > select.PIPE_BUF:
                    sys.stdout.write("".join(piece))
                    piece, size = [], 0
                piece.append(line)
                size += n
            if piece:
                sys.stdout.write("".join(piece))
            sys.stdout.flush()
    except BrokenPipeError:
        raise
    except (OSError, ValueError, AttributeError) as e:  # ValueError/AttributeError: stdout closed
        silence_stdout()
        raise OutputError(f"cannot write the results to standard output "
                          f"({getattr(e, 'strerror', None) or 'it is closed'})") from None


def _write_bytes(buffer, data: bytes) -> None:
    """All of ``data`` to stdout's binary layer ``buffer``, flushed (an unbuffered stdout's raw file may take
    part of a write: the rest follows)."""
    view = memoryview(data)
    while view:
        n = buffer.write(view)
        view = view[n or 0:]  # (None: a non-blocking stdout took nothing yet)
    buffer.flush()


@click.command(epilog="""\b
Example:
  mpsynth batch jobs.jsonl -j 4 > results.jsonl
  cat jobs.jsonl | mpsynth batch - | jq -c 'select(.ok)'
  mpsynth batch jobs.jsonl --scheduler tcp://host:8786 --results results.parquet > results.jsonl

\b
A job line: {"id": "a1", "kind": "bennett", "poses": [...], "units": {...}, "out": "dir"}
  kind: bennett (3 poses) | sixbar (4 poses) | fourbar (3+ coplanar poses); poses and units as in a pose file;
  optional: out (write the linkage there), name, normalize, force, pin_radius, link_radius, pin_length.
Every input line (split on \\n only) gets one result line, in order:
  {"id", "line", "ok": true, "kind", "joints", "extent", "checks", "out"}
  or {"id", "line", "ok": false, "exit_code": 1|2|3, "error": "..."}
  or {"id": null, "line", "ok": true, "skipped": "blank line"}.
'out' paths are relative, below --out-dir (default: the working directory).

\b
Exit codes: 0 every job succeeded, 1 some job failed (its result line says why), 2 JOBS unreadable.""")
@click.argument("jobs_file", metavar="JOBS", type=click.Path(dir_okay=False, allow_dash=True))
@click.option("-j", "--jobs", "workers", type=int,
              help="Worker processes (0: one per CPU; never more than the CPUs or the jobs) [default: 1; "
                   "with --scheduler local: one per CPU].")
@click.option("--out-dir", type=click.Path(file_okay=False), callback=nonempty_path,
              help="Base directory of the jobs' relative 'out' paths (default: the working directory).")
@click.option("--chunksize", type=int, help="Jobs handed to a worker at a time (default: from the job count).")
@click.option("--full", is_flag=True, help="Add the whole linkage.json document to every successful result.")
@click.option("--no-design", is_flag=True,
              help="Jobs with 'out' write the kinematic outputs only: linkage.json and a URDF without meshes "
                   "(no physical design, no collision search; for filtering before building).")
@click.option("--no-step", is_flag=True,
              help="Jobs with 'out' write no linkage.step (URDF, STL and linkage.json with the design as usual; "
                   "the B-rep solids cost more CPU than the rest of a job: `mpsynth export OUT --step` adds them "
                   "to the outputs kept).")
@click.option("--scheduler", metavar="ADDRESS|local",
              help="Run the chunks of jobs on the Dask scheduler at ADDRESS (tcp://host:8786), or on a "
                   "LocalCluster ('local'); needs mpsynth[cluster]. Same result lines, same order.")
@click.option("--results", "results_file", type=click.Path(dir_okay=False), callback=nonempty_path,
              help="Also write one row per job to this Parquet file (id, ok, status, kind, extent, "
                   "checks, Bennett parameters, error); needs pyarrow (mpsynth[cluster]).")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar or summary on stderr.")
@debug_option
@run_guarded
def batch(jobs_file, workers, out_dir, chunksize, full, no_design, no_step, scheduler, results_file, quiet, debug):
    """Run the synthesis jobs in JOBS (JSON lines; '-' reads standard input), one result line per line
    on stdout, in input order, streamed as the jobs finish. A failing job (malformed line, bad poses,
    no real linkage) gives a result line with its error and never stops the batch."""
    if workers is not None and workers < 0:
        raise InputError(f"-j {workers}: must be 0 (one per CPU) or more")
    if chunksize is not None and chunksize < 1:
        raise InputError(f"--chunksize {chunksize}: must be at least 1")
    if out_dir is not None and not os.path.isdir(out_dir):
        raise InputError(f"--out-dir {out_dir}: not an existing directory")
    if scheduler is not None and not scheduler.strip():
        raise InputError("--scheduler: give an address (tcp://host:8786) or 'local'")
    outputs = Outputs.chosen(design=not no_design, step=not no_step)
    stream, total = open_lines(jobs_file)
    if results_file:  # (pyarrow only for --results)
        from synth.tools.resultstable import ResultsTable
    table = ResultsTable(results_file, avoid=(jobs_file,)) if results_file else contextlib.nullcontext()
    client = answers = None
    start = time.monotonic()
    n = failed = 0
    codes: dict[int, int] = {}
    progress = None
    if scheduler is None:
        workers = worker_count(1 if workers is None else workers, total)
    # a worker pool's loop polls for signals (raising inside the pool's bookkeeping could hang its shutdown)
    stopper = signals.StopOnSignal() if scheduler is None and workers > 1 else None
    try:
        with stream, table, stopper or terminate_as_exit():
            if scheduler is None:
                where = f"-j {workers}"
                size = chunksize or default_chunksize(workers, total)
                answers = run_batch(_read(read_chunks(stream, size, idle=None if total else IDLE_SECONDS), jobs_file),
                                    jobs=workers, full=full, initializer=signals.batch_worker, out_dir=out_dir,
                                    stop=stopper and stopper.requested, outputs=outputs, keep=bool(results_file))
            else:
                from synth.tools import cluster  # (Dask's modules only for --scheduler)

                client = cluster.connect(scheduler.strip(), workers)
                where = f"{cluster.worker_threads(client)} Dask workers"
                size = chunksize or default_chunksize(cluster.worker_threads(client), total)
                answers = cluster.run_chunks_on(client, _read(read_chunks(stream, size, idle=None if total else IDLE_SECONDS),
                                                              jobs_file), full=full, out_dir=out_dir,
                                                outputs=outputs, keep=bool(results_file))
            progress = Progress(total) if (not quiet and sys.stderr.isatty()) else None
            for answer in answers:
                if stopper and stopper.requested():
                    raise Stopped
                _write(answer.text, whole=stopper is not None)
                if results_file:
                    for res in answer.results:
                        table.add(res)
                for code in answer.codes:
                    if progress:
                        progress.update(not code)
                    if code is None:
                        continue
                    n += 1
                    if code:
                        failed += 1
                        codes[code] = codes.get(code, 0) + 1
    except Stopped:  # SIGINT/SIGTERM while the pool ran: it has been shut down, now act on the signal
        stopper.act()
    except BrokenPipeError:  # the reader went away (e.g. `| head`): stop quietly
        silence_stdout()
        sys.exit(1 if failed else 0)
    finally:
        if progress:
            progress.close()
        if answers is not None:
            answers.close()  # cancels the chunks still in flight
        if client is not None:
            cluster.close(client)
    if not quiet:
        dt = time.monotonic() - start
        why = {2: "bad input", 1: "no linkage", 3: "internal error"}
        detail = ", ".join(f"{c} {why.get(k, k)}" for k, c in sorted(codes.items()))
        echo(f"batch: {n} jobs, {n - failed} ok, {failed} failed{f' ({detail})' if detail else ''} "
             f"in {dt:.2f} s ({n / max(dt, 1e-9):.1f} jobs/s, {where})")
    sys.exit(1 if failed else 0)
