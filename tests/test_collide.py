"""`mpsynth collide`: self-collision of non-adjacent links along the motion (python-fcl via trimesh)."""
from __future__ import annotations

import json
import math
import re
import shutil

import numpy as np
import pytest

from synth.synthesis.bennett import bennett
from synth.tools.collide import cyclic_runs, candidate_pairs
from synth.io.writer import write_output
from synth.io.poses import load_poses
from synth.io.readback import read_output

from conftest import REPO, run


def needs_fcl():
    pytest.importorskip("fcl", reason="python-fcl is not installed (pip install 'mpsynth[collide]')")


@pytest.fixture(scope="module")
def quat_linkage():
    ps = load_poses(str(REPO / "fixtures" / "bennett_quat.yaml"))
    return bennett(ps.matrices, ps.names)


def straight(linkage, **sizes):
    """The straight design (mounts at the feet of the common normals) with the default sizes: these
    tests are about the collision tool, not about what the design search finds."""
    from synth.design.model import straight_design
    from synth.design.model import CollisionReport, DesignResult
    from synth.design.choose import default_hole_clearance, default_sizes

    pin_radius, bar_radius, hub_length = default_sizes(linkage, **sizes)
    design = straight_design(linkage, pin_radius=pin_radius, bar_radius=bar_radius, hub_length=hub_length,
                             hole_clearance=default_hole_clearance(pin_radius))
    return DesignResult(design, CollisionReport(False, "full", 0.0, float("nan"), linkage.joints[0].name,
                                                (0.0, 2 * math.pi), message="not searched"))


@pytest.fixture(scope="module")
def out_quat(tmp_path_factory, quat_linkage):
    out = tmp_path_factory.mktemp("collide") / "bennett_quat"
    write_output(quat_linkage, out, robot_name="bennett_quat", result=straight(quat_linkage))
    return out


def test_pairs_checked_and_excluded(out_quat):
    test, skip = candidate_pairs(read_output(out_quat))
    assert sorted(map(sorted, test)) == [["base", "coupler"], ["link_h1", "link_k1"]]
    assert len(skip) == 4  # the four joints; coupler_k has no mesh


def test_runs_are_cyclic():
    h = np.array([1, 1, 0, 0, 1, 0, 1, 1], bool)
    assert cyclic_runs(h) == [(4, 4), (6, 1)]  # the last run wraps around through the end
    assert cyclic_runs(np.ones(5, bool)) == [(0, 4)] and cyclic_runs(np.zeros(5, bool)) == []


def test_fixture_bennett_collides_where_it_folds(out_quat):
    """The worked example's Bennett linkage (MATH.md 11 D) with the straight design: base and coupler
    pass through each other twice per cycle (the loop folds nearly flat); the two side links keep a
    clearance of a few mm (pins included: they belong to their carrier links)."""
    needs_fcl()
    r = run("collide", out_quat, "--steps", 180, "--json")
    assert r.exit_code == 1, r.output
    rep = json.loads(r.stdout)
    assert rep["colliding"] and rep["steps"] == 180
    assert [c["links"] for c in rep["collisions"]] == [["base", "coupler"]]
    ranges = rep["collisions"][0]["ranges"]
    assert len(ranges) == 2
    (a0, a1), (b0, b1) = [(x["t_start"], x["t_end"]) for x in ranges]
    assert 0.05 < a0 < a1 < 0.3 and 1.5 < b0 < b1 < 8
    # the range ends are refined: just outside them the pair is free, just inside it collides
    rb = read_output(out_quat)
    from synth.tools.collide import PairTester

    tester = PairTester(rb, "base", "coupler")
    for lo, hi in ((a0, a1), (b0, b1)):
        pl, ph = math.atan(lo), math.atan(hi)
        assert tester.hit(math.tan(pl + 1e-5)) and tester.hit(math.tan(ph - 1e-5))
        assert not tester.hit(math.tan(pl - 1e-4)) and not tester.hit(math.tan(ph + 1e-4))
    (clear,) = rep["clearance"]
    assert clear["links"] == ["link_h1", "link_k1"] and 0.001 < clear["min_distance"] < 0.03
    assert "COLLIDE base <-> coupler" in r.stderr and "clearance" in r.stderr
    # #35: positions as the driver's angle in degrees, each range in the direction the driver turns: the
    # driver meets the start first, the middle of the range collides, just before the start it is free
    from synth.algebra.anglelaw import angle_law_inverse

    d = rb.linkage.joint(rep["driver"])
    for x in ranges:
        s, e = x["driver_start_deg"], x["driver_end_deg"]
        assert 0 <= s < 360 and s < e < s + 180
        t_of = lambda deg: float(angle_law_inverse(d.a, d.b, math.radians(deg)))  # noqa: E731
        assert tester.hit(t_of((s + e) / 2)) and not tester.hit(t_of(s - 1.0)) and not tester.hit(t_of(e + 1.0))
        assert f"{rep['driver']} from {s:.2f} to {e:.2f} deg" in r.stderr
    assert rep["range"] == "full"  # what this linkage.json claims (no claim: the full cycle)


def test_big_pins_collide_everywhere(tmp_path, quat_linkage):
    """Pins as thick as the linkage: every non-adjacent pair touches in every configuration."""
    needs_fcl()
    out = tmp_path / "fat"
    write_output(quat_linkage, out, robot_name="fat", result=straight(quat_linkage, pin_radius=0.3))
    r = run("collide", out, "--steps", 36, "--json")
    assert r.exit_code == 1
    rep = json.loads(r.stdout)
    assert sorted(c["links"] for c in rep["collisions"]) == [["base", "coupler"], ["link_h1", "link_k1"]]
    for c in rep["collisions"]:
        assert c["samples"] == 36 and c["ranges"] == [{"whole_cycle": True, "t_start": None, "t_end": None,
                                                        "samples": 36}]
    assert "over the whole cycle" in r.stderr


def test_no_collision_exits_0(tmp_path, out_quat):
    """An output whose coupler has no geometry: the only non-adjacent pair (the side links) is clear."""
    needs_fcl()
    out = tmp_path / "nocoupler"
    shutil.copytree(out_quat, out)
    urdf = (out / "linkage.urdf").read_text()
    urdf, n = re.subn(r'(<link name="coupler">.*?)<visual>.*?</collision>', r"\1", urdf, flags=re.S)
    assert n == 1
    (out / "linkage.urdf").write_text(urdf)
    r = run("collide", out, "--steps", 90, "--json")
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert not rep["colliding"] and rep["pairs_checked"] == [["link_h1", "link_k1"]]
    assert "ok      link_h1 <-> link_k1" in r.stderr


def test_missing_fcl_exits_2(out_quat, monkeypatch):
    import synth.tools.collide

    monkeypatch.setattr(synth.tools.collide, "fcl_available", lambda: False)
    r = run("collide", out_quat)
    assert r.exit_code == 2 and "pip install 'mpsynth[collide]'" in r.stderr


def test_collide_usage_errors(tmp_path, out_quat):
    r = run("collide", tmp_path / "missing")
    assert r.exit_code == 2 and "no such output directory" in r.stderr
    r = run("collide", out_quat, "--steps", 2)
    assert r.exit_code == 2 and "--steps" in r.stderr
