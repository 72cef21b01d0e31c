"""Closed triangle meshes in plain numpy (plus manifold3d for the boolean union): the export path's
mesh toolkit, so that writing an output never imports trimesh (and with it scipy and networkx).

A `Solid` is an indexed triangle mesh: ``vertices`` (n, 3) float64 and ``faces`` (m, 3) int64, each
triangle wound counter-clockwise seen from outside (outward normals by the right-hand rule). It is
*closed* when every edge is shared by exactly two triangles that run through it in opposite
directions (an oriented 2-manifold without boundary) and it encloses a positive volume.

Binary STL layout (the common one): an 80-byte zero header, the triangle count (uint32), then per
triangle the unit normal and the three corners as little-endian float32, and a zero uint16.
"""
from __future__ import annotations

import contextlib
import os
import sys
from dataclasses import dataclass

import numpy as np

from synth.io import interrupts

STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


@dataclass(frozen=True)
class Solid:
    """An indexed triangle mesh; see the module docstring for the conventions."""

    vertices: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64

    @property
    def triangles(self) -> np.ndarray:
        """(m, 3, 3): the corners of every face."""
        return self.vertices[self.faces]

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3): the lower and upper corner of the axis-aligned bounding box."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def translated(self, d) -> "Solid":
        return Solid(self.vertices + np.asarray(d, float), self.faces)

    def to_trimesh(self):
        """The same mesh as a ``trimesh.Trimesh`` (imports trimesh)."""
        import trimesh

        return trimesh.Trimesh(vertices=self.vertices.copy(), faces=self.faces.copy(), process=False)


# ---------------------------------------------------------------------- primitives
def _proper_completion(w) -> np.ndarray:
    """A rotation matrix whose first column is +-w/|w|: the left singular vectors of the column w."""
    U = np.linalg.svd(np.reshape(np.asarray(w, float), (3, 1)))[0]
    if np.linalg.det(U) < 0:
        U[:, -1] = -U[:, -1]
    return U


_Z_COMPLETION = _proper_completion([0.0, 0.0, 1.0])


def axis_rotation(w) -> np.ndarray:
    """A rotation taking the z axis onto the line of unit vector ``w``: U_w U_z^T with U_v the proper
    completion of v from the SVD. (The facets of our cylinders sit where they always did; a cylinder
    centred on its axis does not care which way along the line z goes.)"""
    return _proper_completion(w) @ _Z_COMPLETION.T


