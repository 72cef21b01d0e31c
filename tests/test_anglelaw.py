"""The one angle law (synth/algebra/anglelaw.py): worked values, inverse, driven angles, repeated factors."""
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.anglelaw import angle_law, angle_law_inverse, driven_angle, half_angle
from synth.algebra.dq import dq_mul
from synth.algebra.geometry import rotation_about_line
from synth.algebra.polynomial import pose_at
from synth.errors import InputError

TWO_PI = 2 * math.pi


def test_worked_values():
    # theta(t) = 2 atan2(b, t - a): a quarter turn at t = a + b, half a turn at t = a, 0 at +-inf
    assert float(angle_law(1.0, 2.0, 3.0)) == pytest.approx(math.pi / 2, abs=1e-12)
    assert float(angle_law(1.0, 2.0, 1.0)) == pytest.approx(math.pi, abs=1e-12)
    assert float(angle_law(1.0, 2.0, np.inf)) == pytest.approx(0.0, abs=1e-12)
    assert float(angle_law(1.0, 2.0, -np.inf)) == pytest.approx(0.0, abs=1e-12)
    assert float(angle_law(1.0, 2.0, 3.0, rate=2)) == pytest.approx(math.pi, abs=1e-12)
    assert float(angle_law(1.0, 2.0, 1.0, rate=2)) == pytest.approx(0.0, abs=1e-12)  # a full turn
    assert float(half_angle(1.0, 2.0, 1.0, rate=2)) == pytest.approx(math.pi, abs=1e-12)
    assert float(angle_law_inverse(1.0, 2.0, math.pi / 2)) == pytest.approx(3.0, abs=1e-12)
    assert math.isinf(float(angle_law_inverse(1.0, 2.0, 0.0)))
    assert float(angle_law_inverse(1.0, 2.0, math.pi, rate=2)) == pytest.approx(3.0, abs=1e-12)
    # the rate-2 joint is at angle 0 at t = inf and at t = a (branch 1)
    assert float(angle_law_inverse(1.0, 2.0, 0.0, rate=2, branch=1)) == pytest.approx(1.0, abs=1e-12)


def test_broadcasting():
    a = np.array([0.0, 1.0, -2.0])
    b = np.array([1.0, 0.5, 3.0])
    t = np.array([[-1.0], [0.0], [np.inf], [7.0]])
    th = angle_law(a, b, t, np.array([1, 2, 1]))
    assert th.shape == (4, 3)
    assert np.all((th >= 0) & (th < TWO_PI))
    assert np.all(th[2] == 0.0)


@settings(max_examples=60, deadline=None)
@given(a=st.floats(-5, 5), b=st.floats(0.05, 5), t=st.floats(-50, 50), rate=st.integers(1, 3))
def test_inverse_round_trip(a, b, t, rate):
    th = angle_law(a, b, t, rate)
    ts = [float(angle_law_inverse(a, b, th, rate, k)) for k in range(rate)]
    # one of the rate branches gives t back; every branch gives the angle back
    assert min(abs(x - t) / (1 + abs(t)) for x in ts if math.isfinite(x)) < 1e-7
    for x in ts:
        d = (float(angle_law(a, b, x, rate)) - th + math.pi) % TWO_PI - math.pi
        assert abs(d) < 1e-7


@settings(max_examples=40, deadline=None)
@given(a=st.floats(-3, 3), b=st.floats(0.1, 3), ad=st.floats(-3, 3), bd=st.floats(0.1, 3),
       t=st.floats(-30, 30), rate=st.integers(1, 2))
def test_driven_angle_is_the_law_at_the_drivers_parameter(a, b, ad, bd, t, rate):
    phi = angle_law(ad, bd, t)
    d = float(driven_angle(a, b, ad, bd, phi, rate)) - float(angle_law(a, b, t, rate))
    assert abs((d + math.pi) % TWO_PI - math.pi) < 1e-7


def test_rate_is_a_repeated_factor():
    """A joint of rate 2 at t turns as the factor (t - h)^2: rotation_about_line by angle_law(rate=2)."""
    u = np.array([2.0, -1.0, 2.0]) / 3
    p = np.array([0.3, -0.2, 0.5])
    m = np.cross(p, u)
    a, b = 0.4, 1.3
    h = np.concatenate([[a], -b * u, [0.0], b * m])
    lin = np.zeros((2, 8))
    lin[0] = -h
    lin[1, 0] = 1.0
    sq = np.zeros((3, 8))  # (t - h)^2 = t^2 - 2 h t + h^2
    sq[2, 0] = 1.0
    sq[1] = -2 * h
    sq[0] = dq_mul(h, h)
    for t in (-2.0, 0.1, 0.4, 3.0):
        assert np.allclose(pose_at(sq, t), rotation_about_line(u, m, float(angle_law(a, b, t, 2))), atol=1e-12)


