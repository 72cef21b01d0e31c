"""The ground link's mounting plate (issue 33): a flat face by which the linkage is screwed to a table or
a bracket, with clearance holes for standard screws, kept clear of the moving links.

Lengths in metres, world frame at the reference configuration (= the base link's frame). Candidates, in
this order (docs/design.md, "Mounting plate"):

- **parallel**: a plate under one hub of the base, its face parallel to both base axes (normal along the
  common normal u1 x u2 of the hub's axis and another base axis; for parallel axes the normal of the plane
  that contains both), then the same turned a quarter turn about the axis; either side. The hub lies on
  the plate like a pillow block: the plate reaches into the hub's wall (never into its bore), spans the
  hub's axial length on the side away from the hub's neighbour on the joint, and has a screw hole on
  either side of the hub;
- **hub**: a square flange on the outer end face of a base hub (normal along its axis), a screw hole at
  each corner and the bore (with room for a pin head) continued through it.

A candidate is kept when its mounting face is the outermost face of the base part along its normal
(nothing of the base reaches past it: it sits flat on a table and on a print bed), at least two of its
holes leave room for a screw head and a tool above them (`HEAD_ROOM`), it stays inside the task's
envelope, and its plate is certified `clearance` clear of every other body, the base's neighbours
included, over the design's range (`synth.design.collision.certify` with the capsules of
`synth.design.model.plate_capsules` fixed in the base). With a base box (constraints.base) each
candidate whose face points towards the box also comes as a *foot*: the plate thickened along its normal
until the face's centre reaches the box (by at most `FOOT_MAX` of the linkage's extent), its holes
counterbored so the screws keep their length; the candidates are tried by the distance of the face's
centre from the box, nearest first. The first kept candidate is the design's ``mounting``; none when
none is kept (the output then has no mounting).

Screws (`SCREWS`): ISO 273 medium-series clearance holes, 4.5 mm for M4 and 3.4 mm for M3, with the
head diameters of ISO 4762 socket head cap screws; the largest whose hole is no wider than the pin's
diameter (no mounting for pins thinner than an M3 hole, nor for a linkage more than `MIN_HOLE`^-1 hole
diameters across: M4 screws do not hold a linkage over 4.5 m). Plate thickness: the bar radius, at least 1.2
hole diameters.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from synth.algebra.geometry import perpendicular_basis
from synth.design.collision import CapsuleSet, certify, segment_distance
from synth.design.sampling import bodies
from synth.design.coordinate import FULL
from synth.design.model import (Capsule, DesignResult, Mounting, axis_point, capsules, head_radius, joint_links,
                                plate_capsules)
from synth.design.search import task_phi_range

BASE = "base"


@dataclass(frozen=True)
class Screw:
    """A metric screw: ``name``, clearance ``hole`` and ``head`` diameters (metres)."""

    name: str
    hole: float
    head: float


SCREWS = (Screw("M4", 4.5e-3, 7.0e-3), Screw("M3", 3.4e-3, 5.5e-3))
MIN_HOLE = 1e-3  # no screws below this fraction of the linkage's extent (M4: a linkage over 4.5 m; the
# holes would also fall below the mesh boolean's tolerance, 1e-6 of a part, for parts kilometres long)
HEAD_ROOM = 2.0  # head diameters above a hole that nothing of the base may enter (the head and a key)
MARGIN = 5e-4  # metres between a screw head's rim and the hub
OVERLAP = 0.25  # thicknesses by which a plate reaches past a hub's end face (into a flange's hub, past a
# pillow block's): coplanar faces of two parts make slivers that the STL's float32 corners fold over


def screw_for(design) -> Screw | None:
    """The largest screw of `SCREWS` whose clearance hole is no wider than the pin's diameter, or None."""
    return next((s for s in SCREWS if s.hole <= 2.0 * design.pin_radius), None)


