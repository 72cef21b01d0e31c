"""The command line's signal policy while an output is written (the library installs no handlers).

`WriteGuard` is registered with `synth.io.interrupts.use` by `cli.common`: while a writer of
`synth.io.atomic` is inside its temporary directory, SIGINT raises KeyboardInterrupt (exit 130) and
SIGTERM SystemExit(143), so that the temporary directory is removed; during the final swap and the
clean-up (``defer``) a signal waits until they are done. Handlers are installed for that time only, in
the main thread only.
"""
from __future__ import annotations

import contextlib
import signal
import sys
import threading


def act(signum) -> None:
    """Raise what ``signum`` means for the command: KeyboardInterrupt or SystemExit(128 + signum)."""
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise SystemExit(128 + int(signum))


class WriteGuard:
    """SIGINT/SIGTERM -> exception while writing; deferred while ``defer`` is set."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.defer = False
        self.pending = None
        self.raised = None  # the signal already turned into an exception (which a library may swallow)
        self.saved = {}
        self.saved_hook = None

    def install(self) -> None:
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
        if self.saved_hook is not None:
            sys.unraisablehook, self.saved_hook = self.saved_hook, None
        return self.pending

    act = staticmethod(act)

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
        act(signum)


class StopOnSignal:
    """While a loop owns a worker pool: SIGINT/SIGTERM only record the first signal (``signum``), and the
    loop asks ``requested()`` between its waits, then shuts the pool down from a clean state and calls
    ``act()``. Raising from the handler instead could land inside the pool's own bookkeeping (a result
    wait, a task hand-over, a half-written stdout line) and leave the pool unjoinable. Whatever happens,
    the process ends within `cli.streams.CLEANUP_SECONDS` of the signal. Main thread only."""

    def __init__(self):
        self.signum = None
        self.saved = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.saved = {s: signal.signal(s, self._handle) for s in WriteGuard.SIGNALS}
        return self

    def __exit__(self, *exc):
        for s, h in self.saved.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        self.saved = {}
        return False

    def _handle(self, signum, frame):
        if self.signum is None:
            from .streams import exit_after_cleanup

            self.signum = signum
            exit_after_cleanup(128 + signum)

    def requested(self) -> bool:
        return self.signum is not None

    def act(self) -> None:
        """Raise what the recorded signal means (`act`)."""
        act(self.signum)


_PR_SET_PDEATHSIG = 1


def batch_worker(parent: int) -> None:
    """Initializer of `mpsynth batch -j N`'s pool workers: ^C is ignored (the batch process handles it
    and terminates the pool), SIGTERM exits quietly, and the kernel kills the worker when its parent
    (the pool's fork server, which exits with the batch process, even on SIGKILL) dies (Linux prctl
    PR_SET_PDEATHSIG): no orphan keeps writing outputs. Then the library's `prepare_worker`."""
    import ctypes
    import os

    from synth.tools.workerpool import prepare_worker

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda signum, frame: os._exit(128 + signum))
    _exit_with(parent)
    try:
        libc = ctypes.CDLL(None, use_errno=True)  # (the process's own symbols, libc's among them: find_library
        # ran `ldconfig -p`, ~7 ms of every worker's start)
        ppid = os.getppid()
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        if os.getppid() != ppid:  # the parent died before the prctl
            os._exit(1)
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass
    prepare_worker(parent)


def _exit_with(parent: int) -> None:
    """End this worker as soon as the batch process ``parent`` ends, even by SIGKILL, whatever the worker
    is doing: a daemon thread waits on a pidfd of ``parent`` (Linux >= 5.3). PR_SET_PDEATHSIG alone is not
    enough: a worker's parent is the pool's fork server, which every worker keeps alive (each holds the
    write end of its "alive" pipe), so a worker busy in a long job (a design search, a STEP export) or
    blocked would outlive the batch and keep writing outputs."""
    import os
    import select
    import threading

    try:
        fd = os.pidfd_open(parent)
    except ProcessLookupError:  # already gone
        os._exit(1)
    except (AttributeError, OSError):  # pragma: no cover - not Linux >= 5.3: PR_SET_PDEATHSIG only
        return

    def wait():
        select.select([fd], [], [])  # readable once the process has ended
        os._exit(1)

    threading.Thread(target=wait, name="exit-with-batch", daemon=True).start()


@contextlib.contextmanager
def held():
    """SIGINT/SIGTERM wait until the block is done, then go to the handlers installed before (main
    thread only; elsewhere nothing is held)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending = []
    saved = {s: signal.signal(s, lambda signum, frame: pending.append(signum)) for s in WriteGuard.SIGNALS}
    try:
        yield
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)
        for s in dict.fromkeys(pending):
            signal.raise_signal(s)


def install() -> None:
    """Make `WriteGuard` the guard of every output the library writes in this process, and `held` the
    way signals wait during native module initialisations."""
    from synth.io import interrupts

    interrupts.use(WriteGuard, held=held)
