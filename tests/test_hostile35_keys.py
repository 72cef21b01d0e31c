"""Issue #35, the newer inputs: task files with tolerance / velocity / order / constraints keys
(docs/fit.md, docs/drive.md) and `mpsynth fourbar`'s options, with hostile values. Each must be a
one-line exit 2 that names the file (and the pose, for a pose's key) with nothing written."""
from __future__ import annotations

import pytest

from conftest import REPO, invoke

FIT = (REPO / "fixtures" / "bennett_fit.yaml").read_text()
MOUNT = (REPO / "fixtures" / "bennett_mount.yaml").read_text()
FOUR = (REPO / "fixtures" / "fourbar_5.yaml").read_text()
FOURFIT = (REPO / "fixtures" / "fourbar_fit.yaml").read_text()

TOL = "tolerance: {position: 1.0, angle: 0.5}"
LIFT = "  exact: true\n- name: lift"
BOX = "[[-50, -50, -100], [200, 200, 250]]"

# (command, fixture text, old, new, words the message must hold)
CASES = {
    "tolerance_nan": ("bennett", FIT, TOL, "tolerance: {position: .nan, angle: 0.5}", ["tolerance.position"]),
    "tolerance_1e400": ("bennett", FIT, TOL, "tolerance: {position: 1.0, angle: 1e400}", ["tolerance.angle"]),
    "tolerance_negative": ("bennett", FIT, TOL, "tolerance: {position: -1, angle: 0.5}", ["negative"]),
    "tolerance_text": ("bennett", FIT, TOL, "tolerance: {position: nan, angle: 0.5}", ["tolerance.position"]),
    "pose_tolerance_inf": ("bennett", FIT, LIFT, LIFT + "\n  tolerance: {position: .inf, angle: 1}", ['"lift"']),
    "velocity_nan": ("bennett", FIT, LIFT, "  exact: true\n  velocity: {linear: [.nan, 0, 0], angular: [0, 0, 0]}"
                     "\n- name: lift", ['"pick"', "velocity"]),
    "velocity_text": ("bennett", FIT, LIFT, "  exact: true\n  velocity: fast\n- name: lift", ['"pick"', "velocity"]),
    "velocity_short": ("bennett", FIT, LIFT, "  exact: true\n  velocity: {linear: [1, 0], angular: [0, 0, 0]}"
                       "\n- name: lift", ['"pick"', "velocity"]),
    "order_unknown": ("bennett", FIT, "order: listed", "order: unknown", ["order"]),
    "fourbar_order_unknown": ("fourbar", FOUR, "order: listed", "order: sometimes", ["order"]),
    "box_min_over_max": ("bennett", MOUNT, BOX, "[[200, 200, 250], [-50, -50, -100]]", ["base"]),
    "box_nan": ("bennett", MOUNT, BOX, "[[.nan, -50, -100], [200, 200, 250]]", ["base"]),
    "box_short": ("bennett", MOUNT, BOX, "[[-50, -50], [200, 200, 250]]", ["base"]),
    "speed_ratio_negative": ("bennett", MOUNT, "max_speed_ratio: 3", "max_speed_ratio: -1", ["max_speed_ratio"]),
    "duplicate_names": ("bennett", FIT, "name: a2", "name: a1", ['"a1"']),
    "fourbar_tolerance_inf": ("fourbar", FOURFIT, "tolerance: {position: 0.0001", "tolerance: {position: .inf",
                              ["tolerance.position"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_hostile_task_key_is_one_line_exit_2(tmp_path, case):
    command, text, old, new, words = CASES[case]
    assert old in text
    task = tmp_path / "task.yaml"
    task.write_text(text.replace(old, new, 1))
    code, _, err = invoke([command, str(task), "-o", "out", "-q"], tmp_path)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert "task.yaml" in err and all(w in err for w in words), err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("value", ["nan", "-1", "91"])
def test_fourbar_min_transmission_out_of_range_is_exit_2(tmp_path, value):
    """NaN passes click's FloatRange (every comparison is false): the library checks the range."""
    code, _, err = invoke(["fourbar", str(REPO / "fixtures" / "fourbar_5.yaml"), "-o", "out", "-q",
                           "--min-transmission", value], tmp_path)
    assert code == 2 and "--min-transmission" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()
