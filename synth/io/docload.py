"""Reading input text: the bounded source reader and the strict YAML / JSON loader shared by the
input files (pose files `synth.io.poses`, curve specs `synth.io.curvespec`).

``read_source(source, text)``: a file, ``-`` (standard input) or given text -> (display name, text),
refusing more than ``MAX_FILE_BYTES`` and text that is not UTF-8. ``load_document(text, name,
force_json)``: JSON (the ``json`` module, when forced or when the text looks like a JSON object) or YAML
through a `yaml.SafeLoader` subclass (`synth.io.yamlload`, imported with the first YAML document) that
rejects duplicate keys, reads ``1e-3`` as a float (YAML 1.2 style), and refuses documents far larger than any input while they are still being parsed (more than
``MAX_POSES`` items in a list, ``MAX_YAML_NODES`` values, merge keys expanding a mapping beyond
``MAX_MERGED_KEYS`` entries). Every problem is a one-line InputError ``<name>: <problem>``.
"""
from __future__ import annotations

import io
import json
import os
import re
import select
import stat
import sys
from typing import IO, Any

from synth.errors import InputError
from synth.io.textlimits import MAX_POSES, clean_text, quote_text  # noqa: F401 (this module's API too)

MAX_FILE_BYTES = 10 * 1024 * 1024


def _looks_like_json(text: str) -> bool:
    return re.match(r"\s*(\{\s*(\"|\})|\[)", text) is not None


def json_object_pairs(pairs):
    """``object_pairs_hook`` for json.loads that rejects duplicate keys (an input error)."""
    out = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"duplicate key {quote_text(k, 40)}")
        out[k] = v
    return out


def load_json(text: str, name: str) -> Any:
    try:
        return json.loads(text, object_pairs_hook=json_object_pairs)
    except json.JSONDecodeError as e:
        raise InputError(
            f"{name}: JSON syntax error at line {e.lineno}, column {e.colno}: {clean_text(e.msg)}"
        ) from None
    except RecursionError:
        raise InputError(f"{name}: JSON is nested too deeply") from None
    except ValueError as e:
        raise InputError(f"{name}: JSON error: {clean_text(' '.join(str(e).split()))}") from None


def load_document(text: str, name: str, force_json: bool) -> Any:
    if force_json:
        return load_json(text, name)
    json_err = None
    if _looks_like_json(text):
        try:
            return load_json(text, name)
        except InputError as e:
            json_err = e
    import yaml  # (~11 ms: only for a YAML document; `mpsynth batch` reads JSON lines)

    from synth.io.yamlload import TooLarge, load_strict, yaml_error_message

    try:
        return load_strict(text)
    except TooLarge as e:
        raise InputError(f"{name}: {e}") from None
    except yaml.YAMLError as e:
        if json_err is not None:
            raise json_err from None
        raise InputError(f"{name}: {yaml_error_message(e)}") from None
    except RecursionError:
        raise InputError(f"{name}: YAML is nested too deeply") from None
    except Exception as e:  # constructor errors on odd scalars (e.g. impossible dates)
        if json_err is not None:
            raise json_err from None
        raise InputError(f"{name}: YAML error: {clean_text(' '.join(str(e).split()))}") from None


MAX_LINE_BYTES = 10 * 1024 * 1024  # one line of a JSON-lines file
_CHUNK = 1 << 16


def _stdin_buffer():
    """The binary standard input; InputError when it is closed."""
    stdin = sys.stdin
    if stdin is None:
        raise InputError("<stdin>: standard input is closed")
    stream = getattr(stdin, "buffer", stdin)
    try:
        if getattr(stream, "closed", False):
            raise ValueError
        if hasattr(stream, "fileno"):
            os.fstat(stream.fileno())
    except io.UnsupportedOperation:  # an in-memory stream (tests)
        pass
    except (OSError, ValueError):
        raise InputError("<stdin>: standard input is closed") from None
    return stream


