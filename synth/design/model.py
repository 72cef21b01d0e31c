"""The physical design of a linkage, apart from its kinematics.

The kinematics (`synth.linkage.Linkage`) fix only the joint axes and the angle laws. Everything a
person builds is free on top of them and recorded here (docs/design.md):

- **mounts**: where each link holds each of its joints, as an offset (metres) along the joint's
  direction from the joint's *site* (`Linkage.joint_sites()`, reference configuration);
- **bars**: the body of a link between two of its mounts, a round bar with round ends along a
  polyline from one mount to the other through optional ``via`` points (straight when empty;
  "cranked" otherwise), in the link's own coordinates at the reference configuration (= world);
- **hubs**: a short cylinder around the axis at every mount (the bore for the pin goes through it);
- **pins**: one per joint, a cylinder along the axis from ``start`` to ``end`` (offsets as for
  mounts) covering the hubs of both links on that joint, fixed in the hub of its ``carrier`` link
  and turning in the bore of the other;
- sizes: pin radius, bar radius, hub radius and length, radial hole clearance, and the clearance the
  design was made for (bodies that share no joint keep at least this far apart).

`capsules` turns a design into the geometry both the collision search and the mesh writer use:
segments with a radius. A round bar with round ends *is* such a capsule; a hub or a pin (flat ends)
lies inside the capsule of its segment and radius, so distances between capsules are lower bounds of
the distances between the solids that are written.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from synth.algebra.geometry import common_normal


@dataclass
class Mount:
    """Link ``link`` holds joint ``joint`` at ``offset`` metres along the joint's direction from the
    joint's site."""

    link: str
    joint: str
    offset: float


@dataclass
class Bar:
    """The round bar of ``link`` from its mount on ``joints[0]`` to its mount on ``joints[1]`` through
    the points ``via`` (each (3,), metres, reference configuration); straight when ``via`` is empty."""

    link: str
    joints: tuple[str, str]
    via: list[np.ndarray] = field(default_factory=list)


@dataclass
class Pin:
    """The pin of ``joint``: along the axis from offset ``start`` to ``end`` (metres, start < end),
    fixed to the link ``carrier``."""

    joint: str
    start: float
    end: float
    carrier: str

    @property
    def length(self) -> float:
        return self.end - self.start


