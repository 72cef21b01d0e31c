"""Layered designs of planar linkages (every joint axis parallel): bars in layers along the axis, cranked
where a bar changes layer, found by a mixed-integer programme and certified (docs/design.md, "Layers").

Conventions: ``u`` the common axis direction; a *height* is a coordinate along ``u`` (metres); the plane
of motion is spanned by ``e1, e2``. Each bar (link, a, b) is cut into ``PIECES`` pieces along its straight
course, each at its own level (an integer times the pitch); a bar whose pieces differ rises between them
(a vertical step at the piece boundary: two via points). The hubs of a link sit at the level of its bar
pieces there. Constraints, from the motion sampled evenly in joint rotation (`sampling.even_samples`):

- a bar piece that passes over a joint of other links (in the plane, within the hub and bar radii and the
  clearance) is above or below the whole column of that joint (both hubs and the pin between them, which
  spans the column); a link's bars leave its own hubs and need not clear them;
- two bar pieces of two links that cross or come near in the plane are on different levels, also when the
  links share a joint (their pieces at that joint are on their hubs' levels, apart by the stack);
- a step (riser) that a joint's column or a bar of a link sharing no joint passes over is above or below
  it; one that the bar of a link sharing a joint passes may be passed (a *touch*: where the neighbour
  turns about the shared joint it sweeps a disc, and a step inside it from one side of the neighbour's
  level to the other meets it), at a cost above every level;
- the two hubs on one axis are on different levels (stacked); two columns that meet two levels apart.

Either-or constraints are big-M binaries; the objective is the number of touches, then of levels used
(compact). Solved with scipy's HiGHS (`scipy.optimize.milp`) within a node limit. Lengths in metres.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from synth.algebra.geometry import perpendicular_basis
from synth.design.collision import adjacent_pairs
from synth.design.sampling import body_motion, even_samples
from synth.design.coordinate import FULL
from synth.design.model import DesignResult, joint_links
from synth.design.search import SAFETY, Layout, certify_layout, cranked_result, sizes_of, stack_gap, task_phi_range

PIECES = 2  # pieces per bar (each on its own level)
STEP_PLACES = np.linspace(0.1, 0.9, 17)  # where along its bar a step may be (fractions)
SAMPLES_PER_JOINT = 160  # samples of the motion per joint for the constraints
MARGIN = 1.0  # the in-plane reach of a constraint, times (hub radius + bar radius + clearance)
LAYER_NODES = 20_000  # branch-and-bound nodes of the layering programme (HiGHS' node limit: counted work, not
# time; fixtures/motion_elliptic.yaml's programme needs 2,755, about 8 CPU s: the limit stands for about a minute)


def parallel_axis(linkage, tol: float = 1e-9) -> np.ndarray | None:
    """The common unit axis direction when every joint axis is parallel to it (a planar linkage), else None."""
    u = linkage.joints[0].direction
    for j in linkage.joints:
        if np.linalg.norm(np.cross(j.direction, u)) > tol:
            return None
    return u / np.linalg.norm(u)


def _point_segment(p0, p1, x):
    """(distance, parameter s in [0, 1]) of points x from segments p0-p1, arrays (K, 2)."""
    d = p1 - p0
    s = np.clip(((x - p0) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p0 + s[..., None] * d - x, axis=-1), s


def _crossings(p0, p1, q0, q1):
    """(crossing, s, t): where segments p0-p1 and q0-q1 (K, 2) cross, at parameters s and t."""
    r, w, qp = p1 - p0, q1 - q0, q0 - p0
    den = r[:, 0] * w[:, 1] - r[:, 1] * w[:, 0]
    ok = np.abs(den) > 1e-300
    den = np.where(ok, den, 1.0)
    s = (qp[:, 0] * w[:, 1] - qp[:, 1] * w[:, 0]) / den
    t = (qp[:, 0] * r[:, 1] - qp[:, 1] * r[:, 0]) / den
    return ok & (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1), s, t


def _step_places(bars, ends, adj, reach) -> np.ndarray:
    """(B,) where along each bar its step is (a fraction): of `STEP_PLACES` the one that the fewest bars of
    the links sharing a joint with it come within ``reach`` of (at any sample), the nearest the middle of
    those (a neighbour turning about the shared joint sweeps a disc; a step outside it is never passed)."""
    at = np.full(len(bars), 0.5)
    for i, (link, _, _) in enumerate(bars):
        p0, p1 = ends[i]
        pts = p0 + STEP_PLACES[:, None, None] * (p1 - p0)  # (C, K, 2)
        passed = np.zeros(len(STEP_PLACES))
        for k, (other, _, _) in enumerate(bars):
            if other != link and adj(link, other):
                passed += (_point_segment(*ends[k], pts)[0] < reach).any(axis=1)
        at[i] = STEP_PLACES[np.lexsort((np.abs(STEP_PLACES - 0.5), passed))[0]]
    return at


class _Programme:
    """Variables and rows of a mixed-integer linear programme (sparse rows as dicts)."""

    def __init__(self):
        self.n, self.rows, self.lo, self.hi, self.binary = 0, [], [], [], []

    def var(self, binary=False):
        self.n += 1
        if binary:
            self.binary.append(self.n - 1)
        return self.n - 1

    def row(self, coefs, lo=-np.inf, hi=np.inf):
        self.rows.append(coefs)
        self.lo.append(lo)
        self.hi.append(hi)

    def apart(self, a_lo, a_hi, b_lo, b_hi, big, gap=1):
        """The intervals [a_lo, a_hi] and [b_lo, b_hi] (variables) at least ``gap`` levels apart, either way."""
        y = self.var(binary=True)
        self.row({a_lo: 1, b_hi: -1, y: big}, gap)  # y = 0: a above b
        self.row({b_lo: 1, a_hi: -1, y: -big}, gap - big)  # y = 1: b above a

    def apart_or_touch(self, a_lo, a_hi, b_lo, b_hi, big):
        """`apart`, or not: the binary returned is 1 where the two intervals may meet (counted in the cost)."""
        y, w = self.var(binary=True), self.var(binary=True)
        self.row({a_lo: 1, b_hi: -1, y: big, w: big}, 1)
        self.row({b_lo: 1, a_hi: -1, y: -big, w: big}, 1 - big)
        return w

    def solve(self, cost, top, nodes):
        # imported here, not at the top: scipy.optimize costs about half a second (more than a whole Bennett
        # run) and only a planar linkage that straight bars cannot free needs it (as Dask for batch runs)
        from scipy.optimize import Bounds, LinearConstraint, milp

        from scipy.sparse import coo_matrix

        rows = [r for r, coefs in enumerate(self.rows) for _ in coefs]
        cols = [k for coefs in self.rows for k in coefs]
        vals = [v for coefs in self.rows for v in coefs.values()]
        A = coo_matrix((vals, (rows, cols)), shape=(len(self.rows), self.n)).tocsr()  # sparse: few per row
        integrality = np.zeros(self.n)
        integrality[self.binary] = 1
        lb, ub = np.zeros(self.n), np.full(self.n, float(top))
        ub[self.binary] = 1
        c = np.zeros(self.n)
        for k, v in cost.items():
            c[k] = v
        res = milp(c=c, constraints=LinearConstraint(A, self.lo, self.hi), integrality=integrality,
                   bounds=Bounds(lb, ub), options={"node_limit": int(nodes)})
        return None if res.x is None else res.x


@dataclass
class _Layering:
    """The layering programme of `layer_plan` under construction: the programme ``P``, the bars (link,
    a, b) with their in-plane ``ends`` over the samples, the joints with their links ``jl`` and in-plane
    tracks ``jxy``, the variables (``z``: level per bar piece, ``col``: a joint's column [lo, hi]), the
    adjacency ``adj(a, b)`` of bodies, the in-plane ``reach`` and the big-M constant ``big``."""

    P: object
    bars: list
    ends: list
    joints: list
    jl: dict
    jxy: dict
    z: dict
    col: dict
    adj: object
    reach: float
    big: float
    at: np.ndarray
    adjacent: bool = True
    touch: dict = field(default_factory=dict)
    steps: dict = field(default_factory=dict)

    def piece(self, i: int, s) -> np.ndarray:
        """The piece (0 or 1) of bar ``i`` at the fractions ``s`` along it (its step at ``at[i]``)."""
        return (np.asarray(s) >= self.at[i]).astype(int)

    def clear_of(self, link, j) -> bool:
        """Whether the bar of ``link`` need not keep clear of the column of joint ``j`` (its own joint: its
        hub there is in the column, and its bars leave that hub on its levels)."""
        return link in self.jl[j] or (not self.adjacent and all(self.adj(link, x) for x in self.jl[j]))

    def kept_apart(self, link, other) -> bool:
        """Whether the bars of ``link`` and ``other`` are kept apart (two links; sharing a joint: if
        ``adjacent``)."""
        return link != other and (self.adjacent or not self.adj(link, other))




def _hub_rows(L: _Layering, hub: dict) -> None:
    """Each hub covers the level of its bar's end piece and lies in its joint's column; the two hubs of a
    joint are stacked."""
    P = L.P
    for i, (link, a, b) in enumerate(L.bars):
        for j, h in ((a, 0), (b, PIECES - 1)):
            lo, hi = hub[(link, j)]
            P.row({lo: 1, L.z[(i, h)]: -1}, hi=0)  # the hub covers the level of its bar's piece
            P.row({hi: 1, L.z[(i, h)]: -1}, lo=0)
    for j in L.joints:
        for link in L.jl[j]:
            lo, hi = hub[(link, j)]
            P.row({hi: 1, lo: -1}, lo=0)
            P.row({L.col[j][0]: 1, lo: -1}, hi=0)
            P.row({L.col[j][1]: 1, hi: -1}, lo=0)
        if len(L.jl[j]) == 2:
            P.apart(*hub[(L.jl[j][0], j)], *hub[(L.jl[j][1], j)], L.big)  # stacked hubs


def _step_rows(L: _Layering, i: int) -> None:
    """The span [lo, hi] of bar ``i``'s step (covering both its pieces), apart from the steps of the earlier
    bars it comes near (two steps of links that share a joint turn about it on two circles: a touch)."""
    P, (p0, p1) = L.P, L.ends[i]
    lo, hi = L.steps[i] = P.var(), P.var()
    for g in range(PIECES):
        P.row({lo: 1, L.z[(i, g)]: -1}, hi=0)
        P.row({hi: 1, L.z[(i, g)]: -1}, lo=0)
    rp = p0 + L.at[i] * (p1 - p0)
    for k in range(i if L.adjacent else 0):  # (not in the programme of before: `layer_plan`'s ``shared``)
        if not L.kept_apart(L.bars[i][0], L.bars[k][0]):
            continue
        q0, q1 = L.ends[k]
        if (np.linalg.norm(q0 + L.at[k] * (q1 - q0) - rp, axis=-1) < L.reach).any():
            if L.adj(L.bars[i][0], L.bars[k][0]):
                L.touch[(L.bars[i], -1, L.bars[k], -1)] = P.apart_or_touch(lo, hi, *L.steps[k], L.big)
            else:
                P.apart(lo, hi, *L.steps[k], L.big)


def _bar_rows(L: _Layering, i: int) -> None:
    """Bar ``i`` apart from what it passes: a piece over a joint's column, the pieces of the later bars it
    crosses or comes near, and the steps between its pieces (the same rows, in the same order, as one
    programme: the same input gives the same layering)."""
    P, z, big, reach = L.P, L.z, L.big, L.reach
    link = L.bars[i][0]
    p0, p1 = L.ends[i]
    for j in L.joints:  # a piece over a joint's column
        if L.clear_of(link, j):
            continue
        d, s = _point_segment(p0, p1, L.jxy[j])
        for h in set(L.piece(i, s[d < reach]).tolist()):
            P.apart(z[(i, h)], z[(i, h)], *L.col[j], big)
    for k in range(i + 1, len(L.bars)):  # crossing pieces (of any two links: also two that share a joint)
        if not L.kept_apart(link, L.bars[k][0]):
            continue
        q0, q1 = L.ends[k]
        hit, s, t = _crossings(p0, p1, q0, q1)
        near = [(L.piece(i, s[hit]), L.piece(k, t[hit]))]  # (piece of bar i, piece of bar k) where they meet
        for x, first, on_i in ((p0, True, False), (p1, False, False), (q0, True, True), (q1, False, True)):
            d, r = _point_segment(*((p0, p1) if on_i else (q0, q1)), x)  # an end near the other bar
            end = np.full(int((d < reach).sum()), 0 if first else PIECES - 1)
            near.append((L.piece(i, r[d < reach]), end) if on_i else (end, L.piece(k, r[d < reach])))
        for hs, hk in near:
            for h, g in set(zip(hs.tolist(), hk.tolist())):
                P.apart(z[(i, h)], z[(i, h)], z[(k, g)], z[(k, g)], big)
    for h in range(1, PIECES):  # the step between two pieces
        _step_rows(L, i)
        lo, hi = L.steps[i]
        rp = p0 + L.at[i] * (p1 - p0)
        for j in L.joints:
            if L.clear_of(link, j):
                continue
            if (np.linalg.norm(L.jxy[j] - rp, axis=-1) < reach).any():
                P.apart(lo, hi, *L.col[j], big)
        for k, (other, c, e) in enumerate(L.bars):
            if not L.kept_apart(link, other):
                continue
            d, s = _point_segment(L.ends[k][0], L.ends[k][1], rp)
            for g in set(L.piece(k, s[d < reach]).tolist()):
                if L.adj(link, other):  # a neighbour turning about the shared joint: may be unavoidable
                    L.touch[(L.bars[i], h, L.bars[k], g)] = P.apart_or_touch(lo, hi, z[(k, g)], z[(k, g)], big)
                else:
                    P.apart(lo, hi, z[(k, g)], z[(k, g)], big)


@dataclass(frozen=True)
class Plan:
    """A layering (`layer_plan`): ``levels`` {(link, a, b): [level per piece]} (and ``(joint, "exit")``
    entries), ``touches`` the steps that a neighbour's bar (of a link sharing a joint with the step's, turning
    about it) passes at a level the step spans: ((link, a, b) of the step, (link, c, d) of the bar) pairs,
    each once, none when every pair of links is kept apart; ``at`` {(link, a, b): where along the bar its
    step is, a fraction}."""

    levels: dict
    touches: tuple
    at: dict


def layer_plan(linkage, u, rng_phi, reach, nodes, keep=None, exits=(), shared=True) -> Plan | None:
    """A layering over phi in ``rng_phi`` (None when none was found
    within ``nodes`` branch-and-bound nodes of the programme: counted work, not time); ``reach``: the
    in-plane distance below which two parts interact (metres). ``keep``: the
    joints layered (default: all; a partly planar linkage layers its joints parallel to ``u`` and the
    bars between two of them, `synth.design.mixed`). ``exits``: joints (of ``keep``) where a bar leaves
    the stack along the axis to a joint not kept (a riser): the joint's column then reaches the top or
    the bottom of the stack, and the result's entry ``(joint, "exit")`` is ``[top + 1]`` or ``[-1]``, the
    level the riser ends on. ``shared`` False: links that share a joint exempt from every row, steps at
    the middle, no rows of two steps, columns one level apart (the programme before issue 33's fix:
    `synth.design.mixed`)."""
    e1, e2 = perpendicular_basis(u)
    jl = joint_links(linkage)
    joints = [j for j in jl if jl[j] and (keep is None or j in keep)]
    adjacent = adjacent_pairs(linkage)

    def adj(a, b):
        return a == b or frozenset((a, b)) in adjacent

    phis = even_samples(linkage, rng_phi[0], rng_phi[1], SAMPLES_PER_JOINT * len(joints))
    motion = body_motion(linkage, phis)
    sites = linkage.joint_sites()

    def xy(body, p):
        D = motion[body]
        w = D[:, :3, :3] @ p + D[:, :3, 3]
        return np.stack([w @ e1, w @ e2], axis=-1)

    bars = [(link, a, b) for link, names in linkage.links.items() for a, b in zip(names, names[1:])
            if keep is None or (a in keep and b in keep)]
    ends = [(xy(link, sites[a]), xy(link, sites[b])) for link, a, b in bars]
    jxy = {j: xy(jl[j][0], sites[j]) for j in joints}
    P = _Programme()
    z = {(i, h): P.var() for i in range(len(bars)) for h in range(PIECES)}
    col = {j: (P.var(), P.var()) for j in joints}  # the column of a joint: [lo, hi]
    hub = {(link, j): (P.var(), P.var()) for j in joints for link in jl[j]}
    levels = len(z)  # levels 0 .. levels: enough for one level per piece
    L = _Layering(P, bars, ends, joints, jl, jxy, z, col, adj, reach, big=levels + 1.0,
                  at=_step_places(bars, ends, adj, reach) if shared else np.full(len(bars), 0.5), adjacent=shared)
    _hub_rows(L, hub)
    for i in range(len(bars)):
        _bar_rows(L, i)
    for n, j in enumerate(joints):  # two columns that meet (bodies that share no joint): two levels apart (a
        for k in joints[n + 1:]:  # hub one pitch from another's end would reach into it: `level_pitch`)
            if all(adj(x, y) for x in jl[j] for y in jl[k]):
                continue
            if (np.linalg.norm(jxy[j] - jxy[k], axis=-1) < reach).any():
                P.apart(*col[j], *col[k], L.big + shared, gap=1 + shared)
    top = P.var()
    for v in z.values():
        P.row({top: 1, v: -1}, lo=0)
    side = {}
    big = L.big
    for j in exits:  # the riser at j: the column reaches the top (y = 0) or the bottom (y = 1)
        y = side[j] = P.var(binary=True)
        P.row({col[j][1]: 1, top: -1, y: big}, lo=0)
        P.row({col[j][0]: 1, y: big}, hi=big)
    x = P.solve({top: 1.0, **{w: big for w in L.touch.values()}}, levels, nodes)  # a touch costs more than all levels
    if x is None:
        return None
    out = {bar: [int(round(x[z[(i, h)]])) for h in range(PIECES)] for i, bar in enumerate(bars)}
    for j, y in side.items():
        out[(j, "exit")] = [-1 if round(x[y]) else int(round(x[top])) + 1]
    touches = dict.fromkeys((a, b) for (a, _, b, _), w in L.touch.items() if round(x[w]))
    return Plan(out, tuple(touches), {bar: float(L.at[i]) for i, bar in enumerate(bars)})


def level_pitch(design) -> float:
    """Metres between two levels: stacked hubs (hub length + clearance) and a bar clear of a hub's capsule
    one level away (half a hub length + hub radius + bar radius + clearance: the capsules the certificate
    uses reach a radius beyond a hub's flat end), with the search's safety factor on the clearance, and at
    least the stack of a joint (`stack_gap`: the round ends of two bars on one joint)."""
    return max(design.hub_length / 2 + design.hub_radius + design.bar_radius + (1 + SAFETY) * design.clearance,
               stack_gap(design.bar_radius, design.hub_radius, design.hub_length, design.clearance))


def stack_geometry(linkage, levels: dict, u, pitch: float, keep=None, at=None) -> tuple[dict, dict, list, list]:
    """(heights, cranks, W, out) of a layering ``levels`` (`Plan`'s) with ``pitch`` metres between levels,
    the stack centred on the plane of height 0: ``heights[(link, joint)]`` the height (along ``u``) of each
    hub, on the level of the first of its link's layered bars there (a joint of ``keep`` without one: 0);
    ``cranks`` (`search.Layout`'s) with via points ``p + w u`` (p on the plane of height 0) at the heights
    ``W`` (in the order of the Layout's via points): a step where a bar's pieces differ (``at``: `Plan`'s;
    default the middle), a
    riser along the axis where a bar ends on another level than its hub, and for a bar from a joint of
    ``keep`` to another joint (``(joint, "exit")`` in ``levels``) a riser out of the stack first; ``out``
    (one per entry of W): +1 or -1 for the end of such a riser (the direction out of the stack), else 0."""
    base = -0.5 * pitch * max(max(v) for k, v in levels.items() if k[-1] != "exit")
    sites = linkage.joint_sites()
    jl = joint_links(linkage)
    heights, cranks, W, out = {}, {}, [], []

    def flat(p):  # a point's projection on the plane of height 0
        return p - (p @ u) * u

    bars = [(link, a, b) for link, names in linkage.links.items() for a, b in zip(names, names[1:])]
    for link, a, b in bars:
        lv = levels.get((link, a, b))
        if lv is not None:
            heights.setdefault((link, a), base + lv[0] * pitch)
            heights.setdefault((link, b), base + lv[-1] * pitch)
    for link, a, b in bars:
        lv = levels.get((link, a, b))
        pts, ws, side = [], [], 0
        if lv is not None:
            ha, hb = base + lv[0] * pitch, base + lv[-1] * pitch
            if abs(heights[(link, a)] - ha) > 1e-12:
                pts, ws = [flat(sites[a])], [ha]
            if len(set(lv)) > 1:
                f = 0.5 if at is None else at[(link, a, b)]
                p = flat(sites[a] + f * (sites[b] - sites[a]))
                pts, ws = pts + [p, p], ws + [ha, hb]
            if abs(heights[(link, b)] - hb) > 1e-12:
                pts, ws = pts + [flat(sites[b])], ws + [hb]
        elif keep is not None and (a in keep) != (b in keep) and ((a if a in keep else b), "exit") in levels:
            j = a if a in keep else b
            pts, ws = [flat(sites[j])], [base + levels[(j, "exit")][0] * pitch]
            side = 1 if levels[(j, "exit")][0] >= 0 else -1
        if pts:
            cranks[(link, a, b)] = (*pts, u)
            W += ws
            out += [side] * len(ws)
    for j in jl:  # a link with no layered bar at a joint (one joint only, or bars to joints not kept)
        if keep is None or j in keep:
            for link in jl[j]:
                heights.setdefault((link, j), 0.0)
    return heights, cranks, W, out


def height_offsets(layout: Layout, heights: dict, u) -> tuple[np.ndarray, np.ndarray]:
    """(S, dS), each (M,) over ``layout.mounts``: the offsets along their joints' axes that put the hubs of
    ``heights`` ({(link, joint): height along ``u``}) at those heights, and the change of each offset per
    unit of height (both 0 for a mount not in ``heights``)."""
    lk = layout.linkage
    sites = lk.joint_sites()
    S, dS = np.zeros(len(layout.mounts)), np.zeros(len(layout.mounts))
    for (link, j), h in heights.items():
        du = float(lk.joint(j).direction @ u)
        S[layout.mindex[(link, j)]] = (h - sites[j] @ u) / du
        dS[layout.mindex[(link, j)]] = 1.0 / du
    return S, dS


def layered_design(linkage, result: DesignResult, *, nodes: int = LAYER_NODES) -> DesignResult:
    """A certified layered design of a planar linkage (docs/design.md, "Layers"), or ``result`` unchanged
    when the axes are not all parallel, no layering is found within ``nodes`` (the programme's
    branch-and-bound nodes), or it does not certify. Keeps the sizes of ``result.design``; the pitch of the levels
    (`pitch`) keeps a bar clear of the hubs one level up or down. The certificate tests the links that share
    a joint too when the layering has no touch (`Plan`) and that certifies, else only the other pairs (as the
    judge), and the report's message names the touches (`touch_note`)."""
    t0 = time.process_time()
    u = parallel_axis(linkage)
    old = result.design
    if u is None or result.collision.free:
        return result
    rng_phi = FULL if result.collision.range == "full" else task_phi_range(linkage)
    reach = MARGIN * (old.hub_radius + old.bar_radius + old.clearance)
    plan = layer_plan(linkage, u, rng_phi, reach, nodes)
    if plan is None:
        result.collision.message += " (no layering of the planar linkage was found either)"
        return result
    heights, cranks, W, _ = stack_geometry(linkage, plan.levels, u, level_pitch(old), at=plan.at)
    for adjacent in (True, False):  # links that share a joint tested (but the touches), else none (as the judge)
        exact = Layout(linkage, merged=False, cranks=cranks, **sizes_of(old), adjacent=adjacent,
                       untested=touching(plan))
        S, _ = height_offsets(exact, heights, u)  # every hub of a planar linkage has its height
        cert = certify_layout(exact, S, rng_phi, old.clearance, W)
        if cert["certified"]:
            break
    else:
        result.collision.message += " (a layering of the planar linkage was tried too; it did not certify)"
        return result
    out = cranked_result(linkage, exact, S, np.asarray(W), old, result.collision.range, cert, cranks)
    out.collision.layers = len({lv for v in plan.levels.values() for lv in v})
    out.collision.seconds = result.collision.seconds + time.process_time() - t0
    out.collision.message = touch_note(plan, adjacent)
    return out


def touching(plan: Plan) -> frozenset:
    """The pairs of links (frozensets) that touch in ``plan`` (its steps a neighbour passes)."""
    return frozenset(frozenset((a[0], b[0])) for a, b in plan.touches)


def touch_note(plan: Plan, adjacent: bool) -> str:
    """The report's note on the links that share a joint of a layered design certified with them tested
    (``adjacent``) but the touches of ``plan``, or not tested: "" when every pair was tested."""
    named = "; ".join(f"{a[0]}'s step on {a[1]}-{a[2]} and {b[0]}'s bar {b[1]}-{b[2]}" for a, b in plan.touches)
    if not adjacent:
        return "links that share a joint are not certified apart in this layering"
    return f"links that share a joint touch in this layering (no order of the levels keeps apart {named})" \
        if named else ""
