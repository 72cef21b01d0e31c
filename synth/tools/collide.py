"""Self-collision of a written linkage along its whole motion (python-fcl through trimesh).

Every pair of links with meshes is tested at ``steps`` configurations of one full cycle (spaced
evenly in joint angle, see ``readback.cycle_parameters``), except the pairs that touch by design:
links that share a joint (their pins overlap on the common axis) and the links of a loop closure
(``coupler``/``coupler_k`` are one rigid body, so a joint into ``coupler_k`` also makes its parent
adjacent to ``coupler``). The meshes are the STL files of OUT, placed as the URDF places them.

For each colliding pair the report gives the ranges of the motion where it collides, as motion
parameters t (``None`` = infinity; a range with t_start > t_end runs through infinity, i.e. through
the first pose) and as joint angles at both ends; each end is refined by bisection between the
last free and the first colliding sample, so it is exact to ``1e-6`` of the cycle (a contact
shorter than one step between two samples can be missed: raise ``steps`` to look closer). For the
pairs that never collide the report gives their smallest distance over the samples (clearance).

python-fcl is an optional dependency (``pip install 'mpsynth[collide]'``); without it
``collide`` raises `MissingEngine` (exit code 2).
"""
from __future__ import annotations

import math
import time

import numpy as np

from synth.algebra.anglelaw import angle_law_inverse
from synth.design.search import driver_joint, task_range
from synth.errors import InputError, MpsynthError
from synth.frames import TWO_PI
from synth.io.readback import Readback, cycle_parameters, phi_of

INSTALL_HINT = "pip install 'mpsynth[collide]'"
REFINE_TOL = 1e-6  # of the cycle, in phi (radians / pi)


class MissingEngine(MpsynthError):
    """An optional engine (python-fcl) is not installed. Exit code 2."""

    exit_code = 2


def fcl_available() -> bool:
    try:
        import fcl  # noqa: F401
    except ImportError:
        return False
    try:
        from trimesh.collision import CollisionManager

        CollisionManager()
    except (ImportError, ValueError):
        return False
    return True


def _require_fcl():
    if not fcl_available():
        raise MissingEngine(f"collision checking needs python-fcl: {INSTALL_HINT}")


def candidate_pairs(rb: Readback) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """(pairs to test, pairs excluded as adjacent), over the links with meshes, in tree order."""
    links = rb.mesh_links
    adjacent = rb.adjacent_pairs()
    test, skip = [], []
    for i, a in enumerate(links):
        for b in links[i + 1:]:
            (skip if frozenset((a, b)) in adjacent else test).append((a, b))
    return test, skip


def _t_of_phi(phi: float) -> float:
    """t = tan(phi) for any real phi (period pi); inf where cos(phi) vanishes."""
    p = math.remainder(phi, math.pi)  # in [-pi/2, pi/2]
    if abs(abs(p) - math.pi / 2) < 1e-15:
        return math.inf
    return math.tan(p)


class PairTester:
    """Tests one pair of links at any parameter t with its own two-object collision manager."""

    def __init__(self, rb: Readback, a: str, b: str):
        from trimesh.collision import CollisionManager

        self.rb, self.a, self.b = rb, a, b
        meshes = rb.meshes()
        self.manager = CollisionManager()
        self.manager.add_object(a, meshes[a])
        self.manager.add_object(b, meshes[b])

    def hit(self, t: float) -> bool:
        P = self.rb.link_poses(t)
        self.manager.set_transform(self.a, P[self.a])
        self.manager.set_transform(self.b, P[self.b])
        return bool(self.manager.in_collision_internal())

    def boundary(self, phi_free: float, phi_hit: float) -> float:
        """Bisect for the phi where the pair starts (or stops) colliding; returns a colliding phi."""
        for _ in range(60):
            if abs(phi_hit - phi_free) <= REFINE_TOL * math.pi:
                break
            mid = (phi_free + phi_hit) / 2
            if self.hit(_t_of_phi(mid)):
                phi_hit = mid
            else:
                phi_free = mid
        return phi_hit


def cyclic_runs(hit: np.ndarray) -> list[tuple[int, int]]:
    """Cyclic runs of True as (first, last) indices (last < first when the run wraps around)."""
    n = len(hit)
    if hit.all():
        return [(0, n - 1)]
    if not hit.any():
        return []
    start = int(np.argmin(hit))  # a free sample: runs are found after it, without a wrap in the middle
    runs, k = [], 0
    while k < n:
        i = (start + k) % n
        if hit[i]:
            j = k
            while j + 1 < n and hit[(start + j + 1) % n]:
                j += 1
            runs.append((i, (start + j) % n))
            k = j + 1
        else:
            k += 1
    return sorted(runs)


