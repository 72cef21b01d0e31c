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

``run_jobs(lines, jobs=N)`` runs them in N worker processes (``multiprocessing``, in chunks, at most
a few chunks ahead of the output, so memory stays bounded) and yields the results in input order as
soon as each is ready (a result waits only for the jobs before it).
"""
from __future__ import annotations

import collections
import difflib
import importlib
import json
import math
import multiprocessing
import os
import sys
from pathlib import Path
from typing import Any, Iterable, Iterator

from synth.errors import InputError, MpsynthError
from synth.io.docload import json_object_pairs
from synth.io.jsonout import linkage_document, plain
from synth.io.names import check_robot_name, safe_robot_name
from synth.io.poses import parse_pose_document
from synth.io.atomic import check_path
from synth.io.writer import check_output_target, write_output
from synth.solve import DesignOptions, SynthesisOptions, solve_bennett, solve_fourbar, solve_points, solve_sixbar
from synth.synthesis.points import MINIMUM, NEEDED

KINDS = {"bennett": 3, "sixbar": 4, "fourbar": (2, None)}  # pose counts (fourbar: its own refusals below 3)
DEGREES = {"bennett": 2, "sixbar": 3}  # degree of the motion of a point task
SIZE_KEYS = ("pin_radius", "link_radius", "pin_length")
TASK_KEYS = ("tolerance", "order", "constraints")  # a task file's keys (docs/fit.md), as in a pose file
JOB_KEYS = ("id", "kind", "poses", "points", "units", "quaternion_order", "out", "name", "normalize", "force", *SIZE_KEYS,
            "best_effort") + TASK_KEYS
MAX_LINE = 10 * 1024 * 1024


class _JobError(Exception):
    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        self.exit_code = exit_code


def _one_line(msg: str, limit: int = 2000) -> str:
    msg = " ".join(str(msg).split())
    return msg if len(msg) <= limit else msg[: limit - 3] + "..."



def _reject_constant(name):
    raise ValueError(f"{name} is not a valid JSON number")


class RawNumber(str):
    """A JSON number too large for a float (``1e400``), kept as its text."""


def _parse_float(text: str):
    x = float(text)
    return x if math.isfinite(x) else RawNumber(text)


def parse_job(text: str | None) -> dict:
    """The job object of one line (None: a line over the limit); _JobError (exit code 2) when it is
    not a valid job."""
    if text is None or len(text) > MAX_LINE:
        raise _JobError("line is longer than 10 MB")
    try:
        job = json.loads(text, object_pairs_hook=json_object_pairs, parse_constant=_reject_constant,
                         parse_float=_parse_float)
    except json.JSONDecodeError as e:
        raise _JobError(f"invalid JSON at column {e.colno}: {e.msg}") from None
    except (ValueError, RecursionError) as e:
        raise _JobError(f"invalid JSON: {e}") from None
    if not isinstance(job, dict):
        raise _JobError(f"a job must be a JSON object, got {type(job).__name__}")
    return job


def _check_job(job: dict) -> None:
    unknown = [k for k in job if k not in JOB_KEYS]
    if unknown:
        k = unknown[0]
        close = difflib.get_close_matches(k, JOB_KEYS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else f" (allowed: {', '.join(JOB_KEYS)})"
        raise _JobError(f"unknown key {k!r}{hint}")
    if "kind" not in job:
        raise _JobError(f"missing 'kind' ({' or '.join(repr(k) for k in KINDS)})")
    if job["kind"] not in KINDS:
        raise _JobError(f"unknown kind {job['kind']!r} (allowed: {', '.join(KINDS)})")
    if "poses" not in job and "points" not in job:
        raise _JobError("missing 'poses' (a list of pose specs as in a pose file) or 'points'")
    jid = job.get("id")
    if jid is not None and not isinstance(jid, (str, int, float)) or isinstance(jid, bool):
        raise _JobError("'id' must be a string or a number")
    for key in ("out", "name"):
        if key in job and not (isinstance(job[key], str) and job[key].strip()) or isinstance(job.get(key), RawNumber):
            raise _JobError(f"{key!r} must be a non-empty string")
    if "name" in job:
        try:
            check_robot_name(job["name"], "'name'")
        except MpsynthError as e:
            raise _JobError(str(e)) from None
    for key in ("normalize", "force"):
        if key in job and not isinstance(job[key], bool):
            raise _JobError(f"{key!r} must be true or false")
    for key in SIZE_KEYS:  # their values: `synth.solve.DesignOptions.sizes`, as the CLI's
        if key in job:
            v = job[key]
            if isinstance(v, (bool, RawNumber)) or not isinstance(v, (int, float)):
                raise _JobError(f"{key!r} must be a positive length in the job's unit")


def _is_task_job(job: dict) -> bool:
    """A job with a task file's keys (top-level tolerance or order, per-pose tolerance, exact or velocity)."""
    if any(k in job for k in ("tolerance", "order")):
        return True
    items = [p for k in ("poses", "points") for p in (job.get(k) if isinstance(job.get(k), list) else [])]
    return any(isinstance(p, dict) and any(k in p for k in ("tolerance", "exact", "velocity")) for p in items)


