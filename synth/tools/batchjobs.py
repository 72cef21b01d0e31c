"""Many synthesis jobs from JSON lines, one result line per job, in input order.

A job is one JSON object on one line::

    {"id": "a7", "kind": "bennett", "poses": [...], "units": {"length": "mm", "angle": "deg"},
     "out": "runs/a7", "name": "a7", "normalize": false, "force": false,
     "pin_radius": 4, "link_radius": 3, "pin_length": 20}

``kind`` is ``"bennett"`` (3 poses), ``"sixbar"`` (4 poses) or ``"fourbar"`` (3 or more coplanar poses, or 2
with a velocity: `synth.solve.solve_fourbar`, as ``mpsynth fourbar``; its result has ``fourbar``); ``poses`` is a list of pose specs
exactly as in a pose file's ``poses`` list, ``units`` as in a pose file (both validated by
``synth.io.poses.parse_pose_document``); everything but ``kind`` and ``poses`` is optional. A point task
(docs/points.md) gives ``points`` (5 for bennett, 7 for sixbar, as a pose file's ``points`` list) instead
of, or besides, ``poses``; its result is the best-scored design. With ``out``
(a relative path, resolved under the base directory ``out_dir``, which it may not leave or be) the
linkage is written there (``synth.io.writer.write_output``: files of others in OUT are kept; robot name
``name``, else the id; missing parent directories are created, an unusable OUT is refused before the
synthesis);
mesh sizes are in the job's length unit. A Bennett job may carry a task file's keys (docs/fit.md:
``tolerance``, ``order``, ``constraints`` and per pose ``tolerance``, ``exact``, ``velocity``; then 2 or more
poses, ``best_effort`` as the CLI's --best-effort); its result then has ``fit``. Unknown keys are an error (a typo must not be
ignored silently). A job is solved by the entry point the CLI calls (`synth.solve`): the same gates and,
with ``out``, the same choice of design.

The result of a job is one JSON object::

    {"id": .., "line": n, "ok": true, "kind": "bennett", "joints": 4, "extent": 0.41, "extent_unit": "m",
     "checks": {...}, "out": "runs/a7" | null, ["linkage": {...linkage.json...}]}
    {"id": .., "line": n, "ok": false, "exit_code": 2, "error": "one line"}

    {"id": null, "line": n, "ok": true, "skipped": "blank line"}

``exit_code`` follows the CLI contract: 2 bad input (malformed JSON, bad poses, unknown kind, a line
over 10 MB), 1 no real linkage for valid input, 3 an internal error. ``line`` is the 1-based line
number in the input; lines are split on \\n only, and every line gets exactly one result, in order
(a blank line, holding only spaces, tabs or CR, the "skipped" one). ``id`` is echoed as given when
it is a string or a finite number, as a string when it is a number JSON cannot carry (``1e400``),
else null. A job never raises: every failure is a result.

``run_jobs(lines, jobs=N)`` runs them in chunks (`default_chunksize`), in N worker processes
(``multiprocessing``, at most a few chunks ahead of the output, so memory stays bounded), and yields the
results in input order as soon as each chunk is ready (a result waits only for the chunks before it).
A chunk (`run_chunk`) checks each job on its own, runs its three-pose Bennett jobs without ``out`` through
one `synth.solve.many.solve_bennett_many` call and every other job (and every set that call leaves
undecided) through `run_job`'s path: the same result lines, byte for byte, as job by job.
"""
from __future__ import annotations

import collections
import contextlib
import gc
import json
import multiprocessing
import os
from dataclasses import dataclass
from typing import Any, Iterable, Iterator

import numpy as np

from synth.errors import MpsynthError, SynthesisError
from synth.io.outputs import Outputs
from synth.task import default_name
from synth.solve.many import solve_bennett_many
from synth.tools.resultlines import dumps, dumps_lines, float_texts  # (dumps: the API of this module too)
from synth.tools.chunking import (MAX_CHUNK, PIPE_CHUNK, SharedSlots, chunks, default_chunksize,  # noqa: F401
                                  numbered, numbered_lines, run_in_slot)
