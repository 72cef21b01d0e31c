"""The hook through which the command line (which owns the process's signals) protects a commit.

The library never installs signal handlers nor exits the process (docs/architecture.md). The writers
(`synth.io.atomic`) ask ``guard()`` for an object with this protocol and use it around a write:

- ``install()`` / ``restore() -> pending signal number | None``: start / end of the write;
- ``defer`` (bool attribute): while True, an arriving signal is remembered, not acted on;
- ``raised``: the signal already turned into an exception (a library may have swallowed it);
- ``act(signum)``: raise what the signal means (KeyboardInterrupt, SystemExit(128 + signum)).

The default guard does nothing (a library user keeps Python's own signal behaviour); `cli` registers
its guard with ``use(factory)`` (cli/signals.py).
"""
from __future__ import annotations


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


def use(factory) -> None:
    """Make ``factory()`` the guard of every later write (the CLI's signal guard)."""
    global _factory
    _factory = factory


def guard():
    """A fresh guard for one write."""
    return _factory()
