"""Collision-free physical design of a linkage: the search over mounts and pins (docs/design.md).

Interface shared by the synthesis commands and the exporters:
``design_linkage(linkage, ...) -> DesignResult(design, collision)``; ``collision_rank`` ranks candidate
linkages (sixbar) by what their designs achieve.

The free parameters searched, per joint j held by links l0, l1 (``model.joint_links``): the centre
``c_j`` of the two hubs along the axis (from the joint's site), their order ``sigma_j`` (+-1: which link
is on top) and the distance ``g_j >= stack_gap`` of their centres (hubs and round ends apart); the mounts
are at ``c_j -+ sigma_j g_j / 2`` and the pin spans both hubs. Bars are straight. Candidates: the natural
stacks (every order, centred on the sites) and seeded random ones, scored on samples of the motion
(evenly spaced in joint rotation) for the full cycle and the task range at once; the best are improved
by coordinate moves (shift, flip, widen) and the winner is certified (`collision.certify`); where the
certificate fails, those samples join the search's and it goes on (the coordinate search itself:
`synth.design.coordinate`; cranked bars: `synth.design.cranks`; planar layers: `synth.design.layers`).
Deterministic for a given ``seed``.
"""
from __future__ import annotations

import functools
import math
import time

import numpy as np

from synth.design.collision import CapsuleSet, axial_kind, certify, shared_joints, tested
from synth.design.sampling import bodies, phi_of_t, t_of_phi
from synth.design.coordinate import FULL, Scorer, mount_space, score, search_rounds, violation
from synth.design.work import GAPS_PER_SECOND, Work
from synth.design.model import Bar, CollisionReport, DesignResult, Mount, PhysicalDesign, Pin, hub_radius_for, joint_links
from synth.drive import driver_joint, task_range  # noqa: F401  (task_range: also for the design's callers)

TWO_PI = 2 * math.pi
CLEARANCE_FRACTION = 0.25  # default clearance: this fraction of the bar radius
SAFETY = 0.5  # the search asks for a sampled gap of clearance * (1 + SAFETY) so that certification holds
FULL_SAMPLES, TASK_SAMPLES = 24, 12  # search samples per joint, full cycle and task range
ATTEMPTS = 2  # independent sets of starts per range, always tried (budgets permitting) ...
MORE_WORK = 1.0 * GAPS_PER_SECOND  # ... and further ones (the next best starts) while the range's search has
# spent less than this many gap evaluations (times ``effort``): a cheap failure is no proof (fixtures/bennett_matrix.json
# was free over the full cycle only at its 4th set of starts, 0.3 CPU s)
SPREADS = (0.25, 0.5, 1.0, 2.0)  # scales (times the extent) of the random stack centres
SCREEN_WORK, SCREEN_EFFORT = 0.2 * GAPS_PER_SECOND, 0.5  # the quick full-cycle search of each candidate (rank_buildable)
WARM_STEP = 0.04  # the first moves of a warm start (`design_linkage`'s ``start``), times the extent
SEARCH_MERGED = True  # the search scores merged hub+pin capsules (fewer pairs), the certificate the exact ones


# ----------------------------------------------------------------------------------------- layout
def search_target(clearance: float, bar_radius: float) -> float:
    """The sampled gap (metres) the searches ask of every capsule pair: the clearance (at least a sixteenth
    of the bar radius, so > 0 even for clearance 0) times 1 + `SAFETY`, so that certification holds."""
    return max(clearance, 0.25 * CLEARANCE_FRACTION * bar_radius) * (1 + SAFETY)


def settled_margin(target: float) -> float:
    """`Scorer`'s ``settled`` (metres): the safety margin of ``target`` (`search_target`) but 2 %."""
    return 0.98 * SAFETY / (1 + SAFETY) * target


def stack_gap(bar_radius: float, hub_radius: float, hub_length: float, clearance: float) -> float:
    """The least distance (metres) of the two mounts on a joint: the hubs a clearance apart, the bars' round
    ends (balls of the bar radius) `search_target` (1 % more: float32 gaps) apart from each other and from
    the other link's hub face (docs/design.md, "Overlap of links that share a joint")."""
    return max(hub_length + clearance, bar_radius + max(bar_radius, hub_length / 2) + 1.01 * search_target(clearance, bar_radius))


