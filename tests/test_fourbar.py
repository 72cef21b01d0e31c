"""The planar four-bar (docs/fourbar.md): loop law, plane, dyads, ranking, linkage and read-back."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fourbar_tasks import coupler_poses, noisy, random_crank_rocker
from synth.algebra.fourbar_loop import FourBarLaw, loop_angles, transmission_angle
from synth.errors import InputError, SynthesisError
from synth.io.jsonout import linkage_document
from synth.io.readback import linkage_from_document
from synth.synthesis.fourbar import fourbar_candidates
from synth.synthesis.fourbar_dyads import (burmester_points, centre_point_curve, circle_figures, least_squares_dyads,
                                           three_pose_dyads)
from synth.synthesis.fourbar_plane import plane_of_motion
from synth.task import Order

NAMES = [f"p{i}" for i in range(12)]


def task_poses(k, seed=1, span_deg=220.0, plane_seed=0):
    L = random_crank_rocker(np.random.default_rng(seed))
    ang = np.linspace(0.3, 0.3 + math.radians(span_deg), k)
    return (L,) + coupler_poses(L, ang, plane_seed=plane_seed)


# ------------------------------------------------------------------------------------------ loop law
def test_parallelogram_worked_numbers():
    """Ground 1, crank 0.5, coupler 1, rocker 0.5 with the crank upright: a parallelogram, whose coupler
    keeps its direction (h2 = -theta, k1 = theta, k2 = -theta); transmission 90 deg there."""
    q = loop_angles(1.0, 0.5, 1.0, 0.5, math.pi / 2, 1, 0.3)
    assert np.allclose(q, [0.3, -0.3, 0.3, -0.3], atol=1e-14)
    assert transmission_angle(1.0, 0.5, 1.0, 0.5, math.pi / 2, 0.0) == pytest.approx(math.pi / 2, abs=1e-15)
    assert np.all(loop_angles(1.0, 0.5, 1.0, 0.5, math.pi / 2, 1, 0.0) == 0.0)


def test_unassemblable_is_nan():
    """A coupler too short to reach the rocker at some crank angle: NaN there."""
    q = loop_angles(1.0, 0.5, 0.2, 0.2, 0.0, 1, math.pi)  # |B0 - A1| = 1.5 > 0.4
    assert np.all(np.isnan(q[1:]))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.floats(-20.0, 20.0), st.sampled_from([1, -1]), st.floats(-math.pi, math.pi))
def test_loop_closes(seed, theta, branch, ref):
    """The four joint angles of a crank-rocker close the loop: B1 reached through the crank and coupler equals
    B1 reached through the rocker, and the coupler's direction agrees along both branches."""
    g, r, c, s = random_crank_rocker(np.random.default_rng(seed), 30.0)
    h1, h2, k1, k2 = loop_angles(g, r, c, s, ref, branch, np.array([0.0, theta]))
    A1 = r * np.exp(1j * (ref + h1))
    d0 = (g - A1[0])  # B0 - A1 at the reference
    psi0 = np.angle(d0) + branch * math.acos((c * c + abs(d0) ** 2 - s * s) / (2 * c * abs(d0)))
    B1 = A1 + c * np.exp(1j * (psi0 + h1 + h2))
    rho0 = np.angle(A1[0] + c * np.exp(1j * psi0) - g)
    assert np.allclose(B1, g + s * np.exp(1j * (rho0 + k1)), atol=1e-12)
    assert np.allclose(np.exp(1j * (h1 + h2)), np.exp(1j * (k1 + k2)), atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([1, -1]))
def test_continued_angles_are_continuous(seed, branch):
    """Over two turns of a crank-rocker's crank every continued angle moves by less than 0.1 rad per 0.01 rad
    step, h2 loses one turn per crank turn and k1, k2 come back."""
    law = dict(zip(("ground", "crank", "coupler", "rocker"), random_crank_rocker(np.random.default_rng(seed), 30.0)))
    th = np.linspace(0.0, 4 * math.pi, 1257)
    q = {j: FourBarLaw(**law, crank_ref=0.7, branch=branch, joint=j).continued(th) for j in ("h2", "k1", "k2")}
    for j, v in q.items():
        assert np.max(np.abs(np.diff(v))) < 0.1, j
    assert q["h2"][-1] == pytest.approx(-4 * math.pi, abs=1e-9)
    assert abs(q["k1"][-1]) < 1e-9 and abs(q["k2"][-1]) < 1e-9


