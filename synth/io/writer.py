"""Write a linkage's output directory (docs/conventions.md) atomically.

``atomic_directory(OUT)`` yields a fresh temporary sibling directory ``.OUT.mpsynth-tmp-XXXX`` (same
parent, so the final rename cannot cross file systems). On a clean exit it drops a marker file
``.mpsynth-output`` into it and renames it to OUT; an existing OUT is first renamed away to
``.OUT.mpsynth-old-XXXX`` and deleted after the new one is in place. On any exception, and on
SIGINT/SIGTERM while inside (handlers are installed only for that time, main thread only), the
temporary directory is removed and the exception propagates: SIGINT as KeyboardInterrupt (exit
status 130 when uncaught), SIGTERM as SystemExit(143). Signals arriving during the final renames
or the clean-up are deferred until those are done. Should the exception be swallowed by the code
inside (some libraries wrap failed optional imports, KeyboardInterrupt included), it is raised again
before the commit: a signal received while writing always means no new OUT.

An existing OUT is replaced only when it is empty, or written by mpsynth (the marker, or a
``linkage.json`` / ``index.json`` whose ``format`` starts with "mpsynth."), or when ``force`` is true;
anything else is an `InputError`, as is a missing or unwritable parent directory.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import sys
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path

from synth.errors import InputError
from synth.io.jsonout import linkage_document, write_json
from synth.io.meshes import default_sizes, design_for, design_solids, mesh_inertials, stl_file
from synth.io import urdf

MARKER = ".mpsynth-output"
_MARKER_TEXT = json.dumps({"format": "mpsynth.output/1",
                           "note": "written by mpsynth; mpsynth replaces this directory when asked to write here"}) + "\n"


def is_mpsynth_output(path) -> bool:
    """True when directory ``path`` carries mpsynth's marker or an mpsynth JSON document."""
    path = Path(path)
    if (path / MARKER).is_file():
        return True
    for name in ("linkage.json", "index.json"):
        try:
            doc = json.loads((path / name).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(doc, dict) and str(doc.get("format", "")).startswith("mpsynth."):
            return True
    return False


def _check_target(out: Path, force: bool) -> None:
    parent = out.parent
    if not parent.exists():
        raise InputError(f"{parent}: output parent directory does not exist")
    if not parent.is_dir():
        raise InputError(f"{parent}: output parent is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{parent}: output parent directory is not writable")
    if not os.path.lexists(out) or force:
        return
    if out.is_symlink() or not out.is_dir():
        raise InputError(f"{out}: exists and is not a directory written by mpsynth; "
                         "refusing to replace it without --force")
    try:
        empty = not any(out.iterdir())
    except OSError as e:
        raise InputError(f"{out}: cannot read the existing output directory ({e.strerror})") from None
    if not empty and not is_mpsynth_output(out):
        raise InputError(f"{out}: directory is not empty and was not written by mpsynth; "
                         "refusing to replace it without --force")


def _commit(tmp: Path, out: Path) -> None:
    """Move the finished ``tmp`` to ``out``, replacing whatever is at ``out``."""
    def fail(e):
        return InputError(f"{out}: cannot move the finished output into place ({e.strerror or e})")

    if not os.path.lexists(out):
        try:
            os.rename(tmp, out)
        except OSError as e:
            raise fail(e) from None
        return
    try:
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.mpsynth-old-", dir=out.parent))
    except OSError as e:
        raise fail(e) from None
    try:
        os.rename(out, old / "old")  # inside a fresh directory: a name nobody else uses
    except OSError as e:
        os.rmdir(old)
        raise fail(e) from None
    try:
        os.rename(tmp, out)
    except OSError as e:
        os.rename(old / "old", out)
        os.rmdir(old)
        raise fail(e) from None
    shutil.rmtree(old, ignore_errors=True)


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
    guard = _SignalGuard()
    tmp = None
    guard.install()
    try:
        guard.defer = True  # a signal between mkdtemp and the assignment would leak the directory
        try:
            tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.mpsynth-tmp-", dir=out.parent))
        except OSError as e:
            raise InputError(f"{out.parent}: cannot create the output directory there ({e.strerror})") from None
        guard.defer = False
        if guard.pending:  # arrived during mkdtemp: act on it now that the directory is known
            raise_for_signal(guard.pending)
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it 0700; OUT should look like a mkdir'ed dir
        yield tmp
        guard.defer = True
        if guard.raised:  # the exception was swallowed (e.g. trimesh's optional imports catch BaseException)
            raise_for_signal(guard.raised)
        (tmp / MARKER).write_text(_MARKER_TEXT, encoding="utf-8")
        _check_target(out, force)  # again: OUT may have appeared while we were writing
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


def write_linkage_files(linkage, directory, *, robot_name: str, package: str | None = None,
                        pin_radius=None, link_radius=None, pin_length=None, hole_clearance=None, clearance=None,
                        result=None) -> list[Path]:
    """Write linkage.urdf, linkage.json, meshes/<link>.stl and meshes/pin_<joint>.stl into the existing
    ``directory`` (not atomic: use inside ``atomic_directory``, e.g. for ``OUT/<id>/`` layouts).
    ``result``: the `DesignResult` to write (default: `meshes.design_for` with the given sizes and
    clearances, metres).
    Returns the paths written, relative to ``directory``."""
    directory = Path(directory)
    if result is None:
        result = design_for(linkage, pin_radius, link_radius, pin_length, hole_clearance, clearance)
    meshes = design_solids(linkage, result.design)
    written = []
    if meshes:
        (directory / "meshes").mkdir()
    offsets = {}
    for name, mesh in meshes.items():
        rel = Path("meshes") / f"{name}.stl"
        # stored about its own centre, in millimetres, placed by the URDF visual/collision origin
        data, offsets[name] = stl_file(mesh, f"mesh of {name}")
        (directory / rel).write_bytes(data)
        written.append(rel)
    text = urdf.urdf_text(linkage, robot_name, mesh_dir="meshes", package=package, masses=mesh_inertials(meshes),
                     mesh_offsets=offsets, design=result.design, collision=result.collision)
    (directory / "linkage.urdf").write_text(text, encoding="utf-8")
    write_json(linkage_document(linkage, result.design, result.collision), directory / "linkage.json")
    return [Path("linkage.urdf"), Path("linkage.json")] + written


def write_output(linkage, out_dir, *, robot_name: str, force: bool = False, package: str | None = None,
                 pin_radius=None, link_radius=None, pin_length=None, hole_clearance=None, clearance=None,
                 result=None) -> list[Path]:
    """Write OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl atomically; returns the final
    paths. Raises InputError for an unusable OUT (see the module docstring) or bad sizes."""
    default_sizes(linkage, pin_radius, link_radius, pin_length)  # fail on bad sizes before touching disk
    out = Path(os.path.abspath(os.fspath(out_dir)))
    with atomic_directory(out, force=force) as tmp:
        rel = write_linkage_files(linkage, tmp, robot_name=robot_name, package=package,
                                  pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                                  hole_clearance=hole_clearance, clearance=clearance, result=result)
    return [out / r for r in rel]


def atomic_write(path, write) -> None:
    """Write one file atomically: ``write(tmp)`` fills a temporary sibling of ``path``, which then
    replaces ``path`` (mode 0644); on any failure the temporary file is removed and nothing is left.
    InputError when the parent directory does not exist."""
    path = Path(path)
    if path.parent and not path.parent.exists():
        raise InputError(f"{path.parent}: directory does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