@dataclass
class Mounting:
    """The ground link's mounting plate (`synth.design.mounting`; metres, world frame at the reference
    configuration, which is the base link's frame): a flat plate of ``thickness`` whose mounting face (the
    face screwed to a table or a bracket) is the rectangle centred at ``origin`` (3,) with outward unit
    ``normal`` (3,) and half-sides ``half`` (2,) along the in-plane unit vectors ``axes`` (2, 3); the plate
    lies behind the face (against the normal). Through-holes of ``hole_diameter`` for ``screw`` ("M3",
    "M4") run along the normal through the points ``holes`` (k, 3) of the face. ``kind``: "parallel" (the
    face parallel to both base axes, under the hub of ``joint``) or "hub" (a flange on the outer end face
    of the hub of ``joint``, normal along its axis, the bore continued through it with radius ``bore``).
    ``counterbore`` (diameter, depth): a plate thickened into a foot (to reach a task's base box) has its
    holes counterbored from the inside, so the screws' heads sit ``thickness - depth`` from the face;
    depth 0: none."""

    link: str
    joint: str
    kind: str
    origin: np.ndarray
    normal: np.ndarray
    axes: np.ndarray
    half: np.ndarray
    thickness: float
    holes: np.ndarray
    hole_diameter: float
    screw: str
    bore: float = 0.0
    counterbore: tuple = (0.0, 0.0)
    box_distance: float = 0.0  # metres from the task's base box to the face's centre (0: in it, or no box)
    box_reasons: dict = field(default_factory=dict)  # {why: count} of the candidates nearer the box, refused

    def to_dict(self) -> dict:
        return {"link": self.link, "joint": self.joint, "kind": self.kind,
                "origin": [float(x) for x in self.origin], "normal": [float(x) for x in self.normal],
                "axes": [[float(x) for x in a] for a in self.axes], "size": [float(2 * h) for h in self.half],
                "thickness": float(self.thickness), "screw": self.screw, "hole_diameter": float(self.hole_diameter),
                "holes": [[float(x) for x in h] for h in self.holes], "bore_diameter": float(2 * self.bore),
                "counterbore": {"diameter": float(self.counterbore[0]), "depth": float(self.counterbore[1])},
                **({"base_box": {"distance": float(self.box_distance), "nearer_refused": dict(self.box_reasons)}}
                   if self.box_distance > 0 else {})}

    def box_sentence(self, scale: float = 1.0, unit: str = "m") -> str:
        """Why the face is outside the task's base box (lengths in ``unit``, metres / ``scale``), or ""."""
        if not self.box_distance > 0:
            return ""
        why = "; ".join(f"{n} {w}" for w, n in self.box_reasons.items()) or "none nearer"
        return (f"the mounting face is {self.box_distance / scale:.3g} {unit} outside the base box; the plates "
                f"nearer it were refused: {why}")

    @classmethod
    def from_dict(cls, d: dict) -> "Mounting":
        return cls(str(d["link"]), str(d["joint"]), str(d["kind"]), np.asarray(d["origin"], float),
                   np.asarray(d["normal"], float), np.asarray(d["axes"], float).reshape(2, 3),
                   np.asarray(d["size"], float) / 2, float(d["thickness"]),
                   np.asarray(d["holes"], float).reshape(-1, 3), float(d["hole_diameter"]), str(d["screw"]),
                   float(d.get("bore_diameter", 0.0)) / 2,
                   tuple(float((d.get("counterbore") or {}).get(k, 0.0)) for k in ("diameter", "depth")),
                   float((d.get("base_box") or {}).get("distance", 0.0)),
                   dict((d.get("base_box") or {}).get("nearer_refused", {})))


