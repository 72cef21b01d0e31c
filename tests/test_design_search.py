"""The collision-free design search (synth.design.collision, synth.design.search; docs/design.md)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import REPO, random_poses
from synth.design.collision import pair_distances, segment_distance, world_ends
from synth.design.coordinate import ROUNDS
from synth.design.ranking import rank_buildable
from synth.design.sampling import body_motion, even_samples, rate_bound, t_of_phi
from synth.design.search import (Layout, collision_rank, design_linkage, sizes_of, task_phi_range, warm_stack,
                                  task_range)
from synth.errors import SynthesisError
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett
from synth.synthesis.sixbar import sixbar


def sizes(linkage):
    e = linkage.extent()
    return dict(pin_radius=0.02 * e, bar_radius=0.015 * e, hub_length=0.06 * e, hole_clearance=0.002 * e)


@pytest.fixture(scope="module")
def fixture_bennett():
    return bennett(load_poses(REPO / "fixtures" / "bennett_mm_deg.yaml").matrices)


@pytest.fixture(scope="module")
def fixture_bennett_design(fixture_bennett):
    return design_linkage(fixture_bennett, **sizes(fixture_bennett))


# ----------------------------------------------------------------------------- primitives
coord = st.floats(-2, 2, allow_nan=False)
point = st.tuples(coord, coord, coord).map(np.array)


@settings(max_examples=60, deadline=None)
@given(point, point, point, point)
def test_segment_distance_is_the_smallest_distance_of_points(p0, p1, q0, q1):
    d = segment_distance(*(x[:, None] for x in (p0, p1, q0, q1)))[0]
    s = np.linspace(0, 1, 201)
    P = p0[None] + s[:, None] * (p1 - p0)[None]
    Q = q0[None] + s[:, None] * (q1 - q0)[None]
    brute = np.sqrt(((P[:, None] - Q[None]) ** 2).sum(-1)).min()
    step = (np.linalg.norm(p1 - p0) + np.linalg.norm(q1 - q0)) / 200
    assert d <= brute + 1e-9
    assert d >= brute - step - 1e-9


def test_segment_distance_worked_numbers():
    z = np.zeros(3)
    cases = [  # (p0, p1, q0, q1, distance)
        ((0, 0, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), 1.0),  # skew, closest inside both
        ((0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0), 1.0),  # collinear, end to end
        ((0, 0, 0), (1, 0, 0), (0.5, 2, 0), (0.5, 2, 0), 2.0),  # a point
        ((0, 0, 0), (0, 0, 0), (3, 4, 0), (3, 4, 0), 5.0),  # two points
        ((0, 0, 0), (2, 0, 0), (1, 1, 0), (3, 1, 0), 1.0),  # parallel, overlapping
    ]
    for p0, p1, q0, q1, want in cases:
        got = segment_distance(*(np.array(x, float)[:, None] + z[:, None] for x in (p0, p1, q0, q1)))[0]
        assert got == pytest.approx(want, abs=1e-12)


def test_rate_bound_bounds_and_is_attained(fixture_bennett):
    """|dtheta/dphi| <= the closed-form bound on every interval, and the bound is its maximum there."""
    rng = np.random.default_rng(3)
    lo = rng.uniform(-math.pi / 2, math.pi / 2, 40)
    hi = lo + rng.uniform(0.01, 1.0, 40)
    bound = rate_bound(fixture_bennett, lo, hi)
    for i, j in enumerate(fixture_bennett.joints):
        for k in range(40):
            phi = np.linspace(lo[k], hi[k], 2001)
            th = np.unwrap(j.angle(t_of_phi(phi)))
            rate = np.abs(np.gradient(th, phi))[1:-1]
            assert rate.max() <= bound[i, k] * (1 + 1e-3) + 1e-9
            assert rate.max() >= bound[i, k] * (1 - 1e-2)


def test_even_samples_cover_the_range_in_order(fixture_bennett):
    phi = even_samples(fixture_bennett, -1.0, 2.0, 50)
    assert phi[0] == pytest.approx(-1.0) and phi[-1] == pytest.approx(2.0)
    assert np.all(np.diff(phi) > 0)


# ----------------------------------------------------------------------------- task range
def checker_task_range(linkage):
    """The task range as the independent verifier defines it (shortest arc of the first joint)."""
    d = linkage.branches[0][0]
    angles = sorted(float(p.joint_angles[d]) % (2 * math.pi) for p in linkage.poses)
    gaps = [(angles[(i + 1) % len(angles)] - angles[i]) % (2 * math.pi) or 2 * math.pi for i in range(len(angles))]
    g = int(np.argmax(gaps))
    start = angles[(g + 1) % len(angles)]
    return d, start, start + 2 * math.pi - gaps[g]


@pytest.mark.parametrize("seed", range(6))
def test_task_range_matches_the_verifier_and_maps_to_phi(seed):
    try:
        lk = bennett(random_poses(np.random.default_rng(100 + seed), 3))
    except SynthesisError:
        pytest.skip("not solvable")
    driver, start, end = task_range(lk)
    want = checker_task_range(lk)
    assert driver == want[0]
    assert (start, end) == pytest.approx(want[1:], abs=1e-12)
    lo, hi = task_phi_range(lk)
    assert 0 < hi - lo <= math.pi
    j = lk.joint(driver)
    phi = np.linspace(lo, hi, 4001)
    th = np.unwrap(j.angle(t_of_phi(phi)))
    swept = abs(th[-1] - th[0])
    assert swept == pytest.approx(end - start, abs=1e-6)
    for p in lk.poses:  # every pose lies inside the phi range
        ph = math.pi / 2 if math.isinf(p.t) else math.atan(p.t)
        assert (ph - lo + 1e-9) % math.pi <= hi - lo + 2e-9


# ----------------------------------------------------------------------------- the search
def dense_gaps(linkage, design, lo, hi, n=6000):
    """Smallest gap between the design's exact capsules at n samples evenly in phi (independent of the
    search's own sampling and certificate)."""
    lay = Layout(linkage, merged=False, pin_radius=design.pin_radius, bar_radius=design.bar_radius,
                 hub_radius=design.hub_radius, hub_length=design.hub_length, clearance=design.clearance)
    S = np.array([design.mount(link, j).offset for link, j in lay.mounts])
    phis = np.linspace(lo, hi, n)
    Q, U = world_ends(lay.cs, body_motion(linkage, phis))
    return pair_distances(lay.cs, Q, U, lay.end_offsets(S[None]))[0].min()


