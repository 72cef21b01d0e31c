"""One pose of a pose file: units, numbers, rotations (docs/conventions.md, pose files).

``pose_matrix(spec, length_scale, angle_unit, normalize)`` turns one pose mapping (``position`` and one
of ``quaternion``, ``rpy``, ``axis_angle``, ``rotation``; or a 4x4 ``matrix`` alone) into a 4x4 pose in
metres, raising `PoseProblem` with just the problem (the caller adds the file and pose);
``pose_from_spec`` is the same with a one-line InputError. Rotation matrices are orthonormal to double
precision: quaternions are normalized, given rotations that pass the 1e-6 test are projected onto the
nearest rotation (SVD), angles that are exact multiples of 90 degrees get exact sines and cosines.
The message helpers (`describe_value`, `check_keys`) keep every message one bounded line.
"""
from __future__ import annotations

import difflib
import math
from typing import Any, Iterable

import numpy as np

from synth.algebra.dq import matrix_to_quat, quat_to_matrix
from synth.algebra.geometry import rotation_about_axis_sincos
from synth.errors import InputError
from synth.io.docload import clean_text, quote_text
from synth.frames import rpy_from_sincos

#: metres per unit
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}
#: radians per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}

MAX_ABS_NUMBER = 1e12  # any number in the file
MAX_POSITION_M = 1e9  # |position| after conversion to metres
UNIT_TOL = 1e-6  # quaternion length, orthonormality, last matrix row
PROJECT_TOL = 1e-3  # how far from orthonormal --normalize may project

ORIENTATION_KEYS = ("quaternion", "orientation", "rpy", "axis_angle", "rotation")  # orientation: ROS {x, y, z, w}
TASK_ITEM_KEYS = ("tolerance", "exact", "velocity")  # read by synth.io.taskspec
POSE_KEYS = ("name", "position") + ORIENTATION_KEYS + ("matrix",) + TASK_ITEM_KEYS
QUAT_KEYS = ("w", "x", "y", "z")
XYZ_KEYS = ("x", "y", "z")
QUATERNION_ORDERS = ("wxyz", "xyzw")  # of a bare quaternion list (the document's quaternion_order)
TWO_PI = 2.0 * math.pi
AXIS_ANGLE_KEYS = ("axis", "angle")


# ============================================================== message helpers
class PoseProblem(Exception):
    """A problem inside one pose or section, without the file/pose prefix."""


def _key(key: Any) -> str:
    if isinstance(key, str):
        return quote_text(key, 40)
    if _is_scalar(key):
        return clean_text(repr(key), 40)
    return describe_value(key)


def _is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


def _num(x: float) -> str:
    return f"{x:.10g}"


