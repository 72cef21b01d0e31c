"""Where each pin's head sits and which bores are blind (issue 33: every part one body).

A joint's two hubs are stacked on its axis; each has an *outer face* (away from the other hub). A link's
bar leaves its hub at an angle to the axis; a bar nearly along the axis leaves through the outer face.
When it is thinner than the opening cut there (the bore, or a head's counterbore), bore and counterbore
take its whole cross-section and the hub is a ring with no bar attached: two bodies, and the bar over
the opening would keep the head out anyway. So (`seat_pins`) such a face is **closed**: the bore stops
a cap (`CAP` of the hub length) short of the face, the pin ends there, and the head goes on the other
link's face when the fit needs a head (docs/design.md, "Pins").

A face is *clear* of an opening of radius r when every bar of the link leaving that mount either does not
leave through the outer face or keeps `margin` (min(half the bar radius, `MIN_WALL`)) of its cross-section
outside the circle r in the face's plane: the bar's centre line meets the plane at e = (L/2) tan(alpha)
from the axis (alpha: its angle to the outward axis, L the hub length), so the test is e + r_bar >= r + margin.

Per fit (C: the carrier, T: the turning link; "free": clear of the counterbore, "open": clear of the bore):
- press: the head on T when T is free (C closed unless open); else on C and T closed (its cap holds it);
- clip: head on C, groove on T when both are free; C free only: head on C, T closed; T free only: head on
  T, C closed (the pin glued in its blind bore);
- plain: a face closed when not open.
When neither face can take what the fit needs (or, plain, neither is open) the pin stays as it was.

The pins only get shorter and the carriers stay, so every capsule of `synth.design.model.capsules` still
bounds the solid written and the collision certificate of the design still holds. The head's side is
read back from the pin's ends (`pin_ends`): the preferred link's face when the pin reaches it, else the
other's; a linkage.json written before this rule has full-length pins and its heads where they were.
Lengths in metres.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from synth.design.model import CAP, MIN_WALL, PhysicalDesign, Pin, bar_polyline, joint_links, pin_ends


def bar_directions(linkage, design: PhysicalDesign, link: str, joint: str, sites=None) -> np.ndarray:
    """(k, 3) unit directions in which the bars of ``link`` leave its mount on ``joint`` (the first
    segment of each bar's polyline, reference configuration)."""
    sites = linkage.joint_sites() if sites is None else sites
    out = []
    for b in design.bars:
        if b.link != link or joint not in b.joints:
            continue
        pts = bar_polyline(linkage, design, b, sites)
        d = pts[1] - pts[0] if b.joints[0] == joint else pts[-2] - pts[-1]
        n = float(np.linalg.norm(d))
        if n > 0:
            out.append(d / n)
    return np.asarray(out, float).reshape(-1, 3)


def face_clear(directions: np.ndarray, outward: np.ndarray, design: PhysicalDesign, opening: float) -> bool:
    """True when bars leaving a mount along ``directions`` (k, 3) keep a margin of their cross-section
    outside a circle of radius ``opening`` around the axis in the plane of the hub's outer face (outward
    unit normal ``outward``): see the module docstring."""
    c = directions @ np.asarray(outward, float)
    through = c > 0
    if not through.any():
        return True
    c = c[through]
    e = 0.5 * design.hub_length * np.sqrt(np.maximum(0.0, 1.0 - c * c)) / c
    margin = min(0.5 * design.bar_radius, MIN_WALL)
    return bool(np.all(e + design.bar_radius >= opening + margin))


def _closed_links(linkage, design: PhysicalDesign, joint: str, sites) -> set:
    """The links whose bore on ``joint`` becomes blind (the rules of the module docstring)."""
    ends = pin_ends(linkage, design, joint, sites)
    if ends is None:
        return set()
    C, T = ends.carrier, ends.turning
    bore = design.pin_radius + design.hole_clearance
    dirs = {n: bar_directions(linkage, design, n, joint, sites) for n in (C, T)}
    free = {n: face_clear(dirs[n], ends.outward[n], design, ends.counterbore) for n in (C, T)}
    open_ = {n: face_clear(dirs[n], ends.outward[n], design, bore) for n in (C, T)}
    if design.pin_fit == "press":
        if free[T]:
            return set() if open_[C] else {C}
        return {T} if free[C] else set()
    if design.pin_fit == "clip":
        if free[C]:
            return set() if free[T] else {T}
        return {C} if free[T] else set()
    closed = {n for n in (C, T) if not open_[n]}
    return closed if len(closed) < 2 else set()


def seat_pins(linkage, design: PhysicalDesign) -> PhysicalDesign:
    """``design`` with every pin spanning its joint's stack of hubs but ending a cap (`CAP` of the hub
    length) short of the outer face of each link whose face is closed (module docstring); mounts, bars and
    carriers unchanged."""
    sites = linkage.joint_sites()
    holders = joint_links(linkage)
    pins = []
    h, cap = design.hub_length / 2, CAP * design.hub_length
    for p in design.pins:
        offs = [m.offset for m in design.mounts if m.joint == p.joint]
        if len(holders.get(p.joint, [])) < 2 or len(offs) < 2:
            pins.append(p)
            continue
        closed = _closed_links(linkage, design, p.joint, sites)
        start, end = min(offs) - h, max(offs) + h  # the whole stack (idempotent)
        for n in closed:
            off = design.mount(n, p.joint).offset
            if abs(off - start) < abs(off - end):
                start += cap
            else:
                end -= cap
        pins.append(Pin(p.joint, start, end, p.carrier))
    return dataclasses.replace(design, pins=pins)
