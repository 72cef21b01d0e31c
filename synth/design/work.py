"""Counted work: what stops the design searches, so that the same input gives the same design on an idle
and on a loaded machine (docs/design.md, "Deterministic"). A CPU-time budget would not: a search stopped
by the clock finds a different design when the machine is busy.

The unit is one **gap evaluation**: the distance of one pair of capsules at one sample of the motion for
one candidate design (`synth.design.coordinate.Scorer` charges N x P x K for a full evaluation of N
candidates over P pairs and K samples, N x L for a screen at L entries). The searches check the budget
between moves, so a budget is exceeded by at most one move's evaluations.
"""
from __future__ import annotations

import contextlib
import math
import threading

GAPS_PER_SECOND = 1e7  # about one CPU second of the batched search (measured: 1.1e7 gap evaluations per CPU s for the
# design of fixtures/sixbar_example.yaml, 6e6-8e6 for a Bennett linkage; the budgets were CPU seconds before)


class Work:
    """A budget of gap evaluations. ``limit``: how many (inf: no limit); ``parent``: a budget this one is
    part of (every evaluation charged here is charged there too; spent when either is spent)."""

    __slots__ = ("limit", "done", "parent")

    def __init__(self, limit: float = math.inf, parent: Work | None = None):
        self.limit, self.done, self.parent = float(limit), 0, parent

    def charge(self, n: int) -> None:
        """Count ``n`` gap evaluations."""
        self.done += int(n)
        flag = getattr(_CANCEL, "flag", None)
        if flag is not None and flag.is_set():
            raise Cancelled("the design search was cancelled")
        if self.parent is not None:
            self.parent.charge(n)

    @property
    def spent(self) -> bool:
        """Whether this budget (or one it is part of) is used up."""
        return self.done >= self.limit or (self.parent is not None and self.parent.spent)

    @property
    def left(self) -> float:
        """Gap evaluations left (inf: no limit)."""
        own = self.limit - self.done
        return own if self.parent is None else min(own, self.parent.left)

    def part(self, limit: float | None) -> Work:
        """A budget of at most ``limit`` more evaluations (None: no own limit) inside this one."""
        return Work(math.inf if limit is None else limit, self)


class Cancelled(Exception):
    """The design search was cancelled (`cancellable`): raised at the next charge of counted work."""


_CANCEL = threading.local()


@contextlib.contextmanager
def cancellable(flag: threading.Event):
    """Within this block, on this thread, every `Work.charge` (between the searches' moves) raises
    `Cancelled` once ``flag`` is set: a design search stops within one move's evaluations."""
    old = getattr(_CANCEL, "flag", None)
    _CANCEL.flag = flag
    try:
        yield
    finally:
        _CANCEL.flag = old