from synth.tools.workerpool import keep_freed_pages, pool_context, prepare_worker, terminate_pool, worker_count  # noqa: F401
from synth.tools.jobspec import (DEGREES, KINDS, SIZE_KEYS, TASK_KEYS, JobError, check_job, echo_id, is_task_job,
                                 one_line_message, parse_job, prepare_out, read_common_bennett, resolve_out)

JOB_SOURCE = "poses"  # a job's poses as messages name them


def _synthesize(kind: str, ps, options):
    """The job's Result: the entry point the CLI calls for the same task (`synth.solve`; imported at the
    first job that needs it, like every module of the per-job path: `mpsynth batch`'s start-up imports the
    chunk path only)."""
    from synth.solve import solve_bennett, solve_fourbar, solve_points, solve_sixbar

    if kind == "fourbar":
        return solve_fourbar(ps, options)
    if kind == "bennett" or ps.has_points:
        return solve_bennett(ps, options) if kind == "bennett" else solve_points(ps, DEGREES[kind], options)
    try:  # sixbar is optional in an installation
        import synth.synthesis.sixbar  # noqa: F401
    except ImportError as e:
        raise JobError(f"kind 'sixbar' is not available in this installation ({e})") from None
    return solve_sixbar(ps, options)


def run_job(item, full: bool = False, out_dir=None, outputs: Outputs = Outputs.FULL) -> dict:
    """Run one job given as (line number, text) (text None: a line over the limit); ``out`` paths are
    resolved under ``out_dir`` (default: the working directory); ``outputs``: what OUT gets
    (`synth.io.outputs.Outputs`: ``--no-step``, ``--no-design``). Never raises (but KeyboardInterrupt)."""
    job = _read_job(item, out_dir)
    return job if isinstance(job, dict) else _solve_job(job, full, outputs)


@dataclass
class _Job:
    """A job line that passed the checks before the synthesis: its result so far (id, line), the job
    object, its validated task and design sizes, OUT (None: none) and the parent directories made for it."""

    result: dict
    job: dict
    ps: Any
    design: Any  # synth.solve.DesignOptions
    out_path: str | None
    created: list


def _read_job(item, out_dir, defer_out: bool = False) -> _Job | dict | None:
    """The checks of one (line number, text) before its synthesis: a `_Job`, or the final result dict
    (a blank line, a bad job); ``defer_out``: None for a valid-looking job with OUT, before anything is
    touched on disk (its caller runs it whole at its turn, after the jobs before it have written theirs)."""
    lineno, text = item
    result: dict[str, Any] = {"id": None, "line": lineno}
    created: list[str] = []  # parent directories made for "out": removed again when the job fails
    if text is not None and not text.strip(" \t\r"):
        result.update({"ok": True, "skipped": "blank line"})
        return result
    with _one_result(result, created):
        job = parse_job(text)
        result["id"] = echo_id(job.get("id"))
        check_job(job)
        if defer_out and "out" in job:
            return None
        doc = {k: job[k] for k in ("poses", "points", "units", "quaternion_order") + TASK_KEYS if k in job}
        kind = job["kind"]
        from synth.io.poses import parse_pose_document
        from synth.solve import DesignOptions
        from synth.task import MINIMUM, NEEDED

        try:
            out_path = resolve_out(job["out"], out_dir) if "out" in job else None
            if out_path is not None:
                prepare_out(out_path, bool(job.get("force", False)), created)
            task = is_task_job(job)
            ps = parse_pose_document(doc, source=JOB_SOURCE, normalize=bool(job.get("normalize", False)),
                                     count=((2, None) if task else KINDS[kind], f"kind {kind!r}"),
                                     points=((MINIMUM[DEGREES.get(kind, 2)], NEEDED[DEGREES.get(kind, 2)]),
                                             f"kind {kind!r}"))
            design = DesignOptions(**{k: float(job[k]) for k in SIZE_KEYS if k in job})
            design.sizes(ps.length_scale, label=repr)  # the job's names in the message
        except MpsynthError as e:
            raise JobError(str(e), e.exit_code) from None
        return _Job(result, job, ps, design, out_path, created)
    return result