def test_fixture_bennett_is_free_over_the_full_cycle(fixture_bennett, fixture_bennett_design):
    r = fixture_bennett_design.collision
    assert r.free and r.certified and r.range == "full"
    assert r.clearance == pytest.approx(0.25 * 0.015 * fixture_bennett.extent())
    assert r.min_distance >= r.clearance
    assert dense_gaps(fixture_bennett, fixture_bennett_design.design, -math.pi / 2, math.pi / 2) >= r.min_distance - 1e-12


def test_hubs_on_one_axis_are_stacked_and_pins_span_them(fixture_bennett, fixture_bennett_design):
    d = fixture_bennett_design.design
    for p in d.pins:
        offs = sorted(m.offset for m in d.mounts if m.joint == p.joint)
        assert len(offs) == 2
        assert offs[1] - offs[0] >= d.hub_length + d.clearance - 1e-12
        assert p.start == pytest.approx(offs[0] - d.hub_length / 2)
        assert p.end == pytest.approx(offs[1] + d.hub_length / 2)


def test_search_is_deterministic(fixture_bennett, fixture_bennett_design):
    again = design_linkage(fixture_bennett, **sizes(fixture_bennett))
    assert again.design.to_dict() == fixture_bennett_design.design.to_dict()


def test_warm_stack_gives_back_the_mounts_of_a_design(fixture_bennett, fixture_bennett_design):
    """A design's mounts as the searched stacks (c, sigma, g) of the same sizes: the same offsets."""
    layout = Layout(fixture_bennett, merged=True, **sizes_of(fixture_bennett_design.design))
    X = warm_stack(layout, fixture_bennett_design.design)
    J = len(layout.joints)
    S = layout.mount_offsets(X[:, :J], X[:, J:2 * J], X[:, 2 * J:])[0]
    want = {(m.link, m.joint): m.offset for m in fixture_bennett_design.design.mounts}
    assert np.allclose(S, [want[m] for m in layout.mounts], rtol=0, atol=1e-12)


