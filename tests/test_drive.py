"""Drivability (synth.drive): the driver, the task range, exact speed ratios, loop conditioning, dead points."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import synth
from synth.algebra.anglelaw import driven_speed, driven_speed_max
from synth.drive import (base_joints, drive_report, driver_joint, follower_angles, loop_jacobian,
                         loop_conditioning, speed_ratio, task_range, with_driver)
from synth.errors import InputError
from synth.infoparts import FitRecord
from synth.io.poses import load_poses

from conftest import REPO, random_poses


def fixture_linkage(name):
    ps = load_poses(str(REPO / "fixtures" / name))
    return (synth.sixbar if len(ps) == 4 else synth.bennett)(ps.matrices, ps.names)


@settings(max_examples=60, deadline=None)
@given(a=st.floats(-3, 3), b=st.floats(0.05, 3).map(lambda x: x * (1 if x > 1 else -1)), ad=st.floats(-3, 3),
       bd=st.floats(0.05, 3), lo=st.floats(-7, 7), span=st.floats(0.0, 6.2), rate=st.integers(1, 2))
def test_driven_speed_max_is_the_maximum(a, b, ad, bd, lo, span, rate):
    """The exact maximum is never below a dense sample's and is reached where it says (so it is the
    maximum: a value of the function at least as large as every sample)."""
    phi = np.linspace(lo, lo + span, 20001)
    dense = np.abs(driven_speed(a, b, ad, bd, phi, rate)).max()
    top, at = driven_speed_max(a, b, ad, bd, lo, lo + span, rate)
    assert top >= dense * (1 - 1e-9)  # the closed form rounds at ~1e-10 near sharp peaks (b = -0.5, bd = 0.05)
    assert lo - 1e-12 <= at <= lo + span + 1e-12
    assert abs(abs(driven_speed(a, b, ad, bd, at, rate)) - top) <= 1e-9 * top


def test_worked_numbers_bennett_mm_deg():
    """bennett_mm_deg: h1 drives 134.2 deg through the poses; k1 turns at most 2.842 times as fast (at
    the end of the range); the loop stays well conditioned (0.414) with no dead point. Driven by k1
    instead: 137.8 deg, ratio 2.769 (k2), so the driver choice matters."""
    lk = fixture_linkage("bennett_mm_deg.yaml")
    r = drive_report(lk)
    assert r.driver == "h1" and not r.dead_points and not r.warnings
    assert math.degrees(r.range[1] - r.range[0]) == pytest.approx(134.2, abs=0.05)
    assert (r.max_speed_joint, r.max_speed_ratio) == ("k1", pytest.approx(2.84197, rel=1e-5))
    assert r.min_conditioning == pytest.approx(0.414, abs=5e-4)
    r2 = drive_report(with_driver(lk, "k1"))
    assert r2.driver == "k1" and (r2.max_speed_joint, r2.max_speed_ratio) == ("k2", pytest.approx(2.76933, rel=1e-5))
    assert math.degrees(r2.range[1] - r2.range[0]) == pytest.approx(137.8, abs=0.05)


def test_speed_ratio_against_finite_differences_of_the_angles():
    """The exact ratio equals the largest chord ratio of the followers' angles on a fine grid."""
    lk = fixture_linkage("sixbar_example.yaml")
    driver, lo, hi = task_range(lk)
    ratio, _ = speed_ratio(lk, driver, lo, hi)
    phi = np.linspace(lo, hi, 200001)
    ang, _ = follower_angles(lk, driver, phi)
    chord = np.abs(np.diff(ang, axis=0)).max(axis=0) / (phi[1] - phi[0])
    np.testing.assert_allclose(chord, ratio, rtol=1e-5)


