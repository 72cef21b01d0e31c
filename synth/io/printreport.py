"""The ``print`` section of linkage.json (issue 33): each part in its best print orientation on a
printer's bed, its volume and mass.

Print orientation of a closed mesh: the lowest part over the mesh faces that can lie flat on the bed
and `SPHERE` directions spread over the sphere (a flat face down when one gives the lowest part); then the footprint turned about the vertical to the smallest
bounding rectangle (an edge of the footprint's outline along x). Pure numpy (no scipy: writing an
output imports nothing heavy). ``extents`` (x, y, z) are that
rectangle's sides (x >= y) and the height, in millimetres; ``fits_bed`` when they fit the bed
(x, y, z; the part may turn 90 degrees on the bed). A part that does not fit fits at ``scale`` =
min over axes of bed / extent (sorted sides against sorted bed sides), < 1.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.io.names import MESH_UNIT_SCALE, mesh_filename
from synth.io.solid import hull_vertices, row_runs, shell_count, signed_volume

BED = (220.0, 220.0, 250.0)  # mm: a common printer's build volume
MATERIAL = ("PLA", 1.24)  # name, density g/cm^3


@dataclass(frozen=True)
class PrintPart:
    """One part on the bed: ``mesh`` (relative path), ``extents`` (3,) mm in print orientation (x >= y,
    z = height), ``fits_bed``, ``scale`` (<= 1: the uniform scale that makes it fit), ``volume`` mm^3,
    ``mass`` g, ``bodies``: its separate pieces (1 for a sound part; `synth.io.solid.shell_count`)."""

    mesh: str
    extents: tuple[float, float, float]
    fits_bed: bool
    scale: float
    volume: float
    mass: float
    bodies: int = 1


DIRECTIONS = 720  # footprint directions sampled for its outline (its extreme points)


SPHERE = 2000  # further down directions tried, spread over the sphere


def sphere_directions(n: int) -> np.ndarray:
    """``n`` unit vectors (n, 3) spread evenly over the sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


_SPHERE = sphere_directions(SPHERE)