def test_a_sizing_round_starts_from_the_last_design(fixture_bennett, fixture_bennett_design):
    """With thicker bars (a sizing round, synth.design.choose._sturdy) the search starts from the last free
    design: certified free over its range (the verifier's claim holds: test_design_verify), near it, and
    for a fraction of the counted work of a search from scratch."""
    first = fixture_bennett_design
    s = {**sizes(fixture_bennett), "bar_radius": 1.04 * sizes(fixture_bennett)["bar_radius"],
         "clearance": first.design.clearance}
    cold = design_linkage(fixture_bennett, **s)
    warm = design_linkage(fixture_bennett, **s, start=first)
    assert warm.collision.free and warm.collision.certified and warm.collision.range == first.collision.range
    assert warm.collision.min_distance >= warm.design.clearance
    assert warm.collision.work < 0.25 * cold.collision.work
    moved = max(abs(a.offset - b.offset) for a, b in zip(first.design.mounts, warm.design.mounts))
    assert moved < 0.1 * fixture_bennett.extent()
    not_free = dataclasses.replace(first, collision=dataclasses.replace(first.collision, free=False))
    again = design_linkage(fixture_bennett, **s, start=not_free)  # only a free design is a start
    assert again.collision.work == cold.collision.work


def test_a_failed_warm_start_falls_back_to_the_whole_search(fixture_bennett, fixture_bennett_design, monkeypatch):
    """When no certificate holds near the last design (forced here: the warm start's certificates fail at
    every pair, so its rounds add samples), the search from scratch runs on its own samples: the design a
    search without the warm start finds."""
    import synth.design.search as search
    real, calls = search.certify_layout, []

    def failing_first(*a, **k):
        cert = real(*a, **k)
        calls.append(cert["certified"])
        if len(calls) <= ROUNDS:
            cert = {**cert, "certified": False, "sampled": np.zeros_like(cert["sampled"])}
        return cert

    monkeypatch.setattr(search, "certify_layout", failing_first)
    s = {**sizes(fixture_bennett), "bar_radius": 1.04 * sizes(fixture_bennett)["bar_radius"],
         "clearance": fixture_bennett_design.design.clearance}
    r = design_linkage(fixture_bennett, **s, start=fixture_bennett_design)
    assert len(calls) > ROUNDS and r.collision.free and r.collision.certified
    monkeypatch.setattr(search, "certify_layout", real)
    cold = design_linkage(fixture_bennett, **s)  # the same search (the warm rounds' samples forgotten)
    assert [m.offset for m in r.design.mounts] == [m.offset for m in cold.design.mounts]
    assert r.collision.min_distance == cold.collision.min_distance


def test_impossible_clearance_is_reported_with_pairs(fixture_bennett):
    """A clearance larger than the linkage cannot be kept: not free, pairs and a message."""
    r = design_linkage(fixture_bennett, **sizes(fixture_bennett), clearance=10 * fixture_bennett.extent(),
                       effort=0.3).collision
    assert not r.free and r.range == "task" and r.pairs and r.message
    assert r.min_distance < r.clearance
    for p in r.pairs:
        assert len(p["bodies"]) == 2 and len(p["driver_angles"]) == 2


def test_collision_rank(fixture_bennett):
    free = design_linkage(fixture_bennett, **sizes(fixture_bennett)).collision
    assert collision_rank(free) == 0
    tight = design_linkage(fixture_bennett, **sizes(fixture_bennett), clearance=10 * fixture_bennett.extent())
    assert collision_rank(tight.collision) == 2


def test_rank_buildable_puts_collision_free_first(fixture_bennett):
    """A candidate that cannot be made collision-free (an absurd clearance) is passed over for the next
    one that is free over the full cycle; the search stops there (the third is not designed)."""
    calls = []

    def design(lk, ranges, full_work, work, effort):
        calls.append(ranges)
        clearance = 10 * lk.extent() if len(calls) == 1 else None
        return design_linkage(lk, **sizes(lk), clearance=clearance, ranges=ranges, full_work=full_work, work=work)

    ranked = rank_buildable([fixture_bennett, fixture_bennett, fixture_bennett], design)
    assert calls == [("full",), ("full",)]
    assert [collision_rank(r.collision) for _, r in ranked] == [0]


