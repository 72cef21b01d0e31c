"""Every part one body (issue 33, synth/design/seats.py): a bar thinner than the opening cut in the face it
leaves through gets a blind bore there, the pin's head goes on the other face.

tests/data/split_links.json holds the designs (mounts, bars, full-length pins, as the search left them) of
three shipped fixtures whose STL and STEP had a link in two pieces before the rule (2026-11-27: bennett_spherical's
coupler and link_h1, sixbar_spherical's link_h1 and link_h2, sixbar_hermite's link_h2)."""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO  # noqa: E402

from synth.design.model import PhysicalDesign  # noqa: E402
from synth.design.model import CAP, pin_ends
from synth.design.seats import face_clear, seat_pins  # noqa: E402
from synth.io import meshes  # noqa: E402
from synth.io.linkagedoc import linkage_from_document  # noqa: E402
from synth.io.solid import boolean, shell_count, signed_volume  # noqa: E402

DATA = json.loads((REPO / "tests/data/split_links.json").read_text())


def _fixture(name, fit):
    doc = DATA[name]
    design = PhysicalDesign.from_dict({**doc["design"], "pin_fit": fit})
    return linkage_from_document(doc), dataclasses.replace(design, mounting=None)


def _pieces(lk, design) -> dict:
    return {n: shell_count(s.faces) for n, s in meshes.design_solids(lk, design).items()}


@pytest.mark.parametrize("name", sorted(DATA))
def test_the_search_left_a_link_in_pieces_and_the_seats_join_it(name):
    lk, design = _fixture(name, "press")
    before = _pieces(lk, design)
    assert max(before.values()) == 2  # what was written before the rule
    for fit in ("press", "clip", "plain"):
        seated = seat_pins(lk, dataclasses.replace(design, pin_fit=fit))
        assert set(_pieces(lk, seated).values()) == {1}, fit
        assert seat_pins(lk, seated).pins == seated.pins  # idempotent


def test_a_blind_bore_ends_past_the_shortened_pin_and_the_head_moves():
    """bennett_spherical's h1: link_h1 (turning) leaves through its outer face 8 degrees off the axis with
    a 1.95 mm bar in a 3.5 mm counterbore: its face closes, the pin ends a quarter hub length short of it,
    the press fit's head goes to the base's face (worked from the fixture's numbers)."""
    lk, design = _fixture("bennett_spherical", "press")
    seated = seat_pins(lk, design)
    full, pin = design.pin("h1"), seated.pin("h1")
    assert pin.length == pytest.approx(full.length - CAP * design.hub_length, abs=1e-12)
    ends = pin_ends(lk, seated, "h1")
    assert ends.blind == ("link_h1",) and ends.head_on == ends.carrier == "base"
    assert pin_ends(lk, design, "h1").head_on == "link_h1"  # full-length pins: the head where it was
    # the pin does not reach into the cap: it overlaps link_h1 by nothing (its bore has clearance)
    shaft = boolean([meshes.primitive_solid(p) for p in meshes.pin_primitives(lk, seated, "h1")])
    body = boolean(*meshes.link_parts(lk, seated, "link_h1"))
    both = boolean([shaft, body])
    overlap = signed_volume(shaft.triangles) + signed_volume(body.triangles) - signed_volume(both.triangles)
    assert abs(overlap) < 1e-3 * design.pin_radius ** 3


def test_full_length_pins_keep_their_meshes():
    """A design whose faces are all clear (the shipped Bennett's sizes) keeps every pin whole."""
    lk, design = _fixture("bennett_spherical", "press")
    big = dataclasses.replace(design, bar_radius=3 * design.hub_radius)
    assert seat_pins(lk, big).pins == big.pins


@settings(max_examples=60, deadline=None)
@given(angle=st.floats(0.0, 89.0), bar=st.floats(0.2, 3.0), sign=st.sampled_from([1.0, -1.0]))
def test_face_clear_is_the_margin_outside_the_opening(angle, bar, sign):
    """A bar leaving at ``angle`` degrees to the outward axis meets the face plane (L/2) tan(angle) from the
    axis: clear iff that plus its radius keeps min(r/2, 1.2 mm) outside the opening; inward: always."""
    lk, design = _fixture("bennett_spherical", "press")
    design = dataclasses.replace(design, bar_radius=bar * 1e-3)
    a = math.radians(angle)
    d = np.array([[math.sin(a), 0.0, sign * math.cos(a)]])
    opening = 3e-3
    e = 0.5 * design.hub_length * math.tan(a)
    want = sign < 0 or e + design.bar_radius >= opening + min(0.5 * design.bar_radius, 1.2e-3)
    assert face_clear(d, np.array([0.0, 0.0, 1.0]), design, opening) == want


def test_the_assembly_sheet_inserts_each_pin_from_its_head_side():
    """synth.tools.plates.assembly_steps: the pin enters at the face that takes its head and ends in the
    blind bore (bennett_spherical's h1 after the rule: from the base's face into link_h1)."""
    from synth.tools.plates import assembly_steps

    lk, design = _fixture("bennett_spherical", "press")
    steps = {s["joint"]: s for s in assembly_steps({"design": seat_pins(lk, design).to_dict()})}
    assert steps["h1"]["through"] == ["base", "link_h1"] and steps["h1"]["head"] == "base"
    assert steps["h1"]["blind"] == ["link_h1"]
    for s in steps.values():  # every head on the first link the pin goes through, never on a blind one
        assert s["head"] == s["through"][0] and s["head"] not in s["blind"]


def test_a_part_in_pieces_is_named_by_the_print_report_and_failed_by_check(tmp_path):
    """Two disjoint cylinders: the print report's part gets "bodies": 2 and a summary sentence, and
    `mpsynth check`'s mesh test fails the STL (`solid.shell_count`, trimesh's split agrees)."""
    import trimesh

    from synth.io.printreport import in_pieces, print_section
    from synth.io.solid import concatenate, cylinder, stl_bytes
    from synth.tools.check.meshes import MeshChecks

    one = cylinder([0, 0, 0], [0, 0, 0.01], 0.005, 16)
    two = concatenate([one, cylinder([0.02, 0, 0], [0.02, 0, 0.01], 0.005, 16)])
    assert shell_count(one.faces) == 1 and shell_count(two.faces) == 2
    section = print_section({"link_a": two})
    assert section["parts"][0]["bodies"] == 2
    assert in_pieces(section) == ["meshes/link_a.stl is 2 separate bodies, not one part (a bore cuts a bar off its hub)"]
    path = tmp_path / "two.stl"
    path.write_bytes(stl_bytes(two.triangles))
    assert len(trimesh.load(path).split(only_watertight=False)) == 2
    assert MeshChecks._mesh_problem(None, trimesh, path, (1.0, 1.0, 1.0), 0.03) == "is 2 separate bodies, not one part"
