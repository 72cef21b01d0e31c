"""End-to-end: `mpsynth fourbar` writes planar four-bars that yourdfpy, `mpsynth check`, the tools and the
shared verifier (with the collision claim) accept."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO, VERIFIER
from fourbar_tasks import coupler_poses, random_crank_rocker, yaml_text
from synth.errors import InputError
from synth.io.poses import load_poses
from test_cli_bennett import fk_check, run

FIX5 = REPO / "fixtures" / "fourbar_5.yaml"
FIXFIT = REPO / "fixtures" / "fourbar_fit.yaml"


@pytest.fixture
def verifier():
    """The shared verifier, or None on a plain copy of the repository (the tests check the rest without it)."""
    return VERIFIER if VERIFIER.exists() else None


def verify_claims(verifier, poses, out):
    """The shared verifier on OUT, with the collision claim of linkage.json when it claims freedom; its
    output, or None when the verifier is absent."""
    if verifier is None:
        return None
    col = json.loads((out / "linkage.json").read_text()).get("collision", {})
    extra = ["--collisions", repr(0.99 * col["clearance"]), "--collision-range", col["range"]] if col.get("free") else []
    r = subprocess.run([sys.executable, str(verifier), str(poses), str(out), *extra], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.strip().splitlines()[-1].startswith("verify OK")
    return r.stdout


def tilted_task(tmp_path, k, seed):
    L = random_crank_rocker(np.random.default_rng(seed))
    T, _, _ = coupler_poses(L, np.linspace(0.2, 0.2 + math.radians(200), k), plane_seed=seed, scale=0.1)
    path = tmp_path / f"fourbar_{k}.yaml"
    path.write_text(yaml_text(T))
    return path


def test_fixture_end_to_end(tmp_path, verifier):
    out = tmp_path / "out"
    r = run("fourbar", FIX5, "-o", out)
    assert r.exit_code == 0, r.output
    assert "planar four-bar (crank-rocker, driver h1)" in r.output and "design: collision-free" in r.output
    doc = json.loads((out / "linkage.json").read_text())
    assert doc["kind"] == "planar_fourbar" and doc["branches"] == [["h1", "h2"], ["k1", "k2"]]
    assert doc["collision"]["free"]
    fk_check(out, FIX5)
    report = verify_claims(verifier, FIX5, out)
    assert report is None or "collision_min" in report
    assert run("check", out, "--poses", FIX5).exit_code == 0


@pytest.mark.parametrize("k, seed", [(3, 11), (4, 12)])
def test_three_and_four_poses_in_a_tilted_plane(tmp_path, verifier, k, seed):
    task = tilted_task(tmp_path, k, seed)
    out = tmp_path / "out"
    r = run("fourbar", task, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    fk_check(out, task)
    verify_claims(verifier, task, out)


def test_top_writes_ranked_solutions(tmp_path):
    out = tmp_path / "out"
    r = run("fourbar", tilted_task(tmp_path, 4, 5), "--top", "2", "-o", out)
    assert r.exit_code == 0, r.output
    index = json.loads((out / "index.json").read_text())
    assert [s["id"] for s in index["solutions"]] == ["01-fourbar", "02-fourbar"]
    for s in index["solutions"]:
        assert run("check", out / s["id"]).exit_code == 0


def test_tools_on_a_fourbar(tmp_path):
    out = tmp_path / "out"
    assert run("fourbar", FIX5, "-o", out, "-q").exit_code == 0
    r = run("trajectory", out, "-o", tmp_path / "traj.json")
    assert r.exit_code == 0, r.output
    traj = json.loads((tmp_path / "traj.json").read_text())
    h2 = np.array(traj["angles"]["h2"])
    assert np.ptp(h2) > math.pi  # h2 turns fully against the crank (not a copy of h1)
    t = np.array(traj["time"])
    for j in ("h2", "k1", "k2"):  # the velocities are the angles' time derivatives
        v, a = np.array(traj["velocities"][j]), np.array(traj["angles"][j])
        assert np.allclose(np.gradient(a, t)[2:-2], v[2:-2], atol=2e-2 * np.abs(v).max())
    r = run("render", out, "--png", tmp_path / "f.png")
    assert r.exit_code == 0 and (tmp_path / "f.png").stat().st_size > 0
    r = run("view", out, "-o", tmp_path / "f.html")
    assert r.exit_code == 0 and (tmp_path / "f.html").stat().st_size > 0


def test_simulate_follows_the_loop_law(tmp_path):
    pytest.importorskip("mujoco")
    out = tmp_path / "out"
    assert run("fourbar", FIX5, "-o", out, "-q").exit_code == 0
    r = run("simulate", out)  # every joint within --tol (1e-3 rad) of the loop law's exact motion
    assert r.exit_code == 0, r.output


def test_fit_fixture(tmp_path, verifier):
    try:
        ps = load_poses(str(FIXFIT))
    except InputError as e:
        pytest.skip(f"the task reader does not know tolerances yet ({e})")
    assert ps.tolerance is not None
    out = tmp_path / "out"
    r = run("fourbar", FIXFIT, "-o", out)
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "linkage.json").read_text())
    assert all(p["error"]["position"] <= 1e-4 for p in doc["poses"])
    verify_claims(verifier, FIXFIT, out)


def test_non_coplanar_exit_2_nothing_written(tmp_path):
    T = load_poses(str(FIX5)).matrices.copy()
    T[2, :3, :3] = T[2, :3, :3] @ np.array([[1, 0, 0], [0, math.cos(0.1), -math.sin(0.1)],
                                            [0, math.sin(0.1), math.cos(0.1)]])
    task = tmp_path / "bent.yaml"
    task.write_text(yaml_text(T))
    out = tmp_path / "out"
    r = run("fourbar", task, "-o", out)
    assert r.exit_code == 2
    assert "pose 2 (p2) is not in the plane of motion" in r.output and "deg off the common normal" in r.output
    assert not out.exists()


def test_two_poses_exit_2(tmp_path):
    T = load_poses(str(FIX5)).matrices[:2]
    task = tmp_path / "two.yaml"
    task.write_text(yaml_text(T))
    r = run("fourbar", task)
    assert r.exit_code == 2 and "3" in r.output


def test_velocity_beyond_five_conditions_refused(tmp_path):
    """Five poses and a velocity: six exact conditions, more than a four-bar meets (exit 2, with the count);
    a velocity without its linear part: exit 2 (tests/test_fourbar_hermite.py has the accepted ones)."""
    text = FIX5.read_text().replace("  - name: grip\n", "  - name: grip\n    velocity: {angular: [0, 0, 1]}\n")
    task = tmp_path / "vel.yaml"
    task.write_text(text)
    r = run("fourbar", task)
    assert r.exit_code == 2 and "at most 5 conditions" in r.output and "5 poses and 1 velocities" in r.output
    lines = text.splitlines(keepends=True)
    cut = [i for i, line in enumerate(lines) if line.startswith("  - name:")][4]
    task.write_text("".join(lines[:cut]))  # four poses: five conditions
    r = run("fourbar", task)
    assert r.exit_code == 2 and "needs both 'angular' and 'linear'" in r.output


def test_min_transmission_option(tmp_path):
    """--min-transmission: outside 0..90 degrees a usage error; 89 degrees, which no four-bar through the
    fixture's poses keeps, exit 1 with nothing written."""
    r = run("fourbar", FIX5, "--min-transmission", "95")
    assert r.exit_code == 2 and "--min-transmission" in r.output
    out = tmp_path / "out"
    r = run("fourbar", FIX5, "--min-transmission", "89", "-o", out)
    assert r.exit_code == 1, r.output
    assert not out.exists()