# ------------------------------------------------------------------ joints of rate 2 (a repeated factor)
def _darboux_chain():
    """The open 4-joint chain of C (t^2 + 1) for the general Darboux motion (docs/exceptional.md, section 6):
    g1, g2 (rate 2), g3 parallel, then the vertical g4; as a `Linkage` without closures, at 3 poses."""
    from synth.algebra.expr import parse_polynomial
    from synth.algebra.polynomial import poly_mul
    from synth.synthesis.assemble import joint_from_factor, pose_records
    from synth.linkage import Linkage

    u = np.array([2, -1, -2]) / 3
    G = [[0, *u, 0, -0.5, 1, -1], [0, *-u, 0, 0.75, 0, 0.75], [0, *u, 0, 0, 0, 0], [0, 0, 0, 1, 0, -1, 0, 0]]
    links = ["base", "l1", "l2", "l3", "coupler"]
    joints = [joint_from_factor(f"g{i + 1}", links[i], links[i + 1], np.array(g, float)) for i, g in enumerate(G)]
    joints[1].rate = 2
    C = np.array(parse_polynomial("(t^2 + 1)*(t - k) + eps*(i + k/2 - (j + k/2)*t)*(t - k)"), float)
    M = np.zeros((3, 8))
    M[0, 0] = M[2, 0] = 1.0
    CM = poly_mul(C, M)
    ts = [np.inf, 0.0, -1.5]
    poses = pose_at(CM, np.array(ts))
    lk = Linkage("curve", joints, {n: [] for n in links}, [[j.name for j in joints]], [], poses[0], CM,
                 pose_records(joints, poses, ["p0", "p1", "p2"], ts))
    return lk


def test_a_rate_two_joint_in_the_self_check():
    from synth.checks import self_check

    lk = _darboux_chain()
    assert lk.poses[1].joint_angles["g2"] == pytest.approx(0.0, abs=1e-12)  # t = 0: 2 x half a turn
    fig = self_check(lk, 40)
    assert fig["max_motion_error"] < 1e-12 and fig["max_pose_error"] < 1e-12
    lk.joints[1].rate = 1  # the same chain read with one angle law per joint does not perform the motion
    assert self_check(lk, 40)["max_motion_error"] > 0.1


def test_rate_round_trips_through_linkage_json():
    from synth.io.jsonout import linkage_document, plain
    from synth.io.readback import angle_rates, linkage_from_document

    lk = _darboux_chain()
    doc = plain(linkage_document(lk))
    laws = {j["name"]: j["angle_law"] for j in doc["joints"]}
    assert laws["g2"]["rate"] == 2 and "rate" not in laws["g1"]  # written only when not 1
    assert angle_rates(doc) == {"g1": 1, "g2": 2, "g3": 1, "g4": 1}
    back = linkage_from_document(doc)
    assert [j.rate for j in back.joints] == [1, 2, 1, 1]
    ts = np.array([-3.0, -0.2, 0.7, 4.0])
    for j, k in zip(lk.joints, back.joints):
        assert np.allclose(j.angle(ts), k.angle(ts), atol=1e-14)
        # the inverse: one of the rate branches gives t back
        for t in ts:
            cands = [float(k.parameter(k.angle(t), br)) for br in range(k.rate)]
            assert min(abs(c - t) for c in cands) < 1e-9
    bad = json.loads(json.dumps(doc))
    bad["joints"][1]["angle_law"]["rate"] = 0
    with pytest.raises(InputError, match="rate"):
        linkage_from_document(bad)


def test_law_angles_and_follower_angles_honour_rates():
    from synth.tools.check.continuation import law_angles
    from synth.tools.trajectory import follower_angles

    lk = _darboux_chain()
    laws = {j.name: (j.a, j.b) for j in lk.joints}
    rates = {j.name: j.rate for j in lk.joints}
    ts = np.array([-2.0, 0.3, 5.0])
    phi = lk.joint("g1").angle(ts)
    ex = law_angles(laws, "g1", phi, rates)
    ang, dang = follower_angles(lk, "g1", phi)
    for i, j in enumerate(lk.joints):
        d = np.angle(np.exp(1j * (ex[j.name] - j.angle(ts))))
        assert np.abs(d).max() < 1e-9
        assert np.abs(np.angle(np.exp(1j * (ang[:, i] - j.angle(ts))))).max() < 1e-9
    # the rate-2 joint turns twice as fast as a rate-1 joint of the same law
    assert dang[:, 1] == pytest.approx(2 * dang[:, 2], rel=1e-12)