def _neighbour_side(design, linkage, joint: str) -> float:
    """+1 when the base's hub on ``joint`` lies above (along the axis direction) its neighbour's, else -1."""
    others = [lk for lk in joint_links(linkage)[joint] if lk != BASE]
    if not others:
        return 1.0
    d = design.mount(BASE, joint).offset - design.mount(others[0], joint).offset
    return 1.0 if d >= 0 else -1.0


def _normals(linkage, joint: str) -> list[np.ndarray]:
    """Unit normals (perpendicular to ``joint``'s axis) of the parallel plates under its hub: along the
    common normal with the first other base axis not parallel to it (else perpendicular to the plane of the
    two parallel axes), both signs, then the same turned a quarter turn about the axis."""
    u = linkage.joint(joint).direction
    sites = linkage.joint_sites()
    n0 = None
    for other in linkage.links[BASE]:
        if other == joint:
            continue
        w = np.cross(u, linkage.joint(other).direction)
        if np.linalg.norm(w) < 0.1:  # (nearly) parallel axes: the plane that contains both
            w = np.cross(u, sites[other] - sites[joint])
        if np.linalg.norm(w) > 1e-9 * linkage.extent():
            n0 = w / np.linalg.norm(w)
            break
    if n0 is None:
        n0 = perpendicular_basis(u)[0]
    n1 = np.cross(u, n0)
    return [n0, -n0, n1, -n1]


def _plate(link, joint, kind, origin, normal, axis0, half, thickness, screw, holes, bore=0.0) -> Mounting:
    axes = np.array([axis0, np.cross(normal, axis0)])
    return Mounting(link, joint, kind, np.asarray(origin, float), np.asarray(normal, float), axes,
                    np.asarray(half, float), float(thickness), np.asarray(holes, float).reshape(-1, 3),
                    screw.hole, screw.name, float(bore))


def candidates(linkage, design, screw: Screw) -> list[Mounting]:
    """Every candidate plate (see the module docstring), parallel ones first, before any check."""
    R, L = design.hub_radius, design.hub_length
    bore = design.pin_radius + design.hole_clearance
    T = max(design.bar_radius, 1.2 * screw.hole)
    across = max(R, design.bar_radius) + 0.5 * screw.head + MARGIN  # hole centres from the axis
    out = []
    for joint in linkage.links[BASE]:
        u = linkage.joint(joint).direction
        c = axis_point(linkage, joint, design.mount(BASE, joint).offset)
        side = _neighbour_side(design, linkage, joint)
        gap = 0.5 * T + design.clearance  # the plate's capsules reach T/2 at most past its end
        length = max(L - gap + OVERLAP * T, screw.head + screw.hole)  # (no end face flush with the hub's)
        mid = c + side * (-0.5 * L + gap + 0.5 * length) * u
        depth = bore + 0.6 * (R - bore) + T  # the face's distance from the axis
        for n in _normals(linkage, joint):
            e = np.cross(n, u)
            face = mid + depth * n
            out.append(_plate(BASE, joint, "parallel", face, n, u, (0.5 * length, across + screw.hole), T, screw,
                              [face + across * e, face - across * e]))
        n = side * u
        face = c + (0.5 * L + T) * n
        e1, e2 = perpendicular_basis(n)
        a = across / math.sqrt(2.0) + 0.5 * screw.head
        holes = [face + s1 * a * e1 + s2 * a * e2 for s1 in (1, -1) for s2 in (1, -1)]
        counterbore = head_radius(design) + design.hole_clearance  # room for a pin's head (seats.pin_ends)
        out.append(_plate(BASE, joint, "hub", face, n, e1, (a + screw.hole, a + screw.hole), (1 + OVERLAP) * T,
                          screw, holes, counterbore))
    return out


def _base_capsules(linkage, design) -> list[Capsule]:
    return [c for c in capsules(linkage, design) if c.link == BASE and c.part != "plate"]


