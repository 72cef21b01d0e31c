"""The ``constraints:`` section of a task file (``../shared/docs/OUTPUT.md``, "Additions (turn 3)").

::

    constraints:
      base: {box: [[x0, y0, z0], [x1, y1, z1]]}      # every joint on the root link has its axis through it
      envelope: {box: [[x0, y0, z0], [x1, y1, z1]]}  # every written solid stays inside over the task range
      max_speed_ratio: 4                             # |d joint / d driver| of every joint over the task range

Box corners are in the file's length unit (converted to metres here), the lower corner first (x0 <= x1,
y0 <= y1, z0 <= z1; a flipped coordinate is an error, not silently sorted). Every problem is an `InputError` of one line naming the file and
the key, e.g. ``task.yaml: constraints.base.box[1][2] must be a number, got a string ("x")``.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from synth.errors import InputError
from synth.io.posespec import PoseProblem, check_keys, describe_value, number, vector
from synth.task import Box, Constraints

__all__ = ["parse_constraints", "CONSTRAINT_KEYS"]

CONSTRAINT_KEYS = ("base", "envelope", "max_speed_ratio")
BOX_KEYS = ("box",)


def parse_constraints(value: Any, *, source: str, length_scale: float) -> Constraints | None:
    """The `Constraints` of a task file's ``constraints:`` value (None when absent or empty).
    ``length_scale``: metres per input length unit; ``source``: the file's name for messages."""
    if value is None:
        return None
    try:
        if not isinstance(value, dict):
            raise PoseProblem(f"constraints must be a mapping with keys {', '.join(CONSTRAINT_KEYS)}, "
                              f"got {describe_value(value)}")
        check_keys(value, CONSTRAINT_KEYS, " in constraints")
        boxes = {key: _box(value[key], f"constraints.{key}", length_scale)
                 for key in ("base", "envelope") if key in value}
        ratio = None
        if "max_speed_ratio" in value:
            ratio = number(value["max_speed_ratio"], "constraints.max_speed_ratio")
            if not ratio > 0:
                raise PoseProblem(f"constraints.max_speed_ratio must be positive, got {ratio:g}")
    except PoseProblem as e:
        raise InputError(f"{source}: {e}") from None
    if not boxes and ratio is None:
        return None
    return Constraints(base=boxes.get("base"), envelope=boxes.get("envelope"), max_speed_ratio=ratio)


def _box(value: Any, what: str, length_scale: float) -> Box:
    """A ``{box: [[x0, y0, z0], [x1, y1, z1]]}`` mapping as a `Box` in metres."""
    if not isinstance(value, dict) or "box" not in value:
        raise PoseProblem(f"{what} must be a mapping {{box: [[x0, y0, z0], [x1, y1, z1]]}}, "
                          f"got {describe_value(value)}")
    check_keys(value, BOX_KEYS, f" in {what}")
    corners = value["box"]
    if not isinstance(corners, (list, tuple)) or len(corners) != 2:
        raise PoseProblem(f"{what}.box must be two corners [[x0, y0, z0], [x1, y1, z1]], got {describe_value(corners)}")
    c = np.array([vector(corner, 3, f"{what}.box[{i}]") for i, corner in enumerate(corners)])
    flipped = [f"{a}0 = {c[0, k]:g} > {a}1 = {c[1, k]:g}" for k, a in enumerate("xyz") if c[0, k] > c[1, k]]
    if flipped:  # a flipped sign or swapped coordinate is a typo more often than a deliberate corner order
        raise PoseProblem(f"{what}.box must be [[x0, y0, z0], [x1, y1, z1]] with the lower corner first, got "
                          + ", ".join(flipped))
    c = c * length_scale
    return Box(lo=c[0], hi=c[1])
