"""Layered designs of planar linkages (docs/design.md, "Layers"): bars on levels along the common axis,
stepping between levels where a sweep requires it, from a mixed-integer programme, certified; the
elliptic translation's 13-joint linkage, which straight bars cannot free, is free over the full cycle."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from synth.design.layers import layered_design, level_pitch, parallel_axis
from synth.design.model import CollisionReport, DesignResult
from synth.design.choose import design_for
from synth.io.meshes import design_solids
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett

from conftest import REPO, assert_verified, run

PLANAR = REPO / "fixtures" / "bennett_planar.yaml"


@pytest.fixture(scope="module")
def four_bar():
    ps = load_poses(str(PLANAR))
    return bennett(ps.matrices, ps.names)


def test_parallel_axis(four_bar):
    ps = load_poses(str(REPO / "fixtures" / "bennett_mm_deg.yaml"))
    spatial = bennett(ps.matrices, ps.names)
    u = parallel_axis(four_bar)
    assert u is not None and np.linalg.norm(u) == pytest.approx(1)
    assert all(abs(abs(j.direction @ u) - 1) < 1e-9 for j in four_bar.joints)
    assert parallel_axis(spatial) is None  # a spatial Bennett linkage


def test_level_pitch_keeps_hubs_stacked_and_bars_clear(four_bar):
    d = design_for(four_bar).design
    p = level_pitch(d)
    assert p >= d.hub_length + d.clearance  # two hubs on one axis, one level apart
    assert p >= d.hub_length / 2 + d.hub_radius + d.bar_radius + d.clearance  # a bar one level off a hub


def test_a_four_bar_in_layers_is_certified_free(four_bar, tmp_path):
    """Any design of the planar four-bar reported not free is replaced by a certified layering."""
    d = design_for(four_bar).design
    stuck = DesignResult(d, CollisionReport(free=False, range="full", clearance=d.clearance, min_distance=-1.0,
                                            driver="h1", driver_range=(0.0, 2 * math.pi),
                                            pairs=[{"bodies": ["link_h1", "link_k1"]}]))
    result = layered_design(four_bar, stuck)
    r = result.collision
    assert r.free and r.certified and r.range == "full" and r.layers >= 2
    u = parallel_axis(four_bar)
    sites = four_bar.joint_sites()
    heights = {(m.link, m.joint): (sites[m.joint] + m.offset * four_bar.joint(m.joint).direction) @ u
               for m in result.design.mounts}
    steps = np.diff(sorted(set(np.round(list(heights.values()), 12))))
    assert (steps >= level_pitch(d) - 1e-9).all()  # hubs on distinct levels, a pitch apart
    design_solids(four_bar, result.design)  # every link one closed solid (raises otherwise)
    from synth.io.writer import write_output

    out = tmp_path / "out"
    write_output(four_bar, out, robot_name="layers", result=result)
    c = json.loads((out / "linkage.json").read_text())["collision"]
    assert c["free"] and c["layers"] == r.layers
    assert_verified(PLANAR, out, "--steps", "90", "--collisions", repr(c["clearance"]), "--collision-range", "full")


@pytest.mark.slow
def test_elliptic_translation_is_free_over_the_full_cycle_and_the_verifier_agrees(tmp_path):
    out = tmp_path / "out"
    res = run("curve", REPO / "fixtures" / "motion_elliptic.yaml", "-o", out)
    assert res.exit_code == 0, res.output
    c = json.loads((out / "linkage.json").read_text())["collision"]
    assert c["free"] and c["certified"] and c["range"] == "full" and c["layers"] and c["cranked"]
    assert "collision-free over the full cycle" in res.output
    assert_verified(out, "--collisions", repr(c["clearance"]), "--collision-range", "full", timeout=900)


def test_a_layered_four_bar_keeps_links_that_share_a_joint_apart():
    """The layered four-bar's links that share a joint: the programme puts their bars on different levels
    where they meet (no step a neighbour must pass: no touches), the certificate tests their pairs (bar
    against bar, a leg against the other's hub), and their written solids do not overlap at the reference
    configuration (main before: the layering exempted them)."""
    from test_overlap import _world_solids

    from synth.design.collision import adjacent_pairs
    from synth.design.coordinate import FULL
    from synth.design.layers import layer_plan, stack_geometry
    from synth.design.search import Layout, sizes_of
    from synth.io.solid import intersection_volume

    lk = bennett(load_poses(str(PLANAR)).matrices)
    d = design_for(lk).design
    u = parallel_axis(lk)
    plan = layer_plan(lk, u, FULL, d.hub_radius + d.bar_radius + d.clearance, 20_000)
    assert plan is not None and plan.touches == ()
    stuck = DesignResult(d, CollisionReport(free=False, range="full", clearance=d.clearance, min_distance=-1.0,
                                            driver="h1", driver_range=(0.0, 2 * math.pi)))
    result = layered_design(lk, stuck)
    assert result.collision.free and result.collision.certified and result.collision.message == ""
    cranks = stack_geometry(lk, plan.levels, u, level_pitch(d), at=plan.at)[1]
    cs = Layout(lk, merged=False, cranks=cranks, **sizes_of(d)).cs  # the certificate's layout (adjacent pairs)
    tested = {frozenset(cs.body_pairs[b]) for b in set(cs.body_pair.tolist())}
    assert adjacent_pairs(lk) <= tested
    one = next(iter(adjacent_pairs(lk)))  # a touching pair (`Plan.touches`) left out, the others kept
    cs = Layout(lk, merged=False, cranks=cranks, **sizes_of(d), untested={one}).cs
    assert {frozenset(cs.body_pairs[b]) for b in set(cs.body_pair.tolist())} == tested - {one}
    links, _ = _world_solids(lk, result.design)
    for pair in adjacent_pairs(lk):
        a, b = sorted(pair)
        assert intersection_volume(links[a], links[b]) < 1e-12, (a, b)  # 1e-3 mm^3


@pytest.mark.slow
def test_curve_ellipse_layers_keep_links_that_share_a_joint_apart(tmp_path):
    """fixtures/curve_ellipse.yaml (a layered Darboux chain): before, its links that share a joint were not
    kept apart (link_a1 x link_k1 overlapped by 240,075 mm^3 at the reference configuration); now the
    programme keeps them apart but for the touches, the report says what was not certified, and the written
    solids of no two of them overlap there."""
    from test_overlap import _bench

    out = tmp_path / "out"
    res = run("curve", REPO / "fixtures" / "curve_ellipse.yaml", "-o", out)
    assert res.exit_code == 0, res.output
    c = json.loads((out / "linkage.json").read_text())["collision"]
    assert c["free"] and c["certified"] and c["layers"] and "share a joint" in c["message"]
    rows = _bench().overlaps(out)
    assert rows and max((v for kind, _, _, v in rows if kind != "press"), default=0.0) < 1.0, rows
    assert_verified(out, "--collisions", repr(c["clearance"]), "--collision-range", "full", timeout=900)
