"""The hook through which the command line (which owns the process's signals) protects a commit.

The library never installs signal handlers nor exits the process (docs/architecture.md). The writers
(`synth.io.atomic`) ask ``guard()`` for an object with this protocol and use it around a write:

- ``install()`` / ``restore() -> pending signal number | None``: start / end of the write;
- ``defer`` (bool attribute): while True, an arriving signal is remembered, not acted on;
- ``raised``: the signal already turned into an exception (a library may have swallowed it);
- ``act(signum)``: raise what the signal means (KeyboardInterrupt, SystemExit(128 + signum)).

The default guard does nothing (a library user keeps Python's own signal behaviour); `cli` registers
its guard with ``use(factory)`` (cli/signals.py). ``held()`` is the context in which signals must wait
(a native module's initialisation that a KeyboardInterrupt would abort): nothing by default, the CLI's
``use(..., held=...)`` defers SIGINT/SIGTERM to its end.
"""
from __future__ import annotations

import contextlib


class NoGuard:
    """The library's default: no handlers, nothing deferred."""

    def __init__(self):
        self.defer = False
        self.pending = None
        self.raised = None

    def install(self) -> None:
        return None

    def restore(self):
        return None

    def act(self, signum) -> None:  # pragma: no cover - never called without a pending signal
        return None


_factory = NoGuard
_held = contextlib.nullcontext


def use(factory, held=None) -> None:
    """Make ``factory()`` the guard of every later write (the CLI's signal guard) and ``held()`` (a
    context manager) the way signals wait during a native module's initialisation."""
    global _factory, _held
    _factory = factory
    if held is not None:
        _held = held


def held():
    """The registered context in which signals wait (see the module docstring)."""
    return _held()


def guard():
    """A fresh guard for one write."""
    return _factory()
