"""Thinning (docs/design.md): when no collision-free design exists at the default bar and pin radii, the
default output uses thinner ones and says so; explicit radii are never changed."""
from __future__ import annotations

import importlib.util
import json
import re

import pytest

from synth.design.choose import (THIN_MIN_BAR_RADIUS, THIN_SCALES, default_hole_clearance, default_sizes, design_for,
                                 thin_scales)
from synth.design.sturdy import SLENDERNESS, slenderness_of
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett

from conftest import REPO, run, run_verifier

THIN = REPO / "tests" / "data" / "bennett_thin.yaml"  # bench seed 22: collides at the default radii


@pytest.fixture(scope="module")
def linkage():
    ps = load_poses(str(THIN))
    return bennett(ps.matrices, ps.names)


def test_thin_scales_halve_then_quarter_above_the_floor():
    assert thin_scales(0.03) == list(THIN_SCALES) == [0.5, 0.25]
    # a small linkage: the quarter would make bars thinner than the floor, so it is raised to the floor
    s = thin_scales(4 * THIN_MIN_BAR_RADIUS / 3)
    assert s == [0.75]
    assert thin_scales(THIN_MIN_BAR_RADIUS) == []  # already at the floor: nothing thinner is tried
    assert thin_scales(THIN_MIN_BAR_RADIUS / 2) == []  # below it (a tiny linkage): never thinned


def test_explicit_radii_are_kept_and_the_message_says_what_to_change(linkage, first_sets_only):
    """Seed 22 over the full cycle with the first two sets of starts: no design at the default radii (over
    its task range it has one since the stacks of links that share a joint, issue 33)."""
    pin, bar, _ = default_sizes(linkage)
    r = design_for(linkage, link_radius=bar, ranges=("full",))
    assert not r.collision.free and r.collision.thinned is None
    assert r.design.bar_radius == bar and r.design.pin_radius == pin
    assert "--link-radius" in r.collision.message
    assert "thinned" not in r.collision.to_dict()


def test_a_full_cycle_only_search_is_not_thinned(linkage):
    """rank_buildable's quick full-cycle pass: its failure is no reason to thin (the task range may work)."""
    r = design_for(linkage, ranges=("full",), full_work=3e6)
    assert r.collision.thinned is None
    assert r.design.bar_radius >= default_sizes(linkage)[1]  # (raised when the written bars are too slender)


def test_slender_defaults_thin_the_bars(linkage, first_sets_only):
    """With bars as slender as before issue 33 (no slenderness limit), seed 22 collides at the default
    radii and the design thins them."""
    r = design_for(linkage, slenderness=1e9)
    col, des = r.collision, r.design
    thin = col.thinned
    assert col.free and thin is not None and thin["scale"] in THIN_SCALES
    assert des.bar_radius == pytest.approx(thin["bar_radius"]) == pytest.approx(thin["scale"] * thin["default_bar_radius"])
    assert des.pin_radius == pytest.approx(thin["scale"] * thin["default_pin_radius"])
    assert des.hole_clearance == pytest.approx(default_hole_clearance(des.pin_radius))  # the rule, kept
    assert des.clearance == pytest.approx(0.25 * des.bar_radius)
    assert thin["default_pairs"]


def test_default_output_is_sturdy_free_and_the_verifier_agrees(tmp_path):
    """Issue 33: the bars of the default output are at most 1:25 slender (here no thinning is needed);
    the shared verifier checks the claim when it is beside the repository (and fcl is installed)."""
    out = tmp_path / "o"
    r = run("bennett", THIN, "-o", out)
    assert r.exit_code == 0, r.output
    line = next(x for x in r.output.splitlines() if "design:" in x)
    assert line.strip().startswith("design: collision-free"), line
    doc = json.loads((out / "linkage.json").read_text())
    col, des = doc["collision"], doc["design"]
    assert col["free"]
    ps = load_poses(str(THIN))
    assert slenderness_of(bennett(ps.matrices, ps.names), des["bar_radius"]) <= SLENDERNESS + 1e-9
    if importlib.util.find_spec("fcl") is None:
        return
    p = run_verifier(THIN, out, "--collisions", repr(col["clearance"]), "--collision-range", col["range"])
    if p is None:
        return
    last = (p.stdout + p.stderr).strip().splitlines()[-1]
    assert p.returncode == 0, last
    m = re.search(r"collision_min=(\S+)m", last)
    assert m and float(m.group(1)) >= col["min_distance"] - 1e-9, last