def _down_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Outward unit normals (k, 3) of the faces of the closed mesh that can lie on a flat bed: the faces
    whose plane has the whole mesh on its inner side (faces of the convex hull), rounded duplicates removed."""
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(n, axis=1)
    keep = area > 1e-12 * max(area.max(), 1e-300)
    n = np.round(n[keep] / area[keep, None], 9)
    order, first = row_runs(n)
    n = n[order[first]]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    size = np.ptp(vertices, axis=0).max()
    out = []
    for chunk in np.array_split(n, max(1, len(n) // 512)):
        proj = vertices @ chunk.T  # (v, c)
        gap = np.subtract(proj.max(axis=0), proj, out=proj)  # |proj - max|, in place (a new array: ~4x the time)
        on = np.count_nonzero(gap <= 1e-9 * size, axis=0) >= 3  # (np.isclose, rtol 0)
        out.append(chunk[on])
    return np.concatenate(out)


def print_orientation(vertices: np.ndarray, faces: np.ndarray, down=None) -> np.ndarray:
    """A rotation R (3, 3) putting the closed mesh (vertices (n, 3), faces (m, 3)) in its print
    orientation (rows of R: the bed's x, y and up in the mesh's frame): the lowest height among the
    mesh faces that can lie on the bed and `SPHERE` directions (a convex hull's face spanning several
    primitives is not a mesh face; those directions come within about 2.5 degrees of it), or the face
    whose outward unit normal is ``down`` (3,) (a base's mounting face); the footprint turned so that an
    edge of its outline (extreme points in `DIRECTIONS` directions) runs along x, smallest bounding
    rectangle, x the longer side."""
    hull = vertices[hull_vertices(vertices)]  # the same extremes in every direction, several times fewer points
    if down is not None:
        up = -np.asarray(down, float) / np.linalg.norm(down)
    else:
        normals = np.concatenate([_down_faces(vertices, faces), _SPHERE])
        up = -normals[np.argmin(np.ptp(hull @ normals.T, axis=0))]  # the face on the bed points down
    e1 = np.cross(up, np.eye(3)[np.argmin(np.abs(up))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    flat = hull @ np.stack([e1, e2], axis=1)  # (n, 2) footprint
    t = np.linspace(0, 2 * np.pi, DIRECTIONS, endpoint=False)
    pts = flat[np.argmax(flat @ np.stack([np.cos(t), np.sin(t)]), axis=0)]  # outline, in angular order
    edges = np.roll(pts, -1, axis=0) - pts
    edges = edges[np.linalg.norm(edges, axis=1) > 0]
    ang = np.arctan2(edges[:, 1], edges[:, 0])  # (k,) candidate directions of x
    c, s = np.cos(ang), np.sin(ang)
    order, first = row_runs(pts)
    corners = pts[order[first]]  # the outline's distinct points (pts repeats each for many directions)
    x = corners @ np.stack([c, s])  # (m, k)
    y = corners @ np.stack([-s, c])
    k = np.argmin(np.ptp(x, axis=0) * np.ptp(y, axis=0))
    ex = c[k] * e1 + s[k] * e2
    ey = np.cross(up, ex)
    if np.ptp(hull @ ex) < np.ptp(hull @ ey):
        ex, ey = ey, -ex
    return np.stack([ex, ey, up])


def fit_scale(extents, bed=BED) -> float:
    """The largest uniform scale (<= 1) at which a part of ``extents`` (x >= y, z) fits ``bed`` (mm),
    turning 90 degrees about the vertical if needed."""
    (x, y), z = sorted(extents[:2], reverse=True), extents[2]
    bx, by = sorted(bed[:2], reverse=True)
    return float(min(1.0, bx / x, by / y, bed[2] / z))


def print_part(name: str, mesh, bed=BED, density: float = MATERIAL[1], down=None) -> PrintPart:
    """The `PrintPart` of the closed mesh ``mesh`` (`synth.io.solid.Solid`, metres) of URDF link ``name``;
    ``down``: the outward normal of the face to print on (`print_orientation`) when the part fits the bed
    so; None (or when it does not fit on that face): the lowest way."""
    v = np.asarray(mesh.vertices, float) / MESH_UNIT_SCALE  # mm
    for face in ([down, None] if down is not None else [None]):
        R = print_orientation(v, np.asarray(mesh.faces), face)
        ext = tuple(float(e) for e in np.ptp(v @ R.T, axis=0))
        scale = fit_scale(ext, bed)
        if scale >= 1.0:
            break
    volume = float(signed_volume(mesh.triangles)) / MESH_UNIT_SCALE ** 3
    return PrintPart(mesh_filename(name), ext, scale >= 1.0, scale, volume, volume * density * 1e-3,
                     shell_count(mesh.faces))


def print_section(solids: dict, bed=BED, material=MATERIAL, down: dict | None = None) -> dict:
    """The ``print`` section: ``bed`` (mm), ``material`` {name, density g/cm^3} and ``parts`` (one
    `PrintPart` per solid of ``solids`` {URDF link: Solid}, as dicts; ``scale`` only when it does not fit);
    ``down`` {URDF link: outward normal (3,)}: the parts printed on a given face (the base's mounting face)."""
    parts = []
    for name, mesh in solids.items():
        p = print_part(name, mesh, bed, material[1], (down or {}).get(name))
        d = {"mesh": p.mesh, "extents": list(p.extents), "fits_bed": p.fits_bed, "volume": p.volume,
             "mass": p.mass}
        if not p.fits_bed:
            d["scale"] = p.scale
        if p.bodies != 1:  # a part in pieces (docs/design.md, "Pins": a bore that cuts a bar off its hub)
            d["bodies"] = p.bodies
        parts.append(d)
    return {"bed": list(map(float, bed)), "material": {"name": material[0], "density": material[1]},
            "parts": parts}


def too_large(section: dict) -> list[str]:
    """Sentences naming the parts of a ``print`` section that do not fit its bed, with the scale that
    would make them fit (for the CLI's summary)."""
    return [f"{p['mesh']} does not fit the {' x '.join(f'{b:g}' for b in section['bed'])} mm bed "
            f"({' x '.join(f'{e:.0f}' for e in p['extents'])} mm): it fits at scale {p['scale']:.3g}"
            for p in section["parts"] if not p["fits_bed"]]


def in_pieces(section: dict) -> list[str]:
    """Sentences naming the parts of a ``print`` section that are not one body (for the CLI's summary)."""
    return [f"{p['mesh']} is {p['bodies']} separate bodies, not one part (a bore cuts a bar off its hub)"
            for p in section["parts"] if p.get("bodies", 1) != 1]


def print_notes(directory) -> list[str]:
    """`in_pieces` and `too_large` of the ``print`` section of ``directory``/linkage.json (none when it has
    no such section)."""
    doc = json.loads((Path(directory) / "linkage.json").read_text(encoding="utf-8"))
    return in_pieces(doc["print"]) + too_large(doc["print"]) if "print" in doc else []