def test_rank_buildable_falls_back_to_the_task_range_in_kinematic_order():
    """No candidate free over the full cycle: every candidate is tried over the full cycle (within the
    limit; a quick screen of all, then deeper searches), then over the task range in kinematic order until one is free there; the free one ranks
    first, the closest-but-colliding after it."""
    from types import SimpleNamespace

    free_over = {"A": set(), "B": {"task"}, "C": {"task"}}
    calls = []

    def design(lk, ranges, full_work, work, effort):
        calls.append((lk, ranges))
        rng = ranges[0]
        return SimpleNamespace(collision=SimpleNamespace(free=rng in free_over[lk], range=rng), slenderness=None)

    ranked = rank_buildable(["A", "B", "C"], design, limit=8, work=1e9)
    full = [("A", ("full",)), ("B", ("full",)), ("C", ("full",))]
    assert calls == full + full + [("A", ("task",)), ("B", ("task",))]  # the quick screen, the deep searches
    assert [lk for lk, _ in ranked] == ["B", "A"]
    assert [collision_rank(r.collision) for _, r in ranked] == [1, 2]


def test_sixbar_fixture_design_holds_between_samples():
    lk = sixbar(load_poses(REPO / "fixtures" / "sixbar_example.yaml").matrices)
    res = design_linkage(lk, **sizes(lk))
    r = res.collision
    assert r.free and r.certified
    lo, hi = (-math.pi / 2, math.pi / 2) if r.range == "full" else task_phi_range(lk)
    assert dense_gaps(lk, res.design, lo, hi, n=1500) >= r.min_distance - 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("kind,count", [("bennett", 24), ("sixbar", 12)])
def test_random_sets_success_rate(kind, count):
    """Seeded random solvable pose sets: every certified claim holds at dense samples, and at least 75% of
    the designs are free over the full cycle (bennett)."""
    synth, n = (bennett, 3) if kind == "bennett" else (sixbar, 4)
    full = done = 0
    seed = 0
    while done < count:
        try:
            lk = synth(random_poses(np.random.default_rng(seed), n))
        except SynthesisError:
            seed += 1
            continue
        seed += 1
        done += 1
        res = design_linkage(lk, **sizes(lk))
        r = res.collision
        if r.free:
            lo, hi = (-math.pi / 2, math.pi / 2) if r.range == "full" else task_phi_range(lk)
            assert dense_gaps(lk, res.design, lo, hi, n=3000) >= r.min_distance - 1e-12
            full += r.range == "full"
    if kind == "bennett":
        assert full >= 0.75 * count


def test_sizing_rounds_start_from_the_last_design_and_skip_a_range_it_missed(fixture_bennett, monkeypatch):
    """`design_for`'s sizing rounds (synth.design.choose._sturdy) pass the last round's design as the start
    of the next search, and, when that one was free over the task range only, search the task range only:
    thicker bars are not freer (the full cycle the thinner ones missed is not searched again)."""
    import synth.design.choose as choose
    seen = []
    base = design_linkage(fixture_bennett, **{**sizes(fixture_bennett), "bar_radius": 0.008 * fixture_bennett.extent()})

    from synth.design.sturdy import written_slenderness
    thin = written_slenderness(fixture_bennett, base.design).length / (2 * 25 * 1.3)  # 1:32.5 as written

    def fake(linkage, pins, bar_radius, pin_length, hole_clearance, clearance, thin_, work, slenderness, search):
        seen.append((bar_radius, search))
        design = dataclasses.replace(base.design, bar_radius=bar_radius or thin)
        return dataclasses.replace(base, design=design, collision=dataclasses.replace(base.collision, range="task"))

    monkeypatch.setattr(choose, "_design_for", fake)
    monkeypatch.setattr(choose, "place_mounting", lambda linkage, result, **k: result)
    choose.design_for(fixture_bennett, pin_radius=sizes(fixture_bennett)["pin_radius"])
    assert len(seen) >= 2 and "start" not in seen[0][1] and "ranges" not in seen[0][1]
    warm = 0
    for (r0, _), (r1, s1) in zip(seen, seen[1:]):
        last = r0 or thin
        if 1 / choose.WARM_RATIO <= r1 / last <= choose.WARM_RATIO:
            assert s1["ranges"] == ("task",) and s1["start"].design.bar_radius == last
            warm += 1
        else:  # a much thicker bar: searched from scratch
            assert "start" not in s1 and "ranges" not in s1
    assert warm, [r for r, _ in seen]