def open_lines(source) -> tuple[IO[bytes], int | None]:
    """A binary stream over ``source`` (a file, or ``-`` for standard input) for `read_lines`, and the
    number of its lines (None for standard input or anything but a regular file). InputError (one
    line) when it cannot be opened."""
    if source == "-":
        stream = _stdin_buffer()
        _refuse_device(stream, "<stdin>")
        return stream, None
    name = clean_text(os.fspath(source))
    try:
        stream = open(source, "rb")
    except FileNotFoundError:
        raise InputError(f"{name}: cannot read file: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{name}: cannot read file: it is a directory") from None
    except OSError as e:
        raise InputError(f"{name}: cannot read file: {clean_text(e.strerror or str(e))}") from None
    mode = _refuse_device(stream, name)
    total = None
    try:
        if stat.S_ISREG(mode):  # never count a pipe
            with open(source, "rb") as fh:
                n = last = 0
                for block in iter(lambda: fh.read(_CHUNK), b""):
                    n += block.count(b"\n")
                    last = block[-1]
                total = n + (1 if last not in (0, 10) else 0)
    except OSError:
        total = None
    return stream, total


def _refuse_device(stream, name: str) -> int:
    """The st_mode of ``stream``'s file; InputError (the stream closed) when it is a device other than
    a terminal or /dev/null: /dev/zero, /dev/urandom, /dev/full or a disk are endless or binary, never
    job lines (as a path or redirected to standard input). 0 for a stream without a file descriptor."""
    try:
        st = os.fstat(stream.fileno())
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return 0
    if (stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)) and not stream.isatty() and not _is_devnull(st):
        if name != "<stdin>":
            stream.close()
        raise InputError(f"{name}: is a device, not a file of job lines")
    return st.st_mode


def _is_devnull(st) -> bool:
    try:
        null = os.stat(os.devnull)
    except OSError:
        return False
    return (st.st_dev, st.st_ino) == (null.st_dev, null.st_ino) or (
        stat.S_ISCHR(null.st_mode) and st.st_rdev == null.st_rdev)


def read_lines(stream, limit: int = MAX_LINE_BYTES):
    """(1-based line number, text) of every line of the binary ``stream``, split on \\n only (a CR is
    an ordinary character; a final line without \\n counts), decoded as UTF-8 with undecodable bytes
    replaced. A line longer than ``limit`` bytes gives ``(number, None)`` and is skipped while it is
    read, never held in memory."""
    read = getattr(stream, "read1", None) or stream.read
    buf = bytearray()
    lineno = 0
    over = False
    while True:
        chunk = read(_CHUNK)
        if not chunk:
            break
        start = 0
        while True:
            i = chunk.find(b"\n", start)
            piece = chunk[start:] if i < 0 else chunk[start:i]
            if not over:
                buf += piece
                if len(buf) > limit:
                    over, buf = True, bytearray()
            if i < 0:
                break
            lineno += 1
            yield lineno, (None if over else buf.decode("utf-8", "replace"))
            buf, over, start = bytearray(), False, i + 1
    if buf or over:
        yield lineno + 1, (None if over else buf.decode("utf-8", "replace"))


