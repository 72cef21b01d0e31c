"""`mpsynth check` through branch crossings (synth/tools/check/continuation.py, docs/exceptional.md section 6): a 7R
Darboux member with six singular configurations, where the continuation used to leave the motion for another
branch at 45 degrees, is followed on its laws' motion and the crossing reported; a wrong angle law or a moved
axis still fails."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

from cli.main import mpsynth
from linkage_fixtures import move_urdf_axis
from synth.algebra.expr import parse_polynomial
from synth.tools.check.continuation import continue_loop, law_angles
from synth.design.choose import design_for
from synth.io.urdfmodel import read_urdf
from synth.io.writer import write_output
from synth.synthesis.darboux import darboux_linkage

GENERAL = "(t^2 + 1)*(t - k) + eps*(i + k/2 - (j + k/2)*t)*(t - k)"  # fixtures/motion_darboux_general.yaml
OTHERS = ["h2", "h3", "k1", "k2", "k3", "k4"]


@pytest.fixture(scope="module")
def member_out(tmp_path_factory):
    """The member turn 5 pi / 8, 3R shift -0.51 e1 (six singular configurations)."""
    C = np.array(parse_polynomial(GENERAL), float)
    lk = darboux_linkage(C, turn=5 * np.pi / 8, shift=(-0.51, 0.0), check_samples=40)
    assert len(lk.info.synthesis.darboux.singular_t) == 6
    out = tmp_path_factory.mktemp("cross") / "d7"
    write_output(lk, out, robot_name="d7", result=design_for(lk, ranges=("full",), full_work=1e7))
    return out


def _laws(out):
    doc = json.loads((out / "linkage.json").read_text())
    return ({j["name"]: (j["angle_law"]["a"], j["angle_law"]["b"]) for j in doc["joints"]},
            {j["name"]: j["angle_law"].get("rate", 1) for j in doc["joints"]})


def test_check_follows_the_laws_through_the_crossing(member_out):
    r = CliRunner().invoke(mpsynth, ["check", str(member_out), "--no-meshes", "--json"])
    doc = json.loads(r.stdout)
    assert r.exit_code == 0 and doc["ok"], doc["problems"]
    cont = doc["figures"]["continuation"]
    assert cont["max_deviation_from_laws"] < 1e-8 and cont["return_error"] < 1e-8
    assert cont["branch_crossings_deg"] and all(any(abs(c - s) < 0.01 for s in (45, 135, 225, 315))
                                                for c in cont["branch_crossings_deg"])
    r = CliRunner().invoke(mpsynth, ["check", str(member_out), "--no-meshes"])
    assert "branch crossing(s) passed on the laws' motion at h1 = 45 deg" in r.output


def test_unguided_continuation_leaves_the_motion_guided_one_does_not(member_out):
    """Without the laws the continuation takes the other branch at 45 degrees (and ends a half turn off);
    with them it re-seeds there, once, on a configuration that closes the loop."""
    u = read_urdf(member_out / "linkage.urdf")
    laws, rates = _laws(member_out)
    cl = [("coupler", "coupler_k")]
    free = continue_loop(u, cl, "h1", OTHERS, length=0.774)
    end = np.array(free["path"][-1][1:])
    assert free["followed"] == 1.0 and np.abs((end + np.pi) % (2 * np.pi) - np.pi).max() > 1.0

    def guide(p):
        ex = law_angles(laws, "h1", np.array([p]), rates)
        return np.array([ex[j][0] for j in OTHERS])

    res = continue_loop(u, cl, "h1", OTHERS, length=0.774, guide=guide)
    path = np.array(res["path"])
    ex = law_angles(laws, "h1", path[:, 0], rates)
    dev = max(np.abs((path[:, k + 1] - ex[j] + np.pi) % (2 * np.pi) - np.pi).max() for k, j in enumerate(OTHERS))
    assert res["followed"] == 1.0 and dev < 1e-7 and res["max_residual"] < 1e-8
    assert len(res["crossings"]) >= 1 and all(c["conditioning"] < 1e-6 for c in res["crossings"])
    assert abs(np.degrees(res["crossings"][0]["angle"]) - 45) < 1e-3


def test_a_wrong_guide_is_dropped_not_followed(member_out):
    """A guide off the linkage's motion away from a rank drop is dropped: no re-seed, the path is the
    linkage's own (it leaves the wrong guide)."""
    u = read_urdf(member_out / "linkage.urdf")
    laws, rates = _laws(member_out)
    laws["k3"] = (laws["k3"][0], laws["k3"][1] * 1.001)

    def guide(p):
        ex = law_angles(laws, "h1", np.array([p]), rates)
        return np.array([ex[j][0] for j in OTHERS])

    res = continue_loop(u, [("coupler", "coupler_k")], "h1", OTHERS, length=0.774, guide=guide)
    assert res["crossings"] == [] and res["followed"] == 1.0


