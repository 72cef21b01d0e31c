"""Full cycle first (issue 33, docs/design.md "Full cycle first"): with the sturdy parts (bars at most 1:25,
1.2 mm bore walls, pins with heads) the shipped fixtures that had fallen back to their task range are
collision-free over the whole cycle again, and the independent verifier's full-turn sweep of the written
meshes agrees (`--collision-range full`)."""
from __future__ import annotations

import json

import pytest

from synth.design.choose import default_sizes, design_for
from synth.design.search import MORE_WORK, design_linkage, resolved_sizes
from synth.design.sturdy import SLENDERNESS, slenderness_of
from synth.design.work import Work
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett

from conftest import REPO, run, run_verifier

THIN = REPO / "tests" / "data" / "bennett_thin.yaml"  # bench seed 22: h2 and k1 nearly on one line


def _bennett(path):
    ps = load_poses(str(path), count=3)
    return bennett(ps.matrices, ps.names)


@pytest.mark.parametrize("kind, fixture", [("bennett", "bennett_matrix.json"), ("sixbar", "sixbar_hermite.yaml")])
def test_fixture_is_free_over_the_full_cycle_and_the_verifier_agrees(kind, fixture, tmp_path):
    """bennett_matrix (a later set of starts of the straight search) and sixbar_hermite (cranked bars over the
    full cycle) claimed their task range only before; now the full cycle, certified, at 1:25."""
    import yourdfpy

    task, out = REPO / "fixtures" / fixture, tmp_path / "o"
    r = run(kind, task, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "linkage.json").read_text())
    col = doc["collision"]
    assert col["free"] and col["certified"] and col["range"] == "full"
    assert col["min_distance"] >= col["clearance"] > 0
    urdf = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False, build_collision_scene_graph=False)
    assert {b["link"] for b in doc["design"]["bars"]} <= set(urdf.link_map)
    judged = run_verifier(task, out, "--collisions", "0", "--collision-range", "full", timeout=900)
    if judged is not None:  # (a plain copy of the repository has no shared verifier: the claims above stand)
        last = judged.stdout.strip().splitlines()[-1] if judged.stdout.strip() else ""
        assert judged.returncode == 0 and last.startswith("verify OK") and "range=full" in last, judged.stdout[-2000:]


def test_later_sets_of_starts_find_what_the_first_two_miss(monkeypatch):
    """Bench seed 22 (tests/data/bennett_thin.yaml) at the default sizes: the first two sets of starts (all
    the search tried before) end colliding (measured: -48.5 mm); the later ones, within `MORE_WORK`, find a
    certified full-cycle design (14.9 mm). The same input gives the same design (counted work). (Until the
    stacks of links that share a joint, issue 33, bennett_matrix.json was such a case: -25.6 mm.)"""
    from synth.design import search

    lk = _bennett(THIN)
    pin, bar, hub = default_sizes(lk)
    sizes = dict(pin_radius=pin, bar_radius=bar, hub_length=hub)
    spent = Work()
    more = design_linkage(lk, **sizes, ranges=("full",), work=spent)
    assert more.collision.free and more.collision.range == "full" and more.collision.certified
    assert more.collision.min_distance >= resolved_sizes(**sizes)["clearance"]
    assert spent.done < MORE_WORK + 2e6
    again = design_linkage(lk, **sizes, ranges=("full",))
    assert again.design.to_dict() == more.design.to_dict()
    monkeypatch.setattr(search, "MORE_WORK", 0.0)  # the first two sets of starts only
    few = design_linkage(lk, **sizes, ranges=("full",))
    assert not few.collision.free and few.collision.min_distance < 0


def test_nearly_coincident_axes_are_free_over_the_full_cycle_at_1_to_25():
    """Bench seed 22 (tests/data/bennett_thin.yaml): the axes of h2 and k1 within 5 mm and 0.4 degrees of
    each other over a 2 m linkage. The last session found it free over its task range only at 1:25 (and
    only with bars thinner than 1:60 over the full cycle); the later sets of starts find a full-cycle design
    with the 1:25 bars, not thinned."""
    lk = _bennett(THIN)
    r = design_for(lk)
    assert r.collision.free and r.collision.range == "full" and r.collision.thinned is None
    assert slenderness_of(lk, r.design.bar_radius) <= SLENDERNESS + 1e-9
