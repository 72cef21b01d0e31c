"""Solid, watertight link meshes for a `Linkage`, each in its link's own frame (metres).

A link that carries joints gets
- one cylindrical *pin* per joint axis, along the axis, long enough to cover every foot of a common
  normal that this link uses on that axis plus ``pin_length / 2`` on each side, and
- one round *bar* per pair of consecutive joints of the link (``linkage.links[name]``), along the
  common normal of the two axes, from foot to foot (skipped when the axes meet).
For parallel axes the common normal is not unique; we take the one through the midpoint of the
two joints' foot points (``Joint.point``). Links with no joints (the loop duplicate ``coupler_k``)
get no mesh.

Default sizes scale with ``linkage.extent()`` (E, the RMS spread of the joints' feet and tool
positions): pin radius 0.02 E, bar radius 0.015 E, pin length 0.15 E. Explicit values (metres)
override them.

The parts are united with manifold3d into one closed 2-manifold, a valid solid for slicers and
physics engines; without manifold3d they are concatenated (still closed, but overlapping shells).

Meshes are `solid.Solid` (numpy arrays): building, checking and writing them never imports trimesh
(whose import costs more than the whole rest of a run); ``link_meshes`` hands out trimesh objects
for the tools that want them.
"""
from __future__ import annotations

import math

import numpy as np

from synth.linkage import pair_feet
from synth.io.frames import link_origins
from synth.io.solid import (Solid, concatenate, cylinder, import_manifold3d, mass_properties, read_stl_triangles,
                    signed_volume, stl_bytes, surface_defect, union, weld)
from synth.io.urdf import MESH_UNIT_SCALE

PIN_RADIUS = 0.02  # times linkage.extent()
LINK_RADIUS = 0.015
PIN_LENGTH = 0.15
PIN_SECTIONS = 48
BAR_SECTIONS = 32
DENSITY = 2700.0  # kg/m^3, aluminium


def default_sizes(linkage, pin_radius=None, link_radius=None, pin_length=None) -> tuple[float, float, float]:
    """(pin_radius, link_radius, pin_length) in metres: explicit values, or fractions of the extent."""
    e = linkage.extent()
    sizes = (
        PIN_RADIUS * e if pin_radius is None else pin_radius,
        LINK_RADIUS * e if link_radius is None else link_radius,
        PIN_LENGTH * e if pin_length is None else pin_length,
    )
    for name, v in zip(("pin radius", "link radius", "pin length"), sizes):
        try:
            ok = math.isfinite(float(v)) and float(v) > 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            from synth.errors import InputError

            raise InputError(f"{name} must be a positive length in metres, got {v!r}")
    return tuple(float(v) for v in sizes)


def have_manifold() -> bool:
    """True when the manifold3d boolean engine is importable."""
    try:
        import_manifold3d()
    except ImportError:
        return False
    return True


def link_parts(linkage, name, pin_radius, link_radius, pin_length) -> list[Solid]:
    """Closed primitive meshes (pins, bars) of one link, in world coordinates at the reference
    configuration. Empty for a link without joints."""
    names = list(linkage.links.get(name, []))
    joints = [linkage.joint(n) for n in names]
    if not joints:
        return []
    scale = max(linkage.extent(), pin_radius)
    feet: dict[str, list[np.ndarray]] = {n: [] for n in names}
    bars = []
    for j1, j2 in zip(joints, joints[1:]):
        f1, f2 = pair_feet(j1, j2)
        feet[j1.name].append(f1)
        feet[j2.name].append(f2)
        if np.linalg.norm(f2 - f1) > 1e-9 * scale:
            bars.append(cylinder(f1, f2, link_radius, BAR_SECTIONS))
    pins = []
    for j in joints:
        pts = feet[j.name] or [linkage.joint_sites()[j.name]]
        s = [float(np.dot(p - j.point, j.direction)) for p in pts]
        lo = j.point + (min(s) - pin_length / 2) * j.direction
        hi = j.point + (max(s) + pin_length / 2) * j.direction
        pins.append(cylinder(lo, hi, pin_radius, PIN_SECTIONS))
    return pins + bars


def _solid(parts) -> Solid:
    if len(parts) == 1:
        return parts[0]
    return union(parts) if have_manifold() else concatenate(parts)


def check_closed(mesh: Solid, what: str) -> None:
    """RuntimeError unless ``mesh`` is a closed oriented surface around a positive volume."""
    defect = surface_defect(mesh.faces)
    if defect is None and not signed_volume(mesh.triangles) > 0:
        defect = "no positive volume"
    if defect is not None:
        raise RuntimeError(f"{what} is not a closed solid ({defect})")


def link_solids(linkage, pin_radius=None, link_radius=None, pin_length=None) -> dict[str, Solid]:
    """{link name: Solid} for every link with joints, each in its own link frame (metres)."""
    pin_radius, link_radius, pin_length = default_sizes(linkage, pin_radius, link_radius, pin_length)
    origins = link_origins(linkage)
    out = {}
    for name in linkage.link_names:
        parts = link_parts(linkage, name, pin_radius, link_radius, pin_length)
        if not parts:
            continue
        mesh = _solid(parts).translated(-origins[name])
        check_closed(mesh, f"mesh of link {name}")
        out[name] = mesh
    return out


def link_meshes(linkage, pin_radius=None, link_radius=None, pin_length=None) -> dict:
    """{link name: trimesh.Trimesh}: `link_solids` as trimesh objects (imports trimesh)."""
    return {n: m.to_trimesh() for n, m in link_solids(linkage, pin_radius, link_radius, pin_length).items()}


def mesh_inertials(meshes: dict, density: float = DENSITY) -> dict:
    """{link: (mass kg, centre of mass (3,), inertia 3x3 about the centre of mass, link axes)} of
    closed meshes (`Solid` or anything with ``vertices`` and ``faces``)."""
    out = {}
    for name, mesh in meshes.items():
        triangles = np.asarray(mesh.vertices, float)[np.asarray(mesh.faces)]
        mass, com, inertia = mass_properties(triangles, density)
        out[name] = (float(mass), com, inertia)
    return out


def stl_file(mesh: Solid, what: str = "mesh") -> tuple[bytes, np.ndarray]:
    """(binary STL, offset): the mesh stored about its own centre ``offset`` (bounding-box centre,
    metres, link frame; STL is single precision and the base link's frame is the world frame, which
    may be far away) in millimetres (``urdf.MESH_UNIT_SCALE``, the unit slicers assume). The bytes are
    read back and checked to be a closed solid as a reader of the file sees it (float32 corners
    welded where bit-equal); RuntimeError otherwise."""
    offset = mesh.bounds.mean(axis=0)
    data = stl_bytes((mesh.triangles - offset) * (1.0 / MESH_UNIT_SCALE))
    check_closed(weld(read_stl_triangles(data)), f"{what} as written to STL")
    return data, offset
