"""`mpsynth trajectory`: joint angles and velocities from the angle laws, checked against the written URDF
(yourdfpy), finite differences, and the collision-free range recorded in linkage.json."""
from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.design.model import CollisionReport
from synth.design.search import task_range
from synth.io.poses import load_poses
from synth.io.readback import read_output
from synth.io.urdf import driver_limits
from synth.io.writer import write_output
from synth.synthesis.bennett import bennett
from synth.synthesis.sixbar import sixbar
from synth.tools.trajectory import follower_angles, plan, quintic

from conftest import REPO, run
from linkage_fixtures import bennett_linkage
from test_design_export import straight_result

TWO_PI = 2 * math.pi


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """Two outputs written without the design search: the Bennett of bennett_mm_deg.yaml with a
    task-range claim (driver h1 limited in the URDF) and the 6R of sixbar_example.yaml with a full one."""
    root = tmp_path_factory.mktemp("traj")
    ps = load_poses(str(REPO / "fixtures" / "bennett_mm_deg.yaml"))
    lk = bennett(ps.matrices, ps.names)
    _, lo, hi = task_range(lk)
    rep = CollisionReport(True, "task", 1e-3, 2e-3, "h1", (lo, hi), certified=True)
    write_output(lk, root / "b", robot_name="b", result=straight_result(lk, rep))
    ps6 = load_poses(str(REPO / "fixtures" / "sixbar_example.yaml"))
    lk6 = sixbar(ps6.matrices, ps6.names)
    rep6 = CollisionReport(True, "full", 1e-3, 2e-3, "h1", (0.0, TWO_PI), certified=True)
    write_output(lk6, root / "s", robot_name="s", result=straight_result(lk6, rep6))
    return {"bennett": root / "b", "sixbar": root / "s"}


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def urdf_tool(out, names, angles):
    yourdfpy = pytest.importorskip("yourdfpy")
    urdf = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False, build_collision_scene_graph=False)
    res = []
    for row in angles:
        urdf.update_cfg({n: float(v) for n, v in zip(names, row) if n in urdf.actuated_joint_names})
        res.append(urdf.get_transform("tool", "base"))
    return np.array(res)


@pytest.mark.parametrize("which,driver", [("bennett", None), ("sixbar", None), ("sixbar", "k2")])
def test_through_poses_reach_every_task_pose_in_the_urdf(tmp_path, outputs, which, driver):
    """Every task pose is held during its rest: yourdfpy's base->tool at the CSV angles of those rows
    equals the pose of linkage.json to 1e-9 relative, and the CSV's tool columns agree with yourdfpy."""
    out = outputs[which]
    f = tmp_path / "t.csv"
    args = ["trajectory", out, "--through-poses", "--dwell", "0.1", "--duration", "3", "--rate", "50", "-o", f, "-q"]
    r = run(*args, *(["--driver", driver] if driver else []))
    assert r.exit_code == 0, r.output
    head, rows = read_csv(f)
    names = [h.removesuffix("_angle_rad") for h in head if h.endswith("_angle_rad")]
    ang = np.array([[float(x) for x in row[1:1 + len(names)]] for row in rows])
    t = np.array([float(row[0]) for row in rows])
    assert np.allclose(np.diff(t), 1 / 50) and t[-1] == pytest.approx(3.0)
    M = urdf_tool(out, names, ang)
    doc = json.loads((out / "linkage.json").read_text())
    scale = max(1.0, max(np.abs(np.array(p["matrix"])[:3, 3]).max() for p in doc["poses"]))
    seen = set()
    for i, row in enumerate(rows):
        if row[-1]:
            P = np.array(next(p["matrix"] for p in doc["poses"] if p["name"] == row[-1]))
            assert np.abs(M[i] - P).max() <= 1e-9 * scale, (row[-1], np.abs(M[i] - P).max())
            seen.add(row[-1])
    assert seen == {p["name"] for p in doc["poses"]}
    pos = np.array([[float(x) for x in row[-8:-5]] for row in rows])
    assert np.abs(pos - M[:, :3, 3]).max() <= 1e-9 * scale


def test_velocities_agree_with_finite_differences(outputs):
    """Central differences of the angles at 2 kHz match the analytic velocities (through-poses law: the
    quintic's velocity too), and the rests have zero velocity."""
    rb = read_output(outputs["sixbar"])
    for kw in ({"through_poses": True, "dwell": 0.05, "duration": 2.0}, {"span": "full", "duration": 2.0}):
        tr = plan(rb, rate=2000.0, **kw)
        fd = (tr.angles[2:] - tr.angles[:-2]) / (tr.time[2:, None] - tr.time[:-2, None])
        top = np.abs(tr.velocities).max()
        assert np.abs(fd - tr.velocities[1:-1]).max() <= 2e-3 * top
        assert np.all(tr.velocities[tr.pose_index >= 0] == 0) if kw.get("through_poses") else True


