"""Distances between the bodies of a linkage along its exact rational motion, for many designs at once,
and a certificate that covers the gaps between samples (docs/design.md).

Conventions:
- the motion is sampled by ``phi`` with ``t = tan(phi)``: phi in [-pi/2, pi/2] is the whole cycle
  (phi = +-pi/2 is t = infinity, the reference configuration);
- a *body* is a link that holds joints (``linkage.links``; a loop's duplicate link holds none and is the
  same rigid body as its partner); two bodies that share a joint are *adjacent* (only the capsule pairs
  their `CapsuleSet` names are tested: `synth.design.search.tested`);
- the geometry is a set of capsules whose end points move along lines fixed in their bodies: an end
  point is ``base + offset * direction`` (reference configuration; a mount: the joint's site and axis
  direction, the offset affine in the design's mount offsets; a via point of a cranked bar: a point and
  a crank direction), so one pass evaluates a batch of designs (leading axis N) at every sample;
- the certificate: along a path of joints j_1..j_m from body A to body B, a point x of B moves
  relative to A at speed at most ``sum_i |dtheta_i/dphi| * |x - q_i|``, q_i the site of j_i, and
  ``|x - q_i|`` is bounded by constant site-to-site lengths along the path; for the last joint j_m
  (fixed in B) by x's distance from its axis (0 for a capsule on that axis: a rotation about it moves
  nothing); ``|dtheta/dphi| =
  2|b| / Q(phi)`` with ``Q = (sin phi - a cos phi)^2 + b^2 cos^2 phi`` whose minimum on an interval is
  closed-form. A distance d that is V-Lipschitz on [phi_0, phi_1] stays above
  ``(d_0 + d_1 - V (phi_1 - phi_0)) / 2``.
Lengths in metres, angles in radians.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np

from synth.design.model import joint_links
from synth.design.sampling import bodies, body_motion, even_samples, rate_bound


# ----------------------------------------------------------------------------------------- topology
def shared_joints(linkage) -> dict[frozenset, set]:
    """{pair of bodies that share a joint: the joints they share}."""
    out: dict[frozenset, set] = {}
    for j, ls in joint_links(linkage).items():
        if len(ls) == 2:
            out.setdefault(frozenset(ls), set()).add(j)
    return out


def adjacent_pairs(linkage) -> set[frozenset]:
    """Pairs of bodies that share a joint."""
    return set(shared_joints(linkage))


def tested(a: tuple, b: tuple, shared) -> bool:
    """Whether two capsules of two bodies are a tested pair; ``a``, ``b``: (part, joint) (part "bar" (joint:
    {joint: end} where the leg meets that joint's axis, at a mount), "hub", "pin" or "cyl": a hub as a
    cylinder),
    ``shared``: the joints the bodies share (None: not adjacent). Bodies that share no joint: every pair
    but the cylinders. Bodies that share a joint (their relative motion about it a turn): bar against
    bar, a leg from the shared joint against the other's hub there as a cylinder (its flat face
    towards the leg; the pin in it too), and a bar against the other's hubs and pins at its other joints
    (fixtures/fourbar_velocity.yaml's base bar ran through link_h1's hub and pin at h2: 31.9 and 3.3 mm^3).
    Not tested: the two hubs of the shared joint (kept apart by the stack, `stack_gap` of
    `synth.design.search`), its pin in its bores (which run along the whole pin,
    `synth.io.meshes.link_primitives`)."""
    if a[0] == "cyl" or b[0] == "cyl":
        bar, other = (a, b) if b[0] == "cyl" else (b, a)
        return shared is not None and bar[0] == "bar" and other[1] in shared and other[1] in bar[1]
    if shared is None or a[0] == b[0] == "bar":
        return True
    bar, other = (a, b) if a[0] == "bar" else (b, a)  # a bar against the other's hubs and pins elsewhere
    return bar[0] == "bar" and other[0] in ("hub", "pin") and other[1] not in shared


def axial_kind(x: tuple, y: tuple, shared) -> tuple[int, tuple]:
    """(`CapsuleSet.axial` kind, end indices (a0, a1, b0, b1)) of the tested pair of capsules x, y of
    `synth.design.search.Layout` (body, label, end0, end1, radius, part, joint); ``shared``: the joints of
    their bodies (None: none).
    Kind 1 (2): x (y) a hub as a cylinder; 3: two legs that leave one shared axis (ordered from it)."""
    row = (x[2], x[3], y[2], y[3])
    if x[5] == "cyl" or y[5] == "cyl":
        return (1 if x[5] == "cyl" else 2), row
    on = [j for j in (shared or ()) if x[5] == y[5] == "bar" and j in x[6] and j in y[6]]
    if not on:
        return 0, row
    a0, b0 = x[6][on[0]], y[6][on[0]]
    return 3, (a0, x[3] if a0 == x[2] else x[2], b0, y[3] if b0 == y[2] else y[2])


def body_paths(linkage, a: str, b: str, limit: int = 8) -> list[list[str]]:
    """Simple paths of joints from body ``a`` to body ``b`` in the body graph (at most ``limit``, shortest
    first)."""
    edges: dict[str, list[tuple[str, str]]] = {n: [] for n in bodies(linkage)}
    for j, ls in joint_links(linkage).items():
        if len(ls) == 2:
            edges[ls[0]].append((j, ls[1]))
            edges[ls[1]].append((j, ls[0]))
    out: list[list[str]] = []

    def walk(node, seen, path):
        if len(out) >= 64:
            return
        if node == b:
            out.append(list(path))
            return
        for j, nxt in edges[node]:
            if nxt not in seen:
                walk(nxt, seen | {nxt}, path + [j])

    walk(a, {a}, [])
    return sorted(out, key=len)[:limit]


# ----------------------------------------------------------------------------------------- geometry
@dataclass
class CapsuleSet:
    """Capsules whose end points move along lines fixed in their bodies (reference configuration).

    ``ends_base``, ``ends_dir``: (E, 3) each end point is ``base + offset * dir`` (a mount: the joint's
    site and direction); ``ends_body``: its body; ``pairs``: (P, 4) end indices (a0, a1, b0, b1) of the
    tested capsule pairs; ``radii``: (P,) sum of the two radii; ``body_pair``: (P,) index into
    ``body_pairs`` (list of (body A, body B)); ``axial``: None, or (P, 2) rows (kind,
    radius) of the pairs of two bodies that turn about a shared axis and whose gap that turn does not
    change: kind 1 (2) when the pair's a (b) segment is the axis of a cylinder of that radius (flat ends:
    a hub) and the other a leg that meets that axis at an end (gap: `axial_distance` minus ``radii``, the
    leg's), kind 3 two legs that leave the axis at a0 and b0 (`legs_distance`); kind 0 the other pairs."""

    ends_base: np.ndarray
    ends_dir: np.ndarray
    ends_body: list[str]
    pairs: np.ndarray
    radii: np.ndarray
    body_pair: np.ndarray
    body_pairs: list[tuple[str, str]]
    labels: list[str]
    axial: np.ndarray | None = None
    paths: dict = field(default_factory=dict, repr=False, compare=False)  # `body_paths` met, by (body, body)


def segment_distance(p0, p1, q0, q1) -> np.ndarray:
    """Distance between segments p0-p1 and q0-q1, component-first arrays (3, ...) (broadcast); handles
    degenerate segments (clamped closest points, as in Ericson, Real-Time Collision Detection 5.1.9)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0

    def dot(x, y):
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]

    a, e, b = dot(d1, d1), dot(d2, d2), dot(d1, d2)
    c, f = dot(d1, r), dot(d2, r)
    tiny = 1e-30 if p0.dtype == np.float64 else 1e-20
    ia, ie = 1.0 / np.maximum(a, tiny), 1.0 / np.maximum(e, tiny)
    denom = a * e - b * b
    ok = denom > (1e-12 if denom.dtype == np.float64 else 1e-5) * a * e
    s = np.where(ok, _unit_clip((b * f - c * e) / np.where(ok, denom, 1.0)), 0.0)
    t = (b * s + f) * ie
    s0 = _unit_clip(-c * ia)  # the point of p closest to q0
    s = np.where(t < 0, s0, np.where(t > 1, _unit_clip((b - c) * ia), s))
    t = _unit_clip(t)
    pa, pe = a <= tiny, e <= tiny  # p or q a single point
    if pa.any() or pe.any():
        s = np.where(pe, np.where(pa, 0.0, s0), np.where(pa, 0.0, s))
        t = np.where(pe, 0.0, np.where(pa, _unit_clip(f * ie), t))
    w = r + s * d1 - t * d2
    return np.sqrt(dot(w, w))


def axial_distance(p0, p1, q0, q1, radius) -> np.ndarray:
    """Distance between the segment p0-p1, which meets the line q0-q1 at p0 or p1, and the cylinder of
    ``radius`` (flat ends) around the segment q0-q1; component-first arrays (3, ...) (broadcast). In the
    half-plane (r, z) of the distance from the axis and the height along it, the segment is a segment and
    the cylinder the box [0, radius] x [-h, h] (the distance does not change with a turn of either about
    the axis): 0 where they meet (clipped as in Liang-Barsky), else the least distance between an end of
    one and the other. (Both ends, both coordinates and the four corners each as one stacked array: a
    few numpy passes for the few pairs a search evaluates at a time.)"""
    shape = np.broadcast_shapes(p0.shape[1:], p1.shape[1:], q0.shape[1:], q1.shape[1:], np.shape(radius))
    axis, m = q1 - q0, 0.5 * (q0 + q1)
    length = np.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
    u = (axis / np.maximum(length, 1e-30))[:, None]
    h = np.broadcast_to(0.5 * length, shape)
    w = np.stack(np.broadcast_arrays(p0 - m, p1 - m), axis=1)  # (3, 2 ends, ...)
    c = np.stack([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]])
    r = np.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])  # (2, ...)
    z = w[0] * u[0] + w[1] * u[1] + w[2] * u[2]
    rim = np.broadcast_to(radius, shape).astype(r.dtype)
    a, dv = np.stack([r[0], z[0]]), np.stack([r[1] - r[0], z[1] - z[0]])  # (2 coordinates, ...)
    lo, hi = np.stack([np.zeros_like(h), -h]), np.stack([rim, h])
    flat = np.abs(dv) < 1e-30
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - a) / np.where(flat, 1.0, dv), (hi - a) / np.where(flat, 1.0, dv)
    inside = (a >= lo) & (a <= hi)
    enter = np.maximum(0.0, np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2)).max(axis=0))
    leave = np.minimum(1.0, np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2)).min(axis=0))
    to_box = np.hypot(np.maximum(r - rim, 0.0), np.maximum(np.abs(z) - h, 0.0)).min(axis=0)  # from either end
    cr, cz = np.stack([0 * rim, 0 * rim, rim, rim]), np.stack([h, -h, h, -h])  # the corners
    dr, dz = dv[0], dv[1]
    t = np.clip(((cr - r[0]) * dr + (cz - z[0]) * dz) / np.maximum(dr * dr + dz * dz, 1e-30), 0.0, 1.0)
    corners = np.hypot(r[0] + t * dr - cr, z[0] + t * dz - cz).min(axis=0)
    return np.where(enter <= leave, 0.0, np.minimum(to_box, corners))


def legs_distance(p0, p1, q0, q1) -> np.ndarray:
    """Least distance, over every turn of one about the axis through p0 and q0, between the segments
    p0-p1 and q0-q1 that leave that axis at p0 and q0 (two bars of links that share a joint); component-
    first arrays (3, ...) (broadcast). In the half-plane (r, z) of the distance from the axis and the
    height along it each is a segment that a turn does not move: their distance there (`segment_distance`
    of `legs_plane`'s segments)."""
    return segment_distance(*legs_plane(p0, p1, q0, q1))


def legs_plane(p0, p1, q0, q1) -> tuple:
    """`legs_distance`'s two segments in the half-plane (r, z, 0) of the axis through p0 and q0 (p0 at the
    origin): four component-first arrays (3, ...)."""
    axis = q0 - p0
    u = (axis / np.maximum(np.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]), 1e-30))[:, None]
    w = np.stack(np.broadcast_arrays(p1 - p0, q0 - p0, q1 - p0), axis=1)  # (3, 3 points, ...): one pass for all
    z = w[0] * u[0] + w[1] * u[1] + w[2] * u[2]
    r = np.sqrt(np.maximum(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] - z * z, 0.0))
    rz = np.stack([r, z, np.zeros_like(z)])  # (3, 3 points, ...)
    return np.zeros_like(rz[:, 0]), rz[:, 0], rz[:, 1], rz[:, 2]


