"""Standard streams and signals for the CLI: an unwritable stdout, SIGTERM as a clean exit (nothing here prints)."""
from __future__ import annotations

import errno
import os
import signal
import sys
import threading
from contextlib import contextmanager

# OSError numbers the user's environment causes (a full disk, a closed pipe or stream, a read-only or
# failing device): a one-line error, never an internal one
ENVIRONMENT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EPIPE, errno.EBADF, errno.EIO, errno.EROFS,
                      errno.EFBIG, errno.EACCES, errno.EPERM, errno.ENXIO}


def silence_stdout() -> None:
    """Point stdout at /dev/null so that the interpreter's final flush cannot fail again."""
    _silence(sys.stdout)


def silence_stderr() -> None:
    """Point stderr at /dev/null (it cannot be written: full, or a closed pipe), dropping what is
    buffered, so that the interpreter's final flush cannot fail."""
    _silence(sys.stderr)


def _silence(stream) -> None:
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, stream.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def environment_error(e: BaseException) -> str | None:
    """A one-line message when ``e`` is an OSError of the user's environment, else None."""
    if isinstance(e, OSError) and e.errno in ENVIRONMENT_ERRNOS:
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        return f"{where}{e.strerror or e}"
    return None


WRITING = threading.Lock()  # held while whole result lines go to stdout (`mpsynth batch`); a forced exit waits for it


def _exit_after(seconds: float, code: int) -> None:
    """Exit with ``code`` after ``seconds`` unless the process has ended by then: a worker pool's clean-up
    (terminate, join) can block for good when SIGTERM interrupted the pool's own bookkeeping, and a
    terminated command must end. Whole result lines already written are flushed first."""

    def exit_now():
        WRITING.acquire(timeout=1.0)  # a result text being written is finished first (never half a line)
        flush = threading.Thread(target=sys.stdout.flush, daemon=True)  # not here: it may wait on a held lock
        flush.start()
        flush.join(1.0)
        os._exit(code)

    timer = threading.Timer(seconds, exit_now)
    timer.daemon = True
    timer.start()


CLEANUP_SECONDS = 10.0  # how long the clean-up after SIGTERM may take (a shutdown bound, not a search budget)


def exit_after_cleanup(code: int) -> None:
    """The process ends with ``code`` at the latest `CLEANUP_SECONDS` from now (a bound on the clean-up
    after a signal; `mpsynth batch -j N` shuts its pool down in well under a second)."""
    _exit_after(CLEANUP_SECONDS, code)


@contextmanager
def terminate_as_exit():
    """Inside: SIGTERM raises SystemExit(143), so that `finally` clauses (worker pools) run and no
    traceback is printed. Main thread only; the previous handler is restored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # one clean-up is enough
        exit_after_cleanup(128 + signum)
        raise SystemExit(128 + signum)

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)