@pytest.fixture
def copy(member_out, tmp_path):
    dst = tmp_path / "out"
    shutil.copytree(member_out, dst)
    return dst


def _problems(out):
    r = CliRunner().invoke(mpsynth, ["check", str(out), "--no-meshes"])
    assert r.exit_code == 1, r.output
    return r.output


def test_wrong_angle_law_of_the_member_fails(copy):
    doc = json.loads((copy / "linkage.json").read_text())
    for j in doc["joints"]:
        if j["name"] == "k3":
            j["angle_law"]["b"] *= 1.001
    (copy / "linkage.json").write_text(json.dumps(doc))
    msg = _problems(copy)
    assert "open along the angle laws' motion" in msg and "deviates from the angle laws" in msg


def test_wrong_rate_of_the_member_fails(copy):
    doc = json.loads((copy / "linkage.json").read_text())
    for j in doc["joints"]:
        if j["name"] == "k2":
            j["angle_law"]["rate"] = 1
    (copy / "linkage.json").write_text(json.dumps(doc))
    assert "deviates from the angle laws" in _problems(copy)


def test_moved_axis_of_the_member_fails(copy):
    move_urdf_axis(copy / "linkage.urdf", "k3")
    msg = _problems(copy)
    assert "open" in msg and ("stuck" in msg or "deviates from the angle laws" in msg)


# ------------------------------------------------------------------------------ simulate near crossings
def test_advice_blames_a_nearby_singular_configuration():
    from synth.tools.sim.run import advice, near_singular

    res = {"max_joint_deviation": 2e-3, "timestep": 5e-4, "max_closure_gap": 1e-6, "worst_joint": "k3",
           "driver": "h1", "worst_driver_angle": np.radians(309.0), "singular_driver_deg": [45.0, 307.1, 315.0]}
    assert near_singular(res) == 307.1
    msg = advice(res, "mujoco", 1e-3, 2.0, 1)
    assert "next to a singular configuration (h1 = 307 deg" in msg and "--seconds 8" in msg
    res["worst_driver_angle"] = np.radians(200.0)  # far from every one: the usual advice
    assert near_singular(res) is None and "singular" not in advice(res, "mujoco", 1e-3, 2.0, 1)
    del res["singular_driver_deg"]
    assert near_singular(res) is None


def test_simulate_too_fast_says_why(member_out):
    """A turn too fast for the member's crossings: the failure names the singular configuration next to
    the worst deviation and the slower turn to try (MuJoCo, 0.5 s: 1.7e-3 rad at h1 = 354 deg; 1 s passes
    with 8.9e-4 rad since the weld's torquescale, measured)."""
    import importlib.util

    if importlib.util.find_spec("mujoco") is None:
        pytest.skip("mujoco is not installed")
    r = CliRunner().invoke(mpsynth, ["simulate", str(member_out), "--seconds", "0.5"])
    assert r.exit_code == 1
    assert "is next to a singular configuration (h1 = " in r.output and "try a slower turn (--seconds" in r.output


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_fixture_output_simulates_with_the_defaults(tmp_path, engine):
    """`mpsynth curve fixtures/motion_darboux_general.yaml` then `mpsynth simulate OUT` with no option passes
    (measured: MuJoCo 9.0e-4 rad at 2 s; PyBullet retried at 16 s, 5.8e-4 rad)."""
    import importlib.util

    from conftest import REPO

    if importlib.util.find_spec(engine) is None:
        pytest.skip(f"{engine} is not installed")
    out = tmp_path / "o"
    r = CliRunner().invoke(mpsynth, ["curve", str(REPO / "fixtures/motion_darboux_general.yaml"), "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(mpsynth, ["simulate", str(out), "--engine", engine, "--json", "-q"])
    res = json.loads(r.stdout)
    assert r.exit_code == 0 and res["max_joint_deviation"] < 1e-3, res
