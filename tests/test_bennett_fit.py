"""Bennett linkages for real tasks (synth.synthesis.bennett_fit, docs/fit.md): fits of many poses with
tolerances, exact poses, Hermite pairs, the listed order, and the end-to-end CLI with the verifier."""
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from synth.algebra.dq import dq_mul, dq_to_pose, normalize_dq, pose_to_dq
from synth.errors import SynthesisError
from synth.io.poses import load_poses
from synth.synthesis.bennett import bennett
from synth.synthesis.bennett_fit import bennett_task, hermite_conic
from synth.synthesis.fit import homogeneous, item_errors, study_rows, task_arrays
from synth.synthesis.fit_seeds import gauge_matrix, regauge
from synth.synthesis.taskfit import error_rows, visiting_order, visits_in_order
from synth.task import Order, PoseSet

from conftest import assert_verified, random_poses, run, write_pose_yaml

REPO = Path(__file__).resolve().parents[1]


# ------------------------------------------------------------------ a known Bennett motion
def known_motion(seed):
    """(C (3, 8) world, reference dq (8,)) of the Bennett linkage through three random poses, the first
    draw whose joints' speed ratio stays below a tenth of the accepted one (a fit of noisy samples moves
    the linkage a little; one near the limit the synthesis refuses is no target)."""
    from synth.synthesis.conditioning import TRANSMISSION_LIMIT, worst_pair

    rng = np.random.default_rng(seed)
    while True:
        try:
            L = bennett(random_poses(rng, 3))
        except SynthesisError:  # refused (e.g. its transmission): draw again
            continue
        if worst_pair(L)[0] <= 0.1 * TRANSMISSION_LIMIT:
            return L.motion, pose_to_dq(L.tool_ref)


def motion_poses(C, Q0, phi):
    """Poses (N, 4, 4) of the motion C(phi) Q0 (phi = 0: the reference)."""
    return dq_to_pose(normalize_dq(dq_mul(homogeneous(C[:2][None], np.asarray(phi, float)[None])[0], Q0)))


def twist_of(C, Q0, phi, h=1e-6):
    """(w, v): angular velocity and velocity of the tool origin of the motion C(phi) Q0 along phi, by
    central differences."""
    T, Tp, Tm = (motion_poses(C, Q0, [phi + d])[0] for d in (0.0, h, -h))
    W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ T[:3, :3].T
    return 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]), (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)


def sampled(seed, n, noise=0.0, exact=(0,), spread=(0.15, 0.85)):
    """n poses of a known motion in listed order (phi decreasing from pi: the first at the reference),
    rotated by ``noise`` rad and moved by ``noise`` (relative to the position spread) about random axes, but
    for the ``exact`` ones. Returns (poses, clean poses)."""
    rng = np.random.default_rng(1000 + seed)
    C, Q0 = known_motion(seed)
    phi = np.pi * (1 - np.r_[0.0, np.sort(rng.uniform(*spread, n - 1))])
    clean = motion_poses(C, Q0, phi)
    T = clean.copy()
    L = np.sqrt(np.mean(np.sum((T[:, :3, 3] - T[:, :3, 3].mean(0)) ** 2, 1)))
    for i in range(n):
        if i in exact:
            continue
        k = rng.normal(size=3)
        k /= np.linalg.norm(k)
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        T[i, :3, :3] = (np.eye(3) + math.sin(noise) * K + (1 - math.cos(noise)) * K @ K) @ T[i, :3, :3]
        T[i, :3, 3] += rng.normal(size=3) / math.sqrt(3) * noise * L
    return T, clean


def task(T, tol, exact=(), order=Order.ANY, velocity=None):
    n = len(T)
    tolerance = np.tile(np.asarray(tol, float), (n, 1))
    tolerance[list(exact)] = 0.0
    return PoseSet(names=[f"p{i}" for i in range(n)], matrices=T, tolerance=tolerance, order=order,
                   velocity=velocity)


def spread_of(T):
    return float(np.sqrt(np.mean(np.sum((T[:, :3, 3] - T[:, :3, 3].mean(0)) ** 2, 1))))


# ------------------------------------------------------------------ worked numbers
def test_visits_in_order_on_the_projective_line():
    assert visits_in_order([np.inf, 0.0, 1.0, 2.5])
    assert visits_in_order([np.inf, 3.0, -1.0, -2.0])  # the other way round
    assert not visits_in_order([np.inf, 0.0, 2.0, 1.0])
    assert visiting_order([np.inf, 2.0, -1.0, 0.5]) == (0, 2, 3, 1)


