"""The task entry points of the Python API (``synth.bennett``, ``synth.fit``; docs/fit.md,
docs/sixbar_fit.md): a classic pose
array goes to the exact synthesis, a task (tolerances, velocities, an order, other counts) to the task
synthesis of its kind.
"""
from __future__ import annotations

from synth.errors import InputError
from synth.synthesis.bennett import bennett as exact_bennett
from synth.synthesis.bennett_fit import bennett_task
from synth.synthesis.taskfit import make_task
from synth.task import PoseSet

__all__ = ["bennett", "fit"]


def bennett(poses, names=None, *, tolerance=None, velocity=None, order=None, best_effort: bool = False, **kw):
    """The Bennett linkage of three poses (`synth.synthesis.bennett.bennett`, keywords ``check_samples``,
    ``member``), or of a task: ``poses`` a `synth.task.PoseSet` (as `synth.io.poses.load_poses` reads a
    task file), or poses (N, 4, 4) with ``tolerance`` ((2,) or (N, 2) [metres, radians], 0 exact, inf
    free), ``velocity`` ((N, 6) world twists [w, v], NaN rows: none) and/or ``order`` ("listed"): exact for
    three poses or a Hermite pair, else fitted (`synth.synthesis.bennett_fit.bennett_task`; ``best_effort``
    returns the best fit even when it misses a tolerance)."""
    if isinstance(poses, PoseSet) or tolerance is not None or velocity is not None or order is not None:
        return fit(poses, names, tolerance=tolerance, velocity=velocity, order=order, best_effort=best_effort)[0]
    return exact_bennett(poses, names, **kw)


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