def _solve_job(j: _Job, full: bool, outputs: Outputs = Outputs.FULL) -> dict:
    """The result of a checked job: the synthesis (`synth.solve`), OUT written when asked for (``outputs``:
    with the physical design or the kinematic outputs only, with or without linkage.step)."""
    from synth.solve import SynthesisOptions

    job, result = j.job, j.result
    with _one_result(result, j.created):
        kind = job["kind"]
        try:
            solved = _synthesize(kind, j.ps, SynthesisOptions(design=j.design, physical="out" in job and outputs.design,
                                                              best_effort=bool(job.get("best_effort", False))))
            linkage, out = solved.linkage, None
            if "out" in job:
                from synth.io.names import safe_robot_name
                from synth.io.writer import write_output

                name = job.get("name") or safe_robot_name(str(result["id"]) if result["id"] is not None else "")
                write_output(linkage, j.out_path, robot_name=name, force=bool(job.get("force", False)),
                             result=solved.design, formats=outputs.formats)
                out = job["out"]
        except MpsynthError as e:
            raise JobError(str(e), e.exit_code) from None
        result.update(_success(kind, linkage, out, full))
    return result


@contextlib.contextmanager
def _one_result(result: dict, created: list):
    """Every failure inside as the result's error (a job never raises, but KeyboardInterrupt); a failed
    job's parent directories made for OUT removed again (nothing partial)."""
    failed = True
    try:
        yield
        failed = False
    except JobError as e:
        result.update({"ok": False, "exit_code": e.exit_code, "error": one_line_message(e)})
    except KeyboardInterrupt:
        raise
    except Exception as e:  # an internal error: still one result line
        result.update({"ok": False, "exit_code": 3, "error": one_line_message(f"internal error: {type(e).__name__}: {e}")})
    finally:
        if failed:
            for d in reversed(created):  # nothing partial: not even an empty parent directory
                try:
                    os.rmdir(d)
                except OSError:
                    break


def _batchable(j: _Job, full: bool) -> bool:
    """A job `synth.solve.many.solve_bennett_many` can decide: three Bennett poses, default options, no OUT."""
    job = j.job
    return (not full and j.out_path is None and job["kind"] == "bennett" and not j.ps.has_points
            and len(j.ps) == 3 and not is_task_job(job) and j.ps.constraints is None and not job.get("best_effort"))


def _success(kind: str, linkage, out, full: bool) -> dict:
    from synth.info import FourBarRecord
    from synth.infoparts import document
    from synth.io.jsonout import linkage_document, plain

    b, f, s = linkage.info.bennett, linkage.info.fit, linkage.info.synthesis
    res = _success_fields(kind, len(linkage.joints), float(linkage.extent()), linkage.checks, out,
                          {"a": b.a, "alpha": b.alpha, "b": b.b, "beta": b.beta} if b else None,
                          {"method": f.method, "within_tolerance": f.within_tolerance,
                           "max_position_error": f.max_position_error, "max_angle_error": f.max_angle_error,
                           "rms_position_error": f.rms_position_error, "rms_angle_error": f.rms_angle_error,
                           "visit_order": f.visit_order} if f else None)
    if isinstance(s, FourBarRecord):
        fb = s.fourbar
        res["fourbar"] = plain({"lengths": document(fb.lengths), "grashof": fb.grashof,
                                "transmission_min_deg": fb.transmission_min_deg, "task_range_deg": fb.task_range_deg})
    if full:
        res["linkage"] = linkage_document(linkage)
    return res


def _success_fields(kind: str, joints: int, extent: float, checks, out, bennett=None, fit=None, clean=None) -> dict:
    """The fields of a successful result line, in their order (``clean``: how nested values become plain
    JSON values, default `synth.io.jsonout.plain`; `_solve_many` passes plain floats already)."""
    if clean is None:
        from synth.io.jsonout import plain as clean
    res = {"ok": True, "kind": kind, "joints": joints, "extent": extent, "extent_unit": "m",
           "checks": clean(dict(checks)), "out": out}
    if bennett is not None:
        res["bennett"] = clean(bennett)
    if fit is not None:
        res["fit"] = clean(fit)
    return res


