"""`mpsynth simulate`: PyBullet and MuJoCo follow the exact motion of a fixture Bennett and a fixture 6R
within 1e-3 rad. Engine tests skip only when the engine cannot be imported."""
from __future__ import annotations

import importlib.util
import json
import os
import xml.etree.ElementTree as ET

import pytest

from conftest import REPO, run

BENNETT = REPO / "fixtures" / "bennett_quat.yaml"
SIXBAR = REPO / "fixtures" / "sixbar_example.yaml"


def needs(engine):
    return pytest.mark.skipif(importlib.util.find_spec(engine) is None, reason=f"{engine} is not installed")


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    base = tmp_path_factory.mktemp("sim")
    made = {}
    r = run("bennett", BENNETT, "-o", base / "bennett", "-q")
    assert r.exit_code == 0, r.output
    made["bennett"] = base / "bennett"
    if importlib.util.find_spec("cli.sixbar") is not None:
        r = run("sixbar", SIXBAR, "-o", base / "sixbar", "-q")
        assert r.exit_code == 0, r.output
        made["6r"] = base / "sixbar"
    return made


def simulate_json(out, engine, *extra):
    r = run("simulate", out, "--engine", engine, "--json", "-q", *extra)
    assert r.exit_code in (0, 1), r.output
    return r, json.loads(r.stdout)


@pytest.mark.parametrize("engine", [pytest.param("pybullet", marks=needs("pybullet")),
                                    pytest.param("mujoco", marks=needs("mujoco"))])
@pytest.mark.parametrize("kind", ["bennett", "6r"])
def test_engine_follows_exact_motion(outputs, engine, kind):
    if kind not in outputs:
        pytest.skip("mpsynth sixbar is not available")
    r, res = simulate_json(outputs[kind], engine)
    assert res["engine"] == engine
    assert res["steps"] >= 1000
    assert res["max_joint_deviation"] < 1e-3, res
    assert res["max_closure_gap"] < 2e-4, res  # metres, for linkages about 0.5 m across
    assert res["max_closure_angle"] < 5e-4, res
    # the exported URDF already shares the coupler mass with coupler_k, so no split is needed here
    assert res["driver"] == "h1" and res["shared_inertial"] == []
    assert r.exit_code == 0 and res["ok"]


@needs("mujoco")
def test_export_mjcf_loads_anywhere(outputs, tmp_path, monkeypatch):
    import mujoco

    dest = tmp_path / "models" / "bennett.xml"
    dest.parent.mkdir()
    r = run("simulate", outputs["bennett"], "--engine", "mujoco", "--seconds", "0.2", "--tol", "1", "-q",
            "--export-mjcf", dest)
    assert r.exit_code == 0, r.output
    root = ET.parse(dest).getroot()
    weld = root.find("equality/weld")
    assert (weld.get("body1"), weld.get("body2"), weld.get("name")) == ("coupler", "coupler_k", "loop_closure")
    assert len(root.findall("contact/exclude")) == 45  # 10 bodies (base, 2 links, coupler, tool, coupler_k, 4 pins)
    assert {m.get("scale") for m in root.iter("mesh")} == {"0.001 0.001 0.001"}
    assert all(not os.path.isabs(m.get("file")) for m in root.iter("mesh"))
    assert root.find("actuator/position").get("joint") == "h1"
    monkeypatch.chdir(tmp_path)  # mesh paths are relative to the MJCF file, not to the working directory
    model = mujoco.MjModel.from_xml_path(str(dest))
    assert model.neq == 1 and model.njnt == 4 and model.nu == 1
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert abs(data.efc_pos[:data.nefc]).max() < 1e-12  # the weld holds at all-zero angles
    # the torquescale the run used (weld_torquescales: the angular rows as stiff as MuJoCo's impedance says)
    from synth.tools.sim import load_setup
    from synth.tools.sim.mujoco_sim import export_torquescales

    ts = float(weld.get("torquescale"))
    assert ts > 1 and model.eq_data[0, 10] == ts and [ts] == list(export_torquescales(load_setup(outputs["bennett"])))


def test_export_mjcf_without_mujoco_run(outputs, tmp_path):
    """--export-mjcf writes the file even when the run uses PyBullet (or PyBullet is missing)."""
    dest = tmp_path / "m.xml"
    run("simulate", outputs["bennett"], "--engine", "pybullet", "--seconds", "0.05", "-q", "--export-mjcf", dest)
    root = ET.parse(dest).getroot()
    assert root.tag == "mujoco"
    mujoco_there = importlib.util.find_spec("mujoco") is not None  # it sets the weld's torquescale, else 1
    assert (float(root.find("equality/weld").get("torquescale")) > 1) == mujoco_there


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_engine_not_installed_exits_2(outputs, engine, monkeypatch):
    import synth.tools.sim as sim

    real = importlib.util.find_spec
    monkeypatch.setattr(sim.importlib.util, "find_spec", lambda name, *a: None if name == engine else real(name, *a))
    r = run("simulate", outputs["bennett"], "--engine", engine)
    assert r.exit_code == 2
    assert f"{engine} is not installed: pip install 'mpsynth[sim]'" in r.stderr


def test_bad_input_exits_2(tmp_path, outputs):
    r = run("simulate", tmp_path / "missing", "--engine", "mujoco")
    assert r.exit_code == 2 and "no such output directory" in r.stderr
    r = run("simulate", outputs["bennett"], "--engine", "mujoco", "--seconds", "-1")
    assert r.exit_code == 2
    r = run("simulate", outputs["bennett"], "--engine", "bullet")
    assert r.exit_code == 2


@needs("pybullet")
def test_pybullet_failure_is_one_line(outputs, tmp_path):
    """A model PyBullet cannot load fails in the child process and comes back as one line, exit 1."""
    import shutil

    out = tmp_path / "broken"
    shutil.copytree(outputs["bennett"], out)
    (out / "meshes" / "link_h1.stl").unlink()
    r = run("simulate", out, "--engine", "pybullet")
    assert r.exit_code == 1
    assert r.stderr.count("\n") == 1 and "pybullet" in r.stderr


@needs("pybullet")
def test_pybullet_crash_is_reported(outputs, monkeypatch):
    """A child process killed by a signal (as a crashing engine is) gives exit 1 and a message."""
    import subprocess

    import synth.tools.sim.pybullet_sim as pb

    real = subprocess.Popen

    def crashing(cmd, **kw):
        return real([cmd[0], "-c", "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)"], **kw)

    monkeypatch.setattr(pb.subprocess, "Popen", crashing)
    r = run("simulate", outputs["bennett"], "--engine", "pybullet")
    assert r.exit_code == 1 and "pybullet crashed (signal 11)" in r.stderr
