"""Read and validate pose files (docs/conventions.md, "Input and output contract").

A pose file is YAML (or JSON, which is parsed with the ``json`` module when the file name ends in
``.json`` or the text looks like a JSON object) of the form::

    units: {length: mm, angle: deg}          # optional; defaults m and rad
    poses:
      - name: pick                           # optional; default p0, p1, ...
        position: [100, 0, 250]
        quaternion: {w: 1, x: 0, y: 0, z: 0} # or a list [w, x, y, z]
      - position: [120, 50, 200]
        rpy: [0, 30, 45]                     # URDF fixed axes: R = Rz(yaw) Ry(pitch) Rx(roll)
      - position: [0, 0, 0]
        axis_angle: {axis: [0, 0, 1], angle: 90}
      - position: [0, 0, 0]
        rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
      - matrix: [[1, 0, 0, 100], [0, 1, 0, 0], [0, 0, 1, 300], [0, 0, 0, 1]]   # alone

Conventions of this module:

* **Pose indices are 0-based**, in the order the poses are listed, matching the default names
  ``p0, p1, ...``, the ``poses`` list of ``linkage.json`` and the T0, T1, ... of docs/conic.md and docs/cubic.md.
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

import difflib
import json
import math
import os
import re
import sys
from dataclasses import dataclass, field
from typing import Any, Iterable

import numpy as np
import yaml

from synth.algebra.dq import matrix_to_quat
from synth.errors import InputError

__all__ = [
    "PoseSet",
    "load_poses",
    "parse_pose_document",
    "pose_from_spec",
    "quaternion_matrix",
    "rpy_matrix",
    "axis_angle_matrix",
    "LENGTH_UNITS",
    "ANGLE_UNITS",
    "MAX_FILE_BYTES",
    "MAX_POSES",
]

#: metres per unit
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}
#: radians per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}

MAX_FILE_BYTES = 10 * 1024 * 1024
MAX_POSES = 10_000
MAX_ABS_NUMBER = 1e12  # any number in the file
MAX_POSITION_M = 1e9  # |position| after conversion to metres
MAX_YAML_NODES = 30 * MAX_POSES  # values in a YAML document (a pose has at most about 25)
MAX_MERGED_KEYS = 1000  # entries of one mapping after expanding YAML merge keys
UNIT_TOL = 1e-6  # quaternion length, orthonormality, last matrix row
PROJECT_TOL = 1e-3  # how far from orthonormal --normalize may project

TOP_KEYS = ("units", "poses")
UNIT_KEYS = ("length", "angle")
ORIENTATION_KEYS = ("quaternion", "rpy", "axis_angle", "rotation")
POSE_KEYS = ("name", "position") + ORIENTATION_KEYS + ("matrix",)
QUAT_KEYS = ("w", "x", "y", "z")
AXIS_ANGLE_KEYS = ("axis", "angle")


@dataclass
class PoseSet:
    """Validated poses. ``matrices`` (N, 4, 4) are in metres whatever the file's unit;
    ``length_scale`` is metres per input length unit; ``source`` is the display name."""

    names: list[str]
    matrices: np.ndarray
    length_unit: str = "m"
    angle_unit: str = "rad"
    length_scale: float = 1.0
    source: str = "<poses>"
    named: list[bool] = field(default_factory=list)  # which names were given in the file

    def __len__(self) -> int:
        return len(self.names)

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) positions in metres."""
        return self.matrices[:, :3, 3]

    @property
    def rotations(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices."""
        return self.matrices[:, :3, :3]

    def dual_quaternions(self) -> np.ndarray:
        """(N, 8) unit dual quaternions (docs/conventions.md convention), lengths in metres."""
        from synth.algebra.dq import pose_to_dq

        return pose_to_dq(self.matrices)


# ============================================================== message helpers
class _Problem(Exception):
    """A problem inside one pose or section, without the file/pose prefix."""


def _clean(text: str, limit: int = 200) -> str:
    """One-line, bounded rendering of arbitrary user text (escapes control characters)."""
    out = []
    for ch in str(text)[: limit + 1]:
        if ch.isprintable() or ch == " ":
            out.append(ch)
        else:
            out.append(ch.encode("unicode_escape").decode("ascii"))
    s = "".join(out)
    if len(s) > limit:
        s = s[:limit] + "..."
    return s


def _quote(text: str, limit: int = 60) -> str:
    return '"' + _clean(text, limit).replace('"', '\\"') + '"'


def _key(key: Any) -> str:
    if isinstance(key, str):
        return _quote(key, 40)
    if _is_scalar(key):
        return _clean(repr(key), 40)
    return _kind(key)


def _is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


def _num(x: float) -> str:
    return f"{x:.10g}"


def _kind(v: Any) -> str:
    """Short description of a value's type (bounded: never renders a whole structure)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return f"a boolean ({'true' if v else 'false'})"
    if isinstance(v, str):
        return f"a string ({_quote(v, 30)})"
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
            hint = f" (did you mean {_quote(close[0])}?)"
    if not hint:
        hint = " (allowed: " + ", ".join(allowed) + ")"
    return hint


def _check_keys(mapping: dict, allowed: tuple[str, ...], where: str) -> None:
    for k in mapping:
        if k not in allowed:
            raise _Problem(f"unknown key {_key(k)}{where}{_did_you_mean(k, allowed)}")


# ============================================================== numbers and shapes
def _number(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _Problem(f"{what} must be a number, got {_kind(v)}")
    if isinstance(v, float) and not math.isfinite(v):
        raise _Problem(f"{what} is not finite ({v})")
    if abs(v) > MAX_ABS_NUMBER:
        shown = _num(float(v)) if abs(v) < 1e300 else "a huge number"
        raise _Problem(f"{what} is too large ({shown}; the limit is 1e12 in absolute value)")
    return float(v)


def _vector(v: Any, n: int, what: str) -> np.ndarray:
    if not isinstance(v, (list, tuple)):
        raise _Problem(f"{what} must be a list of {n} numbers, got {_kind(v)}")
    if len(v) != n:
        raise _Problem(f"{what} must be a list of {n} numbers, got {_kind(v)}")
    return np.array([_number(x, f"{what}[{i}]") for i, x in enumerate(v)], dtype=float)


def _matrix(v: Any, n: int, what: str) -> np.ndarray:
    shape = f"a {n}x{n} matrix (a list of {n} rows of {n} numbers)"
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise _Problem(f"{what} must be {shape}, got {_kind(v)}")
    rows = []
    for r, row in enumerate(v):
        if not isinstance(row, (list, tuple)) or len(row) != n:
            raise _Problem(f"{what} must be {shape}, but row {r} is {_kind(row)}")
        rows.append([_number(x, f"{what}[{r}][{c}]") for c, x in enumerate(row)])
    return np.array(rows, dtype=float)


# ============================================================== rotations
def _sincos(angle: float, unit: str) -> tuple[float, float]:
    """sin and cos of an angle given in ``unit``; exact for multiples of 90 degrees."""
    if unit == "deg":
        q, r = divmod(angle, 90.0)
        if r == 0.0 and abs(q) < 2**52:
            return ((0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0))[int(q) % 4]
    a = angle * ANGLE_UNITS[unit]
    if a == 0.0:
        return 0.0, 1.0
    return math.sin(a), math.cos(a)


def quaternion_matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation matrix of the unit quaternion (w, x, y, z) (normalized here; must be nonzero)."""
    n = math.hypot(w, x, y, z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _rpy_from_sincos(sr, cr, sp, cp, sy, cy) -> np.ndarray:
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ Ry @ Rx


def rpy_matrix(roll: float, pitch: float, yaw: float, unit: str = "rad") -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll); angles in ``unit``."""
    sr, cr = _sincos(roll, unit)
    sp, cp = _sincos(pitch, unit)
    sy, cy = _sincos(yaw, unit)
    return _rpy_from_sincos(sr, cr, sp, cp, sy, cy)


def axis_angle_matrix(axis, angle: float, unit: str = "rad") -> np.ndarray:
    """Rodrigues' formula; ``axis`` is normalized here (must be nonzero)."""
    k = np.asarray(axis, dtype=float)
    k = k / math.hypot(*k)
    s, c = _sincos(angle, unit)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return c * np.eye(3) + s * K + (1.0 - c) * np.outer(k, k)


def _checked_rotation(R: np.ndarray, what: str, normalize: bool) -> np.ndarray:
    dev = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not math.isfinite(dev):  # pragma: no cover - entries are bounded, kept for safety
        raise _Problem(f"{what} is not a rotation")
    if dev > UNIT_TOL:
        if not normalize:
            hint = (
                " (fix it or use --normalize to project it onto the nearest rotation)"
                if dev <= PROJECT_TOL
                else ""
            )
            raise _Problem(
                f"{what} is not orthonormal (max |R^T R - I| = {_num(dev)}, tolerance 1e-6){hint}"
            )
        if dev > PROJECT_TOL:
            raise _Problem(
                f"{what} is too far from orthonormal to project (max |R^T R - I| = {_num(dev)}, "
                f"--normalize accepts up to 1e-3)"
            )
    det = float(np.linalg.det(R))
    if det < 0:
        raise _Problem(f"{what} has determinant {_num(det)} (a reflection); a rotation has determinant +1")
    if dev > 1e-15:
        # nearest rotation (SVD), then through a unit quaternion: orthonormal to a few ulps
        U, _, Vt = np.linalg.svd(R)
        R = quaternion_matrix(*matrix_to_quat(U @ Vt))
    return R


# ============================================================== one pose
def _parse_quaternion(v: Any, normalize: bool) -> np.ndarray:
    if isinstance(v, dict):
        _check_keys(v, QUAT_KEYS, " in quaternion")
        missing = [k for k in QUAT_KEYS if k not in v]
        if missing:
            raise _Problem(f"quaternion is missing {', '.join(_quote(k) for k in missing)} (give w, x, y, z)")
        q = [_number(v[k], f"quaternion.{k}") for k in QUAT_KEYS]
    elif isinstance(v, (list, tuple)):
        if len(v) != 4:
            raise _Problem(f"quaternion list must have 4 numbers [w, x, y, z], got {_kind(v)}")
        q = [_number(x, f"quaternion[{i}]") for i, x in enumerate(v)]
    else:
        raise _Problem(f"quaternion must be a mapping {{w, x, y, z}} or a list [w, x, y, z], got {_kind(v)}")
    n = math.hypot(*q)
    if n < 1e-12:
        raise _Problem(f"quaternion is zero (length {_num(n)}); it does not describe a rotation")
    if abs(n - 1.0) > UNIT_TOL and not normalize:
        raise _Problem(f"quaternion has length {_num(n)}, expected 1 (normalize it or use --normalize)")
    return quaternion_matrix(*q)


def _parse_axis_angle(v: Any, angle_unit: str) -> np.ndarray:
    if not isinstance(v, dict):
        raise _Problem(f"axis_angle must be a mapping {{axis: [x, y, z], angle: a}}, got {_kind(v)}")
    _check_keys(v, AXIS_ANGLE_KEYS, " in axis_angle")
    for k in AXIS_ANGLE_KEYS:
        if k not in v:
            raise _Problem(f"axis_angle is missing {_quote(k)}")
    axis = _vector(v["axis"], 3, "axis_angle.axis")
    angle = _number(v["angle"], "axis_angle.angle")
    if math.hypot(*axis) < 1e-12:
        raise _Problem("axis_angle.axis is zero; give a nonzero direction")
    return axis_angle_matrix(axis, angle, angle_unit)


def _pose_matrix(spec: Any, length_scale: float, angle_unit: str, normalize: bool) -> np.ndarray:
    if not isinstance(spec, dict):
        raise _Problem(
            f"a pose must be a mapping with 'position' and an orientation, or 'matrix', got {_kind(spec)}"
        )
    _check_keys(spec, POSE_KEYS, "")
    orient = [k for k in ORIENTATION_KEYS if k in spec]
    T = np.eye(4)
    if "matrix" in spec:
        others = [k for k in ("position",) + ORIENTATION_KEYS if k in spec]
        if others:
            raise _Problem(
                f"'matrix' must be alone, but the pose also has {', '.join(repr(k) for k in others)}"
            )
        M = _matrix(spec["matrix"], 4, "matrix")
        last = M[3]
        if float(np.max(np.abs(last - [0.0, 0.0, 0.0, 1.0]))) > UNIT_TOL:
            raise _Problem(
                f"matrix last row is [{', '.join(_num(x) for x in last)}], expected [0, 0, 0, 1]"
            )
        T[:3, :3] = _checked_rotation(M[:3, :3], "matrix rotation block", normalize)
        T[:3, 3] = M[:3, 3] * length_scale
        pos_what = "matrix translation"
    else:
        if len(orient) > 1:
            raise _Problem(
                f"two orientations given ({', '.join(repr(k) for k in orient)}); give exactly one"
            )
        if "position" not in spec:
            raise _Problem("missing 'position' (a list of 3 numbers)")
        if not orient:
            raise _Problem(
                "missing orientation: give one of 'quaternion', 'rpy', 'axis_angle', 'rotation' "
                "(or a 4x4 'matrix' alone)"
            )
        T[:3, 3] = _vector(spec["position"], 3, "position") * length_scale
        key = orient[0]
        val = spec[key]
        if key == "quaternion":
            R = _parse_quaternion(val, normalize)
        elif key == "rpy":
            rpy = _vector(val, 3, "rpy")
            R = rpy_matrix(*rpy, unit=angle_unit)
        elif key == "axis_angle":
            R = _parse_axis_angle(val, angle_unit)
        else:
            R = _checked_rotation(_matrix(val, 3, "rotation"), "rotation", normalize)
        T[:3, :3] = R
        pos_what = "position"
    dist = math.hypot(*T[:3, 3])
    if dist > MAX_POSITION_M:
        raise _Problem(f"{pos_what} is too far from the origin ({_num(dist)} m; the limit is 1e9 m)")
    return T


def pose_from_spec(
    spec: Any, *, length_unit: str = "m", angle_unit: str = "rad", normalize: bool = False
) -> np.ndarray:
    """The 4x4 pose (in metres) of one pose mapping as it appears in a pose file (the ``name`` key
    is allowed and ignored). Raises InputError with just the problem (no file/pose prefix)."""
    if length_unit not in LENGTH_UNITS:
        raise InputError(f"unknown length unit {_quote(str(length_unit))} (allowed: {', '.join(LENGTH_UNITS)})")
    if angle_unit not in ANGLE_UNITS:
        raise InputError(f"unknown angle unit {_quote(str(angle_unit))} (allowed: {', '.join(ANGLE_UNITS)})")
    try:
        return _pose_matrix(spec, LENGTH_UNITS[length_unit], angle_unit, normalize)
    except _Problem as e:
        raise InputError(str(e)) from None


# ============================================================== reading text
class _TooLarge(yaml.YAMLError):
    """The document is far larger than any pose file (raised while composing, before construction)."""


class _StrictSafeLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate keys and reads 1e-3 as a float.

    It also refuses, while the document is still being parsed, a list of more than ``MAX_POSES``
    items, more than ``MAX_YAML_NODES`` values in total (aliases included) and merge keys (``<<``)
    that would expand a mapping to more than ``MAX_MERGED_KEYS`` entries ("YAML bombs"): such
    documents otherwise take minutes and gigabytes before the pose limits could even be checked."""

    def compose_node(self, parent, index):
        self._mpsynth_nodes = getattr(self, "_mpsynth_nodes", 0) + 1
        if self._mpsynth_nodes > MAX_YAML_NODES:
            raise _TooLarge(f"{self._mark_text()}the document has more than {MAX_YAML_NODES} values; "
                            f"a pose file of {MAX_POSES} poses has far fewer, refusing to read further")
        if isinstance(index, int) and index >= MAX_POSES:  # the (index+1)-th item of a list
            raise _TooLarge(f"{self._mark_text()}a list has more than {MAX_POSES} items "
                            f"(at most {MAX_POSES} poses are accepted); refusing to read further")
        return super().compose_node(parent, index)

    def _mark_text(self) -> str:
        try:
            mark = self.peek_event().start_mark
            return f"line {mark.line + 1}: "
        except Exception:  # pragma: no cover - the message stays useful without a line
            return ""

    def flatten_mapping(self, node):
        if _merged_size(node, {}) > MAX_MERGED_KEYS:
            raise _TooLarge(f"line {node.start_mark.line + 1}: merge keys ('<<') expand a mapping to more than "
                            f"{MAX_MERGED_KEYS} entries; refusing to expand it")
        return super().flatten_mapping(node)

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    hash(key)
                except TypeError:
                    continue  # the base class reports unhashable keys
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        "while constructing a mapping",
                        node.start_mark,
                        f"found duplicate key {_clean(repr(key), 40)}",
                        key_node.start_mark,
                    )
                seen[key] = True
        return super().construct_mapping(node, deep=deep)


def _merged_size(node, memo: dict) -> int:
    """Number of entries ``node`` (a MappingNode) has once its merge keys are expanded; stops counting
    early above MAX_MERGED_KEYS. Shared (aliased) mappings are counted once per use, as the expansion
    copies them; ``memo`` keeps that linear in the number of nodes."""
    key = id(node)
    if key in memo:
        return memo[key]
    memo[key] = 0  # a mapping that merges itself is reported by the expansion (nested too deeply)
    n = 0
    for k, v in node.value:
        if k.tag != "tag:yaml.org,2002:merge":
            n += 1
            continue
        for sub in (v.value if isinstance(v, yaml.SequenceNode) else [v]):
            if isinstance(sub, yaml.MappingNode):
                n += _merged_size(sub, memo)
        if n > MAX_MERGED_KEYS:
            break
    memo[key] = n
    return n


_StrictSafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _yaml_error_message(e: Exception) -> str:
    mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
    problem = getattr(e, "problem", None) or getattr(e, "context", None) or str(e)
    problem = " ".join(str(problem).split())
    kind = "YAML syntax error" if isinstance(e, (yaml.scanner.ScannerError, yaml.parser.ParserError)) else "YAML error"
    if mark is not None:
        return f"{kind} at line {mark.line + 1}, column {mark.column + 1}: {_clean(problem)}"
    return f"YAML error: {_clean(problem)}"


def _looks_like_json(text: str) -> bool:
    return re.match(r"\s*(\{\s*(\"|\})|\[)", text) is not None


def json_object_pairs(pairs):
    """``object_pairs_hook`` for json.loads that rejects duplicate keys (docs/conventions.md: an input error)."""
    out = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"duplicate key {_quote(k, 40)}")
        out[k] = v
    return out


def _load_json(text: str, name: str) -> Any:
    try:
        return json.loads(text, object_pairs_hook=json_object_pairs)
    except json.JSONDecodeError as e:
        raise InputError(
            f"{name}: JSON syntax error at line {e.lineno}, column {e.colno}: {_clean(e.msg)}"
        ) from None
    except RecursionError:
        raise InputError(f"{name}: JSON is nested too deeply") from None
    except ValueError as e:
        raise InputError(f"{name}: JSON error: {_clean(' '.join(str(e).split()))}") from None


def _load_document(text: str, name: str, force_json: bool) -> Any:
    if force_json:
        return _load_json(text, name)
    json_err = None
    if _looks_like_json(text):
        try:
            return _load_json(text, name)
        except InputError as e:
            json_err = e
    try:
        return yaml.load(text, Loader=_StrictSafeLoader)  # noqa: S506 - a SafeLoader subclass
    except _TooLarge as e:
        raise InputError(f"{name}: {e}") from None
    except yaml.YAMLError as e:
        if json_err is not None:
            raise json_err from None
        raise InputError(f"{name}: {_yaml_error_message(e)}") from None
    except RecursionError:
        raise InputError(f"{name}: YAML is nested too deeply") from None
    except Exception as e:  # constructor errors on odd scalars (e.g. impossible dates)
        if json_err is not None:
            raise json_err from None
        raise InputError(f"{name}: YAML error: {_clean(' '.join(str(e).split()))}") from None


def _read_source(source, text: str | None) -> tuple[str, str]:
    """(display name, text)."""
    if source is None:
        source = "-"
    raw_name = os.fspath(source)
    name = "<stdin>" if raw_name == "-" else _clean(raw_name)
    if text is not None:
        if isinstance(text, bytes):
            data = text
        else:
            if len(text) > MAX_FILE_BYTES:
                raise InputError(f"{name}: file is larger than 10 MB; refusing to read it")
            data = text.encode("utf-8", "surrogatepass")
    elif raw_name == "-":
        stream = getattr(sys.stdin, "buffer", None)
        if stream is None:
            s = sys.stdin.read(MAX_FILE_BYTES + 1)
            data = s.encode("utf-8", "surrogatepass")
        else:
            data = stream.read(MAX_FILE_BYTES + 1)
    else:
        try:
            st = os.stat(raw_name)
            if st.st_size > MAX_FILE_BYTES:
                raise InputError(
                    f"{name}: file is {st.st_size / 1e6:.1f} MB, larger than the 10 MB limit; refusing to read it"
                )
            with open(raw_name, "rb") as f:
                data = f.read(MAX_FILE_BYTES + 1)
        except InputError:
            raise
        except FileNotFoundError:
            raise InputError(f"{name}: cannot read file: no such file") from None
        except IsADirectoryError:
            raise InputError(f"{name}: cannot read file: it is a directory") from None
        except PermissionError:
            raise InputError(f"{name}: cannot read file: permission denied") from None
        except (OSError, ValueError) as e:
            msg = getattr(e, "strerror", None) or str(e)
            raise InputError(f"{name}: cannot read file: {_clean(msg)}") from None
    if len(data) > MAX_FILE_BYTES:
        raise InputError(f"{name}: file is larger than 10 MB; refusing to read it")
    try:
        decoded = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(f"{name}: not UTF-8 text (bad byte at offset {e.start})") from None
    return name, decoded


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


def _count_problem(count, n: int) -> str | None:
    lo, hi, label = _count_spec(count)
    if lo <= n and (hi is None or n <= hi):
        return None
    if hi == lo:
        need = f"exactly {lo}"
    elif hi is None:
        need = f"at least {lo}"
    else:
        need = f"between {lo} and {hi}"
    noun = "pose" if (hi == lo == 1) else "poses"
    got = f"got {n}"
    return f"{label} needs {need} {noun}, {got}" if label else f"expected {need} {noun}, {got}"


def _pose_label(i: int, name: str | None) -> str:
    return f"pose {i} ({_quote(name)})" if name is not None else f"pose {i}"


def parse_pose_document(
    doc: Any, *, source: str = "<poses>", count=None, normalize: bool = False
) -> PoseSet:
    """Validate an already-parsed document (the structure YAML/JSON gives) into a PoseSet."""
    name = source
    if doc is None:
        raise InputError(f"{name}: the file is empty; expected a mapping with a 'poses' list")
    if not isinstance(doc, dict):
        raise InputError(f"{name}: the top level must be a mapping with a 'poses' list, got {_kind(doc)}")
    try:
        _check_keys(doc, TOP_KEYS, " at top level")
    except _Problem as e:
        raise InputError(f"{name}: {e}") from None

    units = doc.get("units", None)
    length_unit, angle_unit = "m", "rad"
    if "units" in doc:
        if not isinstance(units, dict):
            raise InputError(f"{name}: units must be a mapping like {{length: mm, angle: deg}}, got {_kind(units)}")
        try:
            _check_keys(units, UNIT_KEYS, " in units")
        except _Problem as e:
            raise InputError(f"{name}: {e}") from None
        if "length" in units:
            length_unit = units["length"]
            if not isinstance(length_unit, str) or length_unit not in LENGTH_UNITS:
                shown = _quote(length_unit) if isinstance(length_unit, str) else _kind(length_unit)
                raise InputError(
                    f"{name}: unknown length unit {shown} (allowed: {', '.join(LENGTH_UNITS)})"
                )
        if "angle" in units:
            angle_unit = units["angle"]
            if not isinstance(angle_unit, str) or angle_unit not in ANGLE_UNITS:
                shown = _quote(angle_unit) if isinstance(angle_unit, str) else _kind(angle_unit)
                raise InputError(f"{name}: unknown angle unit {shown} (allowed: {', '.join(ANGLE_UNITS)})")
    scale = LENGTH_UNITS[length_unit]

    if "poses" not in doc:
        raise InputError(f"{name}: missing 'poses' (a list of poses)")
    poses = doc["poses"]
    if not isinstance(poses, list):
        raise InputError(f"{name}: 'poses' must be a list, got {_kind(poses)}")
    if not poses:
        raise InputError(f"{name}: 'poses' is empty; give at least one pose")
    if len(poses) > MAX_POSES:
        raise InputError(f"{name}: {len(poses)} poses is more than the limit of {MAX_POSES}")
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
                raise InputError(f"{name}: pose {i}: name must be a string, got {_kind(raw)} (quote it)")
            if not raw.strip():
                raise InputError(f"{name}: pose {i}: name is empty")
            if any(not (c.isprintable() or c == " ") for c in raw):
                raise InputError(f"{name}: pose {i} ({_quote(raw)}): name contains a control character")
            if len(raw) > 200:
                raise InputError(f"{name}: pose {i} ({_quote(raw)}): name is longer than 200 characters")
            pname = raw
        label = _pose_label(i, pname)
        try:
            mats[i] = _pose_matrix(spec, scale, angle_unit, normalize)
        except _Problem as e:
            raise InputError(f"{name}: {label}: {e}") from None
        final = pname if pname is not None else f"p{i}"
        if final in first_with:
            j = first_with[final]
            how = "" if named[j] else " by default"
            raise InputError(f"{name}: {label}: duplicate pose name {_quote(final)} (pose {j} has it{how})")
        first_with[final] = i
        names.append(final)
        named.append(pname is not None)

    return PoseSet(
        names=names,
        matrices=mats,
        length_unit=length_unit,
        angle_unit=angle_unit,
        length_scale=scale,
        source=name,
        named=named,
    )


def load_poses(source, *, count=None, normalize: bool = False, text: str | bytes | None = None) -> PoseSet:
    """Read and validate a pose file (YAML or JSON; ``"-"`` = standard input).

    ``text`` gives the content directly (``source`` then only names it in messages and decides
    JSON-vs-YAML by its ``.json`` suffix). ``count`` checks the number of poses: an int, or
    ``(n, label)`` giving ``"<label> needs exactly n poses, got m"``; ``n`` may also be a pair
    ``(lo, hi)`` (``hi`` None = no upper bound). ``normalize=True`` accepts non-unit quaternions
    (normalizing them) and projects rotations within 1e-3 of orthonormal onto the nearest rotation.

    Pose indices in messages are 0-based. Raises InputError (one line) on every problem.
    """
    name, content = _read_source(source, text)
    raw_name = os.fspath(source) if source is not None else "-"
    force_json = raw_name.lower().endswith(".json")
    doc = _load_document(content, name, force_json)
    return parse_pose_document(doc, source=name, count=count, normalize=normalize)