def _synthesize(kind: str, ps, options: SynthesisOptions):
    """The job's Result: the entry point the CLI calls for the same task (`synth.solve`)."""
    if kind == "fourbar":
        return solve_fourbar(ps, options)
    if kind == "bennett" or ps.has_points:
        return solve_bennett(ps, options) if kind == "bennett" else solve_points(ps, DEGREES[kind], options)
    try:  # sixbar is optional in an installation
        import synth.synthesis.sixbar  # noqa: F401
    except ImportError as e:
        raise _JobError(f"kind 'sixbar' is not available in this installation ({e})") from None
    return solve_sixbar(ps, options)


def _echo_id(jid):
    """The job id as it can go into a result line (see the module docstring)."""
    if isinstance(jid, RawNumber):
        return str(jid)
    if isinstance(jid, bool) or not isinstance(jid, (str, int, float)):
        return None
    return jid


def run_job(item, full: bool = False, out_dir=None) -> dict:
    """Run one job given as (line number, text) (text None: a line over the limit); ``out`` paths are
    resolved under ``out_dir`` (default: the working directory). Never raises (but KeyboardInterrupt)."""
    lineno, text = item
    result: dict[str, Any] = {"id": None, "line": lineno}
    created: list[str] = []  # parent directories made for "out": removed again when the job fails
    if text is not None and not text.strip(" \t\r"):
        result.update({"ok": True, "skipped": "blank line"})
        return result
    try:
        job = parse_job(text)
        result["id"] = _echo_id(job.get("id"))
        _check_job(job)
        doc = {k: job[k] for k in ("poses", "points", "units", "quaternion_order") + TASK_KEYS if k in job}
        kind = job["kind"]
        try:
            out_path = _out_path(job["out"], out_dir) if "out" in job else None
            if out_path is not None:
                _prepare_out(out_path, bool(job.get("force", False)), created)
            task = _is_task_job(job)
            ps = parse_pose_document(doc, source="poses", normalize=bool(job.get("normalize", False)),
                                     count=((2, None) if task else KINDS[kind], f"kind {kind!r}"),
                                     points=((MINIMUM[DEGREES.get(kind, 2)], NEEDED[DEGREES.get(kind, 2)]),
                                             f"kind {kind!r}"))
            design = DesignOptions(**{k: float(job[k]) for k in SIZE_KEYS if k in job})
            design.sizes(ps.length_scale, label=repr)  # the job's names in the message
            solved = _synthesize(kind, ps, SynthesisOptions(design=design, physical="out" in job,
                                                            best_effort=bool(job.get("best_effort", False))))
            linkage, out = solved.linkage, None
            if "out" in job:
                name = job.get("name") or safe_robot_name(str(result["id"]) if result["id"] is not None else "")
                write_output(linkage, out_path, robot_name=name, force=bool(job.get("force", False)),
                             result=solved.design)
                out = job["out"]
        except MpsynthError as e:
            raise _JobError(str(e), e.exit_code) from None
        result.update(_success(kind, linkage, out, full))
    except _JobError as e:
        result.update({"ok": False, "exit_code": e.exit_code, "error": _one_line(e)})
    except KeyboardInterrupt:
        raise
    except Exception as e:  # an internal error: still one result line
        result.update({"ok": False, "exit_code": 3, "error": _one_line(f"internal error: {type(e).__name__}: {e}")})
    finally:
        if not result.get("ok"):
            for d in reversed(created):  # nothing partial: not even an empty parent directory
                try:
                    os.rmdir(d)
                except OSError:
                    break
    return result


