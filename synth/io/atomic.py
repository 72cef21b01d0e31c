"""Atomic outputs: a whole directory or a single file appears complete or not at all.

``atomic_directory(OUT)`` yields a fresh temporary sibling directory ``.OUT.mpsynth-tmp-PID-XXXX`` (same
parent: no rename crosses file systems). On a clean exit it writes the manifest ``.mpsynth-output`` (JSON:
``format`` "mpsynth.output/2", ``files``: the relative paths mpsynth wrote) into it and replaces OUT *as a
whole*: the files of an existing OUT that its manifest does not list (notes, a CAD folder, simulate's
linkage.mjcf.xml) are first hard-linked (or copied) into the new directory, which then swaps places with
OUT in one ``renameat2(RENAME_EXCHANGE)``; the old directory is removed afterwards. A SIGKILL at any
moment therefore leaves the old OUT or the new one, never a mix (on file systems without the exchange:
two renames, and a run that finds OUT missing beside a dead writer's ``-old-`` directory puts it back).

Ownership: only the manifest proves that a directory is mpsynth's (a ``linkage.json`` with an
``mpsynth.*`` format is not enough). A non-empty directory without it, a file this run would write over
that the manifest does not list, or a non-directory OUT (a file, a symlink) needs ``force``; a special
file (device, socket, pipe) is never replaced. The working directory (or one containing it) and mount
points cannot be swapped and are refused. Problems with OUT are `InputError`; a failure to write (disk
full) an `OutputError`, with nothing partial left.

``atomic_write(path, write)``: one file, written beside and renamed over ``path``, which must be absent
or a regular file (never a device, a directory, a symlink); mode 0666 less the umask.

Signals: the writers use the guard of `synth.io.interrupts` (the CLI's: SIGINT/SIGTERM become exceptions
inside, deferred during the swap); without one, Python's own behaviour applies.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import errno
import json
import os
import shutil
import stat
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from synth.errors import InputError, OutputError
from synth.io import interrupts

MARKER = ".mpsynth-output"  # the manifest: which files of OUT mpsynth wrote
MANIFEST_FORMAT = "mpsynth.output/2"
STALE_AGE = 24 * 3600.0  # seconds after which a temporary directory of any writer counts as abandoned
NAME_MAX = 255  # bytes of one path component
_TMP_STEM = 100  # characters of OUT's name kept in its temporaries' names (NAME_MAX for those too)


def check_path(path, what: str = "") -> Path:
    """``path`` as an absolute Path; InputError for an empty path, a name that cannot be encoded (a lone
    surrogate) or a component longer than NAME_MAX bytes."""
    text = os.fspath(path)
    label = f"{what} " if what else ""
    if text == "":
        raise InputError(f"{label}'': an empty path; name a file or directory")
    try:
        raw = os.fsencode(text)
    except UnicodeError:
        raise InputError(f"{label}{ascii(text)[1:-1]}: not a valid file name (undecodable characters)") from None
    if b"\x00" in raw:
        raise InputError(f"{label}{ascii(text)[1:-1]}: not a valid file name (a NUL byte)")
    for part in raw.split(b"/"):
        if len(part) > NAME_MAX:
            raise InputError(f"{label}{ascii(text)[1:61]}...: a path component is {len(part)} bytes, "
                             f"longer than the {NAME_MAX} a file name may have")
    return Path(os.path.abspath(text))


def _read_json(path: Path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.loads(fh.read(1 << 20))
    except (OSError, ValueError, RecursionError):
        return None


def _safe_rel(name) -> str | None:
    """``name`` as a clean relative POSIX path inside OUT, or None (absolute, '..', odd)."""
    if not isinstance(name, str) or not name or "\x00" in name or name.startswith("/"):
        return None
    parts = name.split("/")
    if any(p in ("", ".", "..") for p in parts):
        return None
    return name


def owned_files(path) -> set[str] | None:
    """The relative paths mpsynth wrote into directory ``path`` (its manifest), or None when ``path``
    carries no manifest (then nothing in it is mpsynth's)."""
    doc = _read_json(Path(path) / MARKER)
    if isinstance(doc, dict) and str(doc.get("format", "")).startswith("mpsynth.output/") \
            and isinstance(doc.get("files"), list):
        return {r for r in map(_safe_rel, doc["files"]) if r} | {MARKER}
    return None


def is_mpsynth_output(path) -> bool:
    """True when directory ``path`` carries mpsynth's manifest."""
    return owned_files(path) is not None


def _tree_files(root: Path) -> tuple[list[str], list[str]]:
    """(files, directories) under ``root``, relative POSIX paths, directories parents first; symlinks
    (to directories too) count as files."""
    files, dirs = [], []
    for dirpath, dirnames, filenames in os.walk(root):
        rel = os.path.relpath(dirpath, root)
        pre = "" if rel == "." else rel.replace(os.sep, "/") + "/"
        links = [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]
        dirnames[:] = sorted(d for d in dirnames if d not in links)
        dirs += [pre + d for d in dirnames]
        files += [pre + f for f in sorted(filenames + links)]
    return files, dirs


def _conflicts(out: Path, new_files: list[str], new_dirs: list[str], owned: set[str] | None,
               force: bool) -> str | None:
    """Why the new files cannot replace those of the existing directory OUT, or None."""
    for d in new_dirs:
        p = out / d
        if os.path.lexists(p) and (p.is_symlink() or not p.is_dir()) and not force:
            return f"{p}: exists and is not a directory; refusing to replace it without --force"
    for f in new_files:
        p = out / f
        if not os.path.lexists(p):
            continue
        if p.is_dir() and not p.is_symlink():
            return f"{p}: is a directory; refusing to replace it"
        if not force and (owned is None or f not in owned):
            return f"{p}: exists and was not written by mpsynth; refusing to replace it without --force"
    return None


def _swappable(out: Path) -> None:
    """InputError when the existing directory OUT cannot be replaced as a whole."""
    cwd = os.path.realpath(os.getcwd()) if os.path.exists(".") else ""
    real = os.path.realpath(out)
    if cwd == real or cwd.startswith(real.rstrip("/") + "/"):
        raise InputError(f"{out}: is the working directory (or contains it) and cannot be replaced as a whole; "
                         "write the output into a subdirectory")
    if os.path.ismount(out):
        raise InputError(f"{out}: is a mount point and cannot be replaced as a whole; "
                         "write the output into a subdirectory")


def _check_target(out: Path, force: bool, new: tuple[list[str], list[str]] | None = None) -> None:
    parent = out.parent
    if not parent.exists():
        raise InputError(f"{parent}: output parent directory does not exist")
    if not parent.is_dir():
        raise InputError(f"{parent}: output parent is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{parent}: output parent directory is not writable")
    if not os.path.lexists(out):
        return
    if out.is_symlink() or not out.is_dir():
        if not (out.is_symlink() or stat.S_ISREG(os.lstat(out).st_mode)):
            raise InputError(f"{out}: exists and is a special file (a device, a socket, a pipe); "
                             "refusing to replace it")
        if force:
            return
        raise InputError(f"{out}: exists and is not a directory written by mpsynth; "
                         "refusing to replace it without --force")
    _swappable(out)
    try:
        empty = not any(out.iterdir())
    except OSError as e:
        raise InputError(f"{out}: cannot read the existing output directory ({e.strerror})") from None
    owned = None if empty else owned_files(out)
    if not empty and owned is None and not force:
        raise InputError(f"{out}: directory is not empty and was not written by mpsynth (no {MARKER} "
                         "manifest); refusing to write into it without --force")
    if new is not None:
        why = _conflicts(out, new[0], new[1], owned, force)
        if why:
            raise InputError(why)


def write_manifest(directory: Path, files) -> None:
    """``directory``/.mpsynth-output listing ``files`` (relative paths)."""
    doc = {"format": MANIFEST_FORMAT,
           "note": "written by mpsynth; a new run into this directory replaces the files listed here "
                   "and keeps every other file",
           "files": sorted(set(files) - {MARKER})}
    (directory / MARKER).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")


def _carry_over(out: Path, tmp: Path, owned: set[str]) -> None:
    """Hard-link (or copy) into ``tmp`` every entry of ``out`` mpsynth did not write and this run does
    not replace; the old OUT is left as it is until the swap."""
    files, dirs = _tree_files(out)
    for d in dirs:
        if not any((out / d).iterdir()):  # an empty directory of the user's
            (tmp / d).mkdir(parents=True, exist_ok=True)
    for f in files:
        if f in owned or os.path.lexists(tmp / f):
            continue
        src, dst = out / f, tmp / f
        dst.parent.mkdir(parents=True, exist_ok=True)
        if os.path.islink(src):
            os.symlink(os.readlink(src), dst)
            continue
        try:
            os.link(src, dst, follow_symlinks=False)
        except OSError:
            shutil.copy2(src, dst, follow_symlinks=False)


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _libc():
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
    except OSError:  # pragma: no cover
        return None


_LIBC = _libc()


def exchange(a: Path, b: Path) -> bool:
    """Swap the two existing paths ``a`` and ``b`` atomically (Linux renameat2 RENAME_EXCHANGE). False
    when the system or file system cannot; OSError for other failures."""
    fn = getattr(_LIBC, "renameat2", None)
    if fn is None:
        return False
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), os.fspath(a))


