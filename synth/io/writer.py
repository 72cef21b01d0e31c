"""Write a linkage's output directory (docs/conventions.md) atomically.

``atomic_directory(OUT)`` yields a fresh temporary sibling directory ``.OUT.mpsynth-tmp-PID-XXXX`` (same
parent, so the final renames cannot cross file systems). On a clean exit it writes the manifest
``.mpsynth-output`` (JSON: ``format`` "mpsynth.output/2" and ``files``, the relative paths mpsynth wrote)
into it and renames it to OUT. An existing OUT *directory* is never removed: the new files are moved
into it one by one (each ``os.replace`` atomic), the files the previous run listed in its manifest and
this run did not write are deleted, and everything else in OUT (notes, a CAD folder, the
linkage.mjcf.xml of ``simulate --export-mjcf``) is kept. A non-directory OUT (a file, a symlink) is
replaced only with ``force``. On any exception, and on
SIGINT/SIGTERM while inside (handlers are installed only for that time, main thread only), the
temporary directory is removed and the exception propagates: SIGINT as KeyboardInterrupt (exit
status 130 when uncaught), SIGTERM as SystemExit(143). Signals arriving during the final renames
or the clean-up are deferred until those are done. Should the exception be swallowed by the code
inside (some libraries wrap failed optional imports, KeyboardInterrupt included), it is raised again
before the commit: a signal received while writing always means no new OUT.

Writing into an existing non-empty OUT needs it to be mpsynth's (the manifest, or for outputs of
earlier versions a ``linkage.json`` / ``index.json`` whose ``format`` starts with "mpsynth.") or
``force``; a file this run would write over that mpsynth did not write is refused without ``force``
too. Anything else is an `InputError`, as is a missing or unwritable parent directory; a failure to
write (disk full, I/O error) is an `OutputError` with nothing partial left. Temporary directories of
earlier runs killed while writing (their writer's pid is gone, or older than a day) are removed.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import stat
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from synth.errors import InputError, OutputError
from synth.io.export import export
from synth.io.jsonout import write_json
from synth.io.names import check_package, check_robot_name

MARKER = ".mpsynth-output"  # the manifest: which files of OUT mpsynth wrote
MANIFEST_FORMAT = "mpsynth.output/2"
STALE_AGE = 24 * 3600.0  # seconds after which a temporary directory of any writer counts as abandoned
_LEGACY_FILES = ("linkage.urdf", "linkage.json", "index.json", MARKER)


def _read_json(path: Path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.loads(fh.read(1 << 20))
    except (OSError, ValueError):
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
    """The relative paths mpsynth wrote into directory ``path`` (its manifest; for outputs of earlier
    versions without one, the standard file names and meshes/*.stl), or None when ``path`` is not
    mpsynth's."""
    path = Path(path)
    doc = _read_json(path / MARKER)
    if isinstance(doc, dict) and isinstance(doc.get("files"), list):
        return {r for r in map(_safe_rel, doc["files"]) if r} | {MARKER}
    legacy = isinstance(doc, dict) and str(doc.get("format", "")).startswith("mpsynth.")
    for name in ("linkage.json", "index.json"):
        d = _read_json(path / name)
        if isinstance(d, dict) and str(d.get("format", "")).startswith("mpsynth."):
            legacy = True
    if not legacy:
        return None
    files = set(_LEGACY_FILES)
    try:
        files |= {f"meshes/{p.name}" for p in (path / "meshes").glob("*.stl")}
    except OSError:
        pass
    return files


def is_mpsynth_output(path) -> bool:
    """True when directory ``path`` carries mpsynth's manifest or an mpsynth JSON document."""
    return owned_files(path) is not None


def _tree_files(root: Path) -> tuple[list[str], list[str]]:
    """(files, directories) under ``root``, relative POSIX paths, directories parents first."""
    files, dirs = [], []
    for dirpath, dirnames, filenames in os.walk(root):
        rel = os.path.relpath(dirpath, root)
        pre = "" if rel == "." else rel.replace(os.sep, "/") + "/"
        dirs += [pre + d for d in sorted(dirnames) if not os.path.islink(os.path.join(dirpath, d))]
        files += [pre + f for f in sorted(filenames)]
        files += [pre + d for d in sorted(dirnames) if os.path.islink(os.path.join(dirpath, d))]
    return files, dirs


def _inside(out: Path, rel: str) -> bool:
    """True when OUT/rel's parent directories are real directories inside OUT (no symlink escapes)."""
    real_out = os.path.realpath(out)
    parent = os.path.realpath(os.path.dirname(os.path.join(out, rel)))
    return parent == real_out or parent.startswith(real_out + os.sep)


def _conflicts(out: Path, new_files: list[str], new_dirs: list[str], owned: set[str] | None,
               force: bool) -> str | None:
    """Why the new files cannot be moved into the existing directory OUT, or None."""
    for d in new_dirs:
        p = out / d
        if os.path.lexists(p) and (p.is_symlink() or not p.is_dir()):
            return f"{p}: exists and is not a directory; refusing to replace it"
    for f in new_files:
        p = out / f
        if not _inside(out, f):
            return f"{p}: leads outside {out}; refusing to write there"
        if not os.path.lexists(p):
            continue
        if p.is_dir() and not p.is_symlink():
            return f"{p}: is a directory; refusing to replace it"
        if not force and (owned is None or f not in owned):
            return (f"{p}: exists and was not written by mpsynth; refusing to replace it without --force")
    return None


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
    try:
        empty = not any(out.iterdir())
    except OSError as e:
        raise InputError(f"{out}: cannot read the existing output directory ({e.strerror})") from None
    owned = None if empty else owned_files(out)
    if not empty and owned is None and not force:
        raise InputError(f"{out}: directory is not empty and was not written by mpsynth; "
                         "refusing to write into it without --force")
    if new is not None:
        why = _conflicts(out, new[0], new[1], owned, force)
        if why:
            raise InputError(why)


def _write_manifest(directory: Path, files) -> None:
    doc = {"format": MANIFEST_FORMAT,
           "note": "written by mpsynth; a new run into this directory replaces the files listed here "
                   "and keeps every other file",
           "files": sorted(set(files) - {MARKER})}
    tmp = directory / (MARKER + ".tmp")
    try:
        tmp.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        os.replace(tmp, directory / MARKER)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _commit(tmp: Path, out: Path) -> None:
    """Move the finished ``tmp`` (manifest included) to ``out``: a rename when OUT is new, else the
    files are merged into the existing directory (see the module docstring)."""
    def fail(e):
        return OutputError(f"{out}: cannot move the finished output into place ({e.strerror or e})")

    if not os.path.lexists(out):
        try:
            os.rename(tmp, out)
        except OSError as e:
            raise fail(e) from None
        return
    if out.is_symlink() or not out.is_dir():  # checked: only with force
        try:
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.mpsynth-old-{os.getpid()}-", dir=out.parent))
            os.rename(out, old / "old")
        except OSError as e:
            raise fail(e) from None
        try:
            os.rename(tmp, out)
        except OSError as e:
            os.rename(old / "old", out)
            raise fail(e) from None
        finally:
            shutil.rmtree(old, ignore_errors=True)
        return
    new_files, new_dirs = _tree_files(tmp)
    owned = owned_files(out) or set()
    try:
        _write_manifest(out, owned | set(new_files))  # a crash from here on leaves no file unlisted
        for d in new_dirs:
            os.makedirs(out / d, exist_ok=True)
        for f in new_files:
            if f != MARKER:
                os.replace(tmp / f, out / f)
        for f in sorted(owned - set(new_files), reverse=True):
            p = out / f
            if _inside(out, f) and os.path.lexists(p) and (p.is_symlink() or not p.is_dir()):
                os.unlink(p)
                _prune_empty(out, os.path.dirname(f))
        _write_manifest(out, new_files)
    except OSError as e:
        raise fail(e) from None
    shutil.rmtree(tmp, ignore_errors=True)


def _prune_empty(out: Path, rel: str) -> None:
    """Remove the now empty directories rel, its parent, ... inside OUT (not OUT itself)."""
    while rel:
        try:
            os.rmdir(out / rel)
        except OSError:
            return
        rel = os.path.dirname(rel)


def remove_stale_temporaries(out) -> list[Path]:
    """Remove ``.OUT.mpsynth-tmp-*`` / ``.OUT.mpsynth-old-*`` directories beside ``out`` left by
    writers that were killed: their pid (in the name) no longer runs, or they are older than
    STALE_AGE. Returns what was removed; never raises."""
    out = Path(out)
    removed = []
    try:
        entries = list(os.scandir(out.parent))
    except OSError:
        return removed
    prefixes = (f".{out.name}.mpsynth-tmp-", f".{out.name}.mpsynth-old-")
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


class _SignalGuard:
    """SIGINT/SIGTERM -> exception while writing; deferred while ``defer`` is set."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.defer = False
        self.pending = None
        self.raised = None  # the signal already turned into an exception (which a library may swallow)
        self.saved = {}

    def install(self):
        if threading.current_thread() is not threading.main_thread():
            return
        for s in self.SIGNALS:
            self.saved[s] = signal.getsignal(s)
            signal.signal(s, self._handle)
        self.saved_hook = sys.unraisablehook
        sys.unraisablehook = self._unraisable

    def restore(self):
        for s, h in self.saved.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        self.saved = {}
        if getattr(self, "saved_hook", None) is not None:
            sys.unraisablehook, self.saved_hook = self.saved_hook, None
        return self.pending

    def _unraisable(self, info):
        """A signal that lands inside a callback Python cannot propagate from (e.g. an import lock's
        weakref callback) is printed as 'Exception ignored ... Traceback'. It is ours and is raised
        again before the commit (``raised``), so keep stderr to the contract's one line."""
        if self.raised is not None and isinstance(info.exc_value, (KeyboardInterrupt, SystemExit)):
            return
        self.saved_hook(info)

    def _handle(self, signum, frame):
        if self.defer:
            self.pending = self.pending or signum
            return
        self.defer = True  # the first signal interrupts; a second one waits for the clean-up
        self.raised = signum
        raise_for_signal(signum)


def raise_for_signal(signum):
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise SystemExit(128 + int(signum))


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def check_output_target(out_dir, force: bool = False) -> Path:
    """Raise InputError now if ``out_dir`` could not be written (missing or unwritable parent, a
    foreign non-empty directory without ``force``); returns its absolute path. Lets a command refuse
    a bad OUT before doing any work; `atomic_directory` checks again."""
    out = Path(os.path.abspath(os.fspath(out_dir)))
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
    guard = _SignalGuard()
    tmp = None
    guard.install()
    try:
        guard.defer = True  # a signal between mkdtemp and the assignment would leak the directory
        try:
            tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.mpsynth-tmp-{os.getpid()}-", dir=out.parent))
        except OSError as e:
            raise InputError(f"{out.parent}: cannot create the output directory there ({e.strerror})") from None
        guard.defer = False
        if guard.pending:  # arrived during mkdtemp: act on it now that the directory is known
            raise_for_signal(guard.pending)
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it 0700; OUT should look like a mkdir'ed dir
        try:
            yield tmp
        except OSError as e:  # disk full, quota, I/O error while writing: the user's environment
            raise OutputError(f"{out}: cannot write the output ({e.strerror or e})") from None
        guard.defer = True
        if guard.raised:  # the exception was swallowed (e.g. trimesh's optional imports catch BaseException)
            raise_for_signal(guard.raised)
        new = _tree_files(tmp)
        try:
            _write_manifest(tmp, new[0])
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
            raise_for_signal(guard.raised)
        raise
    finally:
        pending = guard.restore()
    if pending:
        raise_for_signal(pending)


def write_linkage_files(linkage, directory, *, robot_name: str, result, package: str | None = None) -> list[Path]:
    """Write linkage.urdf, linkage.json, meshes/<link>.stl and meshes/pin_<joint>.stl of ``linkage`` with
    its finished design ``result`` (`DesignResult`, from `synth.design.choose.design_for`) into the
    existing ``directory`` (not atomic: use inside ``atomic_directory``, e.g. for ``OUT/<id>/`` layouts;
    the formats: `synth.io.export.EXPORTERS`). Returns the paths written, relative to ``directory``."""
    return export(linkage, result, directory, robot_name=robot_name, package=package)


def write_output(linkage, out_dir, *, robot_name: str, result, force: bool = False,
                 package: str | None = None) -> list[Path]:
    """Write OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl of ``linkage`` with its finished
    design ``result`` atomically; returns the final paths. Raises InputError for an unusable OUT (see
    the module docstring)."""
    check_robot_name(robot_name)
    check_package(package)
    out = Path(os.path.abspath(os.fspath(out_dir)))
    with atomic_directory(out, force=force) as tmp:
        rel = write_linkage_files(linkage, tmp, robot_name=robot_name, result=result, package=package)
    return [out / r for r in rel]


def write_solutions(out_dir, solutions, index: dict, *, force: bool = False, package: str | None = None) -> None:
    """Write several linkages atomically as OUT/<id>/ (each as `write_linkage_files`) plus OUT/index.json;
    ``solutions``: (id, linkage, robot name, DesignResult) tuples."""
    with atomic_directory(Path(out_dir), force=force) as tmp:
        for sid, linkage, robot_name, result in solutions:
            d = tmp / sid
            d.mkdir()
            write_linkage_files(linkage, d, robot_name=robot_name, result=result, package=package)
        write_json(index, tmp / "index.json")


def atomic_write(path, write) -> None:
    """Write one file atomically: ``write(tmp)`` fills a temporary sibling of ``path``, which then
    replaces ``path`` (mode 0644); on any failure the temporary file is removed and nothing is left.
    InputError when the parent directory does not exist."""
    path = Path(path)
    if path.parent and not path.parent.exists():
        raise InputError(f"{path.parent}: directory does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
        os.close(fd)
    except OSError as e:
        raise OutputError(f"{path}: cannot write the file ({e.strerror or e})") from None
    try:
        write(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):
            raise OutputError(f"{path}: cannot write the file ({e.strerror or e})") from None
        raise
