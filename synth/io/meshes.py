"""Solid, watertight meshes of a linkage's physical design (`synth.design.model.PhysicalDesign`), each
in its own frame (metres).

A link with joints is ONE closed solid made of exactly the design's geometry (docs/design.md):
- its **bars**: a round bar with round ends (a capsule of the bar radius) along each segment of the
  bar's polyline, mount -> via points -> mount;
- its **hubs**: a cylinder of the hub radius and hub length around the joint axis at each mount;
- minus a **bore** through every hub along the axis: radius pin radius + hole clearance where the link
  turns on the pin, pin radius where it carries the pin (glued or pressed in).
Each joint's **pin** is a separate solid (a cylinder of the pin radius from the pin's start to its end
along the axis), written as ``meshes/pin_<joint>.stl`` and, in the URDF, a link ``pin_<joint>`` fixed
to its carrier link. Links with no joints (the loop duplicate ``coupler_k``) get no mesh.

Every vertex of a capsule lies on the true capsule and every cylinder lies inside the capsule of its
segment and radius (`synth.design.model.capsules`), so the capsules the collision search uses bound the
written solids from outside.

Default sizes scale with ``linkage.extent()`` (E, the RMS spread of the joints' feet and tool
positions): pin radius 0.02 E, bar radius 0.015 E, hub length 0.06 E (``--pin-length`` sets the hub
length: a joint's pin spans the hubs of its two links, so it is at least that long). The hole clearance
defaults to 0.2 mm (a common 3D-printing fit), but at most a tenth of the pin radius for tiny linkages.

The parts are combined with manifold3d into one closed 2-manifold, a valid solid for slicers and
physics engines; without manifold3d they are concatenated without bores (still closed shells).

Meshes are `solid.Solid` (numpy arrays): building, checking and writing them never imports trimesh
(whose import costs more than the whole rest of a run); ``link_meshes`` hands out trimesh objects
for the tools that want them.
"""
from __future__ import annotations

import math
import time

import numpy as np

from synth.design.model import PhysicalDesign, axis_point, capsules
from synth.design.layers import layered_design, parallel_axis
from synth.design.cranks import crank_bars
from synth.design.mixed import dominant_axis, mixed_design
from synth.design.search import DesignResult, design_linkage, natural_result
from synth.io.frames import link_origins
from synth.io.solid import (Solid, boolean, capsule, concatenate, degenerate_free, cylinder, import_manifold3d,
                            mass_properties, read_stl_triangles, signed_volume, stl_bytes, surface_defect, weld)
from synth.io.urdf import MESH_UNIT_SCALE, pin_link_name

PIN_RADIUS = 0.02  # times linkage.extent()
LINK_RADIUS = 0.015
HUB_LENGTH = 0.06
HOLE_CLEARANCE = 2e-4  # metres (0.2 mm) ...
HOLE_CLEARANCE_MAX_FRACTION = 0.1  # ... but at most this fraction of the pin radius
PIN_SECTIONS = 48  # pins, hubs and bores (same count: a pin's facets face its bore's)
BAR_SECTIONS = 32
DENSITY = 2700.0  # kg/m^3, aluminium


def _positive(name, v, allow_zero=False):
    try:
        ok = math.isfinite(float(v)) and (float(v) > 0 or (allow_zero and float(v) == 0))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        from synth.errors import InputError

        raise InputError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} length in metres, got {v!r}")
    return float(v)


def default_sizes(linkage, pin_radius=None, link_radius=None, pin_length=None) -> tuple[float, float, float]:
    """(pin_radius, bar radius, hub length) in metres: explicit values, or fractions of the extent.
    ``pin_length`` is the hub length (see the module docstring)."""
    e = linkage.extent()
    sizes = (
        PIN_RADIUS * e if pin_radius is None else pin_radius,
        LINK_RADIUS * e if link_radius is None else link_radius,
        HUB_LENGTH * e if pin_length is None else pin_length,
    )
    return tuple(_positive(name, v) for name, v in zip(("pin radius", "link radius", "pin length"), sizes))