def run_chunk(chunk, full: bool, out_dir, outputs: Outputs = Outputs.FULL) -> list[dict]:
    """The results of a list of (line number, text) jobs (a worker's unit of work), in order: the
    three-pose Bennett jobs without OUT in one `synth.solve.many.solve_bennett_many` call (the sets it
    leaves undecided, and every other job, one by one: `run_job`); the same result lines either way."""
    return list(chunk_results(chunk, full, out_dir, outputs))


def chunk_results(chunk, full: bool, out_dir, outputs: Outputs = Outputs.FULL, stop=None, lines: bool = False) -> Iterator:
    """`run_chunk`'s results as they are ready (the batched jobs first, at once); ``stop``: as `run_jobs`,
    asked before every result. The lines of the common Bennett shape are read for the whole chunk at once
    (`synth.tools.jobspec.read_common_bennett`), the others one by one (`_read_job`). ``lines``: the
    successes of the batched jobs come as their result lines (str, `_success_lines`), not dicts."""
    common = read_common_bennett([text for _, text in chunk]) if not full else None
    read: list = [None] * len(chunk)
    if common is not None:
        for n, jid in zip(common.index, common.ids):
            read[n] = {"id": echo_id(jid), "line": chunk[n][0]}
    for n, item in enumerate(chunk):
        if read[n] is None:
            read[n] = _read_job(item, out_dir, defer_out=True)
    fast = [n for n, j in enumerate(read) if isinstance(j, _Job) and _batchable(j, full)]
    if common is not None and (fast or common.index):  # (fast: never with full, as common)
        T = np.concatenate([common.poses] + [read[n].ps.matrices[None] for n in fast])
        rendered = {} if lines else None
        done = _solve_many(T, [read[n] for n in common.index] + [read[n].result for n in fast],
                           [[default_name(i) for i in range(3)]] * len(common.index) + [read[n].ps.names for n in fast],
                           rendered)
        for n, ok in zip(fast, done[len(common.index):]):
            if ok:
                read[n].ps = None  # decided: its result is complete
        for n, ok in zip(common.index, done):
            if not ok:
                read[n] = None  # undecided: the per-job path, at its turn
        where = common.index + fast  # (the sets of T, in order)
        for k, text in (rendered or {}).items():
            read[where[k]] = text
    for item, j in zip(chunk, read):
        if stop is not None and stop():
            raise Stopped
        yield (run_job(item, full, out_dir, outputs) if j is None else j if isinstance(j, (dict, str)) else
               j.result if j.ps is None else _solve_job(j, full, outputs))


def _solve_many(T, results: list, names: list, lines: dict | None = None) -> list:
    """Which of the three-pose Bennett sets T (n, 3, 4, 4) `solve_bennett_many` decides (a list of bools):
    the result dict of each such set (``results[n]``, poses named ``names[n]``) completed with its success
    fields or its refusal; the others are left as they are. ``lines`` (a dict): a success with finite
    figures goes there instead, as its result line (``lines[n]``: `dumps`' text, `_success_lines`)."""
    try:
        many = solve_bennett_many(T)
    except Exception:  # (never: the per-job path then gives every job its own result)
        return [False] * len(results)
    index = np.flatnonzero(many.decided & ~many.refused).tolist()
    finite = np.isfinite(many.extent) & np.all([np.isfinite(v) for v in (*many.figures.values(), *many.bennett.values())],
                                               axis=0)
    if lines is not None:
        lines.update(_success_lines(many, [n for n in index if finite[n]], results))
        index = [n for n in index if not finite[n]]
    checks, parameters = many.rows(index)
    for n, c, b in zip(index, checks, parameters):  # (finite: plain floats, as `plain` leaves them)
        results[n].update(_success_fields("bennett", 4, c["length_scale"], c, None, b,
                                          clean=_same if finite[n] else None))
    for n in np.flatnonzero(many.refused).tolist():  # `solve_bennett`'s SynthesisError, as `_solve_job` words it
        message = f"{JOB_SOURCE}: {many.refusal(n, T[n], names[n])}"
        results[n].update({"ok": False, "exit_code": SynthesisError.exit_code, "error": one_line_message(message)})
    return many.decided.tolist()


def _same(x):
    return x