def describe_value(v: Any) -> str:
    """Short description of a value's type (bounded: never renders a whole structure)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return f"a boolean ({'true' if v else 'false'})"
    if isinstance(v, str):
        return f"a string ({quote_text(v, 30)})"
    if isinstance(v, float):
        return f"the number {_num(v)}"
    if isinstance(v, int):
        return f"the number {v}" if abs(v) < 10**30 else "a huge number"
    if isinstance(v, (list, tuple)):
        return f"a list of {len(v)} item{'s' if len(v) != 1 else ''}"
    if isinstance(v, dict):
        return "a mapping"
    return f"a value of type {type(v).__name__}"


def _did_you_mean(key: Any, allowed: Iterable[str]) -> str:
    allowed = list(allowed)
    hint = ""
    if isinstance(key, str):
        close = difflib.get_close_matches(key.lower(), allowed, n=1, cutoff=0.6)
        if close:
            hint = f"did you mean {quote_text(close[0])}? "
    return f" ({hint}valid keys: {', '.join(allowed)})"


def check_keys(mapping: dict, allowed: tuple[str, ...], where: str) -> None:
    for k in mapping:
        if k not in allowed:
            raise PoseProblem(f"unknown key {_key(k)}{where}{_did_you_mean(k, allowed)}")


# ============================================================== numbers and shapes
def _number(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise PoseProblem(f"{what} must be a number, got {describe_value(v)}")
    if isinstance(v, float) and not math.isfinite(v):
        raise PoseProblem(f"{what} is not finite ({v})")
    if abs(v) > MAX_ABS_NUMBER:
        shown = _num(float(v)) if abs(v) < 1e300 else "a huge number"
        raise PoseProblem(f"{what} is too large ({shown}; the limit is 1e12 in absolute value)")
    return float(v)


def _vector(v: Any, n: int, what: str) -> np.ndarray:
    if type(v) is list and len(v) == n and all(type(x) is float and -MAX_ABS_NUMBER <= x <= MAX_ABS_NUMBER for x in v):
        return np.array(v, dtype=float)  # (the common case: what `_number` accepts unchanged, in one pass)
    if not isinstance(v, (list, tuple)):
        raise PoseProblem(f"{what} must be a list of {n} numbers, got {describe_value(v)}")
    if len(v) != n:
        raise PoseProblem(f"{what} must be a list of {n} numbers, got {describe_value(v)}")
    return np.array([_number(x, f"{what}[{i}]") for i, x in enumerate(v)], dtype=float)


def _matrix(v: Any, n: int, what: str) -> np.ndarray:
    shape = f"a {n}x{n} matrix (a list of {n} rows of {n} numbers)"
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise PoseProblem(f"{what} must be {shape}, got {describe_value(v)}")
    rows = []
    for r, row in enumerate(v):
        if not isinstance(row, (list, tuple)) or len(row) != n:
            raise PoseProblem(f"{what} must be {shape}, but row {r} is {describe_value(row)}")
        rows.append([_number(x, f"{what}[{r}][{c}]") for c, x in enumerate(row)])
    return np.array(rows, dtype=float)


number, vector = _number, _vector  # public names for synth.io.taskspec


# ============================================================== rotations
def sincos_exact(angles, unit: str) -> tuple[np.ndarray, np.ndarray]:
    """sin and cos (arrays) of angles (an array) given in ``unit``; exact for multiples of 90 degrees."""
    x = np.asarray(angles, float)
    with np.errstate(invalid="ignore"):
        a = x * ANGLE_UNITS[unit]
        s, c = np.array(np.sin(a)), np.array(np.cos(a))  # (arrays also for a single angle)
        s += 0.0  # (sin -0 is +0 here, as for an angle of 0)
        if unit == "deg":
            q, r = np.divmod(x, 90.0)
            exact = (r == 0.0) & (np.abs(q) < 2**52)
            if exact.any():
                k = np.where(exact, q, 0.0) % 4
                np.copyto(s, _QUARTER_SIN[k.astype(int)], where=exact)
                np.copyto(c, _QUARTER_COS[k.astype(int)], where=exact)
    return s, c


_QUARTER_SIN, _QUARTER_COS = np.array([0.0, 1.0, 0.0, -1.0]), np.array([1.0, 0.0, -1.0, 0.0])  # at k quarter turns


def quaternion_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation matrix of the unit quaternion (w, x, y, z) (normalized here; must be nonzero)."""
    return quat_to_matrix(np.array([w, x, y, z], float))


