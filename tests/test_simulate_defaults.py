"""`mpsynth simulate` defaults per linkage: a slower turn for several loops (welds in series), MuJoCo by
default, and a failure message that says what to change."""
from __future__ import annotations

import importlib.util
import json

import pytest

from synth.tools.sim.pybullet_sim import residual_threshold
from synth.tools.sim.run import advice, default_seconds

from conftest import REPO, run


def test_default_seconds_grow_with_the_loops():
    assert default_seconds(1) == 2.0 and default_seconds(3) == 12.0 and default_seconds(4) == 16.0


def test_advice_names_the_option_to_change():
    res = {"max_joint_deviation": 4e-3, "timestep": 5e-4, "max_closure_gap": 9e-5}
    msg = advice(res, "mujoco", 1e-3, 2.0, 3)
    assert "--seconds 16" in msg and "--timestep" in msg
    assert "--engine mujoco" in advice(res, "pybullet", 1e-3, 12.0, 3)
    assert "--seconds" in advice(res, "pybullet", 1e-3, 2.0, 1)


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["curve_ellipse.yaml", "motion_elliptic.yaml"])
def test_curve_fixtures_pass_simulate_with_the_defaults(tmp_path, fixture):
    """The shipped curve fixtures pass `mpsynth simulate OUT` with no option (MuJoCo, 4 s per loop)."""
    if importlib.util.find_spec("mujoco") is None:
        pytest.skip("mujoco is not installed")
    out = tmp_path / "o"
    assert run("curve", REPO / "fixtures" / fixture, "-o", out, "-q").exit_code in (0,)
    r = run("simulate", out, "--json", "-q")
    res = json.loads(r.stdout)
    assert r.exit_code == 0 and res["engine"] == "mujoco" and res["max_joint_deviation"] < 1e-3, res


def test_pybullet_tightens_its_solver_for_several_loops():
    assert residual_threshold(1) == 1e-7 and residual_threshold(3) == residual_threshold(4) == 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["curve_ellipse.yaml", "motion_elliptic.yaml"])
def test_curve_fixtures_pass_simulate_in_pybullet_with_the_defaults(tmp_path, fixture):
    """`mpsynth simulate OUT --engine pybullet` with no other option passes on the curve fixtures (3 and 4
    loops; measured 3.8e-4 and 7.2e-4 rad, about 20 s and 30 s CPU)."""
    if importlib.util.find_spec("pybullet") is None:
        pytest.skip("pybullet is not installed")
    out = tmp_path / "o"
    assert run("curve", REPO / "fixtures" / fixture, "-o", out, "-q").exit_code == 0
    r = run("simulate", out, "--engine", "pybullet", "--json", "-q")
    res = json.loads(r.stdout)
    assert r.exit_code == 0 and res["engine"] == "pybullet" and res["max_joint_deviation"] < 1e-3, res
    assert res["residual_threshold"] == 1e-12 and res["loops"] > 1


def test_default_engine_is_mujoco(tmp_path):
    if importlib.util.find_spec("mujoco") is None:
        pytest.skip("mujoco is not installed")
    out = tmp_path / "o"
    assert run("bennett", REPO / "fixtures" / "bennett_quat.yaml", "-o", out, "-q").exit_code == 0
    r = run("simulate", out, "--json", "-q", "--seconds", "0.2", "--tol", "1")
    assert r.exit_code == 0 and json.loads(r.stdout)["engine"] == "mujoco"


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_planar_four_bar_passes_with_the_defaults(tmp_path, engine):
    """The planar fixture's anti-parallelogram passes its flat configurations, where some joints turn
    several times faster than the driver: with no --seconds, a default turn that deviates is retried,
    slower (and with PyBullet's tight solver threshold), and the run passes."""
    if importlib.util.find_spec(engine) is None:
        pytest.skip(f"{engine} is not installed")
    out = tmp_path / "o"
    assert run("bennett", REPO / "fixtures" / "bennett_planar.yaml", "-o", out, "-q").exit_code == 0
    r = run("simulate", out, "--engine", engine, "--json", "-q")
    assert r.exit_code == 0, r.output
    res = json.loads(r.output)
    assert res["ok"] and res["max_joint_deviation"] <= 1e-3
    if "retried" in res:
        assert res["retried"]["max_joint_deviation"] > 1e-3 and res["seconds"] > res["retried"]["seconds"]
    # an explicit --seconds is never changed
    r = run("simulate", out, "--engine", engine, "--seconds", "2", "--json", "-q")
    assert json.loads(r.output)["seconds"] == 2 and "retried" not in json.loads(r.output)


def test_pybullet_gives_welds_in_series_more_solver_iterations():
    from synth.tools.sim.pybullet_sim import solver_iterations

    assert solver_iterations(1) == solver_iterations(2) == 3000 and solver_iterations(5) == 6000
