"""The command line's signal policy while an output is written (the library installs no handlers).

`WriteGuard` is registered with `synth.io.interrupts.use` by `cli.common`: while a writer of
`synth.io.atomic` is inside its temporary directory, SIGINT raises KeyboardInterrupt (exit 130) and
SIGTERM SystemExit(143), so that the temporary directory is removed; during the final swap and the
clean-up (``defer``) a signal waits until they are done. Handlers are installed for that time only, in
the main thread only.
"""
from __future__ import annotations

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


def install() -> None:
    """Make `WriteGuard` the guard of every output the library writes in this process."""
    from synth.io import interrupts

    interrupts.use(WriteGuard)