def test_regauge_keeps_the_motion_and_moves_the_parameters():
    C, Q0 = known_motion(3)
    phi = np.array([[0.0, 0.7, 1.9, 2.6]])
    M = gauge_matrix(phi[:, 1:])
    coef, ref, new = regauge(C[:2][None], Q0[None], phi, M)
    np.testing.assert_allclose(new[0, 1:], [0.0, np.pi / 2, np.pi / 4], atol=1e-12)  # items at t = inf, 0, 1
    before = motion_poses(C, Q0, phi[0])
    after = dq_to_pose(normalize_dq(dq_mul(homogeneous(coef, new)[0], ref[0])))
    np.testing.assert_allclose(after, before, atol=1e-12)
    assert np.abs(study_rows(coef)).max() < 1e-12


def test_hermite_conic_meets_both_poses_and_the_tangent():
    C, Q0 = known_motion(4)
    T = motion_poses(C, Q0, [0.0, 1.1])
    w, v = twist_of(C, Q0, 0.0)
    Q = pose_to_dq(T)
    H = hermite_conic(Q[0], Q[1], np.r_[w, v - np.cross(w, T[0, :3, 3])] * 3.0)  # any positive multiple
    assert np.abs(study_rows(H[None, :2])).max() < 1e-12
    np.testing.assert_allclose(motion_poses(H, Q[0], [np.pi / 2])[0], T[1], atol=1e-9)  # C(0) ~ pose 1
    e = item_errors(H[None, :2], Q[:1], np.array([[0.0]]),
                    task_arrays(Q[:1], T[:1, :3, 3], None, np.r_[w, v][None], 1.0))
    assert np.abs(e).max() < 1e-7  # same pose, same twist direction
    # Hermite data determine the motion: another pose of the known one lies on it
    from scipy.optimize import minimize_scalar

    other = motion_poses(C, Q0, [2.3])[0]
    miss = lambda p: np.linalg.norm(motion_poses(H, Q[0], [p])[0] - other)  # noqa: E731
    grid = np.linspace(0, np.pi, 721)
    p0 = grid[np.argmin([miss(p) for p in grid])]
    best = minimize_scalar(miss, bounds=(p0 - 0.01, p0 + 0.01), method="bounded", options={"xatol": 1e-13})
    assert best.fun < 1e-6  # (the tangent above is a finite difference)


# ------------------------------------------------------------------ fits
def test_clean_samples_are_met_to_rounding():
    T, _ = sampled(1, 8)
    lk = bennett_task(task(T, (1e-6 * spread_of(T), 1e-6)))[0]
    f = lk.info.fit
    assert f.method == "fit" and f.within_tolerance
    assert f.max_position_error <= 1e-9 * spread_of(T) and f.max_angle_error <= 1e-9
    assert lk.checks["max_closure_error"] <= 1e-9 * spread_of(T)


@settings(max_examples=6, deadline=None, derandomize=True, database=None)
@given(seed=st.integers(0, 10_000))
def test_noisy_samples_fit_within_the_tolerance(seed):
    _noisy_fit_within_tolerance(seed)


def test_noisy_samples_seed_9901_meets_its_exact_poses():
    _noisy_fit_within_tolerance(9901)


def _noisy_fit_within_tolerance(seed):
    T, _ = sampled(seed, 9, noise=1e-4, exact=(0, 5))
    tol = (2e-3 * spread_of(T), 2e-3)
    lk = bennett_task(task(T, tol, exact=(0, 5)))[0]
    f = lk.info.fit
    assert f.within_tolerance, f
    for i, rec in enumerate(lk.poses):
        if i in (0, 5):
            assert rec.exact and rec.error[0] <= 1e-9 * spread_of(T) and rec.error[1] <= 1e-9
        else:
            assert rec.error[0] <= tol[0] and rec.error[1] <= tol[1] and rec.tolerance == tol


def test_errors_are_what_forward_kinematics_measures():
    T, _ = sampled(7, 10, noise=3e-4, exact=(0, 9))
    lk = bennett_task(task(T, (5e-3 * spread_of(T), 5e-3), exact=(0, 9)))[0]
    for rec, target in zip(lk.poses, T):
        X = lk.tool_pose(rec.joint_angles)
        dt = np.linalg.norm(X[:3, 3] - target[:3, 3])
        dr = math.acos(min(1.0, (np.trace(X[:3, :3].T @ target[:3, :3]) - 1) / 2))
        assert rec.error[0] == pytest.approx(dt, abs=1e-12) and rec.error[1] == pytest.approx(dr, abs=1e-7)


