"""The job lines of `mpsynth batch` (the format: `synth.tools.batchjobs`): parsing and checking one job,
its ``id`` as a result echoes it, and its ``out`` directory resolved and prepared. A bad job is a
`JobError` with the exit code of the CLI contract (2 bad input)."""
from __future__ import annotations

import difflib
import itertools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

try:  # optional (mpsynth[fast]): the common job lines read ~2x faster (`_canonical`)
    import orjson as _orjson
except ImportError:
    _orjson = None

from synth.errors import InputError, MpsynthError
from synth.io.docload import json_object_pairs
from synth.io.names import check_robot_name
from synth.io.posespec import ANGLE_UNITS, LENGTH_UNITS, MAX_ABS_NUMBER, rpy_poses

KINDS = {"bennett": 3, "sixbar": 4, "fourbar": (2, None)}  # pose counts (fourbar: its own refusals below 3)
DEGREES = {"bennett": 2, "sixbar": 3}  # degree of the motion of a point task
SIZE_KEYS = ("pin_radius", "link_radius", "pin_length")
TASK_KEYS = ("tolerance", "order", "constraints")  # a task file's keys (docs/fit.md), as in a pose file
JOB_KEYS = ("id", "kind", "poses", "points", "units", "quaternion_order", "out", "name", "normalize", "force", *SIZE_KEYS,
            "best_effort") + TASK_KEYS
MAX_LINE = 10 * 1024 * 1024


class JobError(Exception):
    """A job that cannot run, with the exit code of its result line (2 bad input, 1 no linkage)."""

    def __init__(self, message: str, exit_code: int = 2):
        super().__init__(message)
        self.exit_code = exit_code


def one_line_message(msg: str, limit: int = 2000) -> str:
    """``msg`` on one line (whitespace runs made one space), at most ``limit`` characters."""
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
    """The job object of one line (None: a line over the limit); JobError (exit code 2) when it is
    not a valid job."""
    if text is None or len(text) > MAX_LINE:
        raise JobError("line is longer than 10 MB")
    try:
        job = json.loads(text, object_pairs_hook=json_object_pairs, parse_constant=_reject_constant,
                         parse_float=_parse_float)
    except json.JSONDecodeError as e:
        raise JobError(f"invalid JSON at column {e.colno}: {e.msg}") from None
    except (ValueError, RecursionError) as e:
        raise JobError(f"invalid JSON: {e}") from None
    if not isinstance(job, dict):
        raise JobError(f"a job must be a JSON object, got {type(job).__name__}")
    return job