def test_with_driver_reorders_the_cut_only():
    lk = fixture_linkage("bennett_quat.yaml")
    assert driver_joint(lk) == "h1" and base_joints(lk) == ["h1", "k1"]
    k = with_driver(lk, "k1")
    assert driver_joint(k) == "k1" and k.closures == [("coupler_k", "coupler")] and k.joints is lk.joints
    assert with_driver(lk, None) is lk and with_driver(lk, "h1") is lk
    with pytest.raises(InputError, match=r"--driver h2: not a joint on the base .*\(joints that can drive: h1, k1\)"):
        with_driver(lk, "h2")
    _, lo, hi = task_range(k)
    assert task_range(k)[0] == "k1" and 0 <= lo < 2 * math.pi < hi + 2 * math.pi


def test_loop_jacobian_annihilates_the_joint_rates():
    """Along the motion the joint rates d theta_j / dt span the Jacobian's null space: J(t) theta'(t) = 0,
    and the conditioning is sigma_{n-1} / sigma_1 in (0, 1]."""
    rng = np.random.default_rng(3)
    lk = synth.bennett(random_poses(rng, 3))
    t = np.array([-2.0, 0.3, 5.0])
    J = loop_jacobian(lk, t)
    rates = np.array([-2 * j.b / ((t - j.a) ** 2 + j.b ** 2) for j in lk.joints]).T  # (3, 4)
    assert np.abs(np.einsum("sij,sj->si", J, rates)).max() < 1e-9 * np.abs(rates).max()
    c = loop_conditioning(lk, t)
    assert np.all((c > 0) & (c <= 1))


def test_planar_four_bar_passes_a_change_point():
    """The planar anti-parallelogram folds flat inside its task range: a singular configuration (the
    conditioning drops to 0 there) reported as a dead point with a warning."""
    r = drive_report(fixture_linkage("bennett_planar.yaml"))
    assert r.dead_points and r.dead_points[0].inside and r.min_conditioning < 1e-6
    assert any(w.startswith("dead point:") for w in r.warnings)


def test_near_planar_bennett_warns_about_a_poor_drive():
    """Three poses planar up to 1e-4 rad: a huge Bennett linkage whose second joint whips round (a ratio of
    about 94) - reported in words."""
    T = np.array([np.eye(4)] * 3)
    for i, (x, y, yaw, tilt) in enumerate([(0, 0, 0, 0), (0.1, 0.02, 40, 1e-4), (0.15, 0.09, 95, -1e-4)]):
        c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
        T[i, :3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array(
            [[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
        T[i, :3, 3] = (x, y, 0)
    r = drive_report(synth.bennett(T))
    assert r.max_speed_ratio > 50 and any(w.startswith("poor drive:") for w in r.warnings)
    d = r.to_dict()
    assert set(d) == {"driver", "range", "max_speed_ratio", "max_speed_joint", "max_speed_at", "min_conditioning",
                      "min_conditioning_at", "dead_points", "warnings"}


def test_listed_order_task_range_follows_the_listed_arc():
    """With ``order: listed`` (info.fit.order) the task range is the arc from the first pose through the
    others in the listed order, one way: for bennett_mm_deg's h1 angles (pick 0, via 276.6, place 50.8
    deg) listed pick, place, via it is 0 -> 50.8 -> 276.6 (increasing); listed pick, via, place it runs
    down from 360 through 276.6 to 50.8."""
    lk = fixture_linkage("bennett_mm_deg.yaml")
    th = {p.name: math.degrees(p.joint_angles["h1"]) % 360 for p in lk.poses}
    lk.info = lk.info.replace(fit=FitRecord(
        method="exact", seeds=0, refined=0, iterations=0, order="listed", visit_order=None, rms_position_error=0.0,
        max_position_error=0.0, rms_angle_error=0.0, max_angle_error=0.0, within_tolerance=True, failing=()))
    lk.poses = [lk.poses[0], lk.poses[2], lk.poses[1]]
    _, lo, hi = task_range(lk)
    assert (math.degrees(lo), math.degrees(hi)) == (pytest.approx(0.0, abs=1e-9), pytest.approx(th["via"]))
    lk.poses = [lk.poses[0], lk.poses[2], lk.poses[1]]
    _, lo, hi = task_range(lk)
    assert (math.degrees(lo), math.degrees(hi)) == (pytest.approx(th["place"]), pytest.approx(360.0))