def _aside(out: Path, kind: str) -> Path:
    return Path(tempfile.mkdtemp(prefix=f"{_stem(out)}.mpsynth-{kind}-{os.getpid()}-", dir=out.parent))


def _stem(out: Path) -> str:
    return "." + out.name[:_TMP_STEM]


def _commit(tmp: Path, out: Path) -> None:
    """Make the finished ``tmp`` (manifest included) OUT; see the module docstring."""
    try:
        if not os.path.lexists(out):
            os.rename(tmp, out)
            return
        if out.is_dir() and not out.is_symlink():
            _carry_over(out, tmp, owned_files(out) or {MARKER})
            os.chmod(tmp, stat.S_IMODE(os.stat(out).st_mode))
        if exchange(tmp, out):
            _remove(tmp)  # the old OUT now
            return
        old = _aside(out, "old")
        os.rename(out, old / "old")
        try:
            os.rename(tmp, out)
        except OSError:
            os.rename(old / "old", out)
            raise
        _remove(old)
    except OSError as e:
        raise OutputError(f"{out}: cannot move the finished output into place ({e.strerror or e})") from None


def _remove(path: Path) -> None:
    """Remove a directory tree or a file; never raises."""
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            os.unlink(path)
        except OSError:
            pass


def remove_stale_temporaries(out) -> list[Path]:
    """Remove ``.OUT.mpsynth-tmp-*`` / ``.OUT.mpsynth-old-*`` directories beside ``out`` left by writers
    that were killed (their pid, in the name, no longer runs, or older than STALE_AGE); an ``-old-``
    directory of a writer killed between its two renames becomes OUT again when OUT is missing. Returns
    what was removed; never raises."""
    out = Path(out)
    removed = []
    try:
        entries = sorted(os.scandir(out.parent), key=lambda e: e.name)
    except OSError:
        return removed
    prefixes = (f"{_stem(out)}.mpsynth-tmp-", f"{_stem(out)}.mpsynth-old-")
    now = time.time()
    for e in entries:
        if not e.name.startswith(prefixes):
            continue
        try:
            st = e.stat(follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or (hasattr(os, "getuid") and st.st_uid != os.getuid()):
            continue
        pid = e.name[len(prefixes[0]):].split("-", 1)[0]
        dead = pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid))
        if dead or now - st.st_mtime > STALE_AGE:
            if e.name.startswith(prefixes[1]) and not os.path.lexists(out) and os.path.isdir(Path(e.path) / "old"):
                try:
                    os.rename(Path(e.path) / "old", out)
                except OSError:
                    pass
            shutil.rmtree(e.path, ignore_errors=True)
            removed.append(Path(e.path))
    return removed


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def check_output_target(out_dir, force: bool = False) -> Path:
    """Raise InputError now if ``out_dir`` could not be written (an empty or invalid name, a missing or
    unwritable parent, a foreign non-empty directory without ``force``, the working directory); returns
    its absolute path. Lets a command refuse a bad OUT before doing any work; `atomic_directory` checks
    again."""
    out = check_path(out_dir)
    if out.parent == out:
        raise InputError(f"{out}: cannot write the output to a file system root")
    _check_target(out, force)
    return out


