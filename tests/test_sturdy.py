"""Parts sized to be built (issue 33): bar slenderness and bore walls, worked numbers."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from synth.design.choose import LINK_RADIUS, default_sizes, design_for
from synth.design.model import MIN_WALL, hub_radius_for
from synth.design.sturdy import SLENDERNESS, bar_lengths, bar_radius_for, slenderness_of
from synth.errors import InputError
from synth.synthesis.bennett import bennett

from test_design_thin import THIN, linkage  # noqa: F401  (the module fixture)


def test_hub_wall_is_at_least_1_2_mm_for_printable_pins():
    # pin 3 mm, clearance 0.2 mm: half a pin radius (1.5 mm) is over the 1.2 mm minimum
    assert hub_radius_for(3e-3, 1e-3, 2e-4) == pytest.approx(3e-3 + 2e-4 + 1.5e-3)
    # pin 1 mm: half a radius (0.5 mm) is too thin, the wall is 1.2 mm
    assert hub_radius_for(1e-3, 1e-4, 1e-4) == pytest.approx(1e-3 + 1e-4 + MIN_WALL)
    # a 0.1 mm pin (a linkage too small to print): the wall is at most the pin's diameter
    assert hub_radius_for(1e-4, 1e-5, 0.0) == pytest.approx(1e-4 + 2e-4)


def test_bar_radius_follows_the_longest_bar(linkage):  # noqa: F811
    lengths = bar_lengths(linkage)
    assert lengths.shape == (4,) and np.all(lengths > 0)  # Bennett: four links, one bar each
    r = bar_radius_for(linkage, 0.0)
    assert r == pytest.approx(lengths.max() / 50)
    assert slenderness_of(linkage, r) == pytest.approx(SLENDERNESS)
    assert bar_radius_for(linkage, 10 * r) == 10 * r  # a thicker bar is kept
    assert bar_radius_for(linkage, 0.0, 10.0) == pytest.approx(lengths.max() / 20)


def test_default_sizes_respect_the_slenderness(linkage):  # noqa: F811
    bar = default_sizes(linkage)[1]
    assert bar == pytest.approx(max(LINK_RADIUS * linkage.extent(), bar_lengths(linkage).max() / 50))
    assert slenderness_of(linkage, bar) <= SLENDERNESS + 1e-9
    assert default_sizes(linkage, link_radius=1e-3)[1] == 1e-3  # explicit radii are kept
    with pytest.raises(InputError, match="slenderness"):
        design_for(linkage, slenderness=-1.0)
    with pytest.raises(InputError, match="slenderness"):
        design_for(linkage, slenderness=math.nan)


class _Axes:
    """Two parallel joint axes along z through (0, 0, 0) and (3, 0, 0): enough of a linkage for the bars."""

    class _Joint:
        direction = np.array([0.0, 0.0, 1.0])

    def joint_sites(self):
        return {"a": np.zeros(3), "b": np.array([3.0, 0.0, 0.0])}

    def joint(self, name):
        return self._Joint()


def _design(via, radius=0.1):
    from synth.design.model import Bar, Mount, PhysicalDesign

    return PhysicalDesign(pin_radius=0.05, bar_radius=radius, hub_radius=0.2, hub_length=0.1, hole_clearance=0.0,
                          clearance=0.0, mounts=[Mount("L", "a", 1.0), Mount("L", "b", -1.0)],
                          bars=[Bar("L", ("a", "b"), via)], pins=[])


def test_written_bar_length_runs_mount_to_mount_through_the_cranks():
    from synth.design.sturdy import written_bar_lengths, written_slenderness

    # mounts at (0, 0, 1) and (3, 0, -1): straight, sqrt(9 + 4); the joint sites are 3 apart
    straight = _design([])
    assert written_bar_lengths(_Axes(), straight) == pytest.approx([math.sqrt(13.0)])
    # cranked through (1.5, 4, 0): two legs of sqrt(1.5^2 + 4^2 + 1^2) each
    cranked = _design([np.array([1.5, 4.0, 0.0])])
    assert written_bar_lengths(_Axes(), cranked) == pytest.approx([2 * math.sqrt(19.25)])
    s = written_slenderness(_Axes(), cranked)  # 8.775 m over a 0.2 m diameter: 1:43.9, over 1:25
    assert s.ratio == pytest.approx(2 * math.sqrt(19.25) / 0.2) and not s.met
    assert (s.link, s.joints) == ("L", ("a", "b"))
    assert s.sturdier == pytest.approx(2 * math.sqrt(19.25) / 50)  # the radius that would meet 1:25
    d = s.to_dict()
    assert d["met"] is False and d["radius_needed"] == pytest.approx(s.sturdier) and d["limit"] == 25.0
    assert "1:43.9, over the 1:25 limit: a bar radius of 0.175 m would meet it" in s.sentence()
    assert written_slenderness(_Axes(), _design([], radius=0.08)).met  # sqrt(13) / 0.16 = 22.5
    assert "within the 1:25 limit" in written_slenderness(_Axes(), _design([], radius=0.08)).sentence(1e-3, "mm")


def test_next_radius_aims_at_the_fixed_point_of_the_written_length():
    from synth.design.sturdy import next_radius

    # one round: 2.6 m over 50 (1:25), 1 % thicker
    assert next_radius([(0.05, 2.6)]) == pytest.approx(2.6 / 50 * 1.01)
    # two rounds, L(r) = 1.5 + 30 r through (0.04, 2.7), (0.05, 3.0): r = L(r) / 50 at r = 1.5 / 20 = 0.075
    # (L = 3.75; the plain ratio would give 3.0 / 50 = 0.06), 3 % thicker (the second round's margin)
    assert next_radius([(0.04, 2.7), (0.05, 3.0)]) == pytest.approx(0.075 * 1.03)
    # L growing faster than 50 r (k = 60): no fixed point, the plain ratio, 9 % thicker (third round)
    assert next_radius([(0.03, 2.0), (0.04, 2.6), (0.05, 3.2)]) == pytest.approx(0.064 * 1.09)
    assert next_radius([(0.1, 1.0)]) == 0.1  # never thinner than the last round


@pytest.mark.parametrize("kind, fixture", [("bennett", "bennett_mm_deg.yaml"), ("sixbar", "sixbar_hermite.yaml")])
def test_shipped_fixtures_have_no_written_bar_more_slender_than_1_to_25(kind, fixture, tmp_path):
    """The bars as written in linkage.json (mount -> crank points -> mount, computed here from the design
    section) are at most 25 diameters long, and linkage.json says so (main before this rule: bennett_mm_deg
    1:25.3, sixbar_hermite 1:146)."""
    import yourdfpy

    from conftest import REPO, run
    from synth.io.linkagedoc import linkage_from_document

    out = tmp_path / "o"
    r = run(kind, REPO / "fixtures" / fixture, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "linkage.json").read_text())
    lk = linkage_from_document(doc)
    des, sites = doc["design"], lk.joint_sites()
    mounts = {(m["link"], m["joint"]): m["offset"] for m in des["mounts"]}
    worst = 0.0
    for b in des["bars"]:
        pts = [sites[j] + mounts[(b["link"], j)] * lk.joint(j).direction for j in b["joints"]]
        pts[1:1] = [np.asarray(v, float) for v in b["via"]]
        length = sum(float(np.linalg.norm(q - p)) for p, q in zip(pts, pts[1:]))
        worst = max(worst, length / (2 * des["bar_radius"]))
    assert worst <= SLENDERNESS * (1 + 1e-9)
    assert des["slenderness"]["met"] and des["slenderness"]["ratio"] == pytest.approx(worst)
    assert doc["collision"]["free"]
    urdf = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False, build_collision_scene_graph=False)
    assert {b["link"] for b in des["bars"]} <= set(urdf.link_map)


def test_a_given_link_radius_is_kept_and_its_written_slenderness_reported(tmp_path):
    """--link-radius stays as given; linkage.json and the summary state how slender its bars are as written."""
    from conftest import REPO, run

    out = tmp_path / "o"
    r = run("bennett", REPO / "fixtures" / "bennett_mm_deg.yaml", "-o", out, "--link-radius", "2")
    assert r.exit_code == 0, r.output
    s = json.loads((out / "linkage.json").read_text())["design"]["slenderness"]
    assert s["given"] and not s["met"] and s["radius"] == pytest.approx(2e-3)
    assert s["ratio"] == pytest.approx(s["length"] / 4e-3) and s["ratio"] > 75  # a 390 mm bar, 4 mm thick
    assert s["radius_needed"] == pytest.approx(s["length"] / 50)
    line = next(x for x in r.stderr.splitlines() if x.startswith("  bars: "))
    assert f"is 1:{s['ratio']:.1f}, over the 1:25 limit" in line and line.endswith("(the bar radius was given)")
