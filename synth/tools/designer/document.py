"""The task file as the designer edits it: its parsed document, its scalar leaves, and the text written
back with the changed numbers put in place of the old ones (comments and layout kept).

A leaf is addressed by its path from the document's root: ``("poses", 1, "position", 0)``. Values are
in the task's own units (the file's), never converted: what the table shows is what the file says.
"""
from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from typing import Any

import yaml

from synth.errors import InputError
from synth.io.docload import load_document

Path_ = tuple  # a leaf's path: keys (str) and indices (int)
ITEM_KEYS = ("poses", "points")  # the lists of task items, in the order they are looked for


@dataclass(frozen=True, slots=True)
class Leaf:
    """One scalar of the document: its ``path``, ``value`` (number, bool or str) and the ``item`` index it
    belongs to (None: a document-level setting such as ``order``)."""

    path: tuple
    value: Any
    item: int | None


def parse(text: str, source: str) -> Any:
    """The document of a task file's ``text``, read as every task file is (`synth.io.docload`:
    InputError naming ``source`` when it is not YAML/JSON)."""
    return load_document(text, source, str(source).lower().endswith(".json"))


def items_key(doc: Any) -> str | None:
    """The key of the task's item list (``poses`` or ``points``), None when there is none."""
    if isinstance(doc, dict):
        return next((k for k in ITEM_KEYS if isinstance(doc.get(k), list)), None)
    return None


def leaves(doc: Any) -> list[Leaf]:
    """Every scalar of ``doc`` in document order, with the item it belongs to."""
    out: list[Leaf] = []
    key = items_key(doc)

    def walk(node, path, item):
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, path + (k,), item)
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, path + (i,), i if item is None and path == (key,) else item)
        else:
            out.append(Leaf(path, node, item))

    walk(doc, (), None)
    return out


def get(doc: Any, path: tuple) -> Any:
    node = doc
    for k in path:
        node = node[k]
    return node


def position_path(doc: Any, item: int) -> tuple | None:
    """The path of item ``item``'s position (a list of three numbers) or None when it has none that a
    drag can move (a 4x4 matrix pose, say)."""
    key = items_key(doc)
    if key is None or not 0 <= item < len(doc[key]):
        return None
    node = doc[key][item]
    if isinstance(node, dict) and _is_vec3(node.get("position")):
        return (key, item, "position")
    if _is_vec3(node):
        return (key, item)
    return None


def _is_vec3(v) -> bool:
    return isinstance(v, list) and len(v) == 3 and all(_is_number(x) for x in v)


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def with_value(doc: Any, path: tuple, value: Any) -> Any:
    """A copy of ``doc`` with the leaf at ``path`` set to ``value`` (InputError: no such leaf, or a value
    of another type than the old one: a number for a number, a bool for a bool, text for text)."""
    try:
        old = get(doc, path)
    except (KeyError, IndexError, TypeError):
        raise InputError(f"no value at {format_path(path)} in the task") from None
    if isinstance(old, (dict, list)):
        raise InputError(f"{format_path(path)} is not a single value")
    if _is_number(old):
        if not _is_number(value) or not math.isfinite(value):
            raise InputError(f"{format_path(path)} must be a finite number, got {value!r}")
    elif isinstance(old, bool) != isinstance(value, bool) or (isinstance(old, str) and not isinstance(value, str)):
        raise InputError(f"{format_path(path)} must be {type(old).__name__}, got {value!r}")
    new = copy.deepcopy(doc)
    parent = get(new, path[:-1])
    parent[path[-1]] = value
    return new


COMPONENTS = {"position": ("x", "y", "z"), "rpy": ("roll", "pitch", "yaw"), "axis": ("x", "y", "z")}


def label(path: tuple) -> str:
    """A short label of a leaf inside its item: ``position x``, ``rpy yaw``, ``tolerance.position``."""
    if len(path) >= 2 and path[-2] in COMPONENTS and isinstance(path[-1], int) and path[-1] < 3:
        return format_path(path[:-1]) + " " + COMPONENTS[path[-2]][path[-1]]
    return format_path(path)


def format_path(path: tuple) -> str:
    return ".".join(str(k) for k in path) or "(document)"