def cylinder(a, b, radius: float, sections: int, phase: float = 0.0) -> Solid:
    """Closed cylinder of ``radius`` from point ``a`` to point ``b``: a regular ``sections``-gon prism
    (corners at angles 2 pi (k + phase) / sections in the frame of `axis_rotation`) with fan-triangulated
    caps (`revolution` of its rectangle)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    height = float(np.linalg.norm(b - a))
    return revolution(a, (b - a) / height, [(0.0, 0.0), (0.0, radius), (height, radius), (height, 0.0)], sections,
                      phase)


def revolution(origin, direction, profile, sections: int, phase: float = 0.0) -> Solid:
    """Closed solid of revolution about the line through ``origin`` (3,) along unit ``direction`` (3,):
    the polygon ``profile`` (k, 2) of (axial position, radius) corners, from the axis round to the axis
    (first and last radius 0, the others > 0; the inside to the right going round, as
    `synth.io.meshes.coaxial_profile` gives it), turned a full turn as ``sections``-gon rings (corners at
    angles 2 pi (j + phase) / sections in the frame of `axis_rotation`, as `cylinder`'s) and two
    fan-triangulated end caps. A cylinder is the profile [(0, 0), (0, r), (h, r), (h, 0)]."""
    prof = np.asarray(profile, float)
    n, k = int(sections), len(prof) - 2  # k rings: the corners off the axis
    theta = 2.0 * np.pi * (np.arange(n) + phase) / n
    rot = axis_rotation(np.asarray(direction, float))
    spoke = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(n)]) @ rot.T  # (n, 3) unit, across the axis
    axis, o = rot[:, 2], np.asarray(origin, float)
    rings = (o + prof[1:-1, :1, None] * axis + prof[1:-1, 1:, None] * spoke).reshape(-1, 3)  # (k n, 3)
    vertices = np.concatenate([rings, o + prof[[0, -1], :1] * axis])  # cap centres k n, k n + 1
    i = np.arange(n)
    j = (i + 1) % n
    faces = [np.column_stack([np.full(n, k * n), j, i])]  # the first cap, normal against the direction
    for q in range(k - 1):  # ring q to ring q + 1: a cylinder's side, a flat ring or a cone
        lo, hi = q * n, (q + 1) * n
        faces += [np.column_stack([lo + i, lo + j, hi + j]), np.column_stack([lo + i, hi + j, hi + i])]
    faces.append(np.column_stack([np.full(n, k * n + 1), (k - 1) * n + i, (k - 1) * n + j]))  # the last cap
    return Solid(vertices, np.concatenate(faces).astype(np.int64))


def box(a, b, edges) -> Solid:
    """Closed box (a flat plate) over the rectangle centred at point ``a`` with half-edge vectors
    ``edges`` (2, 3) (perpendicular), extruded to the same rectangle centred at ``b`` (``b - a``
    perpendicular to both edges): 8 corners, 12 triangles wound outwards."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    e1, e2 = (np.asarray(e, float) for e in edges)
    if np.dot(np.cross(e1, e2), b - a) < 0:  # keep (e1, e2, b - a) right-handed: outward winding below
        e1, e2 = e2, e1
    square = [-e1 - e2, e1 - e2, e1 + e2, -e1 + e2]
    vertices = np.array([a + q for q in square] + [b + q for q in square])
    faces = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7],  # bottom (normal -(b - a)), top
                      [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    return Solid(vertices, faces.astype(np.int64))


def capsule(a, b, radius: float, sections: int, rings: int | None = None) -> Solid:
    """Closed capsule (round bar with round ends) of ``radius`` around the segment a-b: a cylinder of
    ``sections``-gons capped by two hemispheres of ``rings`` latitude rings each (default sections / 4).
    Every vertex lies at distance exactly ``radius`` from the segment, so the faceted solid lies inside
    the true capsule. A segment shorter than 1e-9 ``radius`` gives a sphere."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = b - a
    height = float(np.linalg.norm(axis))
    n = int(sections)
    m = max(int(rings if rings is not None else n // 4), 2)
    theta = np.linspace(0.0, 2.0 * np.pi, n + 1)[:-1]
    lat = np.linspace(-np.pi / 2, np.pi / 2, 2 * m + 1)[1:-1]  # 2m - 1 rings, the equator in the middle
    sphere = height <= 1e-9 * radius
    half = 0.0 if sphere else height / 2
    rows = []
    for k, phi in enumerate(lat):
        zs = [radius * np.sin(phi) + (half if k >= m else -half)]
        if k == m - 1 and not sphere:  # the equator twice: bottom end and top end of the cylinder
            zs = [-half, half]
        for z in zs:
            rows.append(np.column_stack([radius * np.cos(phi) * np.cos(theta), radius * np.cos(phi) * np.sin(theta),
                                         np.full(n, z)]))
    r = len(rows)
    local = np.concatenate(rows + [[[0.0, 0.0, -half - radius], [0.0, 0.0, half + radius]]])
    i = np.arange(n)
    j = (i + 1) % n
    south, north = r * n, r * n + 1
    faces = [np.column_stack([np.full(n, south), j, i]), np.column_stack([np.full(n, north), (r - 1) * n + i,
                                                                          (r - 1) * n + j])]
    for q in range(r - 1):
        lo, hi = q * n, (q + 1) * n
        faces += [np.column_stack([lo + i, lo + j, hi + j]), np.column_stack([lo + i, hi + j, hi + i])]
    rot = axis_rotation(axis / height) if height > 0 else np.eye(3)
    vertices = local @ rot.T + (a + b) / 2
    return Solid(vertices, np.concatenate(faces).astype(np.int64))


def concatenate(parts) -> Solid:
    """All parts in one mesh (overlapping shells stay separate shells)."""
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    return Solid(np.concatenate([p.vertices for p in parts]),
                 np.concatenate([p.faces + k for p, k in zip(parts, offsets)]))


def import_manifold3d():
    """The manifold3d module. The first import runs inside `synth.io.interrupts.held` (the CLI holds
    SIGINT/SIGTERM back there and delivers them once it is done: a KeyboardInterrupt raised inside
    manifold3d's (nanobind) module initialisation aborts the whole process); its first use here starts
    its thread pool at `limit_boolean_threads`'s size when one was set. Raises ImportError."""
    if "manifold3d" in sys.modules:
        import manifold3d
    else:
        with interrupts.held():
            import manifold3d
    if _THREADS["limit"] is not None and not _THREADS["started"]:
        _start_pool(manifold3d, _THREADS["limit"])
    return manifold3d


# manifold3d 3.5 runs its booleans on a TBB thread pool (linked into the module: no API sets its size), which
# TBB sizes from the CPUs the calling thread may run on when the pool is first used, for the process's life
_THREADS = {"limit": None, "started": False}


def limit_boolean_threads(threads: int = 1) -> None:
    """manifold3d's booleans in this process run on at most ``threads`` threads (from its first use on;
    a pool manifold3d already started keeps its size). For a process that shares the CPUs with as many
    others as there are CPUs (the workers of ``mpsynth batch -j N``, a local Dask cluster's): there a
    second thread finds no idle CPU and only adds CPU time (its waits spin; bench/RESULTS.md, "Output jobs,
    fourth pass"). The meshes are the same bytes."""
    _THREADS["limit"] = max(1, int(threads))


def _start_pool(manifold3d, threads: int) -> None:
    """Start manifold3d's thread pool at ``threads`` threads: this thread's CPUs restricted to that many
    while a small boolean runs (TBB reads them once, then), then restored."""
    _THREADS["started"] = True
    try:
        cpus = os.sched_getaffinity(0)
    except (AttributeError, OSError):  # not Linux: the pool keeps its own size
        return
    if len(cpus) <= threads:
        return
    try:
        os.sched_setaffinity(0, sorted(cpus)[:threads])
    except OSError:  # (not allowed here: the pool keeps its own size)
        return
    try:
        cube = manifold3d.Manifold.cube((1.0, 1.0, 1.0))
        (cube - cube.translate((0.5, 0.5, 0.5))).num_tri()
    finally:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(0, cpus)


def union(parts) -> Solid:
    """Boolean union of closed parts with manifold3d: one closed 2-manifold (see `boolean`)."""
    return boolean(parts)


BOOLEAN_TOLERANCE = 1e-6  # of the parts' size: features below it are merged (float32 STL steps are 6e-8)


def boolean(parts, cut=()) -> Solid:
    """The union of the closed ``parts`` minus the union of the closed ``cut`` solids, with manifold3d:
    one closed 2-manifold.

    Computed at unit size around the origin in double precision (manifold3d's ``Mesh64`` in and out):
    its tolerances are then relative, so micrometre-sized parts and parts far from the world origin work
    alike. (Its single-precision ``Mesh`` rounds distinct vertices of the result onto one another where
    surfaces meet at a grazing angle, e.g. a hub as wide as its bar: zero-area triangles whose edges a
    reader of the STL sees run twice.) The result is then simplified to `BOOLEAN_TOLERANCE` of the size
    (`Manifold.set_tolerance`: edges shorter than that collapse while the solid stays a 2-manifold), well
    above the float32 step of an STL and well below anything a printer or a simulator resolves; an
    edge that cannot collapse may remain, and the STL writer drops the triangles it makes degenerate
    (`degenerate_free`)."""
    manifold3d = import_manifold3d()
    centre, size = _unit_frame(parts)
    body = manifold3d.Manifold.batch_boolean(_unit_manifolds(parts, centre, size), manifold3d.OpType.Add)
    if len(cut):
        body = body - manifold3d.Manifold.batch_boolean(_unit_manifolds(cut, centre, size), manifold3d.OpType.Add)
    mesh = body.set_tolerance(BOOLEAN_TOLERANCE).to_mesh64()
    vertices = np.asarray(mesh.vert_properties, np.float64)[:, :3] * size + centre
    return Solid(vertices, np.asarray(mesh.tri_verts, np.int64).reshape(-1, 3))


def hull_vertices(vertices) -> np.ndarray:
    """Indices (k,), ascending, of the points ``vertices`` (n, 3) that are vertices of their convex hull
    (manifold3d's hull; every index when manifold3d is missing): a linear function's extremes over the
    points are among them."""
    v = np.asarray(vertices, np.float64)
    v = np.ascontiguousarray(v - (v.min(axis=0) + v.max(axis=0)) / 2)  # about their centre: far points alike
    try:
        manifold3d = import_manifold3d()
    except ImportError:
        return np.arange(len(v))
    hull = np.asarray(manifold3d.Manifold.hull_points(v).to_mesh64().vert_properties, np.float64)[:, :3]
    order, first = row_runs(np.concatenate([v, hull]).view(np.uint64))  # the points, then the hull's; bit-equal
    lead = order[np.maximum.accumulate(np.where(first, np.arange(len(order)), 0))]  # the first of each run
    picked = lead[order >= len(v)]
    if np.any(picked >= len(v)):  # a hull point not bit-equal to an input point: keep them all
        return np.arange(len(v))
    return np.unique(picked)


def intersection_volume(a: Solid, b: Solid) -> float:
    """The volume of the intersection of the closed meshes a and b (their units cubed), with manifold3d at
    unit size in double precision as `boolean`."""
    centre, size = _unit_frame([a, b])
    p, q = _unit_manifolds([a, b], centre, size)
    return float((p ^ q).volume()) * size ** 3


def _unit_frame(parts) -> tuple[np.ndarray, float]:
    """The centre and size (largest side) of the bounding box of ``parts``: the map into a unit box
    around the origin in which manifold3d works (`boolean`: relative tolerances)."""
    lo = np.min([p.vertices.min(axis=0) for p in parts], axis=0)
    hi = np.max([p.vertices.max(axis=0) for p in parts], axis=0)
    return (lo + hi) / 2, float(np.max(hi - lo))


def _unit_manifolds(parts, centre, size) -> list:
    """manifold3d solids (``Mesh64``, double precision) of the closed ``parts`` mapped by `_unit_frame`'s
    ``centre`` and ``size``."""
    manifold3d = import_manifold3d()
    return [manifold3d.Manifold(manifold3d.Mesh64(
        vert_properties=np.ascontiguousarray((p.vertices - centre) / size, dtype=np.float64),
        tri_verts=np.ascontiguousarray(p.faces, dtype=np.uint64))) for p in parts]


# ---------------------------------------------------------------------- checks and integrals
READER_GRID = 1e-8  # a reader's vertex merge (trimesh, so yourdfpy and the shared judge: 8 decimals), file units


def weld(triangles, grid: float | None = None) -> Solid:
    """The indexed mesh of a triangle soup (m, 3, 3): corners with bit-equal coordinates become one
    vertex (what a reader of an STL file sees). -0.0 and 0.0 count as equal. ``grid``: corners equal
    once rounded to multiples of it become one too (trimesh's merge, `READER_GRID`), at the coordinates
    of one of them."""
    tri = np.asarray(triangles)
    corners = tri.reshape(-1, 3) + tri.dtype.type(0.0)
    order, first = row_runs(corners if grid is None else np.round(corners.astype(np.float64) / grid))
    index = np.empty(len(order), np.int64)
    index[order] = np.cumsum(first) - 1
    return Solid(corners[order][first].astype(np.float64), index.reshape(-1, 3))


def row_runs(keys) -> tuple[np.ndarray, np.ndarray]:
    """(order (n,), first (n,) bool) of the rows of ``keys`` (n, k): the order sorting them by their first
    column, then the second, ... (`np.lexsort`, stable: equal rows keep their order), and whether each
    sorted row starts a run of equal ones. ``keys[order][first]``: the distinct rows in `np.unique`'s order
    (axis 0), each as its first occurrence (-0.0 and 0.0 are equal)."""
    keys = np.asarray(keys)
    order = np.lexsort(keys.T[::-1])
    ranked = keys[order]
    first = np.ones(len(order), bool)
    first[1:] = (ranked[1:] != ranked[:-1]).any(axis=1)
    return order, first


def shell_count(faces) -> int:
    """The number of connected pieces of the surface with faces (m, 3) (triangles that share a vertex are
    connected): the bodies a slicer or a CAD program sees. Label propagation with pointer jumping."""
    f = np.asarray(faces, np.int64)
    if not len(f):
        return 0
    label = np.arange(int(f.max()) + 1)
    while True:
        low = label[f].min(axis=1)
        new = label.copy()
        np.minimum.at(new, f.ravel(), np.repeat(low, 3))
        new = new[new]
        if np.array_equal(new, label):
            return int(len(np.unique(label[f.ravel()])))
        label = new


def degenerate_free(faces) -> np.ndarray:
    """Indices of the faces (m, 3) that repeat no vertex. After `weld` has merged the two ends of an edge
    shorter than the float32 step, the two triangles on that edge degenerate and the others are the edge
    collapse of the mesh (closed again unless the collapse pinches it, which `surface_defect` tells)."""
    f = np.asarray(faces)
    return np.flatnonzero((f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0]))


def surface_defect(faces) -> str | None:
    """Why the faces (m, 3) do not form a closed oriented surface, or None when they do: every edge
    must be used by exactly two triangles, once in each direction (so no edge is open, none is shared
    by three or more faces, and neighbours agree on the orientation); no triangle may repeat a vertex."""
    faces = np.asarray(faces, np.int64)
    if len(faces) == 0:
        return "no triangles"
    if np.any((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])):
        return "a triangle with a repeated vertex"
    n = int(faces.max()) + 1
    tail = faces.ravel()
    head = faces[:, [1, 2, 0]].ravel()
    forward = np.sort(tail * n + head)
    if np.any(forward[1:] == forward[:-1]):
        return "an edge run through twice in the same direction (non-manifold or inconsistent winding)"
    if not np.array_equal(forward, np.sort(head * n + tail)):
        return "an edge without its opposite half (a hole or a non-manifold edge)"
    return None