def test_law_dict_round_trip_and_validation():
    law = FourBarLaw(1.0, 0.2, 0.9, 0.8, 0.4, -1, "k2")
    assert FourBarLaw.from_dict(law.to_dict()) == law
    for bad in ({"branch": 0}, {"crank": -1.0}, {"joint": "h7"}, {"ground": float("nan")}):
        with pytest.raises(ValueError):
            FourBarLaw.from_dict({**law.to_dict(), **bad})


# ------------------------------------------------------------------------------------------ plane
def test_plane_of_tilted_poses():
    _, T, _, (o, e1, e2) = task_poses(4, plane_seed=7)
    task = plane_of_motion(T, NAMES)
    n = np.cross(e1, e2)
    assert abs(abs(task.normal @ n) - 1) < 1e-12
    assert task.theta[0] == 0.0 and np.allclose(task.q[0], 0.0)
    W = task.to_world(task.qc)  # the tool origins back in space
    assert np.allclose(W, T[:, :3, 3], atol=1e-13)


def test_non_coplanar_pose_is_named():
    _, T, _, _ = task_poses(5)
    T = T.copy()
    T[3, :3, 3] += 1e-3 * np.cross(T[1, :3, 3] - T[0, :3, 3], T[2, :3, 3] - T[0, :3, 3]) / np.linalg.norm(
        np.cross(T[1, :3, 3] - T[0, :3, 3], T[2, :3, 3] - T[0, :3, 3]))
    with pytest.raises(InputError, match=r"pose 3 \(p3\) is not in the plane.*origin is 0.001 m off"):
        plane_of_motion(T, NAMES, "task.yaml")


def test_translations_only_refused():
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, 0, 3] = [0.0, 1.0, 2.0]
    with pytest.raises(SynthesisError, match="translations only"):
        plane_of_motion(T, NAMES)


# ------------------------------------------------------------------------------------------ dyads
def _world_dyads(task, d):
    return task.to_world(d.centre), task.to_world(d.circle)


@pytest.mark.parametrize("k, finder", [(3, three_pose_dyads), (4, centre_point_curve), (5, burmester_points)])
def test_exact_dyads_keep_their_circles(k, finder):
    _, T, _, _ = task_poses(k)
    task = plane_of_motion(T, NAMES)
    d = finder(task)
    assert len(d) >= (2 if k == 5 else 50)
    _, err = circle_figures(task, d.centre, d.circle)
    assert np.max(err) < 1e-9


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_burmester_points_hold_the_true_dyads(seed):
    """Five poses of a known crank-rocker: its two dyads are among the (at most four) Burmester points."""
    _, T, piv, (o, e1, e2) = task_poses(5, seed=seed, plane_seed=seed)
    task = plane_of_motion(T, NAMES)
    d = burmester_points(task)
    assert 2 <= len(d) <= 4
    G, W = _world_dyads(task, d)
    world = [o + p[0] * e1 + p[1] * e2 for p in piv]
    for fixed, moving in ((world[0], world[1]), (world[2], world[3])):
        assert np.min(np.linalg.norm(G - fixed, axis=1) + np.linalg.norm(W - moving, axis=1)) < 1e-9


def test_least_squares_dyads_recover_exact_ones():
    """Eight poses of a crank-rocker, no noise: the fit finds both dyads with zero circle error."""
    _, T, piv, (o, e1, e2) = task_poses(8)
    task = plane_of_motion(T, NAMES)
    d = least_squares_dyads(task)
    G, W = _world_dyads(task, d)
    for fixed, moving in ((piv[0], piv[1]), (piv[2], piv[3])):
        f, m = o + fixed[0] * e1 + fixed[1] * e2, o + moving[0] * e1 + moving[1] * e2
        i = np.argmin(np.linalg.norm(G - f, axis=1) + np.linalg.norm(W - m, axis=1))
        assert np.linalg.norm(G[i] - f) < 1e-9 and d.error[i] < 1e-10


