"""Cranked bars (docs/design.md): where two straight bars must cross, `crank_bars` bends them past each
other along the axes, certified, with closed solids, and the independent verifier agrees."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from synth.design.cranks import crank_bars, crank_direction
from synth.design.model import CollisionReport, DesignResult, pins_for
from synth.design.search import Layout, stack_gap
from synth.design.choose import design_for
from synth.io.meshes import design_solids
from synth.io.poses import load_poses
from synth.io.writer import write_output
from synth.synthesis.bennett import bennett

from conftest import REPO, assert_verified

PLANAR = REPO / "fixtures" / "bennett_planar.yaml"  # a planar four-bar: every axis along z


def test_crank_direction_worked_numbers():
    assert crank_direction(np.array([0.0, 0, 1]), np.array([2.0, 0, 0])) == pytest.approx([0, 0, 1])
    # the axis leans along the bar: only its part normal to the bar is kept
    n = crank_direction(np.array([1.0, 0, 1]) / math.sqrt(2), np.array([3.0, 0, 0]))
    assert n == pytest.approx([0, 0, 1])
    n = crank_direction(np.array([1.0, 0, 0]), np.array([1.0, 0, 0]))  # axis along the bar: any normal
    assert abs(np.dot(n, [1, 0, 0])) < 1e-12 and np.linalg.norm(n) == pytest.approx(1)


HALF = {("base", "h1"): -1, ("link_h1", "h1"): 1, ("link_h1", "h2"): 1, ("coupler", "h2"): -1,
        ("base", "k1"): 1, ("link_k1", "k1"): -1, ("link_k1", "k2"): -1, ("coupler", "k2"): 1}


@pytest.fixture(scope="module")
def flat():
    """The planar four-bar with the two cranks in two planes, link_h1 half a stack (`stack_gap`) above the
    plane of the sites and link_k1 half a stack below it (base and coupler across): the straight bar of
    each crank runs through the other's hubs during the motion, whatever else is done; the cranked design."""
    ps = load_poses(str(PLANAR))
    lk = bennett(ps.matrices, ps.names)
    design = design_for(lk).design
    g = stack_gap(design.bar_radius, design.hub_radius, design.hub_length, design.clearance)
    for m in design.mounts:
        m.offset = HALF[(m.link, m.joint)] * g / 2
    design.pins = pins_for(lk, design)
    report = CollisionReport(free=False, range="full", clearance=design.clearance, min_distance=-1.0, driver="h1",
                             driver_range=(0.0, 2 * math.pi), pairs=[{"bodies": ["link_h1", "link_k1"]}])
    return lk, design, crank_bars(lk, DesignResult(design, report))


def gaps(lk, design, cranked, n=3000):
    """Smallest gap of the exact capsules at n phi evenly over the cycle (not the search's samples)."""
    from synth.design.collision import pair_distances, world_ends
    from synth.design.sampling import body_motion

    cranks = {(b.link, *b.joints): (b.via[0], b.via[1], np.zeros(3)) for b in design.bars if b.via} if cranked else {}
    lay = Layout(lk, merged=False, pin_radius=design.pin_radius, bar_radius=design.bar_radius,
                 hub_radius=design.hub_radius, hub_length=design.hub_length, clearance=design.clearance, cranks=cranks)
    S = np.array([design.mount(link, j).offset for link, j in lay.mounts])
    Q, U = world_ends(lay.cs, body_motion(lk, np.linspace(-math.pi / 2, math.pi / 2, n)))
    return pair_distances(lay.cs, Q, U, lay.end_offsets(S[None]))[0].min()


def test_straight_bars_in_one_plane_collide_and_cranks_free_them(flat):
    lk, straight, result = flat
    assert gaps(lk, straight, False) < -straight.bar_radius  # the bar centre lines cross
    r = result.collision
    assert r.free and r.certified and r.range == "full", r.message
    assert sorted(map(tuple, r.cranked)) == [("link_h1", "h1", "h2"), ("link_k1", "k1", "k2")]
    bars = {b.link: b for b in result.design.bars}
    assert len(bars["link_h1"].via) == 2 and len(bars["link_k1"].via) == 2 and not bars["base"].via
    # mounts and pins are kept; the via points leave the plane of the mounts (a z = const plane)
    assert [(m.link, m.joint, m.offset) for m in result.design.mounts] == [(m.link, m.joint, m.offset)
                                                                          for m in straight.mounts]
    z0 = lk.joint_sites()["h1"][2] + straight.mount("link_h1", "h1").offset * lk.joint("h1").direction[2]
    assert max(abs(v[2] - z0) for v in bars["link_h1"].via) > result.design.bar_radius
    assert gaps(lk, result.design, True) >= r.min_distance - 1e-12 >= r.clearance - 1e-12


def test_cranked_links_are_closed_solids_and_the_verifier_agrees(flat, tmp_path):
    lk, _, result = flat
    solids = design_solids(lk, result.design)  # raises unless every link and pin is one closed solid
    assert {"link_h1", "link_k1"} <= set(solids)
    out = tmp_path / "out"
    write_output(lk, out, robot_name="flat", result=result)
    c = json.loads((out / "linkage.json").read_text())["collision"]
    assert c["free"] and c["cranked"]
    assert json.loads((out / "linkage.json").read_text())["design"]["bars"][1]["via"]
    assert_verified(PLANAR, out, "--steps", "90", "--collisions", repr(c["clearance"]), "--collision-range", "full")


def test_a_free_design_is_left_alone(flat):
    lk, design, _ = flat
    free = DesignResult(design, CollisionReport(free=True, range="full", clearance=design.clearance,
                                                min_distance=1.0, driver="h1", driver_range=(0.0, 2 * math.pi)))
    assert crank_bars(lk, free) is free