def default_hole_clearance(pin_radius: float) -> float:
    """Radial clearance of a bore around its pin (metres): 0.2 mm, at most a tenth of the pin radius."""
    return min(HOLE_CLEARANCE, HOLE_CLEARANCE_MAX_FRACTION * pin_radius)


def design_for(linkage, pin_radius=None, link_radius=None, pin_length=None, hole_clearance=None,
               clearance=None, thin=True, **search) -> DesignResult:
    """The physical design of ``linkage`` (`synth.design.search.design_linkage`) with the given or default
    sizes (metres; see `default_sizes`, `default_hole_clearance`; clearance None: the search's default);
    ``search``: further arguments of `design_linkage` (ranges, full_seconds).

    Thinning (docs/design.md): when the search covered the task range and found no free design, and
    neither radius was given (``thin``), it is retried with the bar and pin radii of the default times
    `thin_scales` (hole clearance by its rule, default clearance with the bar) within `THIN_SECONDS` of
    CPU (none when the first search took over `THIN_FIRST_MAX`); the first free design is returned, its
    report's ``thinned`` saying so; else the default-size result.

    A partly planar linkage (`synth.design.mixed.dominant_axis`) gets, before all that, its parallel part
    layered and the rest searched around it (`synth.design.mixed.mixed_design`, within `LAYER_SECONDS`
    each); the rest follows only when that finds nothing (docs/design.md).

    Then, when that is still not free and the search covered the task range (docs/design.md): a planar
    linkage (every axis parallel) gets a layered design (`synth.design.layers.layered_design`, within
    `LAYER_SECONDS`), any other one cranked bars for the colliding bodies
    (`synth.design.cranks.crank_bars`, within `CRANK_SECONDS`); a certified free result replaces it
    (its report's ``cranked`` names the cranked bars, ``layers`` the levels of a layered design)."""
    partly_planar = dominant_axis(linkage) is not None and "task" in search.get("ranges", ("full", "task"))
    if partly_planar:  # straight bars in its planar part cross (as in a planar linkage): layers first
        first = mixed_design(linkage, _design(linkage, pin_radius, link_radius, pin_length, hole_clearance,
                                              clearance, search, natural=True), seconds=LAYER_SECONDS)
        if first.collision.free:
            return first
    result = _straight(linkage, pin_radius, link_radius, pin_length, hole_clearance, clearance, thin, search)
    if result.collision.free or "task" not in search.get("ranges", ("full", "task")):
        return result
    if parallel_axis(linkage) is not None:
        return layered_design(linkage, result, seconds=LAYER_SECONDS)
    if partly_planar:
        result.collision.message += " (a layering of its parallel joints was searched too)"
    return crank_bars(linkage, result, seconds=CRANK_SECONDS)


def _straight(linkage, pin_radius, link_radius, pin_length, hole_clearance, clearance, thin, search) -> DesignResult:
    """`design_for` with straight bars: the default sizes, then thinner ones."""
    hub = default_sizes(linkage, pin_radius, link_radius, pin_length)[2]
    result = _design(linkage, pin_radius, link_radius, hub, hole_clearance, clearance, search)
    if (not thin or result.collision.free or pin_radius is not None or link_radius is not None
            or "task" not in search.get("ranges", ("full", "task")) or result.collision.seconds > THIN_FIRST_MAX):
        return result
    pin0, bar0, _ = default_sizes(linkage)
    end = time.process_time() + THIN_SECONDS
    tried = None
    for s in thin_scales(bar0):
        left = end - time.process_time()
        if left <= 0:
            break
        r = _design(linkage, s * pin0, s * bar0, hub, hole_clearance, clearance, {**search, "seconds": left})
        if r.collision.free:
            r.collision.thinned = {"scale": s, "pin_radius": s * pin0, "bar_radius": s * bar0,
                                   "default_pin_radius": pin0, "default_bar_radius": bar0,
                                   "default_pairs": [p["bodies"] for p in result.collision.pairs]}
            return r
        tried = s
    if tried is not None:
        result.collision.message += f" (the search tried bars and pins down to {tried:g} x the default radii too)"
    return result


