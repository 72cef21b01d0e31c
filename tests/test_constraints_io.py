"""The ``constraints:`` section of task files (synth.io.constraints): units, corner order, one-line errors."""
import numpy as np
import pytest

from synth.errors import InputError
from synth.io.poses import load_poses

POSE = "poses:\n  - {position: [0, 0, 0], rpy: [0, 0, 0]}\n"
POINTS = "points:\n" + "".join(f"  - [{i}, {i * i}, 1]\n" for i in range(5))


def test_boxes_in_metres_and_ratio():
    text = ("units: {length: mm}\nconstraints:\n  base: {box: [[0, -100, 0], [100, 0, 50]]}\n"
            "  envelope: {box: [[-1, -2, -3], [1, 2, 3]]}\n  max_speed_ratio: 4\n" + POSE)
    c = load_poses("t.yaml", text=text).constraints
    np.testing.assert_allclose(c.base.lo, [0, -0.1, 0])
    np.testing.assert_allclose(c.base.hi, [0.1, 0, 0.05])
    np.testing.assert_allclose(c.envelope.lo, [-1e-3, -2e-3, -3e-3])
    assert c.max_speed_ratio == 4.0


def test_absent_or_empty_is_none_and_point_tasks_carry_it():
    assert load_poses("t.yaml", text=POSE).constraints is None
    assert load_poses("t.yaml", text="constraints: {}\n" + POSE).constraints is None
    ps = load_poses("t.yaml", text="constraints: {max_speed_ratio: 2.5}\n" + POINTS, points=(5, 5))
    assert ps.constraints.max_speed_ratio == 2.5 and ps.constraints.base is None


@pytest.mark.parametrize("section, words", [
    ("constraints: 3", "t.yaml: constraints must be a mapping"),
    ("constraints: {bas: {box: [[0, 0, 0], [1, 1, 1]]}}", 'unknown key "bas" in constraints (did you mean "base"?'),
    ("constraints: {base: {box: [[0, 0, 0]]}}", "constraints.base.box must be two corners"),
    ("constraints: {base: {box: [[0, 0, 0], [100, -100, 50]]}}",
     "constraints.base.box must be [[x0, y0, z0], [x1, y1, z1]] with the lower corner first, got y0 = 0 > y1 = -100"),
    ("constraints: {envelope: {box: [[0, 0, 0], [1, x, 2]]}}", "constraints.envelope.box[1][1] must be a number"),
    ("constraints: {envelope: {box: [[0, 0, 0], [1, 1]]}}", "constraints.envelope.box[1] must be a list of 3"),
    ("constraints: {base: {corner: 1}}", "constraints.base must be a mapping {box:"),
    ("constraints: {base: {box: [[0, 0, 0], [1, 1, 1]], wall: 1}}", 'unknown key "wall" in constraints.base'),
    ("constraints: {max_speed_ratio: 0}", "constraints.max_speed_ratio must be positive"),
    ("constraints: {max_speed_ratio: true}", "constraints.max_speed_ratio must be a number, got a boolean"),
])
def test_errors_are_one_line_naming_file_and_key(section, words):
    with pytest.raises(InputError) as e:
        load_poses("t.yaml", text=section + "\n" + POSE)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("t.yaml: ") and words in msg
