"""The one angle law (synth/algebra/anglelaw.py): worked values, inverse, driven angles, repeated factors."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.anglelaw import angle_law, angle_law_inverse, driven_angle, half_angle
from synth.algebra.dq import dq_mul, rotation_about_line
from synth.algebra.polynomial import pose_at

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