CRANK_SECONDS = 1.0  # CPU budget of the crank search after the straight bars failed
LAYER_SECONDS = 60.0  # time limit of the layering programme of a planar linkage (motion_elliptic: ~8 s)
THIN_SCALES = (0.5, 0.25)  # bar and pin radii tried, times the defaults, when the defaults collide
THIN_MIN_BAR_RADIUS = 4e-4  # metres: a bar 0.8 mm thick, two extrusion widths of a 0.4 mm nozzle
THIN_SECONDS = 1.0  # CPU budget of all the retries together (each search stops when it is spent)
THIN_FIRST_MAX = 2.0  # no retry after a first search this slow (CPU s): a retry's fixed costs (screening the
# starts, the certificate) scale like the first search's, so it would overrun its budget (multi-loop linkages)


def thin_scales(bar_radius: float) -> list[float]:
    """The scales of the default sizes retried when they collide: `THIN_SCALES`, each raised so the bar
    radius stays at least `THIN_MIN_BAR_RADIUS` (never above the default), without repeats (docs/design.md)."""
    out = []
    for s in THIN_SCALES:
        s = max(s, min(1.0, THIN_MIN_BAR_RADIUS / bar_radius))
        if s < 1.0 and (not out or s < out[-1]):
            out.append(s)
    return out


def _design(linkage, pin_radius, link_radius, hub_length, hole_clearance, clearance, search,
            natural=False) -> DesignResult:
    """`design_linkage` with the sizes resolved (defaults, validation); ``natural``: not searched, the
    natural stack with those sizes (`natural_result`)."""
    pin_radius, link_radius, hub_length = default_sizes(linkage, pin_radius, link_radius, hub_length)
    hole = default_hole_clearance(pin_radius) if hole_clearance is None else _positive(
        "hole clearance", hole_clearance, allow_zero=True)
    if clearance is not None:
        clearance = _positive("clearance", clearance, allow_zero=True)
    if natural:
        return natural_result(linkage, pin_radius=pin_radius, bar_radius=link_radius, hub_length=hub_length,
                              hole_clearance=hole, clearance=clearance)
    return design_linkage(linkage, pin_radius=pin_radius, bar_radius=link_radius, hub_length=hub_length,
                          hole_clearance=hole, clearance=clearance, **search)


def have_manifold() -> bool:
    """True when the manifold3d boolean engine is importable."""
    try:
        import_manifold3d()
    except ImportError:
        return False
    return True


def link_parts(linkage, design: PhysicalDesign, name: str) -> tuple[list[Solid], list[Solid]]:
    """(parts, bores) of link ``name``: closed meshes in world coordinates at the reference configuration.
    Parts: a capsule per bar segment, a cylinder per hub; bores: a cylinder per mount, along the axis,
    through the hub and the bar's round end. Both empty for a link without joints."""
    parts, bores = [], []
    carriers = {p.joint: p.carrier for p in design.pins}
    for c in capsules(linkage, design):
        if c.link != name or c.part == "pin":
            continue
        if c.part == "bar":
            parts.append(capsule(c.p0, c.p1, c.radius, BAR_SECTIONS))
        else:  # hub: the cylinder inside its capsule, and the bore through it
            # half a section turned against the bore: its cap spokes never run through the bore's corners
            parts.append(cylinder(c.p0, c.p1, c.radius, PIN_SECTIONS, phase=0.5))
            u = linkage.joint(c.joint).direction
            centre = (c.p0 + c.p1) / 2
            half = 1.01 * max(design.hub_length / 2, design.bar_radius) + 0.01 * design.hub_radius
            r = design.pin_radius + (0.0 if carriers.get(c.joint) == name else design.hole_clearance)
            bores.append(cylinder(centre - half * u, centre + half * u, r, PIN_SECTIONS))
    return parts, bores


