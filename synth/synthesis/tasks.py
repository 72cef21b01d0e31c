"""The task entry point of the Python API (``synth.fit``; docs/fit.md, docs/sixbar_fit.md): a task
(tolerances, velocities, an order, other counts) to the task synthesis of its kind. (``synth.bennett`` and
``synth.sixbar`` stay the exact syntheses.)
"""
from __future__ import annotations

from synth.errors import InputError
from synth.synthesis.bennett_fit import bennett_task
from synth.synthesis.taskfit import make_task
from synth.task import PoseSet

__all__ = ["fit"]


def fit(poses, names=None, *, tolerance=None, velocity=None, order=None, kind: str = "bennett", top: int = 1,
        best_effort: bool = False) -> list:
    """Linkages of ``kind`` ("bennett" or "6r") for a task (a `PoseSet`, or arrays as
    `synth.synthesis.taskfit.make_task`), best first (a list of up to ``top``): exact, Hermite or fitted."""
    task = poses if isinstance(poses, PoseSet) else make_task(poses, names, tolerance, velocity, order)
    if kind == "bennett":
        return bennett_task(task, top=top, best_effort=best_effort)
    if kind == "6r":
        from synth.synthesis.sixbar_task import sixbar_task

        return sixbar_task(task, top=top, best_effort=best_effort)
    raise InputError(f"synth.fit: kind {kind!r} is not available (allowed: 'bennett', '6r')")