def test_the_urdf_limits_hold_the_task_range_trajectory(outputs):
    """A task-range claim: the default range is that arc (the driver stays within the URDF limits), and a
    different driver (k1) gets the same configurations, so h1 stays within them too."""
    rb = read_output(outputs["bennett"])
    _, lo, hi = driver_limits(rb.document["collision"])
    k = rb.linkage.joints.index(rb.linkage.joint("h1"))
    for driver in ("h1", "k1", "h2"):
        tr = plan(rb, driver=driver, rate=200.0, duration=1.0)
        assert lo - 1e-9 <= tr.angles[:, k].min() and tr.angles[:, k].max() <= hi + 1e-9
        assert tr.angles[:, k].max() - tr.angles[:, k].min() == pytest.approx(hi - lo, abs=1e-9)


def test_a_range_outside_the_collision_free_range_is_refused(tmp_path, outputs):
    out = outputs["bennett"]
    r = run("trajectory", out, "--range", "full", "-q")
    assert r.exit_code == 2
    assert "collision-free only over the task range" in r.stderr and "--allow-collisions" in r.stderr
    r = run("trajectory", out, "--range", "full", "--allow-collisions", "--rate", "10", "--json", "-q")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["format"] == "mpsynth.trajectory/1" and doc["driver_range"] == pytest.approx([0, TWO_PI])
    assert len(doc["time"]) == 101 and doc["units"]["angle"] == "rad"


def test_constant_speed(outputs):
    rb = read_output(outputs["sixbar"])
    tr = plan(rb, speed=2.0, rate=100.0)
    assert tr.driver_range == (0.0, TWO_PI)
    assert np.allclose(tr.velocities[:, 0], tr.velocities[0, 0]) and tr.velocities[0, 0] == pytest.approx(2, rel=1e-2)
    assert tr.angles[0, 0] == 0 and tr.angles[-1, 0] == pytest.approx(TWO_PI)
    back = plan(rb, speed=-2.0, rate=100.0)
    assert back.angles[0, 0] == pytest.approx(TWO_PI) and back.angles[-1, 0] == 0
    assert np.allclose(back.angles[::-1], tr.angles, atol=1e-9)


@pytest.mark.parametrize("args,needle", [
    (["--driver", "x9"], "no such joint"),
    (["--rate", "0"], "--rate"),
    (["-o", "t.txt"], "use .csv or .json"),
    (["--through-poses", "--duration", "0.5", "--dwell", "0.2"], "too short"),
    (["--through-poses", "--speed", "1"], "--speed"),
])
def test_bad_options(tmp_path, outputs, monkeypatch, args, needle):
    monkeypatch.chdir(tmp_path)
    r = run("trajectory", outputs["sixbar"], *args)
    assert r.exit_code == 2 and needle in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "t.txt").exists()


@settings(max_examples=25, deadline=None)
@given(st.floats(-20, 20), st.sampled_from(["h1", "h2", "k1", "k2"]))
def test_follower_angles_follow_the_laws(phi, driver):
    """The continued angles equal the laws theta_j(t) (mod 2 pi) at the driver's t, are 0 at phi = 0,
    gain one signed turn per driver turn, and the derivative matches a central difference."""
    lk = bennett_linkage()
    d = lk.joint(driver)
    ang, dang = follower_angles(lk, driver, np.array([phi, phi + TWO_PI, 0.0]))
    t = d.a + d.b / math.tan(phi / 2) if math.sin(phi / 2) != 0 else math.inf
    law = np.array([j.angle(t) for j in lk.joints])
    assert np.allclose((ang[0] - law + math.pi) % TWO_PI - math.pi, 0, atol=1e-9)
    assert np.all(ang[2] == 0)
    sign = np.sign([j.b * d.b for j in lk.joints])
    assert np.allclose(ang[1] - ang[0], TWO_PI * sign, atol=1e-9)
    h = 1e-6
    a2, _ = follower_angles(lk, driver, np.array([phi - h, phi + h]))
    assert np.allclose((a2[1] - a2[0]) / (2 * h), dang[0], rtol=1e-5, atol=1e-5)


def test_quintic_rests():
    s, ds = quintic(np.array([0.0, 0.5, 1.0]))
    assert s.tolist() == [0.0, 0.5, 1.0] and ds[0] == 0 and ds[2] == 0