class Layout:
    """The searched parametrization of a linkage's design and its capsules (see the module docstring).

    ``merged``: one capsule of the hub radius per mount covering the hub and, on the carrier, the whole
    pin (fewer, looser capsules: the search); else bars, hubs and pins separately (the certificate).
    The pairs tested: `collision.tested` (of two links that share a joint: their bars, and a leg from that
    joint against the other's hub there, a cylinder; `collision.axial_kind`); ``adjacent`` False: none of
    two links that share a joint; ``untested``: such pairs (frozensets) not tested (`synth.design.layers.Plan`).
    ``cranks``: {(link, joint a, joint b): (p0, p1, ..., n)}: the bar of ``link`` from a to b is cranked,
    a polyline mount a -> p0 + w0 n -> p1 + w1 n -> ... -> mount b with the crank offsets w
    (``end_offsets``'s ``W``, one column per via point, in the order of ``vias``); points and the unit
    crank direction n in the reference configuration (metres)."""

    def __init__(self, linkage, *, pin_radius, bar_radius, hub_radius, hub_length, clearance, merged, cranks=None,
                 adjacent=True, untested=frozenset()):
        self.linkage = linkage
        jl = joint_links(linkage)
        self.joints = [j.name for j in linkage.joints if jl[j.name]]
        self.links_of = {j: jl[j] for j in self.joints}
        self.mounts = [(link, j) for j in self.joints for link in jl[j]]
        self.mindex = {m: i for i, m in enumerate(self.mounts)}
        self.hub_length = hub_length
        self.gap_min = stack_gap(bar_radius, hub_radius, hub_length, clearance)
        self.cranks = dict(cranks or {})
        self.vias: list[tuple[str, str, str, int]] = []  # (link, a, b, 0|1) per crank offset column
        h = hub_length / 2
        jidx = {j: i for i, j in enumerate(self.joints)}
        sites = linkage.joint_sites()
        ends: list[tuple] = []  # (base, direction, body, kind, index, const); kind 0: mount, 1: min, 2: max of joint, 3: via
        caps: list[tuple] = []  # (body, label, end0, end1, radius, part, joint): part "bar", "hub", "pin", "cyl"

        def end(j, body, kind, index, const):
            ends.append((sites[j], linkage.joint(j).direction, body, kind, index, const))
            return len(ends) - 1

        for link, names in linkage.links.items():
            for a, b in zip(names, names[1:]):
                chain = [end(a, link, 0, self.mindex[(link, a)], 0.0)]
                if (link, a, b) in self.cranks:
                    *points, n = self.cranks[(link, a, b)]
                    for k, p in enumerate(points):
                        ends.append((np.asarray(p, float), np.asarray(n, float), link, 3, len(self.vias), 0.0))
                        self.vias.append((link, a, b, k))
                        chain.append(len(ends) - 1)
                chain.append(end(b, link, 0, self.mindex[(link, b)], 0.0))
                for k, (e0, e1) in enumerate(zip(chain, chain[1:])):  # at: {joint: its end} where a leg meets its axis
                    at = {n: e for n, e, first in ((a, e0, k == 0), (b, e1, k == len(chain) - 2)) if first}
                    caps.append((link, f"bar {a}-{b}", e0, e1, bar_radius, "bar", at))
        for link, j in self.mounts:
            carrier = self.links_of[j][0] == link
            m = self.mindex[(link, j)]
            if len(self.links_of[j]) == 2:  # the hub as a cylinder, for the neighbour's bars (`tested`)
                caps.append((link, f"hub {j}", end(j, link, 0, m, -h), end(j, link, 0, m, h), hub_radius, "cyl", j))
            if merged and carrier:
                pin = (end(j, link, 1, jidx[j], -h), end(j, link, 2, jidx[j], h))
                caps.append((link, f"hub+pin {j}", *pin, hub_radius, "hub", j))
                continue
            caps.append((link, f"hub {j}", end(j, link, 0, m, -h), end(j, link, 0, m, h), hub_radius, "hub", j))
            if carrier:
                caps.append((link, f"pin {j}", end(j, link, 1, jidx[j], -h), end(j, link, 2, jidx[j], h), pin_radius,
                             "pin", j))
        shared = shared_joints(linkage)
        names = bodies(linkage)
        body_pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
        bp_index = {p: i for i, p in enumerate(body_pairs)}
        pairs, radii, axial, bpi, labels, exempt = [], [], [], [], [], (set(untested) if adjacent else set(shared))
        for i, ca in enumerate(caps):
            for cb in caps[i + 1:]:
                key = (ca[0], cb[0]) if (ca[0], cb[0]) in bp_index else (cb[0], ca[0])
                together = shared.get(frozenset(key))
                if key not in bp_index or frozenset(key) in exempt or not tested(ca[5:], cb[5:], together):
                    continue
                x, y = (ca, cb) if key[0] == ca[0] else (cb, ca)
                kind, row = axial_kind(x, y, together)
                pairs.append(row)
                radii.append(x[4] + y[4] if kind in (0, 3) else (y[4] if kind == 1 else x[4]))
                axial.append((kind, x[4] if kind == 1 else (y[4] if kind == 2 else 0.0)))
                bpi.append(bp_index[key])
                labels.append(f"{x[0]}:{x[1]} / {y[0]}:{y[1]}")
        self.ends = [e[3:] for e in ends]
        self.cs = CapsuleSet(ends_base=np.array([e[0] for e in ends], float).reshape(-1, 3),
                             ends_dir=np.array([e[1] for e in ends], float).reshape(-1, 3),
                             ends_body=[e[2] for e in ends], pairs=np.array(pairs, int).reshape(-1, 4),
                             radii=np.array(radii, float), body_pair=np.array(bpi, int),
                             body_pairs=body_pairs, labels=labels,
                             axial=np.array(axial, float).reshape(-1, 2) if any(k for k, _ in axial) else None)

    # parameters: c (N, J) centres, sigma (N, J) +-1, g (N, J) hub distances
    def natural_offsets(self) -> np.ndarray:
        """(M,) mount offsets of the natural stack: every joint's hubs stacked about its site, in tree
        order, ``gap_min`` apart."""
        J = len(self.joints)
        return self.mount_offsets(np.zeros((1, J)), np.ones((1, J)), np.full((1, J), self.gap_min))[0]

    @functools.cached_property
    def _gathers(self):
        """Index arrays of `mount_offsets` and `end_offsets`: per mount its joint and place in the stack
        (k - (n - 1) / 2); per joint its mounts (padded by repeating the first); per end its column in
        [S | lo | hi | W] and constant."""
        jidx = {j: i for i, j in enumerate(self.joints)}
        joint = np.array([jidx[j] for _, j in self.mounts], int)
        place = np.array([self.links_of[j].index(link) - (len(self.links_of[j]) - 1) / 2 for link, j in self.mounts])
        width = max((len(self.links_of[j]) for j in self.joints), default=1)
        stack = np.array([[self.mindex[(ls[min(k, len(ls) - 1)], j)] for k in range(width)]
                          for j, ls in ((j, self.links_of[j]) for j in self.joints)], int).reshape(-1, width)
        M, J = len(self.mounts), len(self.joints)
        start = (0, M, M + J, M + 2 * J)
        column = np.array([start[kind] + index for kind, index, _ in self.ends], int)
        const = np.array([const for *_, const in self.ends], float)
        return joint, place, stack, column, const

    def mount_offsets(self, c, sigma, g) -> np.ndarray:
        """(N, M) mount offsets."""
        joint, place = self._gathers[:2]
        return c[:, joint] + sigma[:, joint] * place * g[:, joint]

    def end_offsets(self, S, W=None) -> np.ndarray:
        """(N, E) end-point offsets of the capsules from the mount offsets S (N, M) and the crank offsets
        W (N, V) (default: zero, the via points on the straight bar)."""
        stack, column, const = self._gathers[2:]
        around = S[:, stack]  # (N, J, width)
        W = np.zeros((len(S), len(self.vias))) if W is None else np.broadcast_to(W, (len(S), len(self.vias)))
        table = np.concatenate([S, around.min(axis=2), around.max(axis=2), W], axis=1)
        return table[:, column] + const

    def design(self, S, W=None, *, pin_radius, bar_radius, hub_radius, hole_clearance, clearance) -> PhysicalDesign:
        """The `PhysicalDesign` of one mount-offset vector S (M,) and crank offsets W (V,)."""
        mounts = [Mount(link, j, float(S[i])) for i, (link, j) in enumerate(self.mounts)]
        W = np.zeros(len(self.vias)) if W is None else W
        vias: dict[tuple, list] = {}
        for (link, a, b, k), w in zip(self.vias, W):
            crank = self.cranks[(link, a, b)]
            vias.setdefault((link, a, b), []).append(np.asarray(crank[k], float) + float(w) * np.asarray(crank[-1]))
        bars = [Bar(link, (a, b), vias.get((link, a, b), [])) for link, names in self.linkage.links.items()
                for a, b in zip(names, names[1:])]
        h = self.hub_length / 2
        pins = []
        for j in self.joints:
            offs = [S[self.mindex[(link, j)]] for link in self.links_of[j]]
            pins.append(Pin(j, float(min(offs) - h), float(max(offs) + h), self.links_of[j][0]))
        return PhysicalDesign(pin_radius=pin_radius, bar_radius=bar_radius, hub_radius=hub_radius,
                              hub_length=self.hub_length, hole_clearance=hole_clearance, clearance=clearance,
                              mounts=mounts, bars=bars, pins=pins)