SPANS = ("claim", "task", "full")


def claimed_span(rb: Readback) -> str:
    """The range linkage.json's design claims ("task" or "full"; "full" without a claim)."""
    claim = rb.document.get("collision")
    return "task" if isinstance(claim, dict) and claim.get("range") == "task" else "full"


def _samples(rb: Readback, steps: int, spacing: str, span: str) -> tuple[np.ndarray, str, bool]:
    """(motion parameters t, the driver, cyclic): one full cycle, or ``steps`` driver angles evenly over
    the task range (`synth.design.search.task_range`; not cyclic)."""
    lk = rb.linkage
    driver = driver_joint(lk)
    if span == "task":
        driver, start, end = task_range(lk, driver)
        if end - start < TWO_PI - 1e-9:
            d = lk.joint(driver)
            return angle_law_inverse(d.a, d.b, np.linspace(start, end, steps), d.rate), driver, False
    return cycle_parameters(lk, steps, spacing=spacing), driver, True


def collide(rb: Readback, steps: int = 360, spacing: str = "angle", clearance: bool = True,
            span: str = "claim") -> dict:
    """Check every non-adjacent pair of links along the motion; returns the report (plain JSON types).
    ``span``: "full" (one cycle), "task" (the arc of the driver through the task poses) or "claim"
    (the range linkage.json's design claims, `claimed_span`). Ranges are given as driver angles
    (degrees, increasing: the direction the driver turns) and motion parameters."""
    _require_fcl()
    from trimesh.collision import CollisionManager

    if span not in SPANS:
        raise InputError(f"--range {span}: expected one of {', '.join(SPANS[1:])}")
    span = claimed_span(rb) if span == "claim" else span
    t0 = time.perf_counter()
    lk = rb.linkage
    steps = int(steps)
    ts, driver, cyclic = _samples(rb, steps, spacing, span)
    phis = phi_of(ts)
    test, skip = candidate_pairs(rb)
    meshes = rb.meshes()

    manager = CollisionManager()
    for n in rb.mesh_links:
        manager.add_object(n, meshes[n])
    wanted = {tuple(sorted(p)): p for p in test}
    hits = {p: np.zeros(steps, bool) for p in test}
    poses = rb.link_poses(ts)
    for k in range(steps):
        for n in rb.mesh_links:
            manager.set_transform(n, poses[n][k])
        _, names = manager.in_collision_internal(return_names=True)
        for pair in names:
            p = wanted.get(tuple(sorted(pair)))
            if p is not None:
                hits[p][k] = True

    collisions = []
    clear = []
    for p in test:
        h = hits[p]
        if not h.any():
            if clearance:
                clear.append({"links": list(p), **_clearance(rb, p, poses, ts, driver)})
            continue
        tester = PairTester(rb, *p)
        ranges = []
        for first, last in (cyclic_runs(h) if cyclic else linear_runs(h)):
            if h.all():
                ranges.append(_range(lk, None, None, steps, driver) if cyclic else
                              _range(lk, phis[0], phis[-1], steps, driver))
                continue
            if not cyclic:  # the task range: its ends are the sample driver angles
                ranges.append(_range(lk, phis[first], phis[last], last - first + 1, driver))
                continue
            prev, nxt = (first - 1) % steps, (last + 1) % steps
            # unwrap phi so that prev < first <= last < nxt along the motion (period pi)
            ph_prev, ph_first = phis[prev], phis[first]
            if ph_prev >= ph_first:
                ph_prev -= math.pi
            ph_last, ph_next = phis[last], phis[nxt]
            if ph_next <= ph_last:
                ph_next += math.pi
            a = tester.boundary(ph_prev, ph_first)
            b = tester.boundary(ph_next, ph_last)
            count = (last - first) % steps + 1
            ranges.append(_range(lk, a, b, count, driver))
        collisions.append({"links": list(p), "samples": int(h.sum()), "fraction": float(h.mean()),
                           "ranges": ranges})
    return {
        "colliding": bool(collisions),
        "range": span,
        "driver": driver,
        "steps": steps,
        "spacing": spacing,
        "pairs_checked": [list(p) for p in test],
        "excluded_adjacent": [list(p) for p in skip],
        "collisions": collisions,
        "clearance": clear,
        "seconds": time.perf_counter() - t0,
    }