def read_chunks(stream, size: int, max_bytes: int = 1 << 20, idle: float | None = None,
                limit: int = MAX_LINE_BYTES):
    """The lines of the binary ``stream`` as `read_lines` splits them, in chunks ``(number of the first
    line, [line bytes without the newline, or None for a line over limit])`` of at most ``size`` lines
    and about ``max_bytes``. ``idle`` (seconds; for a pipe or a terminal, whose writer may pause): when
    nothing arrives within it, the whole lines read so far come at once as a chunk, and then None
    (nothing new) every ``idle`` seconds while the input stays idle, so that the caller can answer
    what was read and look at its signals. Which lines are read, and their numbers, never depend on
    the timing; only when they come does."""
    fd = _fileno(stream) if idle is not None else None
    read = getattr(stream, "read1", None) or stream.read
    lines: list = []
    first, nbytes = 1, 0
    held, held_len, over = [], 0, False  # the pieces of the line being read (not held once over the limit)
    while True:
        while fd is not None and not _readable(fd, idle):
            if lines:
                yield first, lines
                first, lines, nbytes = first + len(lines), [], 0
            else:
                yield None
        block = read(_CHUNK)
        if not block:
            break
        pieces = block.split(b"\n")
        last = len(pieces) - 1
        k = 0
        while k < last:
            if not held and not over:  # whole lines, none over the limit, that fit the chunk: at once
                run = pieces[k : min(last, k + size - len(lines))]
                lengths = list(map(len, run))
                total = nbytes + sum(lengths) + len(run)
                if max(lengths) <= limit and total < max_bytes:
                    lines += run
                    nbytes, k = total, k + len(run)
                    if len(lines) >= size:
                        yield first, lines
                        first, lines, nbytes = first + len(lines), [], 0
                    continue
            piece = pieces[k]  # a line's last piece, one at a time
            if not over:
                held_len += len(piece)
                if held_len > limit:
                    over, held = True, []
                else:
                    held.append(piece)
            lines.append(None if over else held[0] if len(held) == 1 else b"".join(held))
            nbytes += held_len + 1
            held, held_len, over = [], 0, False
            k += 1
            if len(lines) >= size or nbytes >= max_bytes:
                yield first, lines
                first, lines, nbytes = first + len(lines), [], 0
        if not over:  # the start of the next line
            held_len += len(pieces[last])
            if held_len > limit:
                over, held = True, []
            else:
                held.append(pieces[last])
    if over or held_len:
        lines.append(None if over else b"".join(held))
    if lines:
        yield first, lines


def _fileno(stream) -> int | None:
    """The file descriptor of ``stream``, None for an in-memory stream (never idle)."""
    try:
        return stream.fileno()
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return None


def _readable(fd: int, timeout: float) -> bool:
    """Whether ``fd`` has input (or its end) within ``timeout`` seconds (a signal handler that raises
    interrupts the wait)."""
    poller = select.poll()
    poller.register(fd, select.POLLIN | select.POLLHUP | select.POLLERR)
    return bool(poller.poll(timeout * 1000.0))


def read_source(source, text: str | None) -> tuple[str, str]:
    """(display name, text)."""
    if source is None:
        source = "-"
    raw_name = os.fspath(source)
    name = "<stdin>" if raw_name == "-" else clean_text(raw_name)
    if text is not None:
        if isinstance(text, bytes):
            data = text
        else:
            if len(text) > MAX_FILE_BYTES:
                raise InputError(f"{name}: file is larger than 10 MB; refusing to read it")
            data = text.encode("utf-8", "surrogatepass")
    elif raw_name == "-":
        stream = _stdin_buffer()
        try:
            data = stream.read(MAX_FILE_BYTES + 1)
        except OSError as e:
            raise InputError(f"{name}: cannot read standard input: {clean_text(e.strerror or str(e))}") from None
        if isinstance(data, str):
            data = data.encode("utf-8", "surrogatepass")
    else:
        try:
            st = os.stat(raw_name)
            if st.st_size > MAX_FILE_BYTES:
                raise InputError(
                    f"{name}: file is {st.st_size / 1e6:.1f} MB, larger than the 10 MB limit; refusing to read it"
                )
            with open(raw_name, "rb") as f:
                data = f.read(MAX_FILE_BYTES + 1)
        except InputError:
            raise
        except FileNotFoundError:
            raise InputError(f"{name}: cannot read file: no such file") from None
        except IsADirectoryError:
            raise InputError(f"{name}: cannot read file: it is a directory") from None
        except PermissionError:
            raise InputError(f"{name}: cannot read file: permission denied") from None
        except (OSError, ValueError) as e:
            msg = getattr(e, "strerror", None) or str(e)
            raise InputError(f"{name}: cannot read file: {clean_text(msg)}") from None
    if len(data) > MAX_FILE_BYTES:
        raise InputError(f"{name}: file is larger than 10 MB; refusing to read it")
    try:
        decoded = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"{name}: not UTF-8 text (bad byte at offset {e.start})") from None
    return name, decoded