# ------------------------------------------------------------------------------------------ linkages
@pytest.mark.parametrize("k", [3, 4, 5])
def test_exact_fourbars(k):
    _, T, _, _ = task_poses(k, plane_seed=k)
    lks = fourbar_candidates(T, NAMES[:k], top=2, order=Order.LISTED)
    for lk in lks:
        c, f = lk.checks, lk.info.synthesis.fourbar.to_dict()
        assert lk.kind == "planar_fourbar" and lk.motion is None
        assert c["max_pose_error"] < 1e-12 and c["max_closure_error"] < 1e-12
        L = f["lengths"]
        assert L["crank"] < min(L["ground"], L["coupler"], L["rocker"])
        s, l = min(L.values()), max(L.values())
        assert s + l < sum(L.values()) - s - l
        assert f["transmission_min_deg"] >= 40.0
        th = [rec.joint_angles["h1"] for rec in lk.poses]
        steps = np.mod(np.diff(th), 2 * np.pi)
        assert steps.sum() < 2 * np.pi or np.mod(-np.diff(th), 2 * np.pi).sum() < 2 * np.pi  # listed order
        for rec in lk.poses:  # the pose angles are the laws' at the pose parameter
            assert all(abs(np.angle(np.exp(1j * (lk.joint(n).angle(rec.t) - v)))) < 1e-12
                       for n, v in rec.joint_angles.items())


def test_min_transmission_is_honoured():
    _, T, _, _ = task_poses(3)
    best = fourbar_candidates(T, NAMES[:3], top=1, min_transmission_deg=60.0)[0]
    assert best.info.synthesis.fourbar.transmission_min_deg >= 60.0


def test_no_qualifying_fourbar_is_refused():
    _, T, _, _ = task_poses(5)
    with pytest.raises(SynthesisError, match="none of the .* four-bars .* qualifies .*transmission below 89 deg"):
        fourbar_candidates(T, NAMES[:5], min_transmission_deg=89.0)


def test_noisy_eight_pose_fit_within_tolerance():
    L, T, _, _ = task_poses(8, span_deg=250.0, plane_seed=3)
    T = noisy(T, np.random.default_rng(5), 2e-5, 2e-4)
    tol = np.tile([1e-4, 1e-3], (8, 1))
    lk = fourbar_candidates(T, NAMES[:8], tolerance=tol, order=Order.LISTED)[0]
    assert lk.checks["max_closure_error"] < 1e-12
    for rec in lk.poses:
        assert rec.error[0] <= 1e-4 and rec.error[1] <= 1e-3
    fit = lk.info.fit.to_dict()
    assert fit["within_tolerance"] and fit["visit_order"] == NAMES[:8]
    assert fit["max_position_error"] == pytest.approx(max(r.error[0] for r in lk.poses))
    assert 0.0 < fit["max_position_error"] < 5e-5  # noise up to 2e-5 m: a good fit is near it


def test_eight_poses_without_tolerance():
    """Exact poses of a four-bar fit to machine precision; noisy ones are refused with the advice."""
    _, T, _, _ = task_poses(8)
    lk = fourbar_candidates(T, NAMES[:8])[0]
    assert lk.checks["max_pose_error"] < 1e-10
    with pytest.raises(SynthesisError, match="give the task a tolerance"):
        fourbar_candidates(noisy(T, np.random.default_rng(2), 1e-4, 1e-3), NAMES[:8])


def test_deterministic():
    _, T, _, _ = task_poses(4)
    a = fourbar_candidates(T, NAMES[:4], top=3)
    b = fourbar_candidates(T, NAMES[:4], top=3)
    assert [x.info.synthesis.fourbar.lengths for x in a] == [x.info.synthesis.fourbar.lengths for x in b]


