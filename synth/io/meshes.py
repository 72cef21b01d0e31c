"""Solid, watertight meshes of a linkage's physical design (`synth.design.model.PhysicalDesign`), each
in its own frame (metres).

A link with joints is ONE closed solid made of exactly the design's geometry (docs/design.md):
- its **bars**: a round bar with round ends (a capsule of the bar radius) along each segment of the
  bar's polyline, mount -> via points -> mount;
- its **hubs**: a cylinder of the hub radius and hub length around the joint axis at each mount;
- minus a **bore** through every hub along the axis: radius pin radius + hole clearance where the link
  turns on the pin, pin radius where it carries the pin (glued or pressed in);
- on the base, its **mounting plate** (`synth.design.mounting`): a box minus its screw holes (and, for a
  flange on a hub, the bore continued through it).
Each joint's **pin** is a separate solid (a cylinder of the pin radius from the pin's start to its end
along the axis), written as ``meshes/pin_<joint>.stl`` and, in the URDF, a link ``pin_<joint>`` fixed
to its carrier link. Links with no joints (the loop duplicate ``coupler_k``) get no mesh.

Every vertex of a capsule lies on the true capsule and every cylinder lies inside the capsule of its
segment and radius (`synth.design.model.capsules`), so the capsules the collision search uses bound the
written solids from outside.

The sizes (pin, bar and hub radii, hole clearance) are the design's (`synth.design.choose`).

The parts are combined with manifold3d into one closed 2-manifold, a valid solid for slicers and
physics engines; without manifold3d they are concatenated without bores (still closed shells). Coaxial
cylinders need no boolean: a pin (shaft, head, groove) and the bores of a link on one axis line (a bore,
its continuation along the pin, a counterbore) are each their stepped profile revolved (`coaxial_groups`,
`solid.revolution`; the same union, to 1e-8 of the volume: bench/RESULTS.md, "Output jobs, fourth pass"),
as linkage.step builds them.

Meshes are `solid.Solid` (numpy arrays): building, checking and writing them never imports trimesh
(whose import costs more than the whole rest of a run); ``link_meshes`` hands out trimesh objects
for the tools that want them.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.design.model import PhysicalDesign, PinEnds, axis_point, capsules, pin_ends  # noqa: F401  (PinEnds: what pin_ends returns)
from synth.frames import link_origins
from synth.io.solid import (READER_GRID, Solid, boolean, box, capsule, concatenate, degenerate_free, cylinder,
                            import_manifold3d, mass_properties, read_stl_triangles, revolution, signed_volume, stl_bytes,
                            surface_defect, weld)
from synth.io.names import MESH_UNIT_SCALE, pin_link_name

PIN_SECTIONS = 48  # pins, hubs and bores (same count: a pin's facets face its bore's)
BAR_SECTIONS = 32
DENSITY = 2700.0  # kg/m^3, aluminium


def have_manifold() -> bool:
    """True when the manifold3d boolean engine is importable."""
    try:
        import_manifold3d()
    except ImportError:
        return False
    return True


@dataclass(frozen=True)
class Primitive:
    """One solid the parts of a link are built from, in world coordinates at the reference configuration
    (metres): a ``"capsule"`` (round bar with round ends) or a ``"cylinder"`` (flat ends) of ``radius``
    around the segment ``p0``-``p1``, or a ``"box"``: the rectangle of half-edge vectors ``edges`` (2, 3)
    centred at ``p0`` extruded to ``p1`` (`solid.box`); ``phase``: where a cylinder's facets start
    (`solid.cylinder`). The STL (`link_parts`) and the STEP (`synth.io.step`) build the same primitives."""

    kind: str
    p0: np.ndarray
    p1: np.ndarray
    radius: float
    phase: float = 0.0
    edges: np.ndarray | None = None


PRESS_INTERFERENCE = 5e-5  # metres, radial: a press fit of a printed pin (at most 2 % of the pin radius)


def link_primitives(linkage, design: PhysicalDesign, name: str, sites=None,
                    caps=None) -> tuple[list[Primitive], list[Primitive]]:
    """(parts, bores) of link ``name``. Parts: a capsule per bar segment, a cylinder per hub; bores: a
    cylinder per mount, along the axis, through the hub and the bar's round end (the carrier's smaller
    by `PRESS_INTERFERENCE` for a press fit), continued along the rest of the pin (`_pin_span_bores`),
    and a counterbore where a pin's head or clip sits on this
    link's hub. Both empty for a link without joints. ``caps``: the design's `capsules` when at hand."""
    sites = linkage.joint_sites() if sites is None else sites
    parts, bores = [], []
    carriers = {p.joint: p.carrier for p in design.pins}
    press = min(PRESS_INTERFERENCE, 0.02 * design.pin_radius) if design.pin_fit == "press" else 0.0
    for c in capsules(linkage, design, sites) if caps is None else caps:
        if c.link != name or c.part in ("pin", "plate"):
            continue
        if c.part == "bar":
            parts.append(Primitive("capsule", c.p0, c.p1, c.radius))
        else:  # hub: the cylinder inside its capsule, and the bore through it
            # half a section turned against the bore: its cap spokes never run through the bore's corners
            parts.append(Primitive("cylinder", c.p0, c.p1, c.radius, phase=0.5))
            u = linkage.joint(c.joint).direction
            centre = (c.p0 + c.p1) / 2
            half = 1.01 * max(design.hub_length / 2, design.bar_radius) + 0.01 * design.hub_radius
            r = design.pin_radius - press if carriers.get(c.joint) == name else design.pin_radius + design.hole_clearance
            ends = pin_ends(linkage, design, c.joint, sites) if c.joint in carriers else None
            if ends is not None and name in ends.blind:  # a closed face: the bore stops past the pin's end
                w = ends.outward[name]
                pin = design.pin(c.joint)
                stop = axis_point(linkage, c.joint, pin.end if np.dot(u, w) > 0 else pin.start, sites)  # its tip
                bores.append(Primitive("cylinder", centre - half * w, stop + design.hole_clearance * w, r))
            else:
                bores.append(Primitive("cylinder", centre - half * u, centre + half * u, r))
            if c.joint in carriers:
                bores += _pin_span_bores(linkage, design, c.joint, name, centre, half, sites)
            if ends is not None and name in (ends.head_on, ends.groove_on):
                face, w = ends.faces[name], ends.outward[name]
                depth = ends.thickness + design.hole_clearance
                bores.append(Primitive("cylinder", face - depth * w, face + half * w, ends.counterbore))
    m = design.mounting
    if m is not None and m.link == name and parts:
        plate, holes = plate_primitives(m)
        parts.append(plate)
        bores += holes
    return parts, bores


def _pin_span_bores(linkage, design: PhysicalDesign, joint: str, name: str, centre, half: float, sites) -> list:
    """The bore of link ``name`` continued (pin radius + hole clearance) along the rest of ``joint``'s pin
    beyond its own bore (``centre`` +- ``half`` along the axis): a bar of the link that leaves its mount
    toward the neighbour, or its round end past the hub's face, runs over the pin between the hubs and
    must not take it (issue 33; the link's own bore keeps its press fit). A piece where the pin reaches
    past the own bore: from a hundredth of ``half`` inside it (no coplanar caps) to a hole clearance past
    the pin's end."""
    pin = design.pin(joint)
    u = linkage.joint(joint).direction
    o = float(np.dot(centre - sites[joint], u))
    r, e = design.pin_radius + design.hole_clearance, design.hole_clearance
    out = []
    if pin.start < o - half:
        out.append(Primitive("cylinder", axis_point(linkage, joint, pin.start - e, sites), centre - 0.99 * half * u, r))
    if pin.end > o + half:
        out.append(Primitive("cylinder", centre + 0.99 * half * u, axis_point(linkage, joint, pin.end + e, sites), r))
    return out


def plate_primitives(m) -> tuple[Primitive, list[Primitive]]:
    """(the box, the holes) of the mounting plate ``m`` (`synth.design.model.Mounting`): the holes run
    along the normal a fiftieth of the thickness past both faces; a flange's bore likewise; a foot's
    counterbores from its screw heads' seat to past its inner face."""
    n, T = np.asarray(m.normal, float), float(m.thickness)
    plate = Primitive("box", m.origin - T * n, np.asarray(m.origin, float), 0.0,
                      edges=np.asarray(m.axes, float) * np.asarray(m.half, float)[:, None])
    ends = (0.02 * T * n, -1.02 * T * n)
    holes = [Primitive("cylinder", h + ends[0], h + ends[1], 0.5 * m.hole_diameter) for h in m.holes]
    width, depth = m.counterbore
    if depth > 0:  # a foot: the heads sunk from its inner face to thickness - depth from the face
        seat = -(T - depth) * n
        holes += [Primitive("cylinder", h + seat, h + ends[1], 0.5 * width) for h in m.holes]
    if m.bore > 0:
        holes.append(Primitive("cylinder", m.origin + ends[0], m.origin + ends[1], m.bore))
    return plate, holes


def coaxial_profile(prims) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The union of ``prims`` as a solid of revolution, when every one is a cylinder on one axis line
    (a pin: shaft, head, groove) and they leave no gap along it: (origin (3,), unit direction (3,),
    profile (k, 2) of (axial position, radius) corners from the axis round to the axis). None otherwise."""
    if not prims or any(p.kind != "cylinder" for p in prims):
        return None
    o = np.asarray(prims[0].p0, float)
    d = np.asarray(prims[0].p1, float) - o
    d /= np.linalg.norm(d)
    ends = np.array([[p.p0, p.p1] for p in prims], float)  # (n, 2, 3)
    s = (ends - o) @ d
    size = max(float(np.ptp(s)), max(p.radius for p in prims))
    if np.abs(ends - o - s[..., None] * d).max() > 1e-9 * size:  # an end off the axis line
        return None
    lo, hi = s.min(axis=1), s.max(axis=1)
    cuts = np.unique(s)
    mid = (cuts[:-1] + cuts[1:]) / 2
    r = np.array([max((p.radius for p, a, b in zip(prims, lo, hi) if a < m < b), default=0.0) for m in mid])
    if not r.all():  # a gap: pieces, not one solid of revolution
        return None
    keep = np.r_[True, r[1:] != r[:-1]]  # steps of the radius
    starts, radii = cuts[:-1][keep], r[keep]
    corners = [(cuts[0], 0.0)] + [(x, q) for a, b, q in zip(starts, np.r_[starts[1:], cuts[-1]], radii)
                                  for x in (a, b)] + [(cuts[-1], 0.0)]
    return o, d, np.array(corners)


def coaxial_groups(cylinders) -> list[tuple]:
    """``cylinders`` (bores) gathered into runs on one axis line that leave no gap: [(first cylinder,
    `coaxial_profile` of the run, or None for a cylinder alone)], in first-seen order. The union is the
    same; one solid of revolution per run has no coincident faces (measured: sixbar_points' link_h1, a bore
    and its continuation along the pin overlapping by 0.2 mm, whose cylinders OpenCASCADE's cut left in
    pieces in every construction)."""
    runs: list[list] = []
    for c in cylinders:
        run = next((r for r in runs if coaxial_profile(r + [c]) is not None), None)
        if run is None:
            runs.append([c])
        else:
            run.append(c)
    return [(r[0], coaxial_profile(r) if len(r) > 1 else None) for r in runs]


def primitive_solid(p: Primitive) -> Solid:
    """The closed mesh of a primitive (`PIN_SECTIONS` for cylinders, `BAR_SECTIONS` for capsules)."""
    if p.kind == "capsule":
        return capsule(p.p0, p.p1, p.radius, BAR_SECTIONS)
    if p.kind == "box":
        return box(p.p0, p.p1, p.edges)
    return cylinder(p.p0, p.p1, p.radius, PIN_SECTIONS, phase=p.phase)


def coaxial_solid(first: Primitive, profile) -> Solid:
    """The closed mesh of a run of `coaxial_groups` (its first cylinder, its `coaxial_profile` or None): the
    profile revolved with `PIN_SECTIONS` facets placed as the first cylinder's, or that cylinder alone."""
    return primitive_solid(first) if profile is None else revolution(*profile, PIN_SECTIONS, phase=first.phase)


def link_parts(linkage, design: PhysicalDesign, name: str, sites=None, caps=None) -> tuple[list[Solid], list[Solid]]:
    """(parts, bores) of link ``name`` (`link_primitives`) as closed meshes, the bores on one axis line
    as one solid of revolution (`coaxial_groups`; the same union, with no boolean and its facets in line)."""
    parts, bores = link_primitives(linkage, design, name, sites, caps)
    return [primitive_solid(p) for p in parts], [coaxial_solid(*g) for g in coaxial_groups(bores)]


def pin_primitives(linkage, design: PhysicalDesign, joint: str, sites=None) -> list[Primitive]:
    """The pin of ``joint`` in world coordinates at the reference configuration, as cylinders whose union
    it is: the shaft, and unless the fit is "plain" the head flush in its counterbore (on the turning
    link for a press fit, on the carrier for a clip), and for a clip a groove at the turning link's face
    (the shaft at 0.8 pin radii over a third of the head's thickness, one hole clearance inside the
    counterbore's floor) for a standard retaining clip."""
    p = design.pin(joint)
    sites = linkage.joint_sites() if sites is None else sites
    a, b = axis_point(linkage, joint, p.start, sites), axis_point(linkage, joint, p.end, sites)
    r = design.pin_radius
    ends = pin_ends(linkage, design, joint, sites)
    if ends is None or ends.head_on is None:
        return [Primitive("cylinder", a, b, r)]
    head_on, clip_on = ends.head_on, ends.groove_on
    face, w, t = ends.faces[head_on], ends.outward[head_on], ends.thickness
    other = b if np.dot(b - face, w) < np.dot(a - face, w) else a  # the shaft's far end (press)
    shaft_end = face - 0.5 * t * w  # inside the head: no coplanar caps
    prims = [Primitive("cylinder", face - t * w, face, ends.head)]
    if clip_on is None:
        return [Primitive("cylinder", other, shaft_end, r)] + prims
    g_face, g_w = ends.faces[clip_on], ends.outward[clip_on]
    lo = g_face - (t + design.hole_clearance) * g_w  # the groove from the counterbore's floor outwards
    hi = lo + (t / 3) * g_w
    return prims + [Primitive("cylinder", shaft_end, lo, r), Primitive("cylinder", hi, g_face, r),
                    Primitive("cylinder", lo - 0.05 * t * g_w, hi + 0.05 * t * g_w, 0.8 * r)]


def pin_origin(linkage, design: PhysicalDesign, joint: str, sites=None) -> np.ndarray:
    """World position (3,) of the frame of link ``pin_<joint>`` at the reference configuration: the pin's
    midpoint (axes parallel to the world's, like every link frame)."""
    p = design.pin(joint)
    return axis_point(linkage, joint, (p.start + p.end) / 2, sites)


def pin_solid(linkage, design: PhysicalDesign, joint: str, sites=None) -> Solid:
    """The pin of ``joint`` in its own frame (`pin_origin`): its coaxial cylinders' profile revolved (no
    boolean; `coaxial_solid`)."""
    sites = linkage.joint_sites() if sites is None else sites
    prims = pin_primitives(linkage, design, joint, sites)
    profile = coaxial_profile(prims)
    mesh = coaxial_solid(prims[0], profile) if profile is not None else _solid([primitive_solid(p) for p in prims])
    return mesh.translated(-pin_origin(linkage, design, joint, sites))


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
    sites = linkage.joint_sites()
    caps = capsules(linkage, design, sites)
    out = {}
    for name in linkage.link_names:
        parts, bores = link_parts(linkage, design, name, sites, caps)
        if not parts:
            continue
        mesh = _solid(parts, bores).translated(-origins[name])
        check_closed(mesh, f"mesh of link {name}")
        out[name] = mesh
    for p in design.pins:
        mesh = pin_solid(linkage, design, p.joint, sites)
        check_closed(mesh, f"mesh of pin {p.joint}")
        out[pin_link_name(p.joint)] = mesh
    return out


def link_meshes(linkage, design: PhysicalDesign) -> dict:
    """{link name: trimesh.Trimesh}: `design_solids` as trimesh objects (imports trimesh)."""
    return {n: m.to_trimesh() for n, m in design_solids(linkage, design).items()}


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
    may be far away) in millimetres (``names.MESH_UNIT_SCALE``, the unit slicers assume); an edge shorter
    than a float32 step there, or than a reader's vertex merge (`solid.READER_GRID`), is collapsed
    (`solid.degenerate_free`). The bytes are read back and checked to hold those corners, and the mesh a
    reader of the file sees (float32 corners welded where bit-equal, or where equal to 8 decimals: the
    same mesh, below) to be a closed solid; RuntimeError otherwise."""
    offset = stl_offset(mesh)
    triangles = (mesh.triangles - offset) * (1.0 / MESH_UNIT_SCALE)
    # as readers see the file: corners bit-equal in float32, or equal to 8 decimals (trimesh's merge, so
    # yourdfpy's and the judge's); written at the merged corners, one per 8-decimal cell (so distinct in
    # float32 too): either reader's merge gives back ``written`` but for the numbering of its vertices
    stored = weld(triangles.astype(np.float32), READER_GRID)
    keep = degenerate_free(stored.faces)  # edges shorter than that collapsed
    written = Solid(stored.vertices, stored.faces[keep])
    data = stl_bytes(triangles[keep], written.triangles)
    if not np.array_equal(read_stl_triangles(data), written.triangles):
        raise RuntimeError(f"{what}: the STL file does not hold the corners written")
    check_closed(written, f"{what} as written to STL")
    return data, offset


def stl_offset(mesh: Solid) -> np.ndarray:
    """The origin (3,) of ``mesh``'s STL file in its link frame (metres): its bounding-box centre."""
    return mesh.bounds.mean(axis=0)


def write_stl(job, directory: Path) -> list[Path]:
    """The ``stl`` exporter (`synth.io.export`): ``meshes/<link>.stl`` of every solid of ``job``."""
    written = []
    if job.result is None:  # kinematic outputs only (no design, no meshes)
        return written
    if job.solids:
        (directory / "meshes").mkdir()
    for name, mesh in job.solids.items():
        rel = Path("meshes") / f"{name}.stl"
        data, _ = stl_file(mesh, f"mesh of {name}")  # about its own centre, mm, placed by the URDF origin
        (directory / rel).write_bytes(data)
        written.append(rel)
    return written