@dataclass
class PhysicalDesign:
    """Every free parameter of a buildable linkage (lengths in metres)."""

    pin_radius: float
    bar_radius: float
    hub_radius: float  # > pin_radius + hole_clearance: the hub holds the bore
    hub_length: float  # along the axis, centred on the mount
    hole_clearance: float  # radial clearance of a bore around its pin
    clearance: float  # required gap between bodies that share no joint
    mounts: list[Mount]
    bars: list[Bar]
    pins: list[Pin]
    pin_fit: str = "press"  # how a pin holds (`PIN_FITS`): docs/design.md, "Pins"
    mounting: Mounting | None = None  # the ground link's mounting plate (`synth.design.mounting`)

    def mount(self, link: str, joint: str) -> Mount:
        for m in self.mounts:
            if m.link == link and m.joint == joint:
                return m
        raise KeyError((link, joint))

    def pin(self, joint: str) -> Pin:
        for p in self.pins:
            if p.joint == joint:
                return p
        raise KeyError(joint)

    def to_dict(self) -> dict:
        """JSON-ready description (the ``design`` section of linkage.json)."""
        return {
            "pin_radius": self.pin_radius, "bar_radius": self.bar_radius, "hub_radius": self.hub_radius,
            "hub_length": self.hub_length, "hole_clearance": self.hole_clearance, "clearance": self.clearance,
            "mounts": [{"link": m.link, "joint": m.joint, "offset": m.offset} for m in self.mounts],
            "bars": [{"link": b.link, "joints": list(b.joints), "via": [list(map(float, v)) for v in b.via]}
                     for b in self.bars],
            "pins": [{"joint": p.joint, "start": p.start, "end": p.end, "length": p.length, "carrier": p.carrier}
                     for p in self.pins],
            "pin_fit": self.pin_fit,
            **({"mounting": self.mounting.to_dict()} if self.mounting is not None else {}),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "PhysicalDesign":
        return cls(
            pin_radius=float(d["pin_radius"]), bar_radius=float(d["bar_radius"]),
            hub_radius=float(d["hub_radius"]), hub_length=float(d["hub_length"]),
            hole_clearance=float(d["hole_clearance"]), clearance=float(d["clearance"]),
            mounts=[Mount(m["link"], m["joint"], float(m["offset"])) for m in d["mounts"]],
            bars=[Bar(b["link"], tuple(b["joints"]), [np.asarray(v, float) for v in b["via"]]) for b in d["bars"]],
            pins=[Pin(p["joint"], float(p["start"]), float(p["end"]), p["carrier"]) for p in d["pins"]],
            pin_fit=str(d.get("pin_fit", "plain")),  # written before pins had heads: plain cylinders
            mounting=Mounting.from_dict(d["mounting"]) if d.get("mounting") else None,
        )


@dataclass
class Capsule:
    """A segment p0-p1 with a radius, fixed to ``link`` (reference configuration, metres). ``part`` is
    "bar", "hub", "pin" or "plate" (the capsules that bound a mounting plate, `plate_capsules`); ``joint``
    names the joint of a hub, a pin or a plate."""

    link: str
    part: str
    p0: np.ndarray
    p1: np.ndarray
    radius: float
    joint: str | None = None


def axis_point(linkage, joint: str, offset: float, sites=None) -> np.ndarray:
    """The point at ``offset`` along ``joint``'s direction from its site (reference configuration)."""
    sites = linkage.joint_sites() if sites is None else sites
    j = linkage.joint(joint)
    return sites[joint] + offset * j.direction


def plate_capsules(m: Mounting) -> list[Capsule]:
    """Capsules whose union holds the mounting plate ``m`` (a box of half-sides ``half`` and
    ``thickness`` / 2 along ``axes`` and the normal): along its longest side, one per strip of its
    cross-section (the other two sides w >= v cut into k = ceil(w / v) strips of width s = w / k <= v),
    each of radius sqrt((v/2)^2 + (s/2)^2) around the strip's centre line."""
    sides = [(float(m.half[0]), np.asarray(m.axes[0], float)), (float(m.half[1]), np.asarray(m.axes[1], float)),
             (0.5 * float(m.thickness), np.asarray(m.normal, float))]
    (h_len, d_len), (h_w, d_w), (h_v, _) = sorted(sides, key=lambda x: -x[0])
    k = max(1, int(np.ceil(h_w / h_v - 1e-9)))
    s = 2 * h_w / k
    r = float(np.hypot(h_v, s / 2))
    centre = np.asarray(m.origin, float) - 0.5 * float(m.thickness) * np.asarray(m.normal, float)
    out = []
    for i in range(k):
        c = centre + (-h_w + s * (i + 0.5)) * d_w
        out.append(Capsule(m.link, "plate", c - h_len * d_len, c + h_len * d_len, r, m.joint))
    return out


def bar_polyline(linkage, design: PhysicalDesign, bar, sites=None) -> list[np.ndarray]:
    """The centre line of ``bar`` at the reference configuration: its first mount's point on the axis, its
    crank points (``via``), its second mount's point (each (3,), metres)."""
    sites = linkage.joint_sites() if sites is None else sites
    return [axis_point(linkage, bar.joints[0], design.mount(bar.link, bar.joints[0]).offset, sites),
            *[np.asarray(v, float) for v in bar.via],
            axis_point(linkage, bar.joints[1], design.mount(bar.link, bar.joints[1]).offset, sites)]


def capsules(linkage, design: PhysicalDesign, sites=None) -> list[Capsule]:
    """The solids of the design as capsules, each fixed to its link: bar segments (bar radius), hubs
    (hub radius, hub length), pins (pin radius, on their carrier link) and the mounting plate
    (`plate_capsules`). ``sites``: the linkage's ``joint_sites()`` when already at hand."""
    sites = linkage.joint_sites() if sites is None else sites
    out: list[Capsule] = []
    for b in design.bars:
        pts = bar_polyline(linkage, design, b, sites)
        for p0, p1 in zip(pts, pts[1:]):
            out.append(Capsule(b.link, "bar", p0, p1, design.bar_radius))
    for m in design.mounts:
        u = linkage.joint(m.joint).direction
        c = axis_point(linkage, m.joint, m.offset, sites)
        h = design.hub_length / 2
        out.append(Capsule(m.link, "hub", c - h * u, c + h * u, design.hub_radius, m.joint))
    for p in design.pins:
        out.append(Capsule(p.carrier, "pin", axis_point(linkage, p.joint, p.start, sites),
                           axis_point(linkage, p.joint, p.end, sites), design.pin_radius, p.joint))
    if design.mounting is not None:
        out += plate_capsules(design.mounting)
    return out


def joint_links(linkage) -> dict[str, list[str]]:
    """The links that hold each joint (two in a loop: the links whose ``linkage.links`` name it)."""
    out: dict[str, list[str]] = {j.name: [] for j in linkage.joints}
    for link, names in linkage.links.items():
        for n in names:
            out[n].append(link)
    return out


def straight_design(linkage, *, pin_radius: float, bar_radius: float, hub_length: float,
                    hole_clearance: float = 0.0, clearance: float = 0.0, offsets: dict | None = None) -> PhysicalDesign:
    """A design with straight bars: every link mounted at ``offsets[(link, joint)]`` (default: the foot
    of the common normal to the link's other axis, the kinematic "natural" place), a hub of
    ``hub_length`` at each mount, and each joint's pin spanning the hubs of its two links."""
    sites = linkage.joint_sites()
    byname = {j.name: j for j in linkage.joints}
    mounts, bars = [], []
    for link, names in linkage.links.items():
        for a, b in zip(names, names[1:]):
            ja, jb = byname[a], byname[b]
            fa, fb = common_normal(ja.direction, ja.moment, jb.direction, jb.moment).feet
            for n, f in ((a, fa), (b, fb)):
                if all(not (m.link == link and m.joint == n) for m in mounts):
                    off = float(np.dot(f - sites[n], byname[n].direction))
                    if offsets and (link, n) in offsets:
                        off = float(offsets[(link, n)])
                    mounts.append(Mount(link, n, off))
            bars.append(Bar(link, (a, b)))
        if len(names) == 1:
            mounts.append(Mount(link, names[0], float((offsets or {}).get((link, names[0]), 0.0))))
    design = PhysicalDesign(pin_radius=pin_radius, bar_radius=bar_radius,
                            hub_radius=hub_radius_for(pin_radius, bar_radius, hole_clearance),
                            hub_length=hub_length, hole_clearance=hole_clearance, clearance=clearance,
                            mounts=mounts, bars=bars, pins=[])
    design.pins = pins_for(linkage, design)
    return design


PIN_FITS = ("press", "clip", "plain")  # head + press fit in the carrier; head + clip groove; a plain cylinder
MIN_WALL = 1.2e-3  # metres: the wall around a bore, three perimeters of a 0.4 mm nozzle (issue 33)


HUB_MARGIN = 1.1  # a hub's radius and its bar's differ by at least this factor


def hub_radius_for(pin_radius: float, bar_radius: float, hole_clearance: float) -> float:
    """A hub's radius (metres): the pin's bore (pin radius + hole clearance) with a wall of half a pin
    radius, at least `MIN_WALL` (but not over the pin's diameter: a linkage too small to print keeps its
    proportions). A bar thicker than that holds the bore in its round end, and the hub stays this size
    (its capsule in the collision search then reaches little beyond the bar's). A bar within
    `HUB_MARGIN` of it gets a hub `HUB_MARGIN` times the bar's radius: equal radii make the hub tangent
    to the bar's round end and the two cylinders cross at a point (Steinmetz), a degenerate solid."""
    wall = max(0.5 * pin_radius, min(MIN_WALL, 2.0 * pin_radius))
    hub = pin_radius + hole_clearance + wall
    if hub / HUB_MARGIN < bar_radius < hub * HUB_MARGIN:
        return HUB_MARGIN * bar_radius
    return hub


def pins_for(linkage, design: PhysicalDesign) -> list[Pin]:
    """One pin per joint held by two links, spanning both hubs, carried by the first link."""
    pins = []
    for joint, links in joint_links(linkage).items():
        offs = [design.mount(link, joint).offset for link in links]
        if not offs:
            continue
        h = design.hub_length / 2
        pins.append(Pin(joint, min(offs) - h, max(offs) + h, links[0]))
    return pins


CAP = 0.25  # a blind bore's cap (and a pin head's thickness), times the hub length (synth.design.seats)
HEAD_WALL = 0.4  # a pin head's radius: the bore plus this fraction of the hub's wall


@dataclass(frozen=True)
class PinEnds:
    """Where a pin's head and retention go (docs/design.md, "Pins"): ``outward`` (3,) unit vectors along
    the axis pointing out of the stack at the carrier's and at the turning link's outer face, the hubs'
    outer faces ``faces`` (3,) each (world, reference configuration), head radius ``head`` and thickness
    ``thickness``, counterbore radius ``counterbore`` (metres); ``head_on``: the link whose face holds the
    head (None: no head, a plain pin), ``groove_on``: the link whose face holds a clip's groove (or None),
    ``blind``: the links whose bore stops short of their outer face (`seat_pins`)."""

    carrier: str
    turning: str
    faces: dict
    outward: dict
    head: float
    thickness: float
    counterbore: float
    head_on: str | None = None
    groove_on: str | None = None
    blind: tuple = ()


def _stack(design: PhysicalDesign, joint: str):
    """(carrier, turning, sign) of ``joint``'s pin, sign = +1 when the turning link's hub lies further along
    the axis direction; None for a joint held by one link."""
    pin = design.pin(joint)
    mounts = {m.link: m.offset for m in design.mounts if m.joint == joint}
    others = [n for n in mounts if n != pin.carrier]
    if pin.carrier not in mounts or not others:
        return None
    turning = others[0]
    return pin.carrier, turning, 1.0 if mounts[turning] > mounts[pin.carrier] else -1.0


def head_radius(design: PhysicalDesign) -> float:
    """The radius (metres) of a pin's head: the bore plus `HEAD_WALL` of the hub's wall."""
    bore = design.pin_radius + design.hole_clearance
    return bore + HEAD_WALL * (design.hub_radius - bore)


@dataclass(frozen=True)
class PinSeat:
    """How the pin of a joint sits, from the design alone (offsets along the axis, metres): the
    ``carrier`` and ``turning`` link, ``out`` = +1 when the turning link's hub lies further along the axis
    direction (else -1), the hubs' outer ``faces`` {link: offset}, ``blind``: the links whose bore stops
    short of their outer face (the pin ends inside), ``head_on`` / ``groove_on``: the link whose face holds
    the head / a clip's groove (None: none); a head goes in from its own face."""

    carrier: str
    turning: str
    out: float
    faces: dict
    blind: tuple
    head_on: str | None
    groove_on: str | None


def pin_seat(design: PhysicalDesign, joint: str) -> PinSeat | None:
    """The `PinSeat` of ``joint``'s pin, None for a joint held by one link. The head goes on the link the
    fit prefers (press: the turning link, clip: the carrier) when the pin reaches its face, else on the
    other's (`synth.design.seats`); a plain pin has none."""
    stack = _stack(design, joint)
    if stack is None:
        return None
    carrier, turning, out = stack
    pin = design.pin(joint)
    h = design.hub_length / 2
    faces = {turning: design.mount(turning, joint).offset + out * h,
             carrier: design.mount(carrier, joint).offset - out * h}
    pin_end = {turning: pin.end if out > 0 else pin.start, carrier: pin.start if out > 0 else pin.end}
    tol = 1e-6 * design.hub_length
    blind = tuple(n for n in (carrier, turning) if abs(pin_end[n] - faces[n]) > tol)
    head_on = groove_on = None
    if design.pin_fit != "plain":
        first, second = (carrier, turning) if design.pin_fit == "clip" else (turning, carrier)
        head_on = first if first not in blind else (second if second not in blind else None)
        if design.pin_fit == "clip" and head_on == carrier and turning not in blind:
            groove_on = turning
    return PinSeat(carrier, turning, out, faces, blind, head_on, groove_on)


def pin_ends(linkage, design: PhysicalDesign, joint: str, sites=None) -> PinEnds | None:
    """The `PinEnds` of the pin of ``joint`` (`pin_seat` in world coordinates), None for a joint held by
    one link. The head: radius `head_radius`, thickness `CAP` of the hub length, sunk flush into a
    counterbore (head radius + hole clearance, one hole clearance deeper) of the hub it sits on: inside
    that hub. ``sites``: the linkage's ``joint_sites()`` when already at hand."""
    seat = pin_seat(design, joint)
    if seat is None:
        return None
    u = linkage.joint(joint).direction
    head = head_radius(design)
    return PinEnds(seat.carrier, seat.turning,
                   {n: axis_point(linkage, joint, f, sites) for n, f in seat.faces.items()},
                   {seat.turning: seat.out * u, seat.carrier: -seat.out * u}, head, CAP * design.hub_length,
                   head + design.hole_clearance, seat.head_on, seat.groove_on, seat.blind)


@dataclass
class CollisionReport:
    """What the design achieves. Lengths in metres, angles in radians.

    ``free``: no two bodies that share no joint come closer than ``clearance`` over ``range``
    ("full": the whole cycle; "task": the arc of the driving joint ``driver`` from ``driver_range[0]``
    to ``driver_range[1]`` (increasing, may exceed 2 pi) that visits every task pose);
    ``min_distance``: the certified smallest gap over that range (a lower bound; negative: the solids
    may overlap) when ``certified``, else the smallest sampled gap; ``sampled_min_distance``: the
    smallest gap seen at the samples; ``thinned``: when the
    default bar and pin radii collided and thinner ones are used, {"scale": of the defaults,
    "default_pin_radius", "default_bar_radius": metres, "default_pairs": the bodies that collided at
    the defaults}; ``pairs``: the offending body pairs when not free ({"bodies":
    [a, b], "min_distance": d, "driver_angles": [lo, hi]}, the closest first); ``message``: a sentence on what to change
    when not free; ``seconds``: CPU time of the search, ``work``: its gap evaluations (`synth.design.work`)."""

    free: bool
    range: str
    clearance: float
    min_distance: float
    driver: str
    driver_range: tuple[float, float]
    certified: bool = False
    pairs: list[dict] = field(default_factory=list)
    message: str = ""
    sampled_min_distance: float = float("nan")
    seconds: float = 0.0
    work: int = 0  # gap evaluations of the search (synth.design.work); neither it nor seconds is written
    thinned: dict | None = None  # set by synth.design.choose.design_for when the default sizes collided
    cranked: list | None = None  # [[link, joint a, joint b], ...]: the cranked bars (crank_bars, layered_design)
    layers: int | None = None  # levels used by a layered design (synth.design.layers)

    def to_dict(self) -> dict:
        return {"free": self.free, "range": self.range, "clearance": self.clearance,
                "min_distance": self.min_distance, "driver": self.driver,
                "driver_range": [float(self.driver_range[0]), float(self.driver_range[1])],
                "certified": self.certified, "pairs": self.pairs, "message": self.message,
                "sampled_min_distance": self.sampled_min_distance,  # (not ``seconds``: outputs are reproducible)
                **({"thinned": self.thinned} if self.thinned else {}),
                **({"cranked": self.cranked} if self.cranked else {}),
                **({"layers": self.layers} if self.layers else {})}


@dataclass
class DesignResult:
    """A finished design: what the exporters write (`synth.io.export`); ``drive``: the linkage's
    `synth.drive.DriveReport` when already made (else the JSON exporter makes it); ``slenderness``: its bars
    as written against the limit (`synth.design.sturdy.Slenderness`, set by `synth.design.choose.design_for`)."""

    design: PhysicalDesign
    collision: CollisionReport
    drive: object | None = None
    slenderness: object | None = None