def outermost(m: Mounting, base: list[Capsule]) -> bool:
    """True when nothing of the base (its capsules ``base``; hubs and pins have flat ends: their rims)
    reaches past the plane of the mounting face."""
    level = float(np.dot(m.origin, m.normal))
    for c in base:
        if c.part == "bar":
            reach = max(np.dot(c.p0, m.normal), np.dot(c.p1, m.normal)) + c.radius
        else:  # a cylinder: its end discs' farthest points
            d = c.p1 - c.p0
            d = d / max(np.linalg.norm(d), 1e-300)
            rim = c.radius * math.sqrt(max(0.0, 1.0 - float(np.dot(d, m.normal)) ** 2))
            reach = max(np.dot(c.p0, m.normal), np.dot(c.p1, m.normal)) + rim
        if reach > level + 1e-9 * max(1.0, abs(level)):
            return False
    return True


def usable_holes(m: Mounting, base: list[Capsule], head: float) -> np.ndarray:
    """The holes of ``m`` (k, 3) above which a screw head (diameter ``head``) and its key fit: the segment
    from the plate's inner face `HEAD_ROOM` head diameters inwards keeps head / 2 from every base capsule."""
    if not base:
        return m.holes
    q0 = np.array([c.p0 for c in base]).T[:, None, :]  # (3, 1, C)
    q1 = np.array([c.p1 for c in base]).T[:, None, :]
    radius = np.array([c.radius for c in base])[None, :]
    p0 = (m.holes - (m.thickness - m.counterbore[1]) * m.normal).T[:, :, None]  # (3, k, 1): where the heads sit
    p1 = p0 - HEAD_ROOM * head * np.asarray(m.normal, float)[:, None, None]
    d = segment_distance(p0, p1, q0, q1)  # (k, C)
    return m.holes[np.all(d >= radius + 0.5 * head, axis=1)]


def inside(m: Mounting, box) -> bool:
    """True when the plate's capsules lie inside the axis-aligned ``box`` (None: no box)."""
    if box is None:
        return True
    for c in plate_capsules(m):
        for p in (c.p0, c.p1):
            if np.any(p - c.radius < box.lo) or np.any(p + c.radius > box.hi):
                return False
    return True


def plate_set(linkage, design, m: Mounting) -> CapsuleSet:
    """The capsule pairs (the plate's capsules, every capsule of another body) fixed in their bodies at
    the reference configuration (offsets 0); the pin of the plate's own joint turns in its bore and is
    left out."""
    plate = plate_capsules(m)
    others = [c for c in capsules(linkage, replace(design, mounting=None))
              if c.link != BASE and c.link in bodies(linkage) and not (c.part == "pin" and c.joint == m.joint)]
    ends, body, pairs, radii, bpi, labels = [], [], [], [], [], []
    body_pairs = [(BASE, b) for b in bodies(linkage) if b != BASE]
    index = {b: i for i, (_, b) in enumerate(body_pairs)}
    for c in plate + others:
        ends += [c.p0, c.p1]
        body += [c.link, c.link]
    for i, a in enumerate(plate):
        for k, b in enumerate(others):
            j = len(plate) + k
            pairs.append((2 * i, 2 * i + 1, 2 * j, 2 * j + 1))
            radii.append(a.radius + b.radius)
            bpi.append(index[b.link])
            labels.append(f"{BASE}:plate / {b.link}:{b.part}")
    return CapsuleSet(ends_base=np.array(ends, float).reshape(-1, 3), ends_dir=np.zeros((len(ends), 3)),
                      ends_body=body, pairs=np.array(pairs, int).reshape(-1, 4), radii=np.array(radii, float),
                      body_pair=np.array(bpi, int), body_pairs=body_pairs, labels=labels)


def plate_gap(linkage, design, m: Mounting, rname: str, clearance: float) -> dict:
    """`collision.certify` of the plate ``m`` against every other body over the range ``rname`` ("full"
    or "task")."""
    cs = plate_set(linkage, design, m)
    lo, hi = FULL if rname == "full" else task_phi_range(linkage)
    if not len(cs.pairs):
        return {"certified": True, "lower": math.inf}
    return certify(linkage, cs, np.zeros(len(cs.ends_body)), lo, hi, clearance, samples=CERTIFY_SAMPLES)