def test_listed_order_kept_and_refused_when_impossible():
    T, _ = sampled(11, 8, noise=1e-4, exact=(0,))
    tol = (3e-3 * spread_of(T), 3e-3)
    lk = bennett_task(task(T, tol, exact=(0,), order=Order.LISTED))[0]
    assert visits_in_order([r.t for r in lk.poses])
    assert lk.info.fit.visit_order == tuple(f"p{i}" for i in range(8))
    shuffled = T[[0, 4, 1, 6, 2, 7, 3, 5]]
    with pytest.raises(SynthesisError, match="listed order"):
        bennett_task(task(shuffled, tol, exact=(0,), order=Order.LISTED))


def listed_task_with_close_poses(seed=5, noise=0.03):
    """8 poses of a known motion in listed order, poses 3 and 4 0.002 rad apart on it, the positions of all
    but pose 0 moved by ``noise`` spreads: the best fit in any order visits 4 before 3."""
    rng = np.random.default_rng(seed)
    C, Q0 = known_motion(seed)
    T = motion_poses(C, Q0, np.pi - np.array([0, 0.5, 0.9, 1.3, 1.302, 1.8, 2.2, 2.6]))
    L = spread_of(T)
    T[1:, :3, 3] += rng.normal(size=(7, 3)) * noise * L
    return T, (0.15 * L, math.radians(5))