@contextmanager
def atomic_directory(out_dir, force: bool = False):
    """Context manager: yields a temporary directory (Path) that becomes ``out_dir`` on a clean exit
    and vanishes on an exception or signal. See the module docstring."""
    out = check_output_target(out_dir, force)
    remove_stale_temporaries(out)
    guard = interrupts.guard()
    tmp = None
    guard.install()
    try:
        guard.defer = True  # a signal between mkdtemp and the assignment would leak the directory
        try:
            tmp = _aside(out, "tmp")
        except OSError as e:
            raise InputError(f"{out.parent}: cannot create the output directory there ({e.strerror})") from None
        guard.defer = False
        if guard.pending:  # arrived during mkdtemp: act on it now that the directory is known
            guard.act(guard.pending)
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it 0700; OUT should look like a mkdir'ed dir
        try:
            yield tmp
        except OSError as e:  # disk full, quota, I/O error while writing: the user's environment
            raise OutputError(f"{out}: cannot write the output ({e.strerror or e})") from None
        guard.defer = True
        if guard.raised:  # the exception was swallowed (e.g. trimesh's optional imports catch BaseException)
            guard.act(guard.raised)
        new = _tree_files(tmp)
        try:
            write_manifest(tmp, new[0])
        except OSError as e:
            raise OutputError(f"{out}: cannot write the output ({e.strerror or e})") from None
        _check_target(out, force, new)  # again, with the file list: OUT may have changed meanwhile
        _commit(tmp, out)
    except BaseException as e:
        guard.defer = True
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        if guard.raised and not isinstance(e, (KeyboardInterrupt, SystemExit)):
            # the signal was swallowed (trimesh's optional imports catch BaseException) and this error is
            # only its side effect (e.g. a module replaced by an exception wrapper): report the signal
            guard.restore()
            guard.act(guard.raised)
        raise
    finally:
        pending = guard.restore()
    if pending:
        guard.act(pending)


