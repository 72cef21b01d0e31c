"""Result lines of `mpsynth batch` (`synth.tools.batchjobs`): the bytes of ``json.dumps(result,
separators=(",", ":"))``, written by orjson when installed (``mpsynth[fast]``) wherever its text is
provably the same, one result at a time (`dumps`) or a chunk's at once (`dumps_lines`)."""
from __future__ import annotations

import json
import math
import re

try:  # optional (mpsynth[fast]): result lines ~50x faster, the same bytes (`dumps`)
    import orjson as _orjson
except ImportError:
    _orjson = None

from synth.tools.jobspec import one_line_message


def dumps(result: dict) -> str:
    """One result line (never raises: a result JSON cannot carry becomes an internal-error line): the
    bytes of ``json.dumps(result, separators=(",", ":"))``, by orjson when installed (``mpsynth[fast]``;
    ~50x faster) wherever its text is provably the same (`_orjson_line`)."""
    fast = _orjson_line(result)
    if fast is not None:
        return fast
    try:
        return json.dumps(result, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as e:
        return json.dumps({"id": None, "line": result.get("line"), "ok": False, "exit_code": 3,
                           "error": one_line_message(f"internal error: result not serializable: {e}")},
                          separators=(",", ":"))


# where orjson's text can differ from json.dumps': a non-ASCII byte or DEL (json escapes them), a float below 1e-4
# (orjson: 0.00001, json: 1e-05) or with a one-digit negative exponent (orjson: 1.5e-7, json: 1.5e-07)
_SHORT_EXPONENT = re.compile(rb"e-\d(?!\d)")


def _orjson_differs(out: bytes) -> bool:
    """Whether orjson's text ``out`` may differ from json.dumps' (see above; plain substring tests
    first: one regex with the three alternatives took 26 µs a result line)."""
    return (not out.isascii() or b"\x7f" in out or b"0.0000" in out
            or (b"e-" in out and _SHORT_EXPONENT.search(out) is not None))


def _orjson_bytes(result: dict) -> bytes | None:
    """``result`` as orjson writes it, unchecked, or None (no orjson, a non-finite float at the top level
    (orjson writes null; json refuses it: nested values went through `synth.io.jsonout.plain`, which
    makes them null), a type or an integer orjson refuses)."""
    if _orjson is None or any(type(v) is float and not math.isfinite(v) for v in result.values()):
        return None
    try:
        return _orjson.dumps(result)
    except TypeError:
        return None


def _orjson_line(result: dict) -> str | None:
    """``result`` as orjson writes it when that is json.dumps' text, else None (`_orjson_bytes`, or text
    `_orjson_differs` flags)."""
    out = _orjson_bytes(result)
    return None if out is None or _orjson_differs(out) else out.decode("ascii")


def float_texts(values: list) -> list[str]:
    """The JSON texts of finite floats as ``json.dumps`` writes them (``float.__repr__``): by orjson for the
    whole list at once where its text is provably the same (`_orjson_differs`), else one by one."""
    if _orjson is not None and values:
        out = _orjson.dumps(values)
        if not _orjson_differs(out):
            return out[1:-1].decode("ascii").split(",")
    return [float.__repr__(x) for x in values]


def dumps_lines(results) -> str:
    """The result lines of ``results``, each ending in a newline: ``"".join(dumps(r) + "\n" ...)``, checked
    as one text when orjson wrote them all."""
    fast = [_orjson_bytes(r) for r in results]
    if fast and None not in fast:
        fast.append(b"")
        text = b"\n".join(fast)
        if not _orjson_differs(text):
            return text.decode("ascii")
    return "".join(dumps(r) + "\n" for r in results)