def test_document_round_trip():
    """linkage.json's loop laws read back give the same joint angles along the motion."""
    _, T, _, _ = task_poses(5)
    lk = fourbar_candidates(T, NAMES[:5])[0]
    doc = linkage_document(lk)
    assert doc["motion_polynomial"] is None
    assert doc["joints"][1]["angle_law"]["fourbar"]["joint"] == "h2"
    back = linkage_from_document(doc)
    t = np.linspace(-5, 5, 41)
    for j in lk.joints:
        assert np.allclose(back.joint(j.name).angle(t), j.angle(t), atol=1e-15)


def test_exact_task_with_tolerance_records_its_errors():
    """Five poses with a task tolerance: met exactly, and every pose record says so (error and tolerance)."""
    _, T, _, _ = task_poses(5)
    lk = fourbar_candidates(T, NAMES[:5], tolerance=np.tile([1e-3, 1e-2], (5, 1)))[0]
    assert lk.info.fit.method == "exact" and lk.info.fit.within_tolerance
    for rec in lk.poses:
        assert rec.error[0] < 1e-13 and rec.error[1] < 1e-12 and rec.tolerance == (1e-3, 1e-2)
    doc = linkage_document(lk)
    assert doc["poses"][2]["error"]["position"] < 1e-13 and doc["poses"][2]["tolerance"]["position"] == 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("k", [3, 4, 5, 8])
def test_random_crank_rocker_sweep(k):
    """Tasks from 25 random crank-rockers (seeded; 8 poses: in-plane noise and a tolerance), listed order:
    every one gives a four-bar, exact to rounding (closure always; poses for k <= 5)."""
    for seed in range(25):
        L = random_crank_rocker(np.random.default_rng(seed))
        T = coupler_poses(L, np.linspace(0.3, 0.3 + math.radians(220 if k <= 5 else 250), k), plane_seed=seed)[0]
        tol = None
        if k == 8:
            T, tol = noisy(T, np.random.default_rng(seed + 100), 2e-5, 2e-4), np.tile([1e-4, 1e-3], (8, 1))
        lk = fourbar_candidates(T, NAMES[:k], order=Order.LISTED, tolerance=tol)[0]
        assert lk.checks["max_closure_error"] < 1e-12
        assert k == 8 or lk.checks["max_pose_error"] < 1e-11


def test_python_api():
    import synth

    _, T, _, _ = task_poses(5)
    lk = synth.fourbar(T, min_transmission_deg=45.0)
    assert isinstance(lk, synth.Linkage) and lk.poses[3].name == "p3"
    assert lk.info.synthesis.fourbar.transmission_min_deg >= 45.0


def test_solve_fourbar_entry_point():
    """`synth.solve.solve_fourbar`: the task's file name in refusals, --top's ranked index, no design unless asked."""
    from synth.io.poses import load_poses
    from synth.solve import SynthesisOptions, solve_fourbar

    ps = load_poses(str(Path(__file__).resolve().parents[1] / "fixtures" / "fourbar_5.yaml"))
    r = solve_fourbar(ps, SynthesisOptions(top=2))
    assert r.index["format"] == "mpsynth.fourbar-index/1" and r.design is None
    assert [s.id for s in r.solutions][:1] == ["01-fourbar"] and r.linkage is r.solutions[0].linkage
    with pytest.raises(SynthesisError, match=r"fourbar_5.yaml: none of the"):
        solve_fourbar(ps, min_transmission_deg=89.0)


def test_drive_speed_ratio_follows_the_loop_law():
    """linkage.json's drive: the speed ratios of h2, k1, k2 are the loop law's (not the crank's own law)."""
    from synth.drive import follower_angles, speed_ratio

    _, T, _, _ = task_poses(5)
    lk = fourbar_candidates(T, NAMES[:5])[0]
    ratio, _ = speed_ratio(lk, "h1", 0.0, 2 * math.pi)
    phi = np.linspace(0.0, 2 * math.pi, 20001)
    ang, _ = follower_angles(lk, "h1", phi)
    numeric = np.max(np.abs(np.diff(ang, axis=0)), axis=0) / (phi[1] - phi[0])
    assert np.allclose(ratio, numeric, rtol=1e-3) and ratio[1] > 1.0