def format_number(x: float) -> str:
    """A number as written back: integral values without a decimal point, others as the shortest text
    that reads back as the same float."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if float(x).is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(float(x))


def dump(doc: Any, source: str) -> str:
    """The document as a whole new text (JSON for a ``.json`` source, else YAML in block style)."""
    if str(source).lower().endswith(".json"):
        return json.dumps(doc, indent=2) + "\n"
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, allow_unicode=True)


def write_back(text: str, old: Any, new: Any, source: str) -> tuple[str, bool]:
    """The text of ``new``: the original ``text`` (whose document is ``old``) with every changed scalar
    replaced where it stands, so comments and layout stay; when a change cannot be placed (a new key, a
    changed structure) the whole document dumped (`dump`). Returns (text, kept: whether the original
    layout and comments were kept)."""
    spans = _scalar_spans(text)
    edits = []
    new_leaves = {lf.path: lf.value for lf in leaves(new)}
    old_leaves = {lf.path: lf.value for lf in leaves(old)}
    if new_leaves.keys() != old_leaves.keys() or spans is None:
        return dump(new, source), False
    for path, value in new_leaves.items():
        if value == old_leaves[path] and type(value) is type(old_leaves[path]):
            continue
        if path not in spans or not (_is_number(value) or isinstance(value, bool)):
            return dump(new, source), False
        edits.append((*spans[path], format_number(value)))
    out = text
    for start, end, rep in sorted(edits, reverse=True):
        out = out[:start] + rep + out[end:]
    try:
        ok = parse(out, source) == new
    except InputError:
        ok = False
    return (out, True) if ok else (dump(new, source), False)


def _scalar_spans(text: str) -> dict[tuple, tuple[int, int]] | None:
    """path -> (start, end) character offsets of every plain scalar in ``text`` (None: not composable)."""
    try:
        root = yaml.compose(text)
    except yaml.YAMLError:
        return None
    spans: dict[tuple, tuple[int, int]] = {}

    def walk(node, path):
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                walk(v, path + (yaml.safe_load(k.value) if k.tag.endswith(":int") else k.value,))
        elif isinstance(node, yaml.SequenceNode):
            for i, v in enumerate(node.value):
                walk(v, path + (i,))
        elif isinstance(node, yaml.ScalarNode) and node.style is None:  # plain (unquoted) scalars only
            spans[path] = (node.start_mark.index, node.end_mark.index)

    if root is not None:
        walk(root, ())
    return spans


ITEM_FIELDS = ("tolerance", "exact", "velocity")  # what an item (a mapping) may gain (synth.io.posespec)
TOP_FIELDS = ("tolerance", "order")  # what the document may gain (synth.io.taskspec)


def addable(doc: Any, item: int | None) -> list[str]:
    """The task fields that item ``item`` (None: the document) does not have and may be given."""
    node = doc if item is None else (doc[items_key(doc)][item] if items_key(doc) else None)
    if not isinstance(node, dict):
        return []
    return [k for k in (TOP_FIELDS if item is None else ITEM_FIELDS) if k not in node]


def default_field(doc: Any, key: str, size: float) -> Any:
    """The value a new field starts with (then edited in the table): a tolerance of 1 % of the task's size
    ``size`` (task units, rounded) and 1 degree; ``exact``: true; a velocity along x of ``size`` per second;
    the listed order."""
    units = doc.get("units") if isinstance(doc, dict) else None
    degrees = isinstance(units, dict) and units.get("angle") == "deg"
    step = 10.0 ** math.floor(math.log10(max(0.01 * size, 1e-12)))
    return {"tolerance": {"position": float(format_number(step)), "angle": 1 if degrees else 0.0175},
            "exact": True, "velocity": {"linear": [float(format_number(size)), 0, 0]}, "order": "listed"}[key]


def with_field(doc: Any, item: int | None, key: str, size: float) -> Any:
    """A copy of ``doc`` whose item ``item`` (None: the document) has the new field ``key``
    (`default_field`); InputError when it may not have it."""
    if key not in addable(doc, item):
        raise InputError(f"{'the task' if item is None else f'item {item}'} cannot be given {key!r} here")
    new = copy.deepcopy(doc)
    node = new if item is None else new[items_key(new)][item]
    node[key] = default_field(doc, key, size)
    return new


def without_field(doc: Any, item: int | None, key: str) -> Any:
    """A copy of ``doc`` without the task field ``key`` of item ``item`` (None: the document)."""
    node = doc if item is None else (doc[items_key(doc)][item] if items_key(doc) else None)
    if not isinstance(node, dict) or key not in node or key not in (TOP_FIELDS if item is None else ITEM_FIELDS):
        raise InputError(f"{'the task' if item is None else f'item {item}'} has no {key!r} to remove")
    new = copy.deepcopy(doc)
    del (new if item is None else new[items_key(new)][item])[key]
    return new


def orientation_leaves(doc: Any, item: int, R, angle_unit: str | None) -> list[tuple[tuple, float]]:
    """The (path, value) leaves that give item ``item`` the rotation ``R`` (3x3) in the item's own
    orientation form: ``rpy`` (URDF roll-pitch-yaw), ``quaternion`` (mapping, or a list in the document's
    ``quaternion_order``), ``orientation`` (ROS {x, y, z, w}), ``axis_angle``, ``rotation`` (3x3 rows);
    angles in ``angle_unit`` ("deg" or radians). InputError when the item has none of these (a 4x4
    ``matrix`` pose, a point): its orientation is edited in the table."""
    import numpy as np

    from synth.algebra.dq import matrix_to_quat
    from synth.algebra.geometry import rotation_angle
    from synth.frames import rpy_from_matrix

    key = items_key(doc)
    node = doc[key][item] if key is not None and 0 <= item < len(doc[key]) else None
    form = next((k for k in ("rpy", "quaternion", "orientation", "axis_angle", "rotation")
                 if isinstance(node, dict) and k in node), None)
    if form is None:
        raise InputError(f"item {item} has no orientation that a drag can turn (a matrix or a point); edit it in "
                         "the table")
    base = (key, item, form)
    R = np.asarray(R, float)
    deg = (lambda a: math.degrees(a)) if angle_unit == "deg" else (lambda a: a)
    if form == "rpy":
        return [(base + (k,), deg(a)) for k, a in enumerate(rpy_from_matrix(R))]
    if form == "rotation":
        return [(base + (i, j), float(R[i, j])) for i in range(3) for j in range(3)]
    q = matrix_to_quat(R)
    q = q if q[0] >= 0 else -q
    wxyz = dict(zip("wxyz", (float(x) for x in q)))
    if form == "axis_angle":
        angle = float(rotation_angle(R))
        axis = q[1:] / max(float(np.linalg.norm(q[1:])), 1e-300) if angle > 1e-12 else np.array([0.0, 0.0, 1.0])
        return [(base + ("axis", k), float(axis[k])) for k in range(3)] + [(base + ("angle",), deg(angle))]
    value = node[form]
    if isinstance(value, dict):
        return [(base + (k,), wxyz[k]) for k in value if k in wxyz]
    order = "xyzw" if doc.get("quaternion_order") == "xyzw" else "wxyz"
    return [(base + (i,), wxyz[c]) for i, c in enumerate(order)]