def _out_path(out: str, out_dir) -> str:
    """``out`` resolved under the base directory; _JobError when it is absolute or leaves it."""
    base = os.path.abspath(os.fspath(out_dir) if out_dir is not None else os.curdir)
    try:
        check_path(out, "'out'")
    except InputError as e:
        raise _JobError(str(e)) from None
    if "\x00" in out or os.path.isabs(out) or out.startswith("~"):
        raise _JobError(f"'out' {out!r}: must be a relative path under the output base directory {base}")
    path = os.path.normpath(os.path.join(base, out))
    real_base, real = os.path.realpath(base), os.path.realpath(path)
    if not real.startswith(real_base.rstrip(os.sep) + os.sep):
        raise _JobError(f"'out' {out!r}: leaves the output base directory {base} (or is it); "
                        "name a directory below it")
    return path


def _prepare_out(out: str, force: bool, created: list) -> None:
    """Create OUT's missing parent directories and refuse an unusable OUT before any work. A job never
    replaces a file (the jobs or the results file, say), not even with "force"."""
    if os.path.lexists(out) and (os.path.islink(out) or not os.path.isdir(out)):
        raise _JobError(f"'out' {out}: exists and is not a directory; a batch job never replaces a file")
    parent = Path(os.path.abspath(out)).parent
    missing = []
    p = parent
    while not os.path.lexists(p) and p != p.parent:
        missing.append(str(p))
        p = p.parent
    try:
        for d in reversed(missing):
            os.mkdir(d)
            created.append(d)
    except OSError as e:
        raise _JobError(f"{parent}: cannot create the output's parent directory ({e.strerror or e})") from None
    check_output_target(out, force=force)


def _success(kind: str, linkage, out, full: bool) -> dict:
    res = {"ok": True, "kind": kind, "joints": len(linkage.joints), "extent": float(linkage.extent()), "extent_unit": "m",
           "checks": plain(dict(linkage.checks)), "out": out}
    b = linkage.info.get("bennett")
    if b:
        res["bennett"] = plain({k: b[k] for k in ("a", "alpha", "b", "beta") if k in b})
    fb = linkage.info.get("fourbar")
    if fb:
        res["fourbar"] = plain({k: fb[k] for k in ("lengths", "grashof", "transmission_min_deg", "task_range_deg")})
    f = linkage.info.get("fit")
    if f:
        res["fit"] = plain({k: f[k] for k in ("method", "within_tolerance", "max_position_error", "max_angle_error",
                                              "rms_position_error", "rms_angle_error", "visit_order")})
    if full:
        res["linkage"] = linkage_document(linkage)
    return res


def numbered_lines(lines: Iterable[str]) -> Iterator[tuple[int, str]]:
    """(1-based line number, text) of every line of an iterable of text lines."""
    return enumerate(lines, 1)


