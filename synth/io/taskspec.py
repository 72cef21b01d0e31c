"""The task keys of a pose file besides the poses themselves (../shared/docs/OUTPUT.md, "Additions (turn 3)").

``tolerance: {position, angle}`` at the top level (the default of every item, input units; absent: exact),
per item ``tolerance`` (a missing key: that component unconstrained) or ``exact: true``, per pose
``velocity: {angular, linear}`` (world-frame tool twist, angle / length unit per second; only its direction
counts) and ``order: listed | any``. `task_fields` turns them into the arrays of `synth.task.PoseSet`:
``tolerance`` (N, 2) [metres, radians] (0 exact, inf free; None when every item is exact), ``velocity``
(N, 6) [angular rad/s, linear m/s] (NaN: not given) and an `Order`. Problems raise `PoseProblem` (item
level, the caller names the file and item) or InputError (file level).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from synth.errors import InputError
from synth.io.docload import quote_text
from synth.io.posespec import ANGLE_UNITS, TASK_ITEM_KEYS as ITEM_KEYS, PoseProblem, check_keys, describe_value, number, vector
from synth.task import Order

__all__ = ["ITEM_KEYS", "TOP_TASK_KEYS", "parse_tolerance", "parse_velocity", "task_fields", "parse_order"]

TOP_TASK_KEYS = ("tolerance", "order", "constraints")
TOLERANCE_KEYS = ("position", "angle")
VELOCITY_KEYS = ("angular", "linear")


def parse_tolerance(v: Any, length_scale: float, angle_scale: float, what: str = "tolerance") -> np.ndarray:
    """(2,) [metres, radians] of a ``{position, angle}`` mapping in input units; a missing key is inf."""
    if not isinstance(v, dict):
        raise PoseProblem(f"{what} must be a mapping like {{position: 0.5, angle: 0.1}}, got {describe_value(v)}")
    check_keys(v, TOLERANCE_KEYS, f" in {what}")
    out = np.full(2, np.inf)
    for k, key in enumerate(TOLERANCE_KEYS):
        if key in v:
            x = number(v[key], f"{what}.{key}")
            if x < 0:
                raise PoseProblem(f"{what}.{key} is negative ({x:g}); a tolerance is at least 0")
            out[k] = x * (length_scale if k == 0 else angle_scale)
    return out


def parse_velocity(v: Any, length_scale: float, angle_scale: float) -> np.ndarray:
    """(6,) [angular rad/s, linear m/s] of a ``{angular, linear}`` mapping (input units per second);
    a missing half is NaN. Refuses a zero twist (it has no direction)."""
    if not isinstance(v, dict):
        raise PoseProblem(f"velocity must be a mapping like {{angular: [0, 0, 30], linear: [0, 50, 0]}}, "
                          f"got {describe_value(v)}")
    check_keys(v, VELOCITY_KEYS, " in velocity")
    if not any(k in v for k in VELOCITY_KEYS):
        raise PoseProblem("velocity needs 'angular' or 'linear' (or both)")
    out = np.full(6, np.nan)
    if "angular" in v:
        out[:3] = vector(v["angular"], 3, "velocity.angular") * angle_scale
    if "linear" in v:
        out[3:] = vector(v["linear"], 3, "velocity.linear") * length_scale
    if not np.any(np.nan_to_num(out) != 0):
        raise PoseProblem("velocity is zero; it prescribes a direction of motion, so give a nonzero twist")
    return out


def parse_order(v: Any, name: str) -> Order:
    if v in (o.value for o in Order):
        return Order(v)
    shown = quote_text(v) if isinstance(v, str) else describe_value(v)
    raise InputError(f"{name}: unknown order {shown} (allowed: {', '.join(o.value for o in Order)})")


def task_fields(doc: dict, items: list, kinds: list[str], labels: list[str], name: str, length_scale: float,
                angle_unit: str) -> tuple[np.ndarray | None, np.ndarray | None, Order]:
    """(tolerance (N, 2) or None, velocity (N, 6) or None, order) of a pose document ``doc`` whose items
    (pose/point specs, in `PoseSet` order) are ``items``, ``kinds`` ("pose"/"point") and ``labels``
    ("pose 3 ("pick")", for messages). Points have no angle: their angle tolerance is inf."""
    ascale = ANGLE_UNITS[angle_unit]
    default = None
    if "tolerance" in doc:
        try:
            default = parse_tolerance(doc["tolerance"], length_scale, ascale)
        except PoseProblem as e:
            raise InputError(f"{name}: {e}") from None
    order = parse_order(doc["order"], name) if "order" in doc else Order.ANY
    n = len(items)
    tol = np.zeros((n, 2)) if default is None else np.repeat(default[None], n, axis=0)
    vel = np.full((n, 6), np.nan)
    toleranced = default is not None
    for i, (spec, kind, label) in enumerate(zip(items, kinds, labels)):
        if not isinstance(spec, dict):
            continue
        try:
            toleranced |= _item(spec, kind, tol[i], vel[i], length_scale, ascale)
        except PoseProblem as e:
            raise InputError(f"{name}: {label}: {e}") from None
    point = np.array([k == "point" for k in kinds], bool)
    tol[point, 1] = np.inf
    velocity = vel if np.any(~np.isnan(vel)) else None
    return (tol if toleranced else None), velocity, order


def _item(spec: dict, kind: str, tol: np.ndarray, vel: np.ndarray, length_scale: float, ascale: float) -> bool:
    """Fill one item's tolerance and velocity rows in place; whether it has a tolerance of its own."""
    exact = spec.get("exact", False)
    if not isinstance(exact, bool):
        raise PoseProblem(f"exact must be true or false, got {describe_value(exact)}")
    if exact and "tolerance" in spec:
        raise PoseProblem("both 'exact: true' and a 'tolerance' given; give one")
    if exact:
        tol[:] = 0.0
    elif "tolerance" in spec:
        tol[:] = parse_tolerance(spec["tolerance"], length_scale, ascale)
    if "velocity" in spec:
        if kind == "point":
            raise PoseProblem("a point (position only) cannot carry a velocity; give the pose's orientation too")
        vel[:] = parse_velocity(spec["velocity"], length_scale, ascale)
    return "tolerance" in spec