def rpy_matrix_exact(roll: float, pitch: float, yaw: float, unit: str = "rad") -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll); angles in ``unit``, exact for multiples
    of 90 degrees (`synth.frames.rpy_matrix`: radians)."""
    return rpy_matrices_exact(np.array([roll, pitch, yaw], float), unit)


def rpy_matrices_exact(rpy, unit: str = "rad") -> np.ndarray:
    """`rpy_matrix_exact` of roll-pitch-yaw triples (..., 3) in ``unit``: rotations (..., 3, 3), each the
    same bits as one call (`sincos_exact`, elementwise)."""
    s, c = sincos_exact(rpy, unit)
    return rpy_from_sincos(s[..., 0], c[..., 0], s[..., 1], c[..., 1], s[..., 2], c[..., 2])


def rpy_poses(numbers, length_scale, angle_unit: str | None) -> tuple[np.ndarray, np.ndarray]:
    """Poses given as ``position`` and ``rpy`` lists, many at once: ``numbers`` (N, k, 6) (x, y, z in the
    length unit, roll, pitch, yaw in ``angle_unit``; None: none given, radians), ``length_scale`` (N,) metres
    per unit. Returns (ok (N,), poses (N, k, 4, 4) metres): ``ok[n]`` when every pose of row n passes
    `pose_matrix`'s checks with a margin (finite numbers within MAX_ABS_NUMBER, angles within 2 pi without a
    unit, positions well inside MAX_POSITION_M), its poses then the same bits as `pose_matrix` gives; rows
    not ok are to be read by `pose_matrix` (which says what is wrong, or decides at the margin)."""
    x = np.asarray(numbers, float)
    with np.errstate(invalid="ignore"):
        ok = np.all(np.abs(x) <= MAX_ABS_NUMBER, axis=(1, 2))  # (NaN compares false)
        if angle_unit is None:
            ok &= np.all(np.abs(x[..., 3:]) <= TWO_PI, axis=(1, 2))
        p = x[..., :3] * np.asarray(length_scale, float)[:, None, None]
        ok &= np.all(np.sqrt(np.sum(p * p, axis=-1)) < 0.5 * MAX_POSITION_M, axis=1)
    T = np.zeros(x.shape[:2] + (4, 4))
    T[:, :, 3, 3] = 1.0
    T[ok, :, :3, 3] = p[ok]
    T[ok, :, :3, :3] = rpy_matrices_exact(x[ok][..., 3:], angle_unit or "rad")
    return ok, T


def axis_angle_matrix(axis, angle: float, unit: str = "rad") -> np.ndarray:
    """Rodrigues' formula (`synth.algebra.geometry.rotation_about_axis`); ``axis`` is normalized here (must be
    nonzero)."""
    k = np.asarray(axis, dtype=float)
    s, c = sincos_exact(angle, unit)
    return rotation_about_axis_sincos(k / math.hypot(*k), float(s), float(c))


def _checked_rotation(R: np.ndarray, what: str, normalize: bool) -> np.ndarray:
    dev = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not math.isfinite(dev):  # pragma: no cover - entries are bounded, kept for safety
        raise PoseProblem(f"{what} is not a rotation")
    if dev > UNIT_TOL:
        if not normalize:
            hint = (
                " (fix it or use --normalize to project it onto the nearest rotation)"
                if dev <= PROJECT_TOL
                else ""
            )
            raise PoseProblem(
                f"{what} is not orthonormal (max |R^T R - I| = {_num(dev)}, tolerance 1e-6){hint}"
            )
        if dev > PROJECT_TOL:
            raise PoseProblem(
                f"{what} is too far from orthonormal to project (max |R^T R - I| = {_num(dev)}, "
                f"--normalize accepts up to 1e-3)"
            )
    det = float(np.linalg.det(R))
    if det < 0:
        raise PoseProblem(f"{what} has determinant {_num(det)} (a reflection); a rotation has determinant +1")
    if dev > 1e-15:
        # nearest rotation (SVD), then through a unit quaternion: orthonormal to a few ulps
        U, _, Vt = np.linalg.svd(R)
        R = quaternion_matrix(*matrix_to_quat(U @ Vt))
    return R


# ============================================================== one pose
def _parse_quaternion(v: Any, normalize: bool, order: str | None = None, key: str = "quaternion") -> np.ndarray:
    """A unit quaternion given as a mapping {w, x, y, z} (any key order; ``orientation`` is ROS's
    {x, y, z, w}) or, for ``quaternion``, a bare list in the document's ``order`` (None: ambiguous, an
    error)."""
    if isinstance(v, dict):
        check_keys(v, QUAT_KEYS, f" in {key}")
        missing = [k for k in QUAT_KEYS if k not in v]
        if missing:
            raise PoseProblem(f"{key} is missing {', '.join(quote_text(k) for k in missing)} (give w, x, y, z)")
        q = [_number(v[k], f"{key}.{k}") for k in QUAT_KEYS]
    elif isinstance(v, (list, tuple)) and key == "quaternion":
        if len(v) != 4:
            raise PoseProblem(f"quaternion list must have 4 numbers, got {describe_value(v)}")
        q = [_number(x, f"quaternion[{i}]") for i, x in enumerate(v)]
        if order is None:
            raise PoseProblem("a bare quaternion list is ambiguous (w, x, y, z or ROS's x, y, z, w): add "
                              "'quaternion_order: wxyz' (or xyzw) at the top level, or write {w: .., x: .., y: .., z: ..}")
        if order == "xyzw":
            q = q[3:] + q[:3]
    else:
        raise PoseProblem(f"{key} must be a mapping {{w, x, y, z}}"
                          f"{' or a list (see quaternion_order)' if key == 'quaternion' else ''}, "
                          f"got {describe_value(v)}")
    n = math.hypot(*q)
    if n < 1e-12:
        raise PoseProblem(f"quaternion is zero (length {_num(n)}); it does not describe a rotation")
    if abs(n - 1.0) > UNIT_TOL and not normalize:
        raise PoseProblem(f"quaternion has length {_num(n)}, expected 1 (normalize it or use --normalize)")
    return quaternion_matrix(*q)


def _angles(values, what: str, angle_unit: str | None) -> None:
    """PoseProblem when no angle unit was given (``angle_unit`` None) and an angle is beyond 2 pi: it is
    most likely in degrees, and reading it as radians would be a silent guess."""
    if angle_unit is None:
        for i, a in enumerate(np.atleast_1d(values)):
            if abs(a) > TWO_PI + 1e-9:
                at = f"{what}[{i}]" if np.ndim(values) else what
                raise PoseProblem(f"{at} is {_num(float(a))}, beyond 2 pi, and the file gives no angle unit: add "
                                  "'units: {angle: deg}' (or {angle: rad})")


def _position(v: Any) -> np.ndarray:
    """A position as a list [x, y, z] or a (ROS) mapping {x, y, z}."""
    if isinstance(v, dict):
        check_keys(v, XYZ_KEYS, " in position")
        missing = [k for k in XYZ_KEYS if k not in v]
        if missing:
            raise PoseProblem(f"position is missing {', '.join(quote_text(k) for k in missing)} (give x, y, z)")
        return np.array([_number(v[k], f"position.{k}") for k in XYZ_KEYS])
    return _vector(v, 3, "position")


def _parse_axis_angle(v: Any, angle_unit: str | None) -> np.ndarray:
    if not isinstance(v, dict):
        raise PoseProblem(f"axis_angle must be a mapping {{axis: [x, y, z], angle: a}}, got {describe_value(v)}")
    check_keys(v, AXIS_ANGLE_KEYS, " in axis_angle")
    for k in AXIS_ANGLE_KEYS:
        if k not in v:
            raise PoseProblem(f"axis_angle is missing {quote_text(k)}")
    axis = _vector(v["axis"], 3, "axis_angle.axis")
    angle = _number(v["angle"], "axis_angle.angle")
    _angles(angle, "axis_angle.angle", angle_unit)
    if math.hypot(*axis) < 1e-12:
        raise PoseProblem("axis_angle.axis is zero; give a nonzero direction")
    return axis_angle_matrix(axis, angle, angle_unit or "rad")


def pose_matrix(spec: Any, length_scale: float, angle_unit: str | None, normalize: bool,
                order: str | None = "wxyz") -> np.ndarray:
    """The 4x4 pose (metres) of one pose mapping. ``angle_unit`` None: the file gives none (radians, but
    an angle beyond 2 pi is refused); ``order``: of a bare quaternion list (None: refused)."""
    if not isinstance(spec, dict):
        raise PoseProblem(
            f"a pose must be a mapping with 'position' and an orientation, or 'matrix', got {describe_value(spec)}"
        )
    check_keys(spec, POSE_KEYS, "")
    orient = [k for k in ORIENTATION_KEYS if k in spec]
    T = np.eye(4)
    if "matrix" in spec:
        others = [k for k in ("position",) + ORIENTATION_KEYS if k in spec]
        if others:
            raise PoseProblem(
                f"'matrix' must be alone, but the pose also has {', '.join(repr(k) for k in others)}"
            )
        M = _matrix(spec["matrix"], 4, "matrix")
        last = M[3]
        if float(np.max(np.abs(last - [0.0, 0.0, 0.0, 1.0]))) > UNIT_TOL:
            raise PoseProblem(
                f"matrix last row is [{', '.join(_num(x) for x in last)}], expected [0, 0, 0, 1]"
            )
        T[:3, :3] = _checked_rotation(M[:3, :3], "matrix rotation block", normalize)
        T[:3, 3] = M[:3, 3] * length_scale
        pos_what = "matrix translation"
    else:
        if len(orient) > 1:
            raise PoseProblem(
                f"two orientations given ({', '.join(repr(k) for k in orient)}); give exactly one"
            )
        if "position" not in spec:
            raise PoseProblem("missing 'position' (a list of 3 numbers)")
        if not orient:
            raise PoseProblem(
                "missing orientation: give one of 'quaternion', 'orientation', 'rpy', 'axis_angle', 'rotation' "
                "(or a 4x4 'matrix' alone)"
            )
        T[:3, 3] = _position(spec["position"]) * length_scale
        key = orient[0]
        val = spec[key]
        if key in ("quaternion", "orientation"):
            R = _parse_quaternion(val, normalize, order, key)
        elif key == "rpy":
            rpy = _vector(val, 3, "rpy")
            _angles(rpy, "rpy", angle_unit)
            R = rpy_matrix_exact(*rpy, unit=angle_unit or "rad")
        elif key == "axis_angle":
            R = _parse_axis_angle(val, angle_unit)
        else:
            R = _checked_rotation(_matrix(val, 3, "rotation"), "rotation", normalize)
        T[:3, :3] = R
        pos_what = "position"
    dist = math.hypot(*T[:3, 3])
    if dist > MAX_POSITION_M:
        raise PoseProblem(f"{pos_what} is too far from the origin ({_num(dist)} m; the limit is 1e9 m)")
    return T


def point_position(spec: Any, length_scale: float) -> np.ndarray:
    """The position (metres) of one point of a point task (docs/points.md): a list ``[x, y, z]`` or a
    mapping with ``position`` (and optionally ``name``) and no orientation. Raises `PoseProblem`."""
    if isinstance(spec, dict):
        check_keys(spec, ("name", "position") + TASK_ITEM_KEYS, " of a point")
        if "position" not in spec:
            raise PoseProblem("missing 'position' (a list of 3 numbers)")
        spec = spec["position"]
        what = "position"
    else:
        what = "point"
    p = _vector(spec, 3, what) * length_scale
    dist = math.hypot(*p)
    if dist > MAX_POSITION_M:
        raise PoseProblem(f"{what} is too far from the origin ({_num(dist)} m; the limit is 1e9 m)")
    return p


def is_point_spec(spec: Any) -> bool:
    """A ``poses:`` entry that prescribes a position only (a point of a point task)."""
    return isinstance(spec, dict) and "position" in spec and not any(k in spec for k in ORIENTATION_KEYS + ("matrix",))


def pose_from_spec(
    spec: Any, *, length_unit: str = "m", angle_unit: str = "rad", normalize: bool = False
) -> np.ndarray:
    """The 4x4 pose (in metres) of one pose mapping as it appears in a pose file (the ``name`` key
    is allowed and ignored). Raises InputError with just the problem (no file/pose prefix)."""
    if length_unit not in LENGTH_UNITS:
        raise InputError(f"unknown length unit {quote_text(str(length_unit))} (allowed: {', '.join(LENGTH_UNITS)})")
    if angle_unit not in ANGLE_UNITS:
        raise InputError(f"unknown angle unit {quote_text(str(angle_unit))} (allowed: {', '.join(ANGLE_UNITS)})")
    try:
        return pose_matrix(spec, LENGTH_UNITS[length_unit], angle_unit, normalize)
    except PoseProblem as e:
        raise InputError(str(e)) from None


# the value checks under public names, for the other sections of a task file (synth.io.constraints)
number, vector, matrix = _number, _vector, _matrix