def _gaps(cs: CapsuleSet, pts, rows, radii) -> np.ndarray:
    """Gaps of the capsule pairs ``rows`` (indices into ``cs.pairs`` along one axis of pts[i][0]'s shape,
    length 1 along the others) from the end points ``pts`` (4 arrays (3, ...)): segment distance minus
    ``radii``; `axial_distance` and `legs_distance` for the pairs of ``cs.axial``'s kinds 1, 2 and 3 (each
    kind's pairs taken along that axis: whole rows, no gather per element)."""
    if cs.axial is None or not cs.axial[rows, 0].any():
        return segment_distance(*pts) - radii
    shape = pts[0].shape[1:]
    ax = int(np.argmax(np.shape(rows)))  # the axis of the pairs
    pair = np.ravel(rows)
    kind = cs.axial[pair, 0]
    d = np.empty(shape, pts[0].dtype)
    one = len(pair) == 1  # (then no axis to take along: every element is of that pair)
    for group in ((0, 3), (1, 2)):
        idx = np.flatnonzero((kind == group[0]) | (kind == group[1]))
        if not len(idx):
            continue
        p0, p1, q0, q1 = pts if one else (p.take(idx, axis=ax + 1) for p in pts)
        sel = Ellipsis if one else (slice(None),) * ax + (idx,)
        if group == (0, 3):  # one segment distance for both: the legs' segments in their half-planes
            legs = kind[idx] == 3
            if legs.all():
                d[sel] = legs_distance(p0, p1, q0, q1)
            elif legs.any():
                k3 = np.flatnonzero(legs)
                plane = legs_plane(*(p.take(k3, axis=ax + 1) for p in (p0, p1, q0, q1)))
                ends = [p.copy() for p in (p0, p1, q0, q1)]
                for e, x in zip(ends, plane):
                    e[(slice(None),) * (ax + 1) + (k3,)] = x
                d[sel] = segment_distance(*ends)
            else:
                d[sel] = segment_distance(p0, p1, q0, q1)
        else:  # the leg first: b's segment where a's is the hub (kind 1)
            along = [1] * len(shape)
            along[ax] = 1 if one else len(idx)
            a_hub = (kind[idx] == 1).reshape(along)
            rad = cs.axial[pair[idx], 1].reshape(along).astype(d.dtype)
            d[sel] = axial_distance(np.where(a_hub, q0, p0), np.where(a_hub, q1, p1), np.where(a_hub, p0, q0),
                                    np.where(a_hub, p1, q1), rad)
    return d - radii


