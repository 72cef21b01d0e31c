"""`mpsynth parts OUT`: the printable parts of a written linkage laid out on print plates, and an assembly
sheet (issue 33).

**Plates.** Every STL of OUT (links and pins) is turned into its print orientation
(`synth.io.printreport.print_orientation`: the lowest height, a flat face down; footprint x >= y), set
on the bed and packed by shelves: parts by decreasing footprint depth (y), left to right along x with
`GAP` mm between them, a new shelf above the highest part of the last one when x is full, a new plate
when the bed's y is full. A part that does not fit the bed alone is left out and named (with the scale
that would make it fit, linkage.json's ``print`` section). The base lies on its mounting face
(linkage.json ``design.mounting``) when it has one. Each plate is one file in millimetres: a binary STL
``plates/plate_<k>.stl``, parts as separate closed shells, or (``fmt`` "3mf") a 3MF package
``plates/plate_<k>.3mf`` with every part a mesh object named as its URDF link, placed by its build item
(`synth.io.threemf`).

**Assembly sheet.** ``plates/assembly.html``: per joint, which pin goes through which bores in which
order along the axis (the mount offsets of linkage.json's ``design``), which link holds the pin (pressed
or glued into its bore) and which turns on it; the parts list; and an exploded view
(`synth.tools.render.exploded_view`, a PNG embedded in the page).
"""
from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.design.model import PhysicalDesign, pin_seat
from synth.errors import InputError
from synth.io.atomic import atomic_write
from synth.io.printreport import BED, fit_scale, print_orientation
from synth.io.readback import read_output
from synth.io.solid import read_stl_triangles, stl_bytes, weld
from synth.io.threemf import threemf_bytes

GAP = 5.0  # mm between parts on a plate and from the bed's edge


@dataclass
class Placement:
    """A part on a plate: ``name`` (URDF link), ``plate`` (0-based), ``offset`` (x, y) mm of its
    footprint's corner, ``extents`` (x, y, z) mm in print orientation."""

    name: str
    plate: int
    offset: tuple[float, float]
    extents: tuple[float, float, float]


@dataclass
class PartsLayout:
    """What `lay_out` decided: ``placements``, ``plates`` (count), ``too_large`` {name: scale that fits},
    ``bed`` (x, y, z) mm; ``oriented`` {name: (m, 3, 3) triangles, mm, in print orientation, corner at 0}."""

    placements: list[Placement]
    plates: int
    too_large: dict[str, float]
    bed: tuple[float, float, float]
    oriented: dict[str, np.ndarray] = field(repr=False, default_factory=dict)


def oriented_part(triangles: np.ndarray, down=None) -> np.ndarray:
    """The triangles (m, 3, 3) mm of a closed part turned into its print orientation (``down``: the
    outward normal of the face to print on, `print_orientation`), the lower corner of its bounding box at
    the origin."""
    mesh = weld(np.asarray(triangles, np.float64))
    R = print_orientation(mesh.vertices, mesh.faces, down)
    tri = np.asarray(triangles, np.float64) @ R.T
    return tri - tri.reshape(-1, 3).min(axis=0)


def shelf_pack(footprints: dict[str, tuple[float, float]], bed=BED, gap: float = GAP) -> list[tuple[str, int, float, float]]:
    """[(name, plate, x, y)]: the footprints {name: (x, y)} mm packed on plates of ``bed`` by shelves
    (see the module docstring); every footprint must fit the bed within the gaps."""
    order = sorted(footprints, key=lambda n: (-footprints[n][1], -footprints[n][0], n))
    out, plate, x, y, shelf = [], 0, gap, gap, 0.0
    for n in order:
        w, d = footprints[n]
        if x + w + gap > bed[0]:  # next shelf
            x, y, shelf = gap, y + shelf + gap, 0.0
        if y + d + gap > bed[1]:  # next plate
            plate, x, y, shelf = plate + 1, gap, gap, 0.0
        out.append((n, plate, x, y))
        x += w + gap
        shelf = max(shelf, d)
    return out


