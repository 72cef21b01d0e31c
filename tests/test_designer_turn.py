"""mpsynth design, second pass (#34): a pose turned about the view axis and written in its own
orientation form, the kinds that cannot apply and why, the picked candidate written and coloured by its
clearance."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from synth.algebra.geometry import rotation_about_axis
from synth.design.model import CollisionReport
from synth.errors import InputError
from synth.io.poses import parse_pose_document
from synth.tools.designer import document
from synth.tools.designer.scene import clearances
from synth.tools.designer.session import Session
from synth.tools.designer.synth_view import Kind, kind_problems

ROOT = Path(__file__).resolve().parents[1]
BENNETT = ROOT / "fixtures" / "bennett_mm_deg.yaml"


def copied(tmp_path, name):
    p = tmp_path / name
    shutil.copy(ROOT / "fixtures" / name, p)
    return p


def test_turning_a_pose_about_z_adds_to_its_yaw_and_undo_takes_it_back(tmp_path):
    s = Session(copied(tmp_path, "bennett_mm_deg.yaml"), background_design=False)
    before = s.synthesis.ps.matrices[0].copy()
    st_ = s.turn(0, [0, 0, 2], 10)  # pose "pick": rpy [0, 0, 0] -> yaw 10 degrees (the axis is normalized)
    assert s.doc["poses"][0]["rpy"] == [0, 0, 10]
    assert s.doc["poses"][0]["position"] == [0, 0, 200]
    assert st_["problem"] is None and st_["undo"] == 1
    R = s.synthesis.ps.matrices[0][:3, :3]
    assert np.allclose(R, [[math.cos(math.radians(10)), -math.sin(math.radians(10)), 0],
                           [math.sin(math.radians(10)), math.cos(math.radians(10)), 0], [0, 0, 1]], atol=1e-12)
    s.undo()
    assert np.array_equal(s.synthesis.ps.matrices[0], before)


def test_turning_a_quaternion_pose_keeps_the_mapping_form(tmp_path):
    s = Session(copied(tmp_path, "bennett_quat.yaml"), background_design=False)
    R0 = s.synthesis.ps.matrices[1][:3, :3].copy()
    s.turn(1, [1, 0, 0], -30)
    q = s.doc["poses"][1]["quaternion"]
    assert isinstance(q, dict) and set(q) == {"w", "x", "y", "z"}
    want = rotation_about_axis(np.array([1.0, 0, 0]), math.radians(-30)) @ R0
    assert np.allclose(s.synthesis.ps.matrices[1][:3, :3], want, atol=1e-8)


def test_a_turn_that_cannot_apply_is_an_input_error(tmp_path):
    s = Session(copied(tmp_path, "bennett_points.yaml"), background_design=False)
    with pytest.raises(InputError, match="not a pose"):
        s.turn(0, [0, 0, 1], 5)
    s = Session(copied(tmp_path, "bennett_mm_deg.yaml"), background_design=False)
    with pytest.raises(InputError, match="axis of three finite numbers"):
        s.turn(0, [0, 0, 0], 5)


FORMS = {"rpy": [0, 0, 0], "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "axis_angle": {"axis": [0, 0, 1], "angle": 0},
         "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}


@settings(max_examples=40, deadline=None)
@given(q=st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda v: np.linalg.norm(v) > 0.1),
       form=st.sampled_from(sorted(FORMS) + ["list"]), deg=st.booleans())
def test_orientation_leaves_read_back_as_the_rotation(q, form, deg):
    from synth.algebra.dq import quat_to_matrix

    R = quat_to_matrix(np.array(q) / np.linalg.norm(q))
    key = "quaternion" if form == "list" else form
    doc = {"units": {"length": "m", "angle": "deg" if deg else "rad"},
           "poses": [{"position": [0, 0, 0], key: [1, 0, 0, 0] if form == "list" else FORMS[form]}]}
    if form == "list":
        doc["quaternion_order"] = "wxyz"
    for path, value in document.orientation_leaves(doc, 0, R, "deg" if deg else None):
        doc = document.with_value(doc, path, value)
    ps = parse_pose_document(doc, source="t.yaml", count=((1, None), "test"))
    assert np.allclose(ps.matrices[0][:3, :3], R, atol=1e-9)


def test_kinds_that_cannot_apply_say_why():
    from synth.io.docload import read_source

    for name, fourbar in (("bennett_mm_deg.yaml", "coplanar"), ("bennett_points.yaml", "needs poses"),
                          ("bennett_planar.yaml", None)):
        source, text = read_source(str(ROOT / "fixtures" / name), None)
        got = kind_problems(document.parse(text, source), source)
        assert got[Kind.BENNETT] is None
        assert (got[Kind.FOURBAR] is None) if fourbar is None else (fourbar in got[Kind.FOURBAR])


def test_clearances_name_the_closest_gap_of_each_body():
    rep = CollisionReport(free=False, range="task", clearance=0.002, min_distance=-0.001, driver="h1",
                          driver_range=(0.0, 1.0), pairs=[{"bodies": ["a", "b"], "min_distance": -0.001},
                                                          {"bodies": ["b", "c"], "min_distance": 0.0015}])
    c = clearances(None, rep, 0.001)  # task unit: mm
    assert c["free"] is False and c["clearance"] == pytest.approx(2.0)
    assert c["bodies"] == pytest.approx({"a": -1.0, "b": -1.0, "c": 1.5})


def test_the_picked_candidate_is_designed_coloured_and_written(tmp_path):
    """The design behind is candidate 4's of fixtures/sixbar_example.yaml, its clearance report agrees with
    its verdict, and "write output" writes that candidate (as --top 5 writes its 04-f2-p9/; measured
    identical linkage.json)."""
    s = Session(copied(tmp_path, "sixbar_example.yaml"))
    st_ = s.set_pick(3)
    assert st_["written"] == "candidate 4 of 5 (04-f2-p9)"
    assert s.job.wait(300)
    bg = s.state()["background"]
    assert bg["stage"] == "done"
    gaps = bg["clearance"]["bodies"]
    assert bg["free"] == all(g >= bg["clearance"]["clearance"] for g in gaps.values())
    res = s.write_output(tmp_path / "out")
    assert res["written"] == "candidate 4 of 5 (04-f2-p9)"
    assert res["design"].startswith("NOT collision-free") == (not bg["free"])
    written = json.loads((tmp_path / "out" / "linkage.json").read_text())
    want = s.synthesis.linkages[3]
    got = np.array([j["line"]["direction"] for j in written["joints"]], float)
    assert np.allclose(got, [j.direction for j in want.joints], atol=1e-9)
    assert not np.allclose(got, [j.direction for j in s.synthesis.linkages[0].joints], atol=1e-3)
    s.close()
