"""6R synthesis for over-determined tasks: fits of cubic motions (synth.synthesis.sixbar_fit), Hermite
interpolation (synth.synthesis.sixbar_hermite), the task dispatch and the CLI (docs/sixbar_fit.md). Poses come
from known 6R motions (tests/sixbar_motions.py), seeded."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sixbar_motions import poses_at, random_motion, twist_at
from synth.algebra.geometry import pose_difference
from synth.errors import InputError, SynthesisError
from synth.synthesis.conic import condition
from synth.synthesis.sixbar_hermite import hermite_candidates, hermite_members
from synth.synthesis.sixbar_task import sixbar_task, task_kind
from synth.synthesis.taskfit import visiting_order, visits_in_order
from synth.algebra.polynomial import norm_poly_full
from synth.task import Order, PoseSet

ROOT = Path(__file__).resolve().parents[1]
VERIFY = next((p / "shared/tools/verify_output.py" for p in (ROOT.parent, ROOT.parents[1])
               if (p / "shared/tools/verify_output.py").exists()), ROOT.parent / "shared/tools/verify_output.py")
TS8 = np.r_[np.inf, np.linspace(-2.0, 2.0, 7)]


def names(n):
    return [f"p{i}" for i in range(n)]


def spread(T):
    return float(condition(T)[1].scale)


def reached(lk):
    return np.array([lk.tool_pose(rec.joint_angles) for rec in lk.poses])


def noisy(T, rng, pos, ang):
    """Poses with Gaussian position noise (RMS ``pos``) and a rotation by ``ang`` about a random axis."""
    out = T.copy()
    for P in out[1:-1]:
        P[:3, 3] += rng.standard_normal(3) * pos / np.sqrt(3)
        a = rng.standard_normal(3)
        a /= np.linalg.norm(a)
        K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        P[:3, :3] = (np.eye(3) + np.sin(ang) * K + (1 - np.cos(ang)) * K @ K) @ P[:3, :3]
    return out


# ============================================================================ fits
def task(T, tol=None, vel=None, order=Order.ANY):
    return PoseSet(names=names(len(T)), matrices=np.asarray(T, float), tolerance=tol, velocity=vel, order=order,
                   source="task.yaml")


@pytest.mark.parametrize("seed", [1, 2])
def test_clean_poses_of_a_known_motion_are_fitted_to_rounding(seed):
    rng = np.random.default_rng(seed)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, TS8)
    tol = np.tile([1e-3, 1e-2], (8, 1)) * [spread(T), 1]
    lk = sixbar_task(task(T, tol))[0]
    dt, dr = pose_difference(reached(lk), T)
    assert dt.max() < 1e-9 * spread(T) and dr.max() < 1e-9
    assert lk.info.fit.max_position_error == pytest.approx(dt.max(), rel=1e-9, abs=1e-15)
    assert lk.checks["max_closure_error"] < 1e-9 * spread(T)


def test_noisy_poses_are_fitted_within_tolerance_and_the_exact_ones_exactly():
    rng = np.random.default_rng(7)
    C, X0 = random_motion(rng)
    T0 = poses_at(C, X0, TS8)
    L = spread(T0)
    T = noisy(T0, rng, 1e-4 * L, 1e-4)
    tol = np.tile([5e-4 * L, 5e-4], (8, 1))
    tol[[0, 7]] = 0.0  # exact: pick and place (noise-free)
    lks = sixbar_task(task(T, tol), top=2)
    for lk in lks:
        dt, dr = pose_difference(reached(lk), T)
        assert np.all(dt[1:7] <= 5e-4 * L * (1 + 1e-9)) and np.all(dr[1:7] <= 5e-4 * (1 + 1e-9))
        assert dt[[0, 7]].max() < 1e-9 * L and dr[[0, 7]].max() < 1e-9
        assert lk.info.fit.within_tolerance and lk.poses[0].exact and lk.poses[7].exact
        assert np.allclose([rec.error[0] for rec in lk.poses], dt, rtol=1e-9, atol=1e-15)
        assert lk.poses[3].tolerance == (tol[3, 0], tol[3, 1])


def test_exact_velocity_in_a_fit_is_met():
    rng = np.random.default_rng(11)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, [np.inf, -1.0, 0.0, 1.0, 2.0])
    L = spread(T)
    vel = np.full((5, 6), np.nan)
    vel[2] = twist_at(C, X0, 0.0)
    tol = np.tile([1e-3 * L, 1e-3], (5, 1))
    tol[2] = 0.0
    lk = sixbar_task(task(T, tol, vel))[0]
    have = twist_at(lk.motion, _dq(lk.tool_ref), lk.poses[2].t)
    cos = abs(have @ vel[2]) / np.linalg.norm(have) / np.linalg.norm(vel[2])
    assert np.degrees(np.arccos(min(1.0, cos))) < 1e-4


def _dq(T):
    from synth.algebra.dq import pose_to_dq

    return pose_to_dq(T)


def test_listed_order_is_kept_and_the_visiting_order_reported():
    rng = np.random.default_rng(3)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, TS8)
    tol = np.tile([1e-3, 1e-2], (8, 1)) * [spread(T), 1]
    lk = sixbar_task(task(T, tol, order=Order.LISTED))[0]
    ts = [rec.t for rec in lk.poses]
    assert visits_in_order(ts)
    assert lk.info.fit.visit_order == tuple(names(8)[i] for i in visiting_order(ts))
    # the same poses in another listed order: the fit is held to that order (hinge rows), so the best linkage
    # in it misses the swapped poses by far more than the tolerance
    with pytest.raises(SynthesisError, match=r'tolerances not met .*pose 1 \("p1"\) missed by 0\.\d+ m'):
        sixbar_task(task(T[[0, 2, 1, 3, 4, 5, 6, 7]], tol, order=Order.LISTED))


def test_unrealizable_tolerances_exit_with_the_failing_poses():
    rng = np.random.default_rng(2)
    T = np.array([np.eye(4)] * 8)
    for P in T:
        q = rng.standard_normal(4)
        w, x, y, z = q / np.linalg.norm(q)
        P[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
        P[:3, 3] = rng.standard_normal(3)
    tol = np.tile([1e-6, 1e-6], (8, 1))
    with pytest.raises(SynthesisError, match="tolerances not met at the best linkage found: pose"):
        sixbar_task(task(T, tol))
    lk = sixbar_task(task(T, tol), best_effort=True)[0]
    assert lk.info.fit.within_tolerance is False


def point_task(seed, n, noise=0.0):
    """n points (the first exact) of a known 6R motion at t = inf, -2 .. 2, positions moved by ``noise``
    spreads, tolerance max(5 noise, 1e-6) spreads; and the spread."""
    rng = np.random.default_rng(seed)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, np.r_[np.inf, np.linspace(-2.0, 2.0, n - 1)])
    L = spread(T)
    T[1:, :3, 3] += rng.standard_normal((n - 1, 3)) * noise * L
    T[:, :3, :3] = np.eye(3)
    tol = np.tile([max(5 * noise, 1e-6) * L, np.inf], (n, 1))
    tol[0] = 0.0
    return PoseSet(names=names(n), matrices=T, kinds=["point"] * n, tolerance=tol, source="task.yaml"), L


@pytest.mark.parametrize("seed, n", [(0, 9), (1, 12)])
def test_more_than_seven_clean_points_are_fitted_to_rounding(seed, n):
    ps, L = point_task(seed, n)
    lk = sixbar_task(ps)[0]
    f = lk.info.fit
    assert f.method == "fit" and f.within_tolerance and f.max_position_error <= 1e-9 * L
    assert all(rec.kind == "point" for rec in lk.poses) and lk.poses[0].exact


def test_noisy_points_are_fitted_within_tolerance():
    ps, L = point_task(2, 12, noise=1e-3)
    lk = sixbar_task(ps)[0]
    assert lk.info.fit.within_tolerance and lk.poses[0].error[0] <= 1e-9 * L
    for rec, target in zip(lk.poses, ps.matrices):
        assert rec.error[0] <= 5e-3 * L
        assert np.linalg.norm(lk.tool_pose(rec.joint_angles)[:3, 3] - target[:3, 3]) == pytest.approx(rec.error[0],
                                                                                                    abs=1e-12)


# ============================================================================ Hermite
@pytest.mark.parametrize("seed", [5, 6])
def test_hermite_pair_meets_both_poses_and_velocities(seed):
    rng = np.random.default_rng(seed)
    C, X0 = random_motion(rng)
    ts = [np.inf, 0.7]
    T = poses_at(C, X0, ts)
    V = np.stack([twist_at(C, X0, t) for t in ts])
    lk = hermite_candidates(T, V * [1, 1, 1, 1, 1, 1], ["a", "b"], top=1)[0]
    dt, dr = pose_difference(reached(lk), T)
    assert dt.max() < 1e-9 * spread(T) and dr.max() < 1e-9
    ref = _dq(lk.tool_ref)
    for rec, want in zip(lk.poses, V):
        have = twist_at(lk.motion, ref, rec.t)
        cos = abs(have @ want) / np.linalg.norm(have) / np.linalg.norm(want)
        assert np.degrees(np.arccos(min(1.0, cos))) < 1e-4


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000))
def test_hermite_members_are_motion_polynomials(seed):
    """Every member of the scan lies on the Study quadric (dual part of C C~ vanishes), relative 1e-9."""
    rng = np.random.default_rng(seed)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, [np.inf, rng.uniform(-2, 2)])
    V = np.stack([twist_at(C, X0, t) for t in (np.inf, 0.0)])
    Tc, cond = condition(T)
    V[:, 3:] /= cond.scale
    try:
        M, _ = hermite_members(Tc, V, 16)
    except SynthesisError:
        return
    F = norm_poly_full(M)
    scale = np.abs(F).max((-2, -1))
    assert np.all(np.abs(F[..., 4:]).max((-2, -1)) <= 1e-9 * scale)


# ============================================================================ dispatch
def test_task_kinds():
    T = np.array([np.eye(4)] * 4)
    assert task_kind(task(T)) == "exact"
    assert task_kind(task(T[:2], vel=np.ones((2, 6)))) == "hermite"
    assert task_kind(task(np.array([np.eye(4)] * 5))) == "fit"
    assert task_kind(task(T, tol=np.full((4, 2), 1e-3))) == "fit"
    with pytest.raises(InputError, match="a 6R linkage needs 4 poses"):
        task_kind(task(T[:3]))


def test_hermite_task_is_annotated_exact():
    rng = np.random.default_rng(5)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, [np.inf, 0.7])
    V = np.stack([twist_at(C, X0, t) for t in (np.inf, 0.7)])
    lk = sixbar_task(task(T, vel=V))[0]
    assert lk.info.fit.method == "hermite" and all(rec.exact for rec in lk.poses)
    assert max(rec.error[0] for rec in lk.poses) < 1e-9 * spread(T)


# ============================================================================ CLI end to end
def _has_error_claims() -> bool:
    from synth.linkage import PoseRecord

    return "error" in PoseRecord.__dataclass_fields__


@pytest.mark.parametrize("fixture, collisions", [("sixbar_fit.yaml", True), ("sixbar_hermite.yaml", False),
                                                 ("sixbar_points_fit.yaml", True),
                                                 pytest.param("sixbar_hermite.yaml", True, marks=pytest.mark.slow)])
def test_cli_fixture_verifies(tmp_path, fixture, collisions):
    """`mpsynth sixbar FIXTURE -o OUT` passes the shared verifier (tolerances, error claims, velocities,
    listed order), with ``collisions`` also the claimed clearance over the claimed range."""
    task = ROOT / "fixtures" / fixture
    out = tmp_path / "out"
    res = run("sixbar", task, "-o", out, "-q")
    assert res.exit_code == 0, res.output
    doc = json.loads((out / "linkage.json").read_text())
    assert doc["kind"] == "6r" and len(doc["poses"]) == len(_task_poses(task))
    import yourdfpy

    yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False)
    if not VERIFY.exists():
        pytest.skip("verify_output.py not found")
    if not _has_error_claims():
        pytest.skip("linkage.json poses[].error claims arrive with the fit branch")
    col = doc.get("collision") or {}
    args = [sys.executable, str(VERIFY), str(task), str(out)]
    if collisions and col.get("free"):  # the claimed clearance over the claimed range
        args += ["--collisions", f"{col['clearance']:.9g}"] + (["--collision-range", "task"]
                                                                if col["range"] == "task" else [])
    check = subprocess.run(args, capture_output=True, text=True, timeout=900)
    assert check.returncode == 0, check.stdout[-3000:]


def _task_poses(path):
    import yaml

    doc = yaml.safe_load(path.read_text())
    return doc.get("poses") or doc["points"]


def test_cli_unreachable_tolerance_exits_1_and_writes_nothing(tmp_path):
    text = (ROOT / "fixtures" / "sixbar_fit.yaml").read_text().replace("tolerance: {position: 0.5, angle: 0.25}",
                                                                      "tolerance: {position: 0.0001, angle: 0.0001}")
    task = tmp_path / "tight.yaml"
    task.write_text(text)
    out = tmp_path / "out"
    res = run("sixbar", task, "-o", out)
    assert res.exit_code == 1
    assert "tolerances not met at the best linkage found" in res.output and "via" in res.output
    assert not out.exists()


def run(*args):
    from click.testing import CliRunner

    from cli.main import mpsynth

    return CliRunner().invoke(mpsynth, [str(a) for a in args], catch_exceptions=False)


def test_batch_job_and_python_api_take_6r_tasks():
    import yaml

    import synth
    from synth.tools.batchjobs import run_job

    doc = yaml.safe_load((ROOT / "fixtures" / "sixbar_hermite.yaml").read_text())
    res = run_job((1, json.dumps({"id": "h", "kind": "sixbar", **doc})))
    assert res["ok"], res
    assert res["fit"]["method"] == "hermite" and res["fit"]["within_tolerance"]
    rng = np.random.default_rng(3)
    C, X0 = random_motion(rng)
    T = poses_at(C, X0, TS8)
    lk = synth.fit(T, tolerance=(1e-3 * spread(T), 1e-2), order="listed", kind="6r")[0]
    assert lk.kind == "6r" and lk.info.fit.method == "fit" and lk.info.fit.within_tolerance
    assert synth.fit(T, tolerance=(1e-3 * spread(T), 1e-2), kind="6r", top=2)[0].kind == "6r"
