"""The one URDF parser of the readers of an output directory (`synth.io.readback`): a URDF file ->
`UrdfModel`, just what the readers, `mpsynth check` and the simulators need: links, joints (origin,
unit axis, limits), the ``<gazebo><joint type="fixed">`` loop-closure welds, mesh references (filename,
scale, origin, colour), inertials, and forward kinematics by plain 4x4 products.

Parsed with ``xml.etree`` into our own small model: nothing here trusts the synthesis code. An
unreadable or non-XML file raises InputError; anything else wrong is listed in ``UrdfModel.problems``
(one line each, prefixed ``URDF:``), so `mpsynth check` can report them all and the strict reader can
refuse the file with the first one. Lengths in metres, angles in radians (docs/conventions.md).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.errors import InputError
from synth.algebra.geometry import rotation_about_axis
from synth.frames import rpy_matrix


@dataclass
class UJoint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray  # 4x4, joint frame in the parent link frame
    axis: np.ndarray  # unit axis in the joint (= child link) frame
    axis_raw: np.ndarray
    limit: tuple | None = None  # (lower, upper) for revolute joints


@dataclass
class UMesh:
    link: str
    tag: str  # visual | collision
    filename: str
    scale: np.ndarray
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))  # geometry frame in the link frame
    rgba: tuple | None = None  # colour of a visual (its own <color> or a named top-level <material>)


@dataclass
class UrdfModel:
    """Just what the checks need from a URDF file."""

    name: str
    links: list[str]
    joints: dict[str, UJoint]
    closures: list[tuple[str, str, str]]  # (weld name, parent link, child link)
    meshes: list[UMesh]
    problems: list[str] = field(default_factory=list)
    order: list[str] = field(default_factory=list)  # joints in topological order from base
    inertials: dict = field(default_factory=dict)  # link -> (mass, 4x4 inertial frame, 3x3 inertia)
    parent_joint: dict[str, str] = field(default_factory=dict)  # child link -> joint name

    def path(self, link: str) -> list[str]:
        """Joint names from base to ``link``."""
        out, seen = [], set()
        while link in self.parent_joint and link not in seen:
            seen.add(link)
            jn = self.parent_joint[link]
            out.append(jn)
            link = self.joints[jn].parent
        return out[::-1]

    def fk(self, cfg: dict, n: int | None = None) -> dict[str, np.ndarray]:
        """World frames of every reachable link, (4, 4) or (n, 4, 4) when ``n`` is given; ``cfg`` maps
        joint names to angles (scalars or arrays of length n), missing joints are 0."""
        if n is None:
            return self._fk1(cfg)
        m = n
        frames = {"base": np.broadcast_to(np.eye(4), (m, 4, 4)).copy()}
        for jn in self.order:
            j = self.joints[jn]
            F = frames[j.parent] @ j.origin
            if j.kind in ("revolute", "continuous"):
                q = np.broadcast_to(np.asarray(cfg.get(jn, 0.0), float), (m,))
                M = np.zeros((m, 4, 4))
                M[:, :3, :3] = rotation_about_axis(j.axis, q)
                M[:, 3, 3] = 1.0
                F = F @ M
            elif j.kind == "prismatic":
                q = np.broadcast_to(np.asarray(cfg.get(jn, 0.0), float), (m,))
                M = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
                M[:, :3, 3] = q[:, None] * j.axis
                F = F @ M
            frames[j.child] = F
        return frames

    def _fk1(self, cfg: dict) -> dict[str, np.ndarray]:
        """`fk` for one configuration (the continuation's inner loop: plain 4x4 products)."""
        frames = {"base": np.eye(4)}
        for jn in self.order:
            j = self.joints[jn]
            F = frames[j.parent] @ j.origin
            q = float(cfg.get(jn, 0.0))
            if j.kind in ("revolute", "continuous") and q != 0.0:
                x, y, z = j.axis
                c, s = math.cos(q), math.sin(q)
                C = 1.0 - c
                M = np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s, 0.0],
                              [y * x * C + z * s, c + y * y * C, y * z * C - x * s, 0.0],
                              [z * x * C - y * s, z * y * C + x * s, c + z * z * C, 0.0],
                              [0.0, 0.0, 0.0, 1.0]])
                F = F @ M
            elif j.kind == "prismatic" and q != 0.0:
                M = np.eye(4)
                M[:3, 3] = q * j.axis
                F = F @ M
            frames[j.child] = F
        return frames