def linear_runs(hit: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of every run of True in ``hit`` (no wrap-around)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], hit.astype(int), [0]])))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def _driver_deg(lk, driver: str, t: float) -> float:
    """The driver's angle (degrees, [0, 360)) at motion parameter t."""
    return math.degrees(float(lk.angles_at(t)[driver]) % TWO_PI)


def _clearance(rb: Readback, pair, poses, ts, driver: str) -> dict:
    """Smallest distance of a never-colliding pair over the samples, and where."""
    from trimesh.collision import CollisionManager

    a, b = pair
    meshes = rb.meshes()
    ma, mb = CollisionManager(), CollisionManager()
    ma.add_object(a, meshes[a])
    mb.add_object(b, meshes[b])
    best, where = math.inf, 0
    for k in range(len(ts)):
        ma.set_transform(a, poses[a][k])
        mb.set_transform(b, poses[b][k])
        d = ma.min_distance_other(mb)
        if d < best:
            best, where = float(d), k
    t = ts[where]
    return {"min_distance": best, "t": None if np.isinf(t) else float(t),
            "driver_deg": _driver_deg(rb.linkage, driver, float(t))}


def _range(lk, phi_a, phi_b, count, driver: str) -> dict:
    """One colliding range between the motion parameters tan(phi_a) and tan(phi_b) (phi increasing):
    as t and as the driver's angle, from where the driver enters it to where it leaves (degrees,
    start in [0, 360), end > start)."""
    if phi_a is None:
        return {"whole_cycle": True, "t_start": None, "t_end": None, "samples": int(count)}
    ta, tb = _t_of_phi(phi_a), _t_of_phi(phi_b)
    da, db = _driver_deg(lk, driver, ta), _driver_deg(lk, driver, tb)
    if lk.joint(driver).b > 0:  # the driver's angle decreases as t grows: it meets tb first
        da, db = db, da
    return {
        "whole_cycle": False,
        "driver_start_deg": da,
        "driver_end_deg": da + (db - da) % 360.0,
        "t_start": None if math.isinf(ta) else ta,
        "t_end": None if math.isinf(tb) else tb,
        "samples": int(count),
        "angles_start": {k: float(v) for k, v in lk.angles_at(ta).items()},
        "angles_end": {k: float(v) for k, v in lk.angles_at(tb).items()},
    }


def summary_lines(report: dict) -> list[str]:
    """Human-readable lines for the report: positions as the driver's angle in degrees."""
    lines = []
    n, drv = report["steps"], report["driver"]
    where = "the task range" if report["range"] == "task" else "the cycle"
    if not report["pairs_checked"]:
        lines.append("no pair of non-adjacent links to check")
    for c in report["collisions"]:
        a, b = c["links"]
        lines.append(f"COLLIDE {a} <-> {b}: {c['samples']} of {n} samples ({100 * c['fraction']:.1f}% of {where})")
        for r in c["ranges"]:
            if r["whole_cycle"]:
                lines.append("    over the whole cycle")
                continue
            through = " (through the first pose)" if _wraps(r) else ""
            lines.append(f"    {drv} from {r['driver_start_deg']:.2f} to {r['driver_end_deg']:.2f} deg{through} "
                         f"(t from {_ft(r['t_start'])} to {_ft(r['t_end'])})")
    for c in report["clearance"]:
        a, b = c["links"]
        lines.append(f"ok      {a} <-> {b}: clearance {1e3 * c['min_distance']:.3g} mm (at {drv} = "
                     f"{c['driver_deg']:.2f} deg)")
    skipped = ", ".join(f"{a}-{b}" for a, b in report["excluded_adjacent"])
    lines.append(f"{len(report['pairs_checked'])} pair(s) checked at {n} configurations of {where} in "
                 f"{report['seconds']:.2f} s; adjacent pairs not checked: {skipped or 'none'}")
    return lines


def _ft(t) -> str:
    return "inf" if t is None else f"{t:.6g}"


def _wraps(r) -> bool:
    a = math.inf if r["t_start"] is None else r["t_start"]
    b = math.inf if r["t_end"] is None else r["t_end"]
    return a > b or (r["t_start"] is None) or (r["t_end"] is None)