def subset(cs: CapsuleSet, rows) -> CapsuleSet:
    """The capsule set with only the pairs ``rows`` (a boolean mask or indices) tested."""
    rows = np.asarray(rows)
    keep = np.flatnonzero(rows) if rows.dtype == bool else rows
    return replace(cs, pairs=cs.pairs[keep], radii=cs.radii[keep], body_pair=cs.body_pair[keep],
                   labels=[cs.labels[i] for i in keep], axial=None if cs.axial is None else cs.axial[keep],
                   paths=cs.paths)


def _unit_clip(x) -> np.ndarray:
    """x clamped to [0, 1] in place (np.clip's result, without its Python-level overhead)."""
    return np.minimum(np.maximum(x, 0.0, out=x), 1.0, out=x)


def world_ends(cs: CapsuleSet, motion: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(Q, U), each (4, 3, P, K): for the four end points (a0, a1, b0, b1) of every tested capsule pair,
    the moved base point and direction of the end point's line at the samples (component-first); the
    end point itself is ``Q + offset * U``."""
    Q, U = end_lines(cs, motion)
    idx = cs.pairs.T  # (4, P)
    return np.ascontiguousarray(Q[:, idx].transpose(1, 0, 2, 3)), np.ascontiguousarray(U[:, idx].transpose(1, 0, 2, 3))


def end_lines(cs: CapsuleSet, motion: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(Q, U), each (3, E, K): the moved base point and direction of every end point's line at the samples."""
    K = len(next(iter(motion.values()))) if motion else 0
    Q, U = np.empty((3, len(cs.ends_body), K)), np.empty((3, len(cs.ends_body), K))
    names = np.array(cs.ends_body, object)
    for body in dict.fromkeys(cs.ends_body):  # one product per body for all its end points
        idx = np.flatnonzero(names == body)
        R, t = motion[body][:, :3, :3], motion[body][:, :3, 3]
        Q[:, idx] = (R @ cs.ends_base[idx].T + t[:, :, None]).transpose(1, 2, 0)
        U[:, idx] = (R @ cs.ends_dir[idx].T).transpose(1, 2, 0)
    return Q, U


def pair_distances(cs: CapsuleSet, Q, U, offsets, chunk: int = 1 << 16) -> np.ndarray:
    """(N, P, K) capsule-capsule distances (segment distance minus both radii) for N designs given by
    ``offsets`` (N, E) (the offset of every end point along its axis); Q, U from `world_ends`."""
    offsets = np.atleast_2d(offsets)
    N, P, K = offsets.shape[0], len(cs.pairs), Q.shape[-1]
    out = np.empty((N, P, K))
    step = max(1, chunk // max(P * K, 1))
    idx = cs.pairs.T
    for n0 in range(0, N, step):
        o = offsets[n0:n0 + step][:, idx]  # (n, 4, P)
        pts = [Q[c][:, None] + o[None, :, c, :, None] * U[c][:, None] for c in range(4)]  # (3, n, P, K)
        out[n0:n0 + step] = _gaps(cs, pts, np.arange(P)[None, :, None], cs.radii[None, :, None])
    return out


def pair_distances_at(cs: CapsuleSet, Q, U, offsets, pidx, kidx, chunk: int = 1 << 16) -> np.ndarray:
    """(N, L) capsule-capsule distances at L chosen (pair, sample) entries ``pidx``, ``kidx``; evaluated
    in chunks of about ``chunk`` distances (bounded temporaries)."""
    offsets = np.atleast_2d(offsets)
    N, L = offsets.shape[0], len(pidx)
    Qs, Us = Q[:, :, pidx, kidx], U[:, :, pidx, kidx]  # (4, 3, L)
    radii = cs.radii[pidx][None]
    out = np.empty((N, L))
    step = max(1, chunk // max(L, 1))
    cols = cs.pairs[pidx].T  # (4, L)
    for n0 in range(0, N, step):
        o = offsets[n0:n0 + step][:, cols]  # (n, 4, L)
        pts = [Qs[c][:, None] + o[None, :, c] * Us[c][:, None] for c in range(4)]
        out[n0:n0 + step] = _gaps(cs, pts, np.asarray(pidx)[None], radii)
    return out


def item_distances(cs: CapsuleSet, Q, U, offsets, cand, pidx, kidx, chunk: int = 1 << 16) -> np.ndarray:
    """(L,) capsule-capsule distances of L items: the design ``cand[i]`` (a row of ``offsets`` (N, E)) at
    the (pair, sample) entry ``pidx[i]``, ``kidx[i]`` (`pair_distances_at`'s numbers for other designs at
    each entry: an evaluation of only the entries a search needs); in chunks of ``chunk`` items."""
    out = np.empty(len(pidx))
    K, E = Q.shape[3], offsets.shape[1]
    Qf, Uf, of = Q.reshape(4, 3, -1), U.reshape(4, 3, -1), np.ravel(offsets)
    for i0 in range(0, len(pidx), chunk):
        p, k = pidx[i0:i0 + chunk], kidx[i0:i0 + chunk]
        Qs, Us = Qf.take(p * K + k, axis=2), Uf.take(p * K + k, axis=2)  # (4, 3, L)
        o = of.take(cand[i0:i0 + chunk][None] * E + cs.pairs[p].T)  # (4, L), contiguous rows
        pts = [Qs[c] + o[c] * Us[c] for c in range(4)]
        out[i0:i0 + chunk] = _gaps(cs, pts, p, cs.radii[p])
    return out


# ----------------------------------------------------------------------------------------- certificate
def speed_coefficients(linkage, cs: CapsuleSet, offsets: np.ndarray, sites: dict) -> list[np.ndarray]:
    """For one design (``offsets`` (E,)): a list of (P, J) arrays, one per way of bounding the relative
    speed of each capsule pair: ``V <= coef @ rate_bound`` (see the module docstring). The ways (paths of
    joints) depend on the capsules only (`_speed_paths`); the design sets each path's first term."""
    J = len(linkage.joints)
    last, e0, e1, steps, lengths, way, special = _speed_paths(linkage, cs, sites)
    pts = cs.ends_base + np.asarray(offsets, float)[:, None] * cs.ends_dir  # (E, 3): mounts and via points
    S = np.array([sites[j.name] for j in linkage.joints]).reshape(-1, 3)
    w = pts[:, None] - S[None]  # (E, J, 3)
    u = np.array([j.direction for j in linkage.joints]).reshape(-1, 3)
    reach = np.linalg.norm(w, axis=2)  # (E, J): from each site; from each axis (the last one is fixed in dst)
    off_axis = np.sqrt(np.maximum(reach ** 2 - np.einsum("ejk,jk->ej", w, u) ** 2, 0.0))
    coef = np.zeros((len(last) + 2, J + 1))  # one row per path, then the rows of no motion and of no bound
    rows = np.arange(len(last))
    coef[rows, last] = np.maximum(off_axis[e0, last], off_axis[e1, last])
    acc = np.maximum(reach[e0, last], reach[e1, last])
    for k in range(steps.shape[1]):  # the site-to-site lengths added in the order of the path, last first
        acc = acc + lengths[:, k]
        coef[rows, steps[:, k]] = acc
    coef[-1] = 1e300
    coef = coef[:, :J]
    return [coef[np.where(special == 0, way[:, k], len(last) + special - 1)] for k in range(way.shape[1])]


def _speed_paths(linkage, cs: CapsuleSet, sites: dict) -> tuple:
    """The paths of joints of `speed_coefficients`, the same for every design of these capsules (kept on
    the linkage, at most 8 capsule structures): per path its last joint, the moving capsule's ends (e0,
    e1), its other joints from the last (padded with column J) and the site-to-site lengths added there
    (padded with 0); per pair its paths (P, ways) (a pair with fewer repeats its last) and ``special``
    (P,): 1 when a turn about a shared axis changes nothing of its gap (`CapsuleSet.axial`), 2 when no
    chain of joints joins its bodies."""
    key = ("speed", cs.pairs.tobytes(), cs.body_pair.tobytes(), None if cs.axial is None else cs.axial[:, 0].tobytes(),
           tuple(cs.body_pairs), tuple(sites), np.array(list(sites.values())).tobytes(),
           tuple((j.name, j.parent, j.child) for j in linkage.joints), tuple(map(tuple, linkage.links.values())))
    kept = linkage.__dict__.setdefault("_speed_paths", {})  # every round's certificate of a sizing round
    if key in kept:  # has the same capsule structure: its paths are found once per linkage
        return kept[key]
    jindex = {j.name: i for i, j in enumerate(linkage.joints)}
    J = len(linkage.joints)
    rows, per_pair, special = [], [], []
    for p, (a0, a1, b0, b1) in enumerate(cs.pairs):
        A, B = cs.body_pairs[cs.body_pair[p]]
        mine = []
        if not (cs.axial is not None and cs.axial[p, 0]):
            for src, (e0, e1), dst in ((A, (b0, b1), B), (B, (a0, a1), A)):
                if (src, dst) not in cs.paths:
                    cs.paths[(src, dst)] = body_paths(linkage, src, dst)
                for path in cs.paths[(src, dst)]:
                    if path:  # an empty path: one body (e.g. merged by a loop weld), nothing moves between them
                        back = range(len(path) - 2, -1, -1)
                        lengths = [np.linalg.norm(sites[path[i + 1]] - sites[path[i]]) for i in back]
                        mine.append(len(rows))
                        rows.append((jindex[path[-1]], e0, e1, [jindex[path[i]] for i in back], lengths))
            special.append(0 if mine else 2)
        else:
            special.append(1)
        per_pair.append(mine or [0])
    depth = max([len(r[3]) for r in rows], default=0)
    ways = max(len(m) for m in per_pair) if per_pair else 0
    out = (np.array([r[0] for r in rows], int), np.array([r[1] for r in rows], int),
           np.array([r[2] for r in rows], int),
           np.array([r[3] + [J] * (depth - len(r[3])) for r in rows], int).reshape(len(rows), depth),
           np.array([r[4] + [0.0] * (depth - len(r[4])) for r in rows], float).reshape(len(rows), depth),
           np.array([[m[min(k, len(m) - 1)] for k in range(ways)] for m in per_pair], int).reshape(len(per_pair), ways),
           np.array(special, int))
    if len(kept) >= 8:
        kept.pop(next(iter(kept)))
    kept[key] = out
    return out


def certify(linkage, cs: CapsuleSet, offsets: np.ndarray, lo: float, hi: float, clearance: float, *,
            samples: int = 256, max_samples: int = 20000) -> dict:
    """Certified smallest capsule gap of one design over phi in [lo, hi].

    Samples evenly in joint rotation, then bisects every interval whose Lipschitz bound falls below
    ``clearance`` while both its ends keep it. Returns {"certified": bool (every interval's bound is at
    least ``clearance``), "lower": the certified lower bound of the gap (min over intervals),
    "sampled": (P,) smallest sampled gap per capsule pair, "where": (P,) phi of it, "phis", "dist":
    (P, K) final samples}."""
    sites = linkage.joint_sites()
    coefs = speed_coefficients(linkage, cs, offsets, sites)
    phis = even_samples(linkage, lo, hi, samples)
    steady = np.zeros(len(cs.pairs), bool) if cs.axial is None else cs.axial[:, 0] > 0
    moving = subset(cs, ~steady)  # the gaps a turn about a shared axis does not change (`CapsuleSet.axial`) are
    still = _dist_at(linkage, subset(cs, steady), offsets, phis[:1])  # evaluated once (their speed bound is 0)

    def gaps_at(ph, keep=False):
        d = np.empty((len(cs.pairs), len(ph)))
        d[~steady], d[steady] = _dist_at(linkage, moving, offsets, ph, keep=keep), still
        return d

    dist = gaps_at(phis, keep=True)
    while True:
        rates = rate_bound(linkage, phis[:-1], phis[1:])  # (J, K-1)
        V = functools.reduce(np.minimum, (c @ rates for c in coefs))  # (P, K-1), two at a time (memory)
        dphi = np.diff(phis)
        lower = (dist[:, :-1] + dist[:, 1:] - V * dphi) / 2
        lower = np.minimum(lower, np.minimum(dist[:, :-1], dist[:, 1:]))
        worst = lower.min(axis=0)
        ends_ok = np.minimum(dist[:, :-1], dist[:, 1:]).min(axis=0) >= clearance
        bad = (worst < clearance) & ends_ok & (dphi > 1e-12)
        if not bad.any() or len(phis) + bad.sum() > max_samples:
            break
        mids = (phis[:-1][bad] + phis[1:][bad]) / 2
        new = gaps_at(mids)
        order = np.argsort(np.concatenate([phis, mids]), kind="stable")
        phis = np.concatenate([phis, mids])[order]
        dist = np.concatenate([dist, new], axis=1)[:, order]
    k = np.argmin(dist, axis=1)
    return {"certified": bool(worst.min() >= clearance), "lower": float(worst.min()),
            "sampled": dist.min(axis=1), "where": phis[k], "phis": phis, "dist": dist}


def _dist_at(linkage, cs, offsets, phis, chunk: int = 1 << 18, keep: bool = False) -> np.ndarray:
    """(P, K) capsule-pair distances of one design at the driver angles ``phis``, in blocks of samples
    of about ``chunk`` pair distances (the end points of every pair at every sample are 64 floats)."""
    step = max(1, chunk // max(len(cs.pairs), 1))
    parts, P = [], len(cs.pairs)
    for k0 in range(0, len(phis), step):  # `pair_distances`' numbers, the end points moved once each
        Q, U = end_lines(cs, body_motion(linkage, phis[k0:k0 + step], keep))
        ends = Q + np.asarray(offsets, float)[None, :, None] * U  # (3, E, K)
        pts = [ends[:, cs.pairs[:, c]][:, None] for c in range(4)]  # (3, 1, P, K)
        parts.append(_gaps(cs, pts, np.arange(P)[None, :, None], cs.radii[None, :, None])[0])
    return np.concatenate(parts, axis=1) if len(parts) != 1 else parts[0]