def pin_origin(linkage, design: PhysicalDesign, joint: str) -> np.ndarray:
    """World position (3,) of the frame of link ``pin_<joint>`` at the reference configuration: the pin's
    midpoint (axes parallel to the world's, like every link frame)."""
    p = design.pin(joint)
    return axis_point(linkage, joint, (p.start + p.end) / 2)


def pin_solid(linkage, design: PhysicalDesign, joint: str) -> Solid:
    """The pin of ``joint`` in its own frame (`pin_origin`)."""
    p = design.pin(joint)
    a, b = axis_point(linkage, joint, p.start), axis_point(linkage, joint, p.end)
    return cylinder(a, b, design.pin_radius, PIN_SECTIONS).translated(-pin_origin(linkage, design, joint))


def _solid(parts, bores=()) -> Solid:
    if have_manifold():
        return boolean(parts, bores)
    return parts[0] if len(parts) == 1 else concatenate(parts)


def check_closed(mesh: Solid, what: str) -> None:
    """RuntimeError unless ``mesh`` is a closed oriented surface around a positive volume."""
    defect = surface_defect(mesh.faces)
    if defect is None and not signed_volume(mesh.triangles) > 0:
        defect = "no positive volume"
    if defect is not None:
        raise RuntimeError(f"{what} is not a closed solid ({defect})")


def design_solids(linkage, design: PhysicalDesign) -> dict[str, Solid]:
    """{URDF link name: Solid}: every link with joints (in its link frame) and every pin as link
    ``pin_<joint>`` (in its pin frame, `pin_origin`), metres. RuntimeError if one is not a closed solid."""
    origins = link_origins(linkage)
    out = {}
    for name in linkage.link_names:
        parts, bores = link_parts(linkage, design, name)
        if not parts:
            continue
        mesh = _solid(parts, bores).translated(-origins[name])
        check_closed(mesh, f"mesh of link {name}")
        out[name] = mesh
    for p in design.pins:
        mesh = pin_solid(linkage, design, p.joint)
        check_closed(mesh, f"mesh of pin {p.joint}")
        out[pin_link_name(p.joint)] = mesh
    return out


def link_solids(linkage, pin_radius=None, link_radius=None, pin_length=None, design=None) -> dict[str, Solid]:
    """`design_solids` of ``design`` (default: `design_for` with these sizes)."""
    if design is None:
        design = design_for(linkage, pin_radius, link_radius, pin_length).design
    return design_solids(linkage, design)


def link_meshes(linkage, pin_radius=None, link_radius=None, pin_length=None, design=None) -> dict:
    """{link name: trimesh.Trimesh}: `link_solids` as trimesh objects (imports trimesh)."""
    return {n: m.to_trimesh() for n, m in link_solids(linkage, pin_radius, link_radius, pin_length, design).items()}


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
    may be far away) in millimetres (``urdf.MESH_UNIT_SCALE``, the unit slicers assume); an edge shorter
    than a float32 step there is collapsed (`solid.degenerate_free`). The bytes are
    read back and checked to be a closed solid as a reader of the file sees it (float32 corners
    welded where bit-equal); RuntimeError otherwise."""
    offset = mesh.bounds.mean(axis=0)
    triangles = (mesh.triangles - offset) * (1.0 / MESH_UNIT_SCALE)
    stored = weld(triangles.astype(np.float32))  # as a reader sees the file
    keep = np.isin(np.arange(len(triangles)), degenerate_free(stored.faces))
    data = stl_bytes(triangles[keep])  # edges shorter than a float32 step collapsed
    check_closed(weld(read_stl_triangles(data)), f"{what} as written to STL")
    return data, offset