def _cone(triangles):
    """(r, a, b, c, 6 V): the mean corner r, the corners relative to it (each (m, 3)) and six times the
    signed volume of every tetrahedron (r, a, b, c) (m,). Taken about r, sums over the tetrahedra stay
    well conditioned far from the origin."""
    tri = np.asarray(triangles, np.float64)
    r = tri.reshape(-1, 3).mean(axis=0)
    a, b, c = (tri[:, k] - r for k in range(3))
    return r, a, b, c, np.einsum("ij,ij->i", a, np.cross(b, c))


def signed_volume(triangles) -> float:
    """Volume enclosed by closed, outward-wound triangles (m, 3, 3) (negative when wound inward)."""
    return float(_cone(triangles)[-1].sum()) / 6.0


def mass_properties(triangles, density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass (3,), inertia tensor (3, 3) about the centre of mass in the mesh's axes) of
    the uniform solid bounded by closed, outward-wound ``triangles`` (m, 3, 3).

    Divergence theorem: the solid is the signed sum of the tetrahedra (r, a, b, c) of `_cone`. With
    corners relative to r and 6 V_t = a . (b x c), a tetrahedron contributes V_t, V_t (a + b + c) / 4 to
    the first moment and V_t / 20 (a a^T + b b^T + c c^T + s s^T), s = a + b + c, to the second
    moments S = integral of x x^T dV. The inertia tensor is density (trace(S) E - S) about the centre."""
    r, a, b, c, vol6 = _cone(triangles)
    volume = float(vol6.sum()) / 6.0
    s = a + b + c
    first = vol6 @ s / 24.0
    second = sum(np.einsum("i,ij,ik->jk", vol6, p, p) for p in (a, b, c, s)) / 120.0
    com = first / volume
    S = second - volume * np.outer(com, com)
    inertia = density * (np.trace(S) * np.eye(3) - S)
    return density * volume, r + com, inertia


def stl_bytes(triangles, corners=None) -> bytes:
    """Binary STL of the triangles (m, 3, 3), stored as float32 (see the module docstring); the normal
    of a triangle whose float64 cross product vanishes is written as zero. ``corners`` (m, 3, 3): the
    corners stored instead of the triangles' (the normals stay the triangles')."""
    tri = np.asarray(triangles, np.float64)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    records = np.zeros(len(tri), STL_RECORD)
    records["normal"] = normal
    records["corners"] = tri if corners is None else corners
    return bytes(80) + np.uint32(len(tri)).astype("<u4").tobytes() + records.tobytes()


def read_stl_triangles(data: bytes) -> np.ndarray:
    """(m, 3, 3) float32 corners of a binary STL as `stl_bytes` writes it; ValueError when the size does
    not match the count."""
    if len(data) < 84:
        raise ValueError("shorter than a binary STL header")
    count = int(np.frombuffer(data, "<u4", 1, 80)[0])
    if len(data) != 84 + STL_RECORD.itemsize * count:
        raise ValueError(f"{len(data)} bytes do not hold the {count} triangles the header announces")
    return np.frombuffer(data, STL_RECORD, count, 84)["corners"]