# ----------------------------------------------------------------------------------------- ranges
def phi_of_angle(joint, theta) -> float:
    """phi in (-pi/2, pi/2] where ``joint`` has angle theta (its angle law is a bijection of the cycle)."""
    th = float(theta) % TWO_PI
    if th < 1e-15 or TWO_PI - th < 1e-15:
        return math.pi / 2
    return float(phi_of_t(joint.parameter(th)))


def task_phi_range(linkage) -> tuple[float, float]:
    """[lo, hi] in phi (hi - lo <= pi) of the task range (`task_range`)."""
    driver, start, end = task_range(linkage)
    if end - start >= TWO_PI - 1e-12:
        return FULL
    j = linkage.joint(driver)
    p0, p1 = phi_of_angle(j, start), phi_of_angle(j, end)
    if j.b > 0:  # the angle decreases with phi
        p0, p1 = p1, p0
    return p0, p0 + ((p1 - p0) % math.pi)


# ----------------------------------------------------------------------------------------- search
def design_linkage(linkage, *, pin_radius: float, bar_radius: float, hub_length: float,
                   hole_clearance: float = 0.0, clearance: float | None = None, seed: int = 0,
                   effort: float = 1.0, ranges: tuple[str, ...] = ("full", "task"),
                   full_work: float | None = None, work: Work | None = None,
                   start: DesignResult | None = None) -> DesignResult:
    """A collision-free physical design for ``linkage`` (full cycle if found, else task range) and its
    certified `CollisionReport`; the most compact one found. Lengths in metres. ``clearance`` defaults
    to ``CLEARANCE_FRACTION`` times the bar radius; ``effort`` scales the number of candidates.
    ``ranges``: the ranges tried, in order (("full",): a quick full-cycle-only search, whose failure is
    reported as not free over the full cycle; ("task",): the task range only). ``full_work``: a budget
    of gap evaluations (`synth.design.work`) for the full-cycle search (None: no limit); ``work``: the
    budget of the whole search, charged with every evaluation (checked between moves; None: no limit;
    the certificate of the last candidate is made even when it is spent). ``start``: a free design of this
    linkage with other sizes (a sizing round's last, `synth.design.choose`): searched first, from its
    stacks with small moves, over the range it is free in (`warm_stack`); the whole search only when that
    finds no certified design (on the samples it would have had). The report's ``work`` counts the evaluations of this search; its
    ``seconds`` the CPU time (information only: nothing depends on it)."""
    t0 = time.process_time()
    budget = Work() if work is None else work
    done0 = budget.done
    sizes = resolved_sizes(pin_radius, bar_radius, hub_length, hole_clearance, clearance)
    clearance, hub_radius = sizes["clearance"], sizes["hub_radius"]
    search = Layout(linkage, merged=SEARCH_MERGED, **sizes)
    exact = Layout(linkage, merged=False, **sizes)
    if not len(exact.cs.pairs):  # every two bodies share a joint: nothing can collide
        return _natural_free(linkage, exact, sizes, hole_clearance)
    scale = linkage.extent()
    task = task_phi_range(linkage)
    J = len(search.joints)
    gmin = search.gap_min
    target = search_target(clearance, bar_radius)
    rng = np.random.default_rng(seed)
    effort = effort * min(1.0, (6 / J) ** 2)  # many joints: many more pairs per candidate

    def to_S(X):
        return search.mount_offsets(X[:, :J], X[:, J:2 * J], X[:, 2 * J:])

    scorer = Scorer(search, FULL_SAMPLES * J, TASK_SAMPLES * J, task, lambda X: search.end_offsets(to_S(X)), budget,
                    settled_margin(target))
    space = mount_space(J, gmin, scale)

    X0 = initial_stacks(rng, J, int(effort * 32 * J), gmin, scale)
    coarse = (np.arange(len(scorer.phis)) % 3 == 0) | (np.arange(len(scorer.phis)) == scorer.once_k)  # (`Scorer.once`)
    size0 = space.size(X0)
    coarse_task = scorer.is_task[coarse]

    @functools.cache
    def screen():  # the sampled gaps of every start at the coarse samples (once, when a start is needed)
        if budget.spent:  # nothing will be searched (the natural stack is certified below): no screen either
            return np.zeros((len(X0), len(search.cs.pairs), int(coarse.sum())))
        return scorer.grid(X0, np.flatnonzero(coarse))

    result, last = None, None
    n_starts = max(2, int(4 * effort))
    ranges = _ranges(ranges, task)
    full = budget.part(None if full_work is None else full_work)  # the screen counts
    warm = (start.collision.range, warm_stack(search, start.design)) if start and start.collision.free else None
    for rname, rng_phi, attempt in _attempts(ranges, len(X0) // n_starts, warm):
        if budget.spent:
            break
        scorer.work = full if rname == "full" else budget
        if scorer.work.spent:  # the full-cycle budget: on to the task range
            continue
        if attempt == 0:
            range_start = scorer.work.done
        elif attempt >= ATTEMPTS and scorer.work.done - range_start >= MORE_WORK * effort:
            continue  # the later sets of starts only within MORE_WORK
        if attempt < 0:  # the warm start: small moves from the given design's stacks
            X, step = warm[1].copy(), WARM_STEP
        else:
            mask0 = np.ones(coarse.sum(), bool) if rname == "full" else coarse_task
            ranked = np.argsort(-score(violation(screen(), target, mask0), size0), kind="stable")
            X, step = X0[ranked[attempt * n_starts:(attempt + 1) * n_starts]].copy(), 0.25
        found, tried = search_rounds(
            scorer, space, X, lambda: np.ones(len(scorer.phis), bool) if rname == "full" else scorer.is_task,
            target, scale, effort=effort, step=step,
            certify_best=lambda x: certify_layout(exact, to_S(x[None])[0], rng_phi, clearance))
        last = (tried or last) if attempt >= 0 else last
        if attempt < 0 and found is None:  # the search from scratch as without a warm start: its samples only
            scorer.keep_first(len(coarse))
        if found is not None:
            result = (rname, to_S(found[0][None])[0], found[1])
            break
    if result is None and last is None:  # the budget was spent before any search: the natural stack
        last = (X0[:1], np.zeros(1))
    if result is None:  # not even the task range: report the design that came closest over it
        X, best = last
        S = to_S(X[int(np.argmax(best))][None])[0]
        result = (ranges[-1][0], S, certify_layout(exact, S, ranges[-1][1], clearance))
    rname, S, cert = result
    design = exact.design(S, pin_radius=pin_radius, bar_radius=bar_radius, hub_radius=hub_radius,
                          hole_clearance=hole_clearance, clearance=clearance)
    report = report_for(linkage, exact, rname, cert, clearance)
    report.seconds, report.work = time.process_time() - t0, budget.done - done0
    return DesignResult(design, report)


def _natural_free(linkage, layout: Layout, sizes: dict, hole_clearance: float) -> DesignResult:
    """The natural stack of a linkage in which every two bodies share a joint: free over the full cycle."""
    design = layout.design(layout.natural_offsets(), pin_radius=sizes["pin_radius"], bar_radius=sizes["bar_radius"],
                           hub_radius=sizes["hub_radius"], hole_clearance=hole_clearance, clearance=sizes["clearance"])
    report = CollisionReport(free=True, range="full", clearance=sizes["clearance"], min_distance=math.inf,
                             driver=driver_joint(linkage), driver_range=(0.0, TWO_PI), certified=True,
                             sampled_min_distance=math.inf)
    return DesignResult(design, report)


def initial_stacks(rng, J: int, n_rand: int, gmin: float, scale: float) -> np.ndarray:
    """The starts of the mount search, rows X = [c | sigma | g] (N, 3J): every order of the natural stack
    (up to 64), then ``n_rand`` random stacks (centres spread by `SPREADS` times ``scale``, gaps from
    ``gmin`` up), drawn from ``rng`` in a fixed order (the same seed, the same starts)."""
    n_orders = min(2 ** J, 64)
    orders = np.array([[1 - 2 * ((k >> i) & 1) for i in range(J)] for k in range(n_orders)], float)
    sigma0 = np.concatenate([orders, rng.choice([-1.0, 1.0], size=(n_rand, J))])
    spread = rng.choice(SPREADS, size=(n_rand, 1)) * scale
    c0 = np.concatenate([np.zeros((n_orders, J)), rng.uniform(-1, 1, size=(n_rand, J)) * spread])
    g0 = np.concatenate([np.full((n_orders, J), gmin),
                         gmin * (1 + rng.exponential(0.5, size=(n_rand, J)) * (rng.random((n_rand, J)) < 0.3))])
    return np.concatenate([c0, sigma0, g0], axis=1)


def natural_result(linkage, *, pin_radius: float, bar_radius: float, hub_length: float,
                   hole_clearance: float = 0.0, clearance: float | None = None) -> DesignResult:
    """The natural stack (every hub stack centred on its joint's site) with the sizes `design_linkage`
    would use, not searched and not checked (``free`` False, ``min_distance`` nan): the start of a
    search that keeps only the sizes (`synth.design.mixed.mixed_design`)."""
    sizes = resolved_sizes(pin_radius, bar_radius, hub_length, hole_clearance, clearance)
    layout = Layout(linkage, merged=False, **sizes)
    design = layout.design(layout.natural_offsets(), pin_radius=pin_radius, bar_radius=bar_radius,
                           hub_radius=sizes["hub_radius"], hole_clearance=hole_clearance, clearance=sizes["clearance"])
    report = CollisionReport(free=False, range="full", clearance=sizes["clearance"], min_distance=math.nan,
                             driver=driver_joint(linkage), driver_range=(0.0, TWO_PI))
    return DesignResult(design, report)


def resolved_sizes(pin_radius: float, bar_radius: float, hub_length: float, hole_clearance: float = 0.0,
                   clearance: float | None = None) -> dict:
    """`Layout`'s sizes (metres) for a design's inputs: the clearance CLEARANCE_FRACTION times the bar radius
    unless given, the hub radius `synth.design.model.hub_radius_for`."""
    return dict(pin_radius=pin_radius, bar_radius=bar_radius,
                hub_radius=hub_radius_for(pin_radius, bar_radius, hole_clearance), hub_length=hub_length,
                clearance=CLEARANCE_FRACTION * bar_radius if clearance is None else float(clearance))


def sizes_of(design) -> dict:
    """`Layout`'s sizes of an existing `PhysicalDesign` (to search another shape with the same parts)."""
    return dict(pin_radius=design.pin_radius, bar_radius=design.bar_radius, hub_radius=design.hub_radius,
                hub_length=design.hub_length, clearance=design.clearance)


def cranked_result(linkage, layout: Layout, S, W, like, rname: str, cert: dict, cranks: dict) -> DesignResult:
    """The design of ``layout`` with mount offsets S (M,) and crank offsets W (V,), with the sizes, hole
    clearance and clearance of the design ``like``, and the report of its certificate ``cert`` over the
    range ``rname`` naming the cranked bars (``cranks``: `Layout`'s)."""
    design = layout.design(S, W, pin_radius=like.pin_radius, bar_radius=like.bar_radius, hub_radius=like.hub_radius,
                           hole_clearance=like.hole_clearance, clearance=like.clearance)
    report = report_for(linkage, layout, rname, cert, like.clearance)
    report.cranked = [list(k) for k in cranks]
    return DesignResult(design, report)


def _attempts(ranges, sets: int, warm=None):
    """(range name, (lo, hi), attempt) in search order: every set of starts (``sets`` of them) of each range;
    first attempt -1 (the warm start) in the range ``warm[0]`` names, when given."""
    for rname, rng_phi in ranges:
        if warm is not None and warm[0] == rname:
            yield rname, rng_phi, -1
        for attempt in range(max(ATTEMPTS, sets)):
            yield rname, rng_phi, attempt


def warm_stack(layout: Layout, design) -> np.ndarray:
    """(1, 3J) the stacks X = [c | sigma | g] of ``layout`` nearest the mounts of ``design`` (a design of the
    same linkage with other sizes): per joint the mean offset of its mounts, the order and spacing of its
    first and last (g at least ``layout.gap_min``; a mount the design lacks: the site)."""
    offset = {(m.link, m.joint): m.offset for m in design.mounts}
    c, sigma, g = [], [], []
    for j in layout.joints:
        S = [offset.get((link, j), 0.0) for link in layout.links_of[j]]
        spread = (S[-1] - S[0]) / max(len(S) - 1, 1)
        c.append(float(np.mean(S)))
        sigma.append(-1.0 if spread < 0 else 1.0)
        g.append(max(abs(spread), layout.gap_min))
    return np.array([c + sigma + g], float)


def _ranges(names, task) -> tuple:
    """((name, (lo, hi)), ...) of the ranges to search, in order; a task range that is the whole cycle is
    the full cycle."""
    out = []
    for name in names:
        if name not in ("full", "task"):
            raise ValueError(f"unknown range {name!r}")
        if name == "full" or task == FULL:
            if ("full", FULL) not in out:
                out.append(("full", FULL))
        else:
            out.append(("task", task))
    return tuple(out)


def certify_layout(layout: Layout, S, rng, clearance, W=None) -> dict:
    """`collision.certify` of the design with mount offsets S (M,) and crank offsets W (V,) over phi in rng."""
    W = None if W is None else np.asarray(W)[None]
    return certify(layout.linkage, layout.cs, layout.end_offsets(S[None], W)[0], rng[0], rng[1], clearance)


def report_for(linkage, layout: Layout, rname: str, cert: dict, clearance: float) -> CollisionReport:
    """The `CollisionReport` of a certificate ``cert`` of a design of ``layout`` over the range ``rname``."""
    driver, start, end = task_range(linkage)
    drange = (0.0, TWO_PI) if rname == "full" else (start, end)
    cs = layout.cs
    pairs = []
    sampled = float(cert["sampled"].min()) if len(cs.pairs) else math.inf
    if not cert["certified"]:
        j = linkage.joint(driver)
        for b, (A, B) in enumerate(cs.body_pairs):
            rows = cs.body_pair == b
            if not rows.any():
                continue
            d = cert["dist"][rows].min(axis=0)
            if d.min() >= clearance:
                continue
            hit = np.flatnonzero(d < clearance)
            ang = j.angle(t_of_phi(cert["phis"][hit]))
            pairs.append({"bodies": [A, B], "min_distance": float(d.min()),
                          "driver_angles": [float(ang[0]), float(ang[-1])]})
    free = bool(cert["certified"])
    message = ""
    if not free:  # (the offending pairs and their gaps are data: ``pairs``, worst first)
        pairs.sort(key=lambda p: p["min_distance"])
        message = ("no collision-free design with straight bars found even over the task range; "
                   "use thinner bars and pins (--link-radius, --pin-radius), a smaller clearance, "
                   "or another solution of the synthesis")
    lower = cert["lower"] if free else sampled
    return CollisionReport(free=free, range=rname, clearance=clearance, min_distance=float(lower),
                           driver=driver, driver_range=drange, certified=free, pairs=pairs, message=message,
                           sampled_min_distance=sampled)


def collision_rank(report: CollisionReport) -> int:
    """0: collision-free over the full cycle, 1: over the task range only, 2: neither."""
    return 0 if report.free and report.range == "full" else (1 if report.free else 2)
