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

The parts are united with ``trimesh.boolean.union`` (manifold3d engine) into one closed 2-manifold,
a valid solid for slicers and physics engines; without manifold3d they are concatenated (still
watertight, but overlapping shells).

trimesh is imported inside the functions so that importing this module stays cheap.
"""
from __future__ import annotations

import math

import numpy as np

from ..linkage import pair_feet
from .frames import link_origins

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
            from ..errors import InputError

            raise InputError(f"{name} must be a positive length in metres, got {v!r}")
    return tuple(float(v) for v in sizes)


def have_manifold() -> bool:
    """True when trimesh's manifold3d boolean engine is importable."""
    try:
        import manifold3d  # noqa: F401
    except ImportError:
        return False
    return True


def _cylinder(a, b, radius, sections):
    """Closed cylinder from point a to point b."""
    import trimesh

    a = np.asarray(a, float)
    b = np.asarray(b, float)
    axis = b - a
    height = float(np.linalg.norm(axis))
    T = np.eye(4)
    T[:3, :3] = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis / height)[:3, :3]
    T[:3, 3] = (a + b) / 2
    # built at unit radius, then scaled: trimesh merges vertices closer than 1e-8 at creation, which
    # would destroy micrometre-sized cylinders
    mesh = trimesh.creation.cylinder(radius=1.0, height=height / radius, sections=sections)
    mesh.apply_scale(radius)
    mesh.apply_transform(T)
    return mesh


def link_parts(linkage, name, pin_radius, link_radius, pin_length):
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
            bars.append(_cylinder(f1, f2, link_radius, BAR_SECTIONS))
    pins = []
    for j in joints:
        pts = feet[j.name] or [linkage.joint_sites()[j.name]]
        s = [float(np.dot(p - j.point, j.direction)) for p in pts]
        lo = j.point + (min(s) - pin_length / 2) * j.direction
        hi = j.point + (max(s) + pin_length / 2) * j.direction
        pins.append(_cylinder(lo, hi, pin_radius, PIN_SECTIONS))
    return pins + bars


def _solid(parts):
    import trimesh

    if len(parts) == 1:
        return parts[0]
    if have_manifold():
        # Unite at unit size around the origin: trimesh's and manifold's absolute tolerances would
        # otherwise reject micrometre-sized parts or parts far from the world origin.
        lo = np.min([p.bounds[0] for p in parts], axis=0)
        hi = np.max([p.bounds[1] for p in parts], axis=0)
        centre, size = (lo + hi) / 2, float(np.max(hi - lo))
        unit = [p.copy() for p in parts]
        for p in unit:
            p.apply_translation(-centre)
            p.apply_scale(1.0 / size)
        mesh = trimesh.boolean.union(unit, engine="manifold")
        mesh.apply_scale(size)
        mesh.apply_translation(centre)
        return mesh
    return trimesh.util.concatenate(parts)


def link_meshes(linkage, pin_radius=None, link_radius=None, pin_length=None) -> dict:
    """{link name: trimesh.Trimesh} for every link with joints, each in its own link frame (metres)."""
    pin_radius, link_radius, pin_length = default_sizes(linkage, pin_radius, link_radius, pin_length)
    origins = link_origins(linkage)
    out = {}
    for name in linkage.link_names:
        parts = link_parts(linkage, name, pin_radius, link_radius, pin_length)
        if not parts:
            continue
        mesh = _solid(parts)
        mesh.apply_translation(-origins[name])
        if not mesh.is_watertight or not mesh.volume > 0:
            raise RuntimeError(f"mesh of link {name} is not a closed solid")
        out[name] = mesh
    return out


def mesh_inertials(meshes: dict, density: float = DENSITY) -> dict:
    """{link: (mass kg, centre of mass (3,), inertia 3x3 about the centre of mass, link axes)}."""
    out = {}
    for name, mesh in meshes.items():
        mp = _mass_properties(mesh, density)
        out[name] = (float(mp["mass"]), np.asarray(mp["center_mass"], float), np.asarray(mp["inertia"], float))
    return out


def _mass_properties(mesh, density):
    from trimesh.triangles import mass_properties

    return mass_properties(triangles=mesh.triangles, density=density, skip_inertia=False)
