"""Read and validate pose files (docs/conventions.md, pose files).

A pose file is YAML (or JSON, which is parsed with the ``json`` module when the file name ends in
``.json`` or the text looks like a JSON object) of the form::

    units: {length: mm, angle: deg}          # optional; defaults m and rad
    poses:
      - name: pick                           # optional; default p0, p1, ...
        position: [100, 0, 250]
        quaternion: {w: 1, x: 0, y: 0, z: 0} # a list needs quaternion_order: wxyz | xyzw
      - position: [120, 50, 200]
        rpy: [0, 30, 45]                     # URDF fixed axes: R = Rz(yaw) Ry(pitch) Rx(roll)
      - position: [0, 0, 0]
        axis_angle: {axis: [0, 0, 1], angle: 90}
      - position: [0, 0, 0]
        rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
      - matrix: [[1, 0, 0, 100], [0, 1, 0, 0], [0, 0, 1, 300], [0, 0, 0, 1]]   # alone

The file is read by `synth.io.docload` (size limits, the strict YAML loader), each pose is parsed by
`synth.io.posespec` (units, numbers, rotations); this module checks the document and the pose names
and returns a `PoseSet`. Conventions:

* **Pose indices are 0-based**, in the order the poses are listed, matching the default names
  ``p0, p1, ...`` and the ``poses`` list of ``linkage.json`` (docs/conventions.md).
* Every problem raises :class:`synth.errors.InputError` with a single line
  ``<file>: pose <i> ("<name>"): <problem>`` (``("<name>")`` only when the pose has a name;
  file-level problems are ``<file>: <problem>``). ``<file>`` is the path as given, or ``<stdin>``.
* The YAML loader is :class:`yaml.SafeLoader` (never an object-constructing loader) extended to
  (a) reject duplicate mapping keys and (b) read ``1e-3``-style numbers as floats (YAML 1.2
  style; plain YAML 1.1 would read them as strings).
* Lengths are converted to metres; angles are interpreted in the file's angle unit.
* Rotation matrices are built to be orthonormal to double precision: quaternions are normalized,
  given rotations that pass the 1e-6 test are projected onto the nearest rotation (SVD), and angles
  that are exact multiples of 90 degrees get exact sines and cosines.
* A non-unit ``axis_angle`` axis is accepted and normalized (it only gives a direction); a zero
  axis is an error.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from synth.errors import InputError
from synth.task import PoseSet, default_name
from synth.io.docload import MAX_FILE_BYTES, MAX_POSES, json_object_pairs, load_document, quote_text, read_source
from synth.io.constraints import parse_constraints
from synth.io.taskspec import TOP_TASK_KEYS, task_fields
from synth.io.posespec import (ANGLE_UNITS, LENGTH_UNITS, QUATERNION_ORDERS, PoseProblem, axis_angle_matrix, check_keys,
                               describe_value, is_point_spec, point_position, pose_from_spec, pose_matrix,
                               quaternion_matrix, rpy_matrix_exact)

__all__ = [
    "PoseSet",
    "load_poses",
    "parse_pose_document",
    "pose_from_spec",
    "quaternion_matrix",
    "rpy_matrix_exact",
    "axis_angle_matrix",
    "json_object_pairs",
    "LENGTH_UNITS",
    "ANGLE_UNITS",
    "MAX_FILE_BYTES",
    "MAX_POSES",
]

TOP_KEYS = ("units", "quaternion_order", "poses", "points") + TOP_TASK_KEYS
SIZE_RANGE_M = (1e-5, 10.0)  # spread of the positions (m) believable without an explicit length unit
UNIT_KEYS = ("length", "angle")


# ============================================================== the document

def _count_spec(count) -> tuple[int, int | None, str | None]:
    """count: int | (int, label) | ((lo, hi), label) | (lo, hi) with hi None for 'at least'."""
    label = None
    if isinstance(count, tuple) and len(count) == 2 and isinstance(count[1], str):
        count, label = count
    if isinstance(count, int):
        return count, count, label
    lo, hi = count
    return lo, hi, label


def _count_problem(count, n: int, noun: str = "pose") -> str | None:
    lo, hi, label = _count_spec(count)
    if lo <= n and (hi is None or n <= hi):
        return None
    if hi == lo:
        need = f"exactly {lo}"
    elif hi is None:
        need = f"at least {lo}"
    else:
        need = f"between {lo} and {hi}"
    noun = noun if (hi == lo == 1) else noun + "s"
    got = f"got {n}"
    return f"{label} needs {need} {noun}, {got}" if label else f"expected {need} {noun}, {got}"


def _pose_label(i: int, name: str | None) -> str:
    return f"pose {i} ({quote_text(name)})" if name is not None else f"pose {i}"


def parse_pose_document(
    doc: Any, *, source: str = "<poses>", count=None, normalize: bool = False, points=None
) -> PoseSet:
    """Validate an already-parsed document (the structure YAML/JSON gives) into a PoseSet.

    ``points``: None refuses point tasks; else a count spec (as ``count``) for a document holding
    points (a ``points:`` list, or ``poses:`` entries with a position only; docs/points.md), which
    then lists the ``poses:`` entries first and the ``points:`` after them, with ``kinds`` telling
    which item is which; ``count`` applies to documents without points."""
    name = source
    if doc is None:
        raise InputError(f"{name}: the file is empty; expected a mapping with a 'poses' list")
    if not isinstance(doc, dict):
        raise InputError(f"{name}: the top level must be a mapping with a 'poses' list, got {describe_value(doc)}")
    try:
        check_keys(doc, TOP_KEYS, " at top level")
    except PoseProblem as e:
        raise InputError(f"{name}: {e}") from None

    units = doc.get("units", None)
    length_unit, angle_unit = "m", "rad"
    if "units" in doc:
        if not isinstance(units, dict):
            raise InputError(f"{name}: units must be a mapping like {{length: mm, angle: deg}}, "
                             f"got {describe_value(units)}")
        try:
            check_keys(units, UNIT_KEYS, " in units")
        except PoseProblem as e:
            raise InputError(f"{name}: {e}") from None
        if "length" in units:
            length_unit = units["length"]
            if not isinstance(length_unit, str) or length_unit not in LENGTH_UNITS:
                shown = quote_text(length_unit) if isinstance(length_unit, str) else describe_value(length_unit)
                raise InputError(
                    f"{name}: unknown length unit {shown} (allowed: {', '.join(LENGTH_UNITS)})"
                )
        if "angle" in units:
            angle_unit = units["angle"]
            if not isinstance(angle_unit, str) or angle_unit not in ANGLE_UNITS:
                shown = quote_text(angle_unit) if isinstance(angle_unit, str) else describe_value(angle_unit)
                raise InputError(f"{name}: unknown angle unit {shown} (allowed: {', '.join(ANGLE_UNITS)})")
    scale = LENGTH_UNITS[length_unit]
    order = doc.get("quaternion_order")
    if "quaternion_order" in doc and order not in QUATERNION_ORDERS:
        raise InputError(f"{name}: quaternion_order must be one of {', '.join(QUATERNION_ORDERS)}, "
                         f"got {describe_value(order)}")
    reading = dict(angle=angle_unit if isinstance(units, dict) and "angle" in units else None, order=order,
                   length_given=isinstance(units, dict) and "length" in units)

    if "points" in doc or "poses" not in doc:
        return _point_document(doc, name, scale, length_unit, angle_unit, count, normalize, points, reading)
    poses = doc["poses"]
    if not isinstance(poses, list):
        raise InputError(f"{name}: 'poses' must be a list, got {describe_value(poses)}")
    if not poses:
        raise InputError(f"{name}: 'poses' is empty; give at least one pose")
    if len(poses) > MAX_POSES:
        raise InputError(f"{name}: {len(poses)} poses is more than the limit of {MAX_POSES}")
    if points is not None and any(is_point_spec(p) for p in poses):
        return _point_document(doc, name, scale, length_unit, angle_unit, count, normalize, points, reading)
    if count is not None:
        problem = _count_problem(count, len(poses))
        if problem:
            raise InputError(f"{name}: {problem}")

    names: list[str] = []
    named: list[bool] = []
    mats = np.empty((len(poses), 4, 4))
    first_with: dict[str, int] = {}
    for i, spec in enumerate(poses):
        pname = None
        if isinstance(spec, dict) and "name" in spec:
            raw = spec["name"]
            if not isinstance(raw, str):
                raise InputError(f"{name}: pose {i}: name must be a string, got {describe_value(raw)} (quote it)")
            if not raw.strip():
                raise InputError(f"{name}: pose {i}: name is empty")
            if any(not (c.isprintable() or c == " ") for c in raw):
                raise InputError(f"{name}: pose {i} ({quote_text(raw)}): name contains a control character")
            if len(raw) > 200:
                raise InputError(f"{name}: pose {i} ({quote_text(raw)}): name is longer than 200 characters")
            pname = raw
        label = _pose_label(i, pname)
        try:
            mats[i] = pose_matrix(spec, scale, reading["angle"], normalize, reading["order"])
        except PoseProblem as e:
            raise InputError(f"{name}: {label}: {e}") from None
        final = pname if pname is not None else default_name(i)
        if final in first_with:
            j = first_with[final]
            how = "" if named[j] else " by default"
            raise InputError(f"{name}: {label}: duplicate pose name {quote_text(final)} (pose {j} has it{how})")
        first_with[final] = i
        names.append(final)
        named.append(pname is not None)

    _believable_size(mats, name, reading["length_given"])
    labels = [_pose_label(i, n if k else None) for i, (n, k) in enumerate(zip(names, named))]
    return _with_task(doc, poses, ["pose"] * len(poses), labels, PoseSet(
        names=names, matrices=mats, length_unit=length_unit, angle_unit=angle_unit, length_scale=scale,
        source=name, named=named))


def _with_task(doc, items, kinds, labels, ps: PoseSet) -> PoseSet:
    """``ps`` with the task keys of ``doc`` (`synth.io.taskspec`: tolerance, velocity, order; constraints)."""
    ps.tolerance, ps.velocity, ps.order = task_fields(doc, items, kinds, labels, ps.source, ps.length_scale,
                                                      ps.angle_unit)
    ps.constraints = parse_constraints(doc.get("constraints"), source=ps.source, length_scale=ps.length_scale)
    return ps


def _believable_size(mats: np.ndarray, name: str, length_given: bool) -> None:
    """InputError when the file gives no length unit and its positions (``mats`` (n, 4, 4), metres) spread
    over more than 10 m or less than 10 µm (but not exactly one point): the numbers are most likely in
    another unit (a gripper task in mm read as metres became a 171 m linkage)."""
    if length_given:
        return
    p = mats[:, :3, 3]
    spread = float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))
    lo, hi = SIZE_RANGE_M
    if spread > hi or 1e-12 < spread < lo:
        what = "beyond 10 m" if spread > hi else "below 10 µm"
        raise InputError(f"{name}: read as metres, the positions spread over {spread:.3g} m (a linkage {what}) and "
                         "the file gives no length unit: add 'units: {length: mm}' (or cm, in; 'm' to confirm)")


def _point_document(doc, name, scale, length_unit, angle_unit, count, normalize, points, reading) -> PoseSet:
    """A document with points (docs/points.md): ``poses:`` entries (those with a position only are
    points), then the ``points:`` list ([x, y, z] or {name, position})."""
    if points is None:
        if "points" in doc:
            raise InputError(f"{name}: 'points' (a point task) is accepted by mpsynth bennett and mpsynth sixbar "
                             "only; this command needs poses with orientations")
        raise InputError(f"{name}: missing 'poses' (a list of poses)")
    items = []
    for key in ("poses", "points"):
        if key not in doc:
            continue
        lst = doc[key]
        if not isinstance(lst, list):
            raise InputError(f"{name}: {key!r} must be a list, got {describe_value(lst)}")
        items += [(key, spec) for spec in lst]
    if not items:
        raise InputError(f"{name}: missing 'poses' (a list of poses) or 'points' (a list of positions)")
    if len(items) > MAX_POSES:
        raise InputError(f"{name}: {len(items)} points is more than the limit of {MAX_POSES}")
    problem = _count_problem(points, len(items), "point")
    if problem:
        lo, hi, _ = _count_spec(points)
        hint = f" (fewer than {hi}: the design search chooses the rest)" if hi is not None and lo < hi else ""
        raise InputError(f"{name}: {problem} for a point task{hint}")
    names, named, kinds, labels, first_with = [], [], [], [], {}
    mats = np.repeat(np.eye(4)[None], len(items), axis=0)
    for i, (key, spec) in enumerate(items):
        pname = spec.get("name") if isinstance(spec, dict) else None
        if pname is not None and (not isinstance(pname, str) or not pname.strip() or len(pname) > 200
                                  or any(not (c.isprintable() or c == " ") for c in pname)):
            raise InputError(f"{name}: point {i}: name must be a non-empty printable string of at most 200 characters")
        point = key == "points" or is_point_spec(spec)
        noun = "point" if point else "pose"
        label = f"{noun} {i} ({quote_text(pname)})" if pname is not None else f"{noun} {i}"
        try:
            if point:
                mats[i, :3, 3] = point_position(spec, scale)
                kinds.append("point")
            else:
                mats[i] = pose_matrix(spec, scale, reading["angle"], normalize, reading["order"])
                kinds.append("pose")
        except PoseProblem as e:
            raise InputError(f"{name}: {label}: {e}") from None
        final = pname if pname is not None else default_name(i)
        if final in first_with:
            raise InputError(f"{name}: {label}: duplicate name {quote_text(final)} (item {first_with[final]} has it)")
        first_with[final] = i
        names.append(final)
        named.append(pname is not None)
        labels.append(label)
    _believable_size(mats, name, reading["length_given"])
    return _with_task(doc, [spec for _, spec in items], kinds, labels, PoseSet(
        names=names, matrices=mats, length_unit=length_unit, angle_unit=angle_unit, length_scale=scale,
        source=name, named=named, kinds=kinds))


def load_poses(source, *, count=None, normalize: bool = False, text: str | bytes | None = None,
               points=None) -> PoseSet:
    """Read and validate a pose file (YAML or JSON; ``"-"`` = standard input).

    ``text`` gives the content directly (``source`` then only names it in messages and decides
    JSON-vs-YAML by its ``.json`` suffix). ``points``: see `parse_pose_document`. ``count`` checks the
    number of poses: an int, or ``(n, label)`` giving ``"<label> needs exactly n poses, got m"``; ``n`` may also be a pair
    ``(lo, hi)`` (``hi`` None = no upper bound). ``normalize=True`` accepts non-unit quaternions
    (normalizing them) and projects rotations within 1e-3 of orthonormal onto the nearest rotation.

    Pose indices in messages are 0-based. Raises InputError (one line) on every problem.
    """
    name, content = read_source(source, text)
    raw_name = os.fspath(source) if source is not None else "-"
    force_json = raw_name.lower().endswith(".json")
    doc = load_document(content, name, force_json)
    return parse_pose_document(doc, source=name, count=count, normalize=normalize, points=points)
