"""Task keys of pose files (../shared/docs/OUTPUT.md, "Additions (turn 3)"): tolerance, exact, velocity, order."""
import math

import numpy as np
import pytest

from synth.errors import InputError
from synth.io.poses import load_poses
from synth.task import Order

HEAD = "units: {length: mm, angle: deg}\n"
POSE = "  - {name: %s, position: [%d, 0, 0], rpy: [0, 0, %d]%s}\n"


def doc(top="", extras=("", "", "")):
    body = "".join(POSE % (f"p{i}", 100 * i, 10 * i, e) for i, e in enumerate(extras))
    return HEAD + top + "poses:\n" + body


def test_classic_file_is_exact_with_no_velocity():
    ps = load_poses("t.yaml", text=doc())
    assert ps.tolerance is None and ps.velocity is None and ps.order is Order.ANY and ps.constraints is None


def test_tolerances_in_input_units_with_overrides():
    ps = load_poses("t.yaml", text=doc("tolerance: {position: 0.5, angle: 0.25}\norder: listed\n",
                                       (", exact: true", ", tolerance: {position: 2}", "")))
    assert ps.order is Order.LISTED
    np.testing.assert_allclose(ps.tolerance[0], [0, 0])
    assert ps.tolerance[1, 0] == pytest.approx(2e-3) and math.isinf(ps.tolerance[1, 1])  # missing key: free
    np.testing.assert_allclose(ps.tolerance[2], [0.5e-3, math.radians(0.25)])


def test_per_pose_tolerance_alone_leaves_the_others_exact():
    ps = load_poses("t.yaml", text=doc(extras=("", ", tolerance: {angle: 1}", "")))
    np.testing.assert_allclose(ps.tolerance[[0, 2]], 0)
    assert math.isinf(ps.tolerance[1, 0]) and ps.tolerance[1, 1] == pytest.approx(math.radians(1))


def test_velocity_in_si_with_missing_half_nan():
    ps = load_poses("t.yaml", text=doc(extras=(", velocity: {angular: [0, 0, 90], linear: [10, 0, 0]}",
                                                ", velocity: {linear: [0, 5, 0]}", "")))
    np.testing.assert_allclose(ps.velocity[0], [0, 0, math.pi / 2, 0.01, 0, 0])
    assert np.isnan(ps.velocity[1, :3]).all() and ps.velocity[1, 4] == pytest.approx(5e-3)
    assert np.isnan(ps.velocity[2]).all()


def test_points_have_free_angles():
    text = HEAD + "tolerance: {position: 1}\npoints:\n" + "".join(
        f"  - {{position: [{i}, {i * i}, 1]{', exact: true' if i == 0 else ''}}}\n" for i in range(6))
    ps = load_poses("t.yaml", text=text, points=((3, None), "test"))
    assert ps.tolerance.shape == (6, 2) and np.isinf(ps.tolerance[:, 1]).all()
    assert ps.tolerance[0, 0] == 0 and ps.tolerance[1, 0] == pytest.approx(1e-3)


def test_constraints_key_is_accepted():
    load_poses("t.yaml", text=doc("constraints: {max_speed_ratio: 4}\n"))


@pytest.mark.parametrize("top, extra, message", [
    ("", ", tolerance: {position: -1}", 't.yaml: pose 1 ("p1"): tolerance.position is negative'),
    ("", ", velocity: {angular: [0, 0, 0]}", 't.yaml: pose 1 ("p1"): velocity is zero'),
    ("", ", velocity: {angle: [0, 0, 1]}", "unknown key \"angle\" in velocity"),
    ("", ", exact: true, tolerance: {position: 1}", "both 'exact: true' and a 'tolerance'"),
    ("", ", tolerans: {position: 1}", 'did you mean "tolerance"?'),
    ("", ", exact: yes please", "exact must be true or false"),
    ("tolerance: 3\n", "", "t.yaml: tolerance must be a mapping"),
    ("tolerance: {position: 1, angel: 2}\n", "", 'unknown key "angel" in tolerance'),
    ("order: sorted\n", "", "t.yaml: unknown order \"sorted\" (allowed: any, listed)"),
])
def test_one_line_errors_name_file_pose_and_problem(top, extra, message):
    with pytest.raises(InputError) as e:
        load_poses("t.yaml", text=doc(top, ("", extra, "")))
    assert message in str(e.value) and "\n" not in str(e.value)