def numbered(lines) -> Iterator[tuple[int, str]]:
    """(line number, text) pairs from (line number, text) pairs or plain text lines."""
    return (it if isinstance(it, tuple) else (n, it) for n, it in enumerate(lines, 1))


def run_chunk(chunk, full: bool, out_dir):
    """The results of a list of (line number, text) jobs (a worker's unit of work)."""
    return [run_job(item, full=full, out_dir=out_dir) for item in chunk]


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


def worker_count(requested: int, total: int | None) -> int:
    """Worker processes actually used for ``requested`` (0: one per CPU): at most the CPUs this
    process may run on and the number of jobs (when known), at least 1."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    n = cpus if requested == 0 else min(requested, cpus)
    if total is not None:
        n = min(n, total)
    return max(1, n)


class Stopped(Exception):
    """``run_jobs`` gave up because its ``stop()`` said so (the caller's request, e.g. a signal)."""


POLL_SECONDS = 0.1  # how often a waiting `run_jobs` asks ``stop()`` (a reaction time, not a work budget)


def run_jobs(lines, jobs: int = 1, chunksize: int | None = None, full: bool = False,
             total: int | None = None, out_dir=None, initializer=None, stop=None) -> Iterator[dict]:
    """Results of the jobs in ``lines``, in input order. ``lines``: an iterable of (line number, text)
    pairs (`synth.io.docload.read_lines`) or of text lines. ``jobs`` worker processes (the caller caps
    it, `worker_count`), each set up by ``initializer(parent pid)`` (an importable function; default
    `prepare_worker`). ``stop``: a callable asked before every job (chunk of jobs, with workers) and,
    while waiting for a worker, every `POLL_SECONDS`; when it returns true the pool is terminated (from this loop, never from inside the
    pool's own bookkeeping) and `Stopped` is raised."""
    items = numbered(lines)
    stop = stop or (lambda: False)
    if jobs <= 1:
        for item in items:
            if stop():
                raise Stopped
            yield run_job(item, full=full, out_dir=out_dir)
        return
    if chunksize is None:
        chunksize = max(1, min(16, (total or 64) // (jobs * 8)))
    ctx = multiprocessing.get_context("forkserver" if os.name == "posix" else "spawn")
    pool = ctx.Pool(processes=jobs, initializer=initializer or prepare_worker, initargs=(os.getpid(),))
    pending: collections.deque = collections.deque()

    def first_done():
        while not (stop() or pending[0].ready()):
            pending[0].wait(POLL_SECONDS)
        if stop():
            raise Stopped
        return pending.popleft().get()

    try:
        for chunk in chunks(items, chunksize):
            if stop():
                raise Stopped
            pending.append(pool.apply_async(run_chunk, (chunk, full, out_dir)))
            while len(pending) > 2 * jobs:
                yield from first_done()
            while pending and pending[0].ready():
                yield from first_done()
        while pending:
            yield from first_done()
        pool.close()
    except BaseException:
        pool.terminate()
        raise
    finally:
        pool.join()


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
    """A pool worker's set-up: its stderr goes quiet once the batch process ``parent`` is gone, and the
    optional sixbar synthesis is imported once (bennett and the pose reader come with this module). The
    command line adds its signal policy (cli/signals.py `batch_worker`: ^C ignored, SIGTERM a quiet
    exit, killed with its parent); the library installs no handler."""
    if parent is not None and sys.stderr is not None:
        sys.stderr = _QuietWhenOrphaned(sys.stderr, parent)
    try:
        importlib.import_module("synth.synthesis.sixbar")
    except ImportError:
        pass


def dumps(result: dict) -> str:
    """One result line (never raises: a result JSON cannot carry becomes an internal-error line)."""
    try:
        return json.dumps(result, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as e:
        return json.dumps({"id": None, "line": result.get("line"), "ok": False, "exit_code": 3,
                           "error": _one_line(f"internal error: result not serializable: {e}")},
                          separators=(",", ":"))