def check_file_target(path, what: str = "") -> Path:
    """``path`` (absolute) if a single output file may be written there: its directory exists and it is
    absent or a regular file; InputError otherwise (a device such as /dev/full, a directory, a symlink,
    a pipe are never replaced)."""
    label = f"{what} " if what else ""
    p = check_path(path, what)
    if not p.parent.is_dir():
        raise InputError(f"{label}{p}: its directory {p.parent} does not exist")
    try:
        st = os.lstat(p)
    except FileNotFoundError:
        return p
    except OSError as e:
        raise InputError(f"{label}{p}: cannot write there ({e.strerror or e})") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{label}{p}: is a directory; name a file")
    if not stat.S_ISREG(st.st_mode):
        kind = "a symbolic link" if stat.S_ISLNK(st.st_mode) else "a special file (a device, a socket, a pipe)"
        raise InputError(f"{label}{p}: exists and is {kind}; refusing to replace it")
    return p


def commit_file(tmp, path: Path) -> None:
    """Give the finished temporary file ``tmp`` the mode a new file gets (0666 less the umask) and rename
    it over ``path`` (checked again: it must still be absent or a regular file)."""
    os.chmod(tmp, 0o666 & ~_umask())
    check_file_target(path)
    os.replace(tmp, path)


def atomic_write(path, write, what: str = "") -> None:
    """Write one file atomically: ``write(tmp)`` fills a temporary sibling of ``path``, which then
    replaces ``path`` (see `check_file_target`, `commit_file`); on any failure the temporary file is
    removed and nothing is left."""
    path = check_file_target(path, what)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name[:_TMP_STEM]}.", suffix=".tmp", dir=path.parent)
        os.close(fd)
    except OSError as e:
        raise OutputError(f"{path}: cannot write the file ({e.strerror or e})") from None
    try:
        write(tmp)
        commit_file(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):
            raise OutputError(f"{path}: cannot write the file ({e.strerror or e})") from None
        raise