def _success_lines(many, index: list, results: list) -> dict:
    """{n: result line} of the decided successful sets ``index`` (finite figures) of `solve_bennett_many`'s
    ``many``, each the text `dumps` gives for ``results[n]`` (id, line) completed by `_success_fields`:
    the fields' layout from that function (one `json.dumps` of the fields with a marker in every value
    that varies), the floats a column at a time (`synth.tools.resultlines.float_texts`)."""
    if not index:
        return {}
    checks, parameters = many.columns(index)
    columns: list = []

    def mark(values):  # a column's place in the layout (scalars every row has stay in it)
        if not isinstance(values, np.ndarray):
            return values
        columns.append(float_texts(values.tolist()))
        return f"@@{len(columns) - 1}@@"

    marked = {k: mark(v) for k, v in checks.items()}
    fields = _success_fields("bennett", 4, marked["length_scale"], marked, None,
                             {k: mark(v) for k, v in parameters.items()}, clean=_same)
    layout = json.dumps({"id": "@@id@@", "line": "@@line@@", **fields}, separators=(",", ":"), allow_nan=False)
    layout = layout.replace("{", "{{").replace("}", "}}").replace('"@@id@@"', "{0}").replace('"@@line@@"', "{1}")
    for k in range(len(columns)):  # (a column may have several places: the extent is the length scale)
        layout = layout.replace(f'"@@{k}@@"', f"{{{k + 2}}}")
    ids = [results[n]["id"] for n in index]
    ids = [str(i) if type(i) is int else json.dumps(i) for i in ids]
    return {n: layout.format(i, results[n]["line"], *row) for n, i, *row in zip(index, ids, *columns)}


class Stopped(Exception):
    """``run_jobs`` gave up because its ``stop()`` said so (the caller's request, e.g. a signal)."""


POLL_SECONDS = 0.1  # how often a waiting `run_jobs` asks ``stop()`` (a reaction time, not a work budget)
IDLE_SECONDS = 0.05  # a pipe without input this long: answer what was read (`synth.io.docload.read_chunks`)


@dataclass
class ChunkLines:
    """The answer to a chunk of job lines: ``text``, its result lines (each ending in a newline, in input
    order), ``codes`` per input line (0 ok, the exit code of a failed job, None a skipped blank line)
    and, when asked for, the result dicts (``results``; else None)."""

    text: str
    codes: list
    results: list | None = None


def run_chunk_lines(chunk, full: bool, out_dir, outputs: Outputs = Outputs.FULL, keep: bool = False) -> ChunkLines:
    """`run_chunk` of a chunk given as (line number, text) pairs or as `synth.io.docload.read_chunks`
    gives it, (first line number, [line bytes, or None for a line over the limit]): the raw bytes go to
    a worker (no parsed objects), the result lines come back as one text (`dumps_lines`); ``keep``:
    with the result dicts too."""
    if isinstance(chunk, tuple):
        first, raw = chunk
        chunk = [(first + i, None if b is None else b.decode("utf-8", "replace")) for i, b in enumerate(raw)]
    if keep:
        results = run_chunk(chunk, full, out_dir, outputs)
        return ChunkLines(dumps_lines(results), [_code(r) for r in results], results)
    results = list(chunk_results(chunk, full, out_dir, outputs, lines=True))  # (successes as their lines)
    if all(type(r) is str for r in results):
        return ChunkLines("\n".join(results) + "\n" if results else "", [0] * len(results))
    return ChunkLines("".join((r if type(r) is str else dumps(r)) + "\n" for r in results),
                      [0 if type(r) is str else _code(r) for r in results])


def _code(result: dict):
    """A result's code in `ChunkLines.codes`: 0 ok, the exit code of a failed job, None a skipped line."""
    return None if result.get("skipped") else 0 if result["ok"] else result["exit_code"]


