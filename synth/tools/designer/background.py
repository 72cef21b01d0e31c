"""The designer's work behind the live drawing: the drive report and the physical design (the
collision-free search) of the current task, exactly as the CLI makes them (`synth.solve` with a physical
design), on a thread, cancellable: a new change sets the job's flag, and the design search stops at its
next charge of counted work (`synth.design.work.cancellable`).
"""
from __future__ import annotations

import enum
import threading
from dataclasses import dataclass, field

from synth.design.work import Cancelled, cancellable
from synth.drive import drive_report
from synth.errors import MpsynthError
from synth.solve import SynthesisOptions


SETTLE_SECONDS = 0.25  # a job starts this long after its change, unless a newer one cancels it first (a
# drag sends a change every few ms: the search starts when the hand rests; timing decides only *whether* a job
# runs, never what it finds, which counted work decides)
STOP_SECONDS = 2.0  # how long a change waits for the cancelled job to stop (one move of the search) before its
# own synthesis, so the two do not share the interpreter


class Stage(enum.StrEnum):
    RUNNING = "running"
    DONE = "done"
    CANCELLED = "cancelled"
    FAILED = "failed"


@dataclass(slots=True)
class Job:
    """One background design of revision ``revision``; ``result``: the `synth.solve.Result` the CLI
    would write (with its design), ``drive``: the drive report's sentence, ``problem``: why it failed."""

    revision: int
    stage: Stage = Stage.RUNNING
    drive: str | None = None
    result: object = None
    problem: str | None = None
    flag: threading.Event = field(default_factory=threading.Event)
    thread: threading.Thread | None = None

    def cancel(self) -> None:
        self.flag.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the job's end; whether it ended."""
        if self.thread is not None:
            self.thread.join(timeout)
        return self.stage is not Stage.RUNNING


def design_result(solve, ps):
    """The Result of the CLI's call ``solve(ps, SynthesisOptions(physical=True))`` (`mpsynth KIND TASK -o
    OUT` without options)."""
    return solve(ps, SynthesisOptions(physical=True))


def start(revision: int, design, linkage, on_done=None) -> Job:
    """Start the job ``design()`` (a `synth.solve.Result` with its design: `design_result`, or
    `synth.solve.design_solution` of a picked candidate) with ``linkage`` (the one drawn, for the drive
    report); ``on_done(job)`` is called on the thread at the end."""
    job = Job(revision)

    def run():
        try:
            if job.flag.wait(SETTLE_SECONDS):  # a newer change came first: nothing to do
                raise Cancelled()
            with cancellable(job.flag):
                job.drive = drive_report(linkage).sentence()
                if job.flag.is_set():
                    raise Cancelled()
                job.result = design()
            job.stage = Stage.DONE
        except Cancelled:
            job.stage = Stage.CANCELLED
        except MpsynthError as e:
            job.problem, job.stage = str(e), Stage.FAILED
        except Exception as e:  # an internal error: shown, never a frozen page
            job.problem, job.stage = f"internal error: {type(e).__name__}: {e}", Stage.FAILED
        if on_done is not None:
            on_done(job)

    job.thread = threading.Thread(target=run, name=f"mpsynth-design-{revision}", daemon=True)
    job.thread.start()
    return job