def check_job(job: dict) -> None:
    unknown = [k for k in job if k not in JOB_KEYS]
    if unknown:
        k = unknown[0]
        close = difflib.get_close_matches(k, JOB_KEYS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else f" (allowed: {', '.join(JOB_KEYS)})"
        raise JobError(f"unknown key {k!r}{hint}")
    if "kind" not in job:
        raise JobError(f"missing 'kind' ({' or '.join(repr(k) for k in KINDS)})")
    if job["kind"] not in KINDS:
        raise JobError(f"unknown kind {job['kind']!r} (allowed: {', '.join(KINDS)})")
    if "poses" not in job and "points" not in job:
        raise JobError("missing 'poses' (a list of pose specs as in a pose file) or 'points'")
    jid = job.get("id")
    if jid is not None and not isinstance(jid, (str, int, float)) or isinstance(jid, bool):
        raise JobError("'id' must be a string or a number")
    for key in ("out", "name"):
        if key in job and not (isinstance(job[key], str) and job[key].strip()) or isinstance(job.get(key), RawNumber):
            raise JobError(f"{key!r} must be a non-empty string")
    if "name" in job:
        try:
            check_robot_name(job["name"], "'name'")
        except MpsynthError as e:
            raise JobError(str(e)) from None
    for key in ("normalize", "force"):
        if key in job and not isinstance(job[key], bool):
            raise JobError(f"{key!r} must be true or false")
    for key in SIZE_KEYS:  # their values: `synth.solve.DesignOptions.sizes`, as the CLI's
        if key in job:
            v = job[key]
            if isinstance(v, (bool, RawNumber)) or not isinstance(v, (int, float)):
                raise JobError(f"{key!r} must be a positive length in the job's unit")


def is_task_job(job: dict) -> bool:
    """A job with a task file's keys (top-level tolerance or order, per-pose tolerance, exact or velocity)."""
    if any(k in job for k in ("tolerance", "order")):
        return True
    items = [p for k in ("poses", "points") for p in (job.get(k) if isinstance(job.get(k), list) else [])]
    return any(isinstance(p, dict) and any(k in p for k in ("tolerance", "exact", "velocity")) for p in items)


def echo_id(jid):
    """The job id as it can go into a result line (see the module docstring)."""
    if isinstance(jid, RawNumber):
        return str(jid)
    if isinstance(jid, bool) or not isinstance(jid, (str, int, float)):
        return None
    return jid


def resolve_out(out: str, out_dir) -> str:
    """``out`` resolved under the base directory; JobError when it is absolute or leaves it."""
    from synth.io.atomic import check_path  # (a job with OUT: the writers are imported at the first)

    base = os.path.abspath(os.fspath(out_dir) if out_dir is not None else os.curdir)
    try:
        check_path(out, "'out'")
    except InputError as e:
        raise JobError(str(e)) from None
    if "\x00" in out or os.path.isabs(out) or out.startswith("~"):
        raise JobError(f"'out' {out!r}: must be a relative path under the output base directory {base}")
    path = os.path.normpath(os.path.join(base, out))
    real_base, real = os.path.realpath(base), os.path.realpath(path)
    if not real.startswith(real_base.rstrip(os.sep) + os.sep):
        raise JobError(f"'out' {out!r}: leaves the output base directory {base} (or is it); "
                        "name a directory below it")
    return path


def prepare_out(out: str, force: bool, created: list) -> None:
    """Create OUT's missing parent directories and refuse an unusable OUT before any work. A job never
    replaces a file (the jobs or the results file, say), not even with "force"."""
    from synth.io.writer import check_output_target

    if os.path.lexists(out) and (os.path.islink(out) or not os.path.isdir(out)):
        raise JobError(f"'out' {out}: exists and is not a directory; a batch job never replaces a file")
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
        raise JobError(f"{parent}: cannot create the output's parent directory ({e.strerror or e})") from None
    check_output_target(out, force=force)


# ------------------------------------------------------------------ the common Bennett job, a chunk at once
COMMON_KEYS = frozenset(("id", "kind", "units", "poses"))
UNIT_KEYS = frozenset(("length", "angle"))
_NUMBER_TYPES = frozenset((float, int))


@dataclass
class CommonBennett:
    """The lines of a chunk `read_common_bennett` has read: their positions in the chunk (``index``), their
    ids as a result echoes them and their poses (n, 3, 4, 4) in metres."""

    index: list
    ids: list
    poses: np.ndarray


def read_common_bennett(texts) -> CommonBennett:
    """The job lines among ``texts`` (str, or None for a line over the limit) of the common shape ``{"id",
    "kind": "bennett", "units": {"length", ["angle"]}, "poses": [3 x {"position", "rpy"}]}`` (any key order,
    no other key) that the full reader (`parse_job`, `check_job`, `synth.io.poses.parse_pose_document`)
    accepts, with the pose matrices it gives, bit for bit: parsed by orjson where the text is its own
    (`_canonical`), else by the json module's C scanner without hooks (the same numbers), refused here (left
    to the full reader, which says what is wrong) when a line has a backslash, a duplicate key (the colons
    outside strings must equal the keys parsed), a number
    that is not finite or is beyond the limits (with a margin: `synth.io.posespec.rpy_poses`), or any
    other shape. Every other line is the full reader's."""
    rows = [(n, _common_bennett(t)) for n, t in enumerate(texts)]
    rows = [(n, r) for n, r in rows if r is not None]
    out = CommonBennett([], [], np.empty((0, 3, 4, 4)))
    parts = []
    for unit in ("deg", "rad", None):
        group = [(n, r) for n, r in rows if r[3] == unit]
        if not group:
            continue
        ok, T = rpy_poses([r[1] for _, r in group], [r[2] for _, r in group], unit)
        keep = np.flatnonzero(ok).tolist()
        out.index += [group[k][0] for k in keep]
        out.ids += [group[k][1][0] for k in keep]
        parts.append(T[ok])
    if parts:
        order = np.argsort(out.index, kind="stable")
        out.index = [out.index[k] for k in order]
        out.ids = [out.ids[k] for k in order]
        out.poses = np.concatenate(parts)[order]
    return out


def _canonical(text: str):
    """The JSON value of ``text`` by orjson (installed: ``mpsynth[fast]``; ~2x faster than the json module)
    when the text is exactly what orjson writes for that value but for spaces, else None. Such text has no
    duplicate key, and each of its numbers is the shortest text of the float orjson read, which the json
    module's ``float()`` reads as the same float (README's generator, ``json.dumps``, writes such lines)."""
    if _orjson is None:
        return None
    try:
        value = _orjson.loads(text)
    except (ValueError, RecursionError):
        return None
    try:
        same = _orjson.dumps(value) == text.replace(" ", "").encode()
    except (TypeError, UnicodeEncodeError):
        return None
    return value if same else None


def _common_bennett(text):
    """(id, numbers (3, 6), metres per length unit, angle unit or None) of one line of the common shape
    (`read_common_bennett`), else None."""
    if text is None or "\\" in text or len(text) > MAX_LINE:
        return None
    job = _canonical(text)
    checked = job is not None  # (no duplicate key: `_canonical`)
    if not checked:
        try:
            job = json.loads(text)
        except (ValueError, RecursionError):
            return None
    if type(job) is not dict or job.get("kind") != "bennett" or not job.keys() <= COMMON_KEYS:
        return None
    units, poses, jid = job.get("units"), job.get("poses"), job.get("id")
    if type(units) is not dict or not units.keys() <= UNIT_KEYS or type(poses) is not list or len(poses) != 3:
        return None
    length, angle = units.get("length"), units.get("angle")
    if type(length) is not str or length not in LENGTH_UNITS or (
            "angle" in units and (type(angle) is not str or angle not in ANGLE_UNITS)):
        return None
    if jid is not None and type(jid) not in (str, int, float):
        return None
    numbers = []
    for p in poses:
        if type(p) is not dict or len(p) != 2:
            return None
        position, rpy = p.get("position"), p.get("rpy")
        if type(position) is not list or type(rpy) is not list or len(position) != 3 or len(rpy) != 3:
            return None
        numbers.append(position + rpy)
    kinds = set(map(type, itertools.chain.from_iterable(numbers)))  # (floats: the usual line, checked in C)
    if not kinds <= _NUMBER_TYPES or int in kinds and not all(
            type(x) is float or -MAX_ABS_NUMBER <= x <= MAX_ABS_NUMBER for row in numbers for x in row):
        return None
    if type(jid) is float and not math.isfinite(jid):
        return None
    if not checked and "".join(text.split('"')[::2]).count(":") != len(job) + len(units) + 6:  # a duplicate key
        return None
    return jid, numbers, LENGTH_UNITS[length], angle