def run_batch(chunks, jobs: int = 1, full: bool = False, out_dir=None, initializer=None, stop=None,
              outputs: Outputs = Outputs.FULL, keep: bool = False) -> Iterator[ChunkLines]:
    """`ChunkLines` of ``chunks`` (`synth.io.docload.read_chunks`: chunks, or None while the input is
    idle), in input order, as soon as each is ready and every one before it. ``jobs`` worker processes
    (the caller caps it, `worker_count`), each set up by ``initializer(parent pid)`` (an importable
    function; default `prepare_worker`), each chunk a task of one worker, at most two chunks per
    worker ahead of the output (bounded memory); with ``jobs`` 1 this process runs them and keeps the memory
    it frees (`synth.tools.workerpool.keep_freed_pages`, as a worker does). ``stop``: a callable asked
    before every chunk, on every idle tick and, while waiting for a worker, every `POLL_SECONDS`; when it
    returns true the pool is terminated (from this loop, never from inside the pool's own bookkeeping) and
    `Stopped` is raised; asked while the input is idle, the chunks already read are answered first (every line read
    gets its result). ``full``, ``out_dir``, ``outputs``: as `run_job`; ``keep``: as `run_chunk_lines`."""
    stop = stop or (lambda: False)
    if jobs <= 1:
        keep_freed_pages()  # (this process runs the chunks: as a worker does, `prepare_worker`)
        for chunk in chunks:
            if stop():
                raise Stopped
            if chunk is not None:
                yield run_chunk_lines(chunk, full, out_dir, outputs, keep)
        return
    ctx = pool_context()
    before = set(multiprocessing.active_children())
    # forked workers inherit shared slots for the chunks in flight (`synth.tools.chunking.SharedSlots`)
    slots = SharedSlots(2 * jobs + 1) if ctx.get_start_method() == "fork" and not keep else None
    gc.freeze()  # (forked workers: the collector never visits, so never copies, the pages of what is imported)
    try:
        pool = ctx.Pool(processes=jobs, initializer=initializer or prepare_worker, initargs=(os.getpid(),))
    finally:
        gc.unfreeze()
    workers = [p for p in multiprocessing.active_children() if p not in before]  # (no replacements: no maxtasks)
    pending: collections.deque = collections.deque()  # (task, slot or None)

    def first_done(finish: bool = False):
        while not (stop() and not finish or pending[0][0].ready()):
            pending[0][0].wait(POLL_SECONDS)
        if not pending[0][0].ready():
            raise Stopped
        task, slot = pending.popleft()
        got = task.get() if slot is None else slots.answer(slot, task.get())
        return got if isinstance(got, ChunkLines) else ChunkLines(*got)

    def submit(chunk):
        where = slots.put(chunk) if slots is not None and isinstance(chunk, tuple) else None
        if where is None:
            return pool.apply_async(run_chunk_lines, (chunk, full, out_dir, outputs, keep)), None
        return pool.apply_async(run_in_slot, (run_chunk_lines, *where, full, out_dir, outputs)), where[0]

    try:
        for chunk in chunks:
            if stop():
                while chunk is None and pending:  # idle: what was read is answered, then stop
                    yield first_done(finish=True)
                raise Stopped
            if chunk is not None:
                pending.append(submit(chunk))
            while len(pending) > 2 * jobs:
                yield first_done()
            while pending and pending[0][0].ready():
                yield first_done()
        while pending:
            yield first_done()
        pool.close()
    except BaseException:
        terminate_pool(pool, workers)
        if slots is not None:
            slots.close()
        raise
    pool.join()
    if slots is not None:
        slots.close()


def run_jobs(lines, jobs: int = 1, chunksize: int | None = None, full: bool = False,
             total: int | None = None, out_dir=None, initializer=None, stop=None,
             outputs: Outputs = Outputs.FULL) -> Iterator[dict]:
    """Results of the jobs in ``lines``, in input order. ``lines``: an iterable of (line number, text)
    pairs (`synth.io.docload.read_lines`) or of text lines. ``jobs``, ``initializer``, ``outputs``: as
    `run_batch`; ``stop``: asked before every job, and as `run_batch` asks it; when it returns true the
    pool is terminated and `Stopped` is raised."""
    items = numbered(lines)
    stop = stop or (lambda: False)
    if chunksize is None:
        chunksize = default_chunksize(jobs, total)
    if jobs <= 1:
        for chunk in chunks(items, chunksize):
            yield from chunk_results(chunk, full, out_dir, outputs, stop)
        return
    with contextlib.closing(run_batch(chunks(items, chunksize), jobs, full, out_dir, initializer, stop, outputs,
                                      keep=True)) as answers:
        for answer in answers:
            for res in answer.results:
                if stop():
                    raise Stopped
                yield res