def test_listed_order_is_a_constraint_of_the_fit(tmp_path):
    T, tol = listed_task_with_close_poses()
    free = bennett_task(task(T, tol, exact=(0,)))[0].info.fit.visit_order
    assert free == ("p0", "p1", "p2", "p4", "p3", "p5", "p6", "p7")  # (a filter on these fits finds none)
    lk = bennett_task(task(T, tol, exact=(0,), order=Order.LISTED))[0]
    assert visits_in_order([r.t for r in lk.poses]) and lk.info.fit.within_tolerance
    assert lk.info.fit.visit_order == tuple(f"p{i}" for i in range(8))
    text = write_pose_yaml(tmp_path / "t.yaml", T).read_text().replace("units: {length: m}", (
        f"units: {{length: m, angle: deg}}\norder: listed\ntolerance: {{position: {tol[0]!r}, angle: 5}}"))
    f = tmp_path / "t.yaml"
    f.write_text(text.replace("  - name: p0\n", "  - name: p0\n    exact: true\n"))
    r = run("bennett", f, "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    line = verify(f, tmp_path / "out")
    if line is not None:
        assert "order=listed" in line


def test_velocity_in_a_fit_is_met_exactly():
    C, Q0 = known_motion(12)
    phi = np.array([0.0, 2.8, 2.4, 2.0, 1.6, 1.2])
    T = motion_poses(C, Q0, phi)
    vel = np.full((6, 6), np.nan)
    vel[3] = -np.r_[twist_of(C, Q0, 2.0)]  # direction only (either sense)
    lk = bennett_task(task(T, (1e-3 * spread_of(T), 1e-3), velocity=vel))[0]
    assert lk.info.fit.max_position_error < 1e-9 * spread_of(T)


def test_more_than_five_points_are_fitted_within_tolerance():
    T, _ = sampled(31, 9, noise=1e-4, exact=(0,))
    pts = T.copy()
    pts[:, :3, :3] = np.eye(3)
    tol = np.tile([2e-3 * spread_of(T), np.inf], (9, 1))
    tol[0] = 0.0
    ps = PoseSet(names=[f"q{i}" for i in range(9)], matrices=pts, kinds=["point"] * 9, tolerance=tol)
    lk = bennett_task(ps)[0]
    assert lk.info.fit.within_tolerance and lk.poses[0].error[0] < 1e-9 * spread_of(T)
    for rec, target in zip(lk.poses, T):
        assert rec.kind == "point" and np.allclose(rec.matrix[:3, 3], target[:3, 3], atol=0)
        assert np.linalg.norm(lk.tool_pose(rec.joint_angles)[:3, 3] - target[:3, 3]) == pytest.approx(rec.error[0],
                                                                                                    abs=1e-12)


@pytest.mark.parametrize("seed", [31, 37])
def test_clean_points_are_met_to_rounding(seed):
    T, _ = sampled(seed, 9)  # (seed 31 took 86 Jacobians: the finish on the best seed)
    pts = T.copy()
    pts[:, :3, :3] = np.eye(3)
    ps = PoseSet(names=[f"q{i}" for i in range(9)], matrices=pts, kinds=["point"] * 9,
                 tolerance=np.tile([1e-6 * spread_of(T), np.inf], (9, 1)))
    f = bennett_task(ps)[0].info.fit
    assert f.within_tolerance and f.max_position_error <= 1e-9 * spread_of(T)


def test_random_poses_are_refused_with_the_failing_poses():
    T = random_poses(np.random.default_rng(5), 8)
    with pytest.raises(SynthesisError, match=r"tolerances not met at the best linkage found: pose \d"):
        bennett_task(task(T, (1e-4, 1e-4), exact=(0,)))
    lk = bennett_task(task(T, (1e-4, 1e-4), exact=(0,)), best_effort=True)[0]
    assert not lk.info.fit.within_tolerance and lk.info.fit.failing


def test_error_table_rows_in_input_units():
    T, _ = sampled(2, 6, noise=1e-4, exact=(0,))
    ps = task(T, (2e-3 * spread_of(T), math.radians(0.5)), exact=(0,))
    ps.length_unit, ps.length_scale = "mm", 1e-3
    lk = bennett_task(ps)[0]
    rows = error_rows(lk, ps)
    assert rows[0][0] == "0 p0" and rows[0][3] == "exact"
    assert rows[1][3].endswith("mm / 0.5 deg") and rows[1][1].endswith(" mm") and rows[1][2].endswith(" deg")


# ------------------------------------------------------------------ CLI end to end
def verify(poses, out):
    """The shared verifier's last line on the output (with the collision claim when fcl is installed), or
    None when it is absent."""
    col = json.loads((out / "linkage.json").read_text())["collision"]
    args = [poses, out]
    try:
        import fcl  # noqa: F401
        args += ["--collisions", repr(0.99 * col["clearance"]), "--collision-range", col["range"]]
    except ImportError:
        pass
    return assert_verified(*args)


@pytest.mark.parametrize("name", ["bennett_fit", "bennett_hermite", "bennett_points_fit"])
def test_fixture_end_to_end(name, tmp_path):
    fixture = REPO / "fixtures" / f"{name}.yaml"
    out = tmp_path / "out"
    r = run("bennett", fixture, "-o", out)
    assert r.exit_code == 0, r.output
    assert "position error" in r.output and "tolerance" in r.output
    doc = json.loads((out / "linkage.json").read_text())
    ps = load_poses(fixture, points=((3, None), "test"))
    for rec, tol in zip(doc["poses"], ps.tolerance if ps.tolerance is not None else [None] * len(ps)):
        assert "error" in rec
        assert rec.get("exact") is True or rec["tolerance"]["position"] == pytest.approx(tol[0])
    assert doc["info"]["fit"]["within_tolerance"]
    line = verify(fixture, out)
    if line is not None:
        assert ("order=listed" in line) == (name == "bennett_fit")
        assert ("velocity_err" in line) == (name == "bennett_hermite")


def test_unmet_tolerances_exit_1_and_best_effort_writes(tmp_path):
    text = (REPO / "fixtures" / "bennett_fit.yaml").read_text().replace(
        "tolerance: {position: 1.0, angle: 0.5}", "tolerance: {position: 0.01, angle: 0.005}")
    fixture = tmp_path / "tight.yaml"
    fixture.write_text(text)
    out = tmp_path / "out"
    r = run("bennett", fixture, "-o", out)
    assert r.exit_code == 1 and not out.exists()
    assert "tolerances not met" in r.output and "mm /" in r.output and len(r.output.strip().splitlines()) == 1
    r = run("bennett", fixture, "-o", out, "--best-effort", "-q")
    doc = json.loads((out / "linkage.json").read_text())
    assert r.exit_code == 0 and doc["within_tolerance"] is False and doc["info"]["fit"]["within_tolerance"] is False


def test_top_writes_ranked_fits(tmp_path):
    out = tmp_path / "out"
    r = run("bennett", REPO / "fixtures" / "bennett_fit.yaml", "--top", "2", "-o", out, "-q")
    assert r.exit_code == 0, r.output
    index = json.loads((out / "index.json").read_text())
    assert index["solutions"] and all((out / s["path"] / "linkage.json").exists() for s in index["solutions"])


def test_batch_job_with_task_keys():
    from synth.tools.batchjobs import run_job
    import yaml

    doc = yaml.safe_load((REPO / "fixtures" / "bennett_fit.yaml").read_text())
    res = run_job((1, json.dumps({"id": "t", "kind": "bennett", **doc})))
    assert res["ok"], res
    assert res["fit"]["within_tolerance"] and res["fit"]["visit_order"][0] == "pick"
    doc["tolerance"] = {"position": 0.001, "angle": 0.001}
    res = run_job((2, json.dumps({"id": "u", "kind": "bennett", **doc})))
    assert not res["ok"] and res["exit_code"] == 1 and "tolerances not met" in res["error"]


def test_python_api_takes_arrays_or_a_task_file():
    import synth

    T, _ = sampled(21, 7, noise=1e-4, exact=(0,))
    tol = np.tile([2e-3 * spread_of(T), 2e-3], (7, 1))
    tol[0] = 0
    lk = synth.fit(T, tolerance=tol, order="listed")[0]
    assert lk.info.fit.within_tolerance and lk.poses[0].exact
    fits = synth.fit(load_poses(REPO / "fixtures" / "bennett_fit.yaml"), top=2)
    assert fits and fits[0].info.fit.order == "listed"
    with pytest.raises(synth.InputError, match="order"):
        synth.fit(T, tolerance=tol, order="sorted")


def test_hermite_velocity_at_the_second_pose_and_three_toleranced_poses(tmp_path):
    C, Q0 = known_motion(41)
    T = motion_poses(C, Q0, [0.0, 1.3])
    vel = np.full((2, 6), np.nan)
    vel[1] = np.r_[twist_of(C, Q0, 1.3)]
    lk = bennett_task(PoseSet(names=["a", "b"], matrices=T, velocity=vel))[0]
    assert lk.info.fit.method == "hermite" and lk.poses[0].t == np.inf and lk.poses[1].t == 0.0
    assert max(r.error[0] for r in lk.poses) < 1e-9 * spread_of(T)
    # three poses with a tolerance: the exact synthesis, its (zero) misses recorded
    T3 = random_poses(np.random.default_rng(8), 3)
    lk = bennett_task(task(T3, (1e-3, 1e-3)))[0]
    assert lk.info.fit.method == "exact" and all(r.error[0] < 1e-9 and not r.exact for r in lk.poses)


def test_partial_velocity_constrains_its_half_only():
    C, Q0 = known_motion(13)
    phi = np.array([0.0, 2.8, 2.4, 2.0, 1.6, 1.2])
    T = motion_poses(C, Q0, phi)
    vel = np.full((6, 6), np.nan)
    vel[2, 3:] = twist_of(C, Q0, 2.4)[1]  # the tool origin's direction only
    lk = bennett_task(task(T, (1e-3 * spread_of(T), 1e-3), velocity=vel))[0]
    assert lk.info.fit.max_position_error < 1e-9 * spread_of(T)


@pytest.mark.parametrize("positions", [[[0, 0, 0]] * 4, [[i, 0, 0] for i in range(4)]],
                         ids=["coinciding", "translations"])
def test_degenerate_tasks_exit_1_with_the_reason(tmp_path, positions):
    import yaml

    items = [{"position": p, "rpy": [0, 0, 0]} for p in positions]
    f = tmp_path / "t.yaml"
    f.write_text(yaml.safe_dump({"tolerance": {"position": 0.01, "angle": 0.01}, "poses": items}))
    r = run("bennett", f, "-o", tmp_path / "o")
    assert r.exit_code == 1 and not (tmp_path / "o").exists()
    assert "every triple of poses is degenerate" in r.output and str(f) in r.output


def test_planar_and_spherical_tasks_of_more_than_three_poses_are_refused_with_the_way_out(tmp_path):
    import yaml

    items = [{"position": [40.0 * i, 10.0 * i * i, 0.0], "rpy": [0, 0, 20 * i]} for i in range(5)]
    f = tmp_path / "planar.yaml"
    f.write_text(yaml.safe_dump({"units": {"length": "mm", "angle": "deg"},
                                 "tolerance": {"position": 0.5, "angle": 0.5}, "poses": items}))
    r = run("bennett", f, "-o", tmp_path / "o")
    assert r.exit_code == 1 and not (tmp_path / "o").exists()
    assert "5 poses are planar" in r.output and "mpsynth fourbar" in r.output and str(f) in r.output
    rng = np.random.default_rng(3)  # rotations about one point c: x -> R (x - c) + c
    c = np.array([0.3, -0.2, 0.5])
    T = random_poses(rng, 4)
    T[:, :3, 3] = c - np.einsum("nij,j->ni", T[:, :3, :3], c)
    with pytest.raises(SynthesisError, match="4 poses are spherical"):
        bennett_task(task(T, (1e-3, 1e-3)))