def _box_distance(p, box) -> float:
    return float(np.linalg.norm(np.maximum(box.lo - p, 0.0) + np.maximum(p - box.hi, 0.0)))


CERTIFY_SAMPLES = 64  # the certificate's first samples (it bisects where the bound needs it)
FOOT_MAX = 0.25  # times the linkage's extent: the most a plate is thickened to reach a base box


def foot(m: Mounting, box, limit: float, head: float) -> Mounting | None:
    """``m`` thickened along its normal into a foot whose face's centre lies at the ``box`` (the smallest
    such extra thickness, at most ``limit``), its holes counterbored (``head`` + 2 `MARGIN` wide) down to
    the plate's former thickness above the face; None when the face's centre is in the box already, or
    its line along the normal misses the box or meets it farther than ``limit``."""
    o, n = np.asarray(m.origin, float), np.asarray(m.normal, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (box.lo - o) / n, (box.hi - o) / n
    flat = np.abs(n) < 1e-12
    if np.any(flat & ((o < box.lo) | (o > box.hi))):
        return None
    enter = float(np.max(np.where(flat, -np.inf, np.minimum(t0, t1))))
    leave = float(np.min(np.where(flat, np.inf, np.maximum(t0, t1))))
    if leave < enter or enter <= 0.0 or enter > limit:
        return None
    return replace(m, origin=o + enter * n, holes=m.holes + enter * n, thickness=m.thickness + enter,
                   counterbore=(head + 2 * MARGIN, enter))


def place_mounting(linkage, result: DesignResult, *, base=None, envelope=None) -> DesignResult:
    """``result`` with its design's ``mounting`` set to the first kept candidate (module docstring), or
    None; ``base``, ``envelope``: the task's boxes (`synth.task.Box`, None: none). The collision report's
    ``min_distance`` becomes the smaller of its own and the plate's certified gap. Changes ``result`` in
    place and returns it."""
    design = result.design
    design.mounting = None
    screw = screw_for(design)
    too_small = screw is None or screw.hole < MIN_HOLE * linkage.extent()
    if too_small or not linkage.links.get(BASE) or BASE not in bodies(linkage):
        return result
    base_caps = _base_capsules(linkage, design)
    found = candidates(linkage, design, screw)
    if base is not None:  # feet that reach the box first, then the plates nearest it
        feet = [foot(m, base, FOOT_MAX * linkage.extent(), screw.head) for m in found]
        found = [f for f in feet if f is not None] + found
        found.sort(key=lambda m: _box_distance(m.origin, base))  # (stable: parallel first at equal distance)
    report = result.collision
    refused: dict[str, int] = {}
    for m in found:
        why = _refusal(linkage, design, m, base_caps, envelope, screw, report)
        if isinstance(why, str):
            refused[why] = refused.get(why, 0) + 1
            continue
        m, cert = why
        if base is not None and _box_distance(m.origin, base) > 0:  # say why none nearer the box was kept
            m = replace(m, box_distance=_box_distance(m.origin, base), box_reasons=refused)
        design.mounting = m
        report.min_distance = min(report.min_distance, cert["lower"])
        return result
    return result


def _refusal(linkage, design, m: Mounting, base_caps, envelope, screw, report):
    """Why the candidate ``m`` is refused (a phrase), else (``m`` with its usable holes, its certificate)."""
    if not outermost(m, base_caps):
        return "not the base's outermost face"
    if not inside(m, envelope):
        return "outside the envelope"
    holes = usable_holes(m, base_caps, screw.head)
    if len(holes) < 2:
        return "without room for two screw heads"
    m = replace(m, holes=holes)
    cert = plate_gap(linkage, design, m, report.range, report.clearance)
    if not cert["certified"]:
        cs = plate_set(linkage, design, m)
        body = cs.body_pairs[int(cs.body_pair[int(np.argmin(cert["sampled"]))])][1]
        return f"within the clearance of {body} ({report.range} range)"
    return m, cert