def _floats(text, count, what, problems):
    try:
        vals = [float(v) for v in (text or "").split()]
    except ValueError:
        vals = []
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        problems.append(f"URDF: {what} is {text!r}, expected {count} finite numbers")
        return None
    return vals


def _origin(el, what, problems) -> np.ndarray:
    """4x4 transform of an <origin xyz rpy> element (identity when absent)."""
    T = np.eye(4)
    if el is None:
        return T
    xyz = _floats(el.get("xyz", "0 0 0"), 3, f"{what} xyz", problems)
    rpy = _floats(el.get("rpy", "0 0 0"), 3, f"{what} rpy", problems)
    if xyz is not None and rpy is not None:
        T[:3, :3] = rpy_matrix(*rpy)
        T[:3, 3] = xyz
    return T


def _colour(mat, materials: dict, link: str, problems) -> tuple | None:
    """rgba of a visual's <material>: its own <color>, else the named top-level material."""
    if mat is None:
        return None
    c = mat.find("color")
    if c is None:
        return materials.get(mat.get("name"))
    rgba = _floats(c.get("rgba", "0.5 0.5 0.5 1"), 4, f"visual colour of link {link}", problems)
    return tuple(rgba) if rgba is not None else None


def read_urdf(path) -> UrdfModel:
    """Parse a URDF file into a `UrdfModel`. An unreadable or non-XML file raises InputError; anything
    else wrong is listed in ``problems``."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror or e})") from None
    except ET.ParseError as e:
        raise InputError(f"{path}: not well-formed XML ({e})") from None
    if root.tag != "robot":
        raise InputError(f"{path}: root element is <{root.tag}>, expected <robot>")
    problems: list[str] = []
    links, meshes, inertials = _read_links(root, problems)
    joints: dict[str, UJoint] = {}
    parent_joint: dict[str, str] = {}
    for el in root.findall("joint"):
        j = _read_joint(el, links, joints, problems)
        if j is None:
            continue
        if j.child in parent_joint:
            problems.append(f"URDF: link {j.child} has two parents (joints {parent_joint[j.child]} and {j.name})")
            continue
        parent_joint[j.child] = j.name
        joints[j.name] = j
    roots = [lk for lk in links if lk not in parent_joint]
    if roots != ["base"]:
        problems.append(f"URDF: root link(s) {roots}, expected exactly ['base']")
    order = _tree_order(links, joints, problems)
    return UrdfModel(root.get("name", ""), links, joints, _read_closures(root, problems), meshes, problems, order,
                     inertials, parent_joint)


def _read_links(root, problems: list) -> tuple[list[str], list[UMesh], dict]:
    """(link names, meshes of their visuals and collisions, {link: (mass, origin 4x4, inertia 3x3)})."""
    links: list[str] = []
    meshes: list[UMesh] = []
    inertials: dict = {}
    materials: dict[str, tuple] = {}
    for m in root.findall("material"):
        c = m.find("color")
        if m.get("name") and c is not None:
            rgba = _floats(c.get("rgba", "0.5 0.5 0.5 1"), 4, f"colour of material {m.get('name')}", problems)
            if rgba is not None:
                materials[m.get("name")] = tuple(rgba)
    for el in root.findall("link"):
        name = _unique_name(el, "link", links, problems)
        if name is None:
            continue
        links.append(name)
        for tag in ("visual", "collision"):
            for part in el.findall(tag):
                m = part.find("geometry/mesh")
                if m is None:
                    continue
                scale = _floats(m.get("scale", "1 1 1"), 3, f"mesh scale of link {name}", problems)
                meshes.append(UMesh(name, tag, m.get("filename", ""), np.array(scale or [1.0, 1.0, 1.0]),
                                    _origin(part.find("origin"), f"{tag} origin of link {name}", problems),
                                    _colour(part.find("material"), materials, name, problems)))
        inertial = el.find("inertial")
        if inertial is not None:
            value = _inertial(inertial, name, problems)
            if value is not None:
                inertials[name] = value
    return links, meshes, inertials


def _inertial(inertial, name: str, problems: list) -> tuple | None:
    """(mass, origin 4x4, inertia 3x3) of an <inertial> of link ``name``, or None (a problem noted)."""
    mass_el, I_el = inertial.find("mass"), inertial.find("inertia")
    mass = _floats(mass_el.get("value") if mass_el is not None else None, 1, f"mass of link {name}", problems)
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    vals = _floats(" ".join(I_el.get(k, "0") for k in keys) if I_el is not None else None, 6,
                   f"inertia of link {name}", problems)
    if mass is None or vals is None:
        return None
    ixx, ixy, ixz, iyy, iyz, izz = vals
    I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return mass[0], _origin(inertial.find("origin"), f"inertial origin of link {name}", problems), I


def _read_joint(el, links: list, joints: dict, problems: list) -> UJoint | None:
    """The `UJoint` of a <joint> element, or None (a problem noted) when it cannot be one."""
    name, kind = _unique_name(el, "joint", joints, problems), el.get("type")
    if name is None:
        return None
    p, c = el.find("parent"), el.find("child")
    parent = p.get("link") if p is not None else None
    child = c.get("link") if c is not None else None
    if not parent or not child:
        problems.append(f"URDF: joint {name} lacks a parent or child link")
        return None
    bad = [lk for lk in (parent, child) if lk not in links]
    if bad:
        problems.append(f"URDF: joint {name} names missing link(s) {', '.join(bad)}")
        return None
    if kind not in ("revolute", "continuous", "prismatic", "fixed"):
        problems.append(f"URDF: joint {name} has type {kind!r} (expected continuous, revolute or fixed)")
        return None
    n_before = len(problems)
    T = _origin(el.find("origin"), f"origin of joint {name}", problems)
    a = el.find("axis")
    axis = _floats(a.get("xyz", "1 0 0") if a is not None else "1 0 0", 3, f"axis of joint {name}", problems)
    if axis is None or len(problems) > n_before:
        return None
    axis = np.array(axis)
    if kind != "fixed" and not np.linalg.norm(axis) > 0:
        problems.append(f"URDF: joint {name} has a zero axis")
        return None
    limit = None
    lim = el.find("limit")
    if kind == "revolute" and lim is not None:
        limit = (float(lim.get("lower", "0")), float(lim.get("upper", "0")))
    unit = axis / np.linalg.norm(axis) if np.linalg.norm(axis) > 0 else axis
    return UJoint(name, kind, parent, child, T, unit, axis, limit)


def _tree_order(links: list, joints: dict, problems: list) -> list[str]:
    """The joints in topological order from base; links not reached (in a cycle or under another root)
    are a problem."""
    order, reached, frontier = [], {"base"}, ["base"]
    children: dict[str, list[str]] = {}
    for jn, j in joints.items():
        children.setdefault(j.parent, []).append(jn)
    while frontier:
        nxt = []
        for lk in frontier:
            for jn in children.get(lk, []):
                order.append(jn)
                reached.add(joints[jn].child)
                nxt.append(joints[jn].child)
        frontier = nxt
    lost = [lk for lk in links if lk not in reached]
    if lost and "base" in links:
        problems.append(f"URDF: link(s) {', '.join(lost)} not connected to base")
    return order


def _read_closures(root, problems: list) -> list[tuple[str, str, str]]:
    """(name, parent, child) of every fixed <gazebo> joint: the loop-closure welds."""
    closures = []
    for g in root.findall("gazebo"):
        for el in g.findall("joint"):
            if el.get("type") != "fixed":
                continue
            p, c = el.find("parent"), el.find("child")
            if p is None or c is None or not (p.text or "").strip() or not (c.text or "").strip():
                problems.append(f"URDF: <gazebo> joint {el.get('name')} lacks <parent> or <child>")
                continue
            closures.append((el.get("name") or "", p.text.strip(), c.text.strip()))
    return closures


def _unique_name(el, what: str, seen, problems: list) -> str | None:
    """The name of a <link> or <joint> element, or None (a problem noted) when missing or repeated."""
    name = el.get("name")
    if not name:
        problems.append(f"URDF: a <{what}> has no name")
        return None
    if name in seen:
        problems.append(f"URDF: {what} {name} is defined twice")
        return None
    return name