def lay_out(parts: dict[str, np.ndarray], bed=BED, gap: float = GAP, down: dict | None = None) -> PartsLayout:
    """The `PartsLayout` of closed parts {URDF link: triangles (m, 3, 3) mm}; ``down`` {URDF link: the
    outward normal (3,) of the face it is printed on} (the others: `print_orientation`'s choice)."""
    oriented, too_large, feet = {}, {}, {}
    room = (bed[0] - 2 * gap, bed[1] - 2 * gap, bed[2])
    for name, tri in parts.items():
        faces = [(down or {}).get(name)] + ([None] if (down or {}).get(name) is not None else [])
        for face in faces:  # on its mounting face when it fits the bed so, else the lowest way
            o, ext = _on_bed(oriented_part(tri, face), room)
            if ext is not None:
                break
        if ext is None:
            too_large[name] = fit_scale(tuple(np.ptp(o.reshape(-1, 3), axis=0)), room)
            continue
        oriented[name] = o
        feet[name] = (float(ext[0]), float(ext[1]))
    placements = [Placement(n, k, (x, y), tuple(float(e) for e in np.ptp(oriented[n].reshape(-1, 3), axis=0)))
                  for n, k, x, y in shelf_pack(feet, bed, gap)]
    plates = 1 + max((p.plate for p in placements), default=-1)
    return PartsLayout(placements, plates, too_large, tuple(bed), oriented)


def _on_bed(o: np.ndarray, room) -> tuple[np.ndarray, np.ndarray | None]:
    """(the oriented part ``o``, turned 90 degrees about the vertical when only that fits ``room``, its
    extents), extents None when it does not fit either way."""
    ext = np.ptp(o.reshape(-1, 3), axis=0)
    if ext[0] <= room[0] and ext[1] <= room[1] and ext[2] <= room[2]:
        return o, ext
    if ext[1] <= room[0] and ext[0] <= room[1] and ext[2] <= room[2]:  # fits turned by 90 degrees
        return np.stack([o[..., 1], ext[0] - o[..., 0], o[..., 2]], axis=-1), ext[[1, 0, 2]]
    return o, None


def plate_triangles(layout: PartsLayout, plate: int) -> np.ndarray:
    """(m, 3, 3) mm: every part of ``plate`` at its place."""
    tris = [layout.oriented[p.name] + np.array([p.offset[0], p.offset[1], 0.0])
            for p in layout.placements if p.plate == plate]
    return np.concatenate(tris) if tris else np.zeros((0, 3, 3))


def assembly_steps(document: dict) -> list[dict]:
    """Per joint of linkage.json's ``design``: {"joint", "pin", "through": [links in the order the pin
    enters them: from the face that takes its head (`synth.design.model.pin_seat`), else along the axis from
    the pin's start], "carrier": the link holding the pin, "turning": the others, "head": the link whose
    face takes the head (or None), "blind": the links whose bore the pin ends in}."""
    design = document.get("design") or {}
    seats = {}
    if design.get("pins") and design.get("mounts"):
        model = PhysicalDesign.from_dict(design)
        seats = {p.joint: pin_seat(model, p.joint) for p in model.pins}
    steps = []
    for pin in design.get("pins", []):
        mounts = sorted((m["offset"], m["link"]) for m in design.get("mounts", []) if m["joint"] == pin["joint"])
        through = [link for _, link in mounts]
        seat = seats.get(pin["joint"])
        head = seat.head_on if seat is not None else None
        if head is not None and through and through[0] != head:
            through = through[::-1]
        steps.append({"joint": pin["joint"], "pin": f"pin_{pin['joint']}", "through": through,
                      "carrier": pin["carrier"], "turning": [n for n in through if n != pin["carrier"]],
                      "head": head, "blind": list(seat.blind) if seat is not None else []})
    return steps


def _step_html(s: dict) -> str:
    """One joint's line of the assembly sheet."""
    e = html.escape
    order = " then ".join(e(t) + (" (its bore is blind: the pin ends inside)" if t in s["blind"] else "")
                          for t in s["through"])
    side = (f"in from the face of <b>{e(s['head'])}</b>, where its head sits" if s["head"]
            else "in this order along the axis")
    return (f"<li>Joint <b>{e(s['joint'])}</b>: push <b>{e(s['pin'])}</b> through the bores of {order} ({side}); "
            f"it is pressed or glued into <b>{e(s['carrier'])}</b> and "
            f"{', '.join(e(t) for t in s['turning']) or 'nothing'} turns on it.</li>")


def sheet_html(name: str, layout: PartsLayout, steps: list[dict], picture: bytes | None, fmt: str = "stl") -> str:
    """The assembly sheet (one self-contained HTML page)."""
    e = html.escape
    rows = "".join(f"<tr><td>{e(p.name)}</td><td>{p.plate + 1}</td><td>{' x '.join(f'{v:.1f}' for v in p.extents)}</td></tr>"
                   for p in layout.placements)
    rows += "".join(f"<tr><td>{e(n)}</td><td>does not fit the bed: print at scale {s:.3g}</td><td></td></tr>"
                    for n, s in layout.too_large.items())
    items = "".join(_step_html(s) for s in steps)
    img = (f'<img alt="exploded view" src="data:image/png;base64,{base64.b64encode(picture).decode()}">'
           if picture else "<p>(no picture: pip install 'mpsynth[viz]')</p>")
    bed = " x ".join(f"{b:g}" for b in layout.bed)
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{e(name)}: assembly</title>"
            "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto}td,th{padding:2px 8px}"
            "img{max-width:100%}</style></head><body>"
            f"<h1>{e(name)}: parts and assembly</h1>{img}<h2>Assembly</h2><ol>{items}</ol>"
            f"<h2>Parts</h2><p>{layout.plates} plate(s) of {bed} mm (plates/plate_&lt;k&gt;.{fmt}).</p>"
            f"<table><tr><th>part</th><th>plate</th><th>extents mm</th></tr>{rows}</table></body></html>")


def plate_3mf(layout: PartsLayout, plate: int) -> bytes:
    """The 3MF package of ``plate``: each part an object named as its link, in its print orientation with
    its corner at the origin, placed by its build item."""
    return threemf_bytes([(p.name, weld(layout.oriented[p.name]), (p.offset[0], p.offset[1], 0.0))
                          for p in layout.placements if p.plate == plate])


PLATE_FORMATS = ("stl", "3mf")


def mounting_down(document: dict) -> dict:
    """{link: outward normal (3,)} of the mounting face in linkage.json's ``design.mounting`` (the link's
    STL shares the world's axes), or {}."""
    m = (document.get("design") or {}).get("mounting")
    try:
        n = np.asarray(m["normal"], float) if isinstance(m, dict) else None
    except (KeyError, TypeError, ValueError):
        n = None
    if n is None or n.shape != (3,) or not np.all(np.isfinite(n)) or not np.linalg.norm(n) > 0:
        return {}
    return {str(m.get("link", "base")): n}


def write_parts(out, bed=BED, fmt: str = "stl") -> tuple[PartsLayout, list[Path]]:
    """Lay out the parts of the output ``out`` (`lay_out`) and write ``plates/plate_<k>.stl`` (``fmt``
    "3mf": ``.3mf``) and ``plates/assembly.html`` into it; (layout, paths written). InputError when OUT
    is not an output or ``fmt`` is not one of `PLATE_FORMATS`."""
    if fmt not in PLATE_FORMATS:
        raise InputError(f"plate format must be one of {', '.join(PLATE_FORMATS)}, got {fmt!r}")
    rb = read_output(out)
    parts = {}
    for f in sorted((rb.root / "meshes").glob("*.stl")):
        try:
            parts[f.stem] = read_stl_triangles(f.read_bytes()).astype(np.float64)
        except ValueError as e:
            raise InputError(f"{f}: {e}") from None
    if not parts:
        raise InputError(f"{rb.root}: no meshes/*.stl to lay out")
    layout = lay_out(parts, bed, down=mounting_down(rb.document))
    target = rb.root / "plates"
    target.mkdir(exist_ok=True)
    written = []
    for k in range(layout.plates):
        path = target / f"plate_{k + 1}.{fmt}"
        data = plate_3mf(layout, k) if fmt == "3mf" else stl_bytes(plate_triangles(layout, k))
        atomic_write(path, lambda tmp, data=data: Path(tmp).write_bytes(data), "plate")
        written.append(path)
    picture = None
    try:
        from synth.tools.render import exploded_view

        buf = io.BytesIO()
        exploded_view(rb, buf)
        picture = buf.getvalue()
    except InputError:  # no matplotlib: the sheet says so
        pass
    page = sheet_html(rb.robot_name, layout, assembly_steps(rb.document), picture, fmt)
    path = target / "assembly.html"
    atomic_write(path, lambda tmp: Path(tmp).write_text(page, encoding="utf-8"), "assembly sheet")
    written.append(path)
    return layout, written
