"""The physical design in the outputs: CLI options, linkage.json's design/collision sections, pin links
in the URDF, the driver's limits for a task-range claim, the verifier on the claim, contacts in the
simulators."""
from __future__ import annotations

import importlib.util
import json
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner

from cli.main import mpsynth
from synth.design.model import straight_design
from synth.design.model import CollisionReport, DesignResult
from synth.design.choose import default_hole_clearance, default_sizes, design_for
from synth.io.poses import load_poses
from synth.io.readback import read_output
from synth.io.urdf import driver_limits
from synth.io.writer import write_output
from synth.design.choose import design_for
from synth.synthesis.bennett import bennett

from conftest import REPO, VERIFIER, run, run_verifier

FIXTURE = REPO / "fixtures" / "bennett_mm_deg.yaml"
TWO_PI = 2 * math.pi


@pytest.fixture(scope="module")
def linkage():
    ps = load_poses(str(FIXTURE))
    return bennett(ps.matrices, ps.names)


def straight_result(linkage, report, **sizes):
    pin_radius, bar_radius, hub_length = default_sizes(linkage, **sizes)
    design = straight_design(linkage, pin_radius=pin_radius, bar_radius=bar_radius, hub_length=hub_length,
                             hole_clearance=default_hole_clearance(pin_radius))
    return DesignResult(design, report)


def task_arc(linkage, driver):
    """(lo, hi): the shortest arc of ``driver`` through every pose, as verify_output.py takes it."""
    angles = sorted(float(p.joint_angles[driver]) % TWO_PI for p in linkage.poses)
    gaps = [(angles[(i + 1) % len(angles)] - angles[i]) % TWO_PI or TWO_PI for i in range(len(angles))]
    g = int(np.argmax(gaps))
    lo = angles[(g + 1) % len(angles)]
    return lo, lo + TWO_PI - gaps[g]


def verify(*args):
    """(exit code, last line) of the shared verifier on ARGS; None when it is absent (a plain copy)."""
    r = run_verifier(*args)
    if r is None:
        return None
    return r.returncode, r.stdout.strip().splitlines()[-1] if r.stdout.strip() else r.stderr


# ------------------------------------------------------------------ sizes and CLI options
def test_hole_clearance_rule():
    assert default_hole_clearance(4e-3) == pytest.approx(2e-4)  # 0.2 mm for a 4 mm pin
    assert default_hole_clearance(1e-4) == pytest.approx(1e-5)  # a tenth of a tiny pin


@pytest.mark.parametrize("command", ["bennett", "sixbar", "curve"])
def test_design_options_in_help(command):
    r = run(command, "--help")
    assert r.exit_code == 0
    for opt in ("--clearance", "--hole-clearance", "--require-collision-free", "--pin-length"):
        assert opt in r.output
    assert "Hub length" in r.output


@pytest.mark.parametrize("args", [("--clearance", "-1"), ("--hole-clearance", "nan"), ("--hole-clearance", "1e8"),
                                  ("--pin-length", "0"), ("--clearance", "inf")])
def test_bad_design_values_exit_2_one_line(tmp_path, args):
    out = tmp_path / "o"
    r = CliRunner().invoke(mpsynth, ["bennett", str(FIXTURE), "-o", str(out), *args])
    assert r.exit_code == 2, r.output
    assert r.output.startswith("mpsynth: ") and len(r.output.strip().splitlines()) == 1
    assert args[0] in r.output and not out.exists()


def test_sizes_reach_the_design_in_input_units():
    r = run("bennett", FIXTURE, "--json", "-q", "--pin-length", "10", "--hole-clearance", "0.3", "--clearance", "0.5",
            "--pin-radius", "2")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    d = doc["design"]
    assert d["hub_length"] == pytest.approx(0.010) and d["hole_clearance"] == pytest.approx(3e-4)
    assert d["pin_radius"] == pytest.approx(2e-3) and d["hub_radius"] > d["pin_radius"] + d["hole_clearance"]
    assert doc["collision"]["clearance"] == pytest.approx(5e-4)
    assert {p["joint"] for p in d["pins"]} == {"h1", "h2", "k1", "k2"}
    assert all(p["length"] >= d["hub_length"] - 1e-12 for p in d["pins"])


def test_summary_and_require_collision_free(tmp_path):
    out = tmp_path / "o"
    r = run("bennett", FIXTURE, "-o", out, "--require-collision-free")
    if r.exit_code == 0:
        assert json.loads((out / "linkage.json").read_text())["collision"]["free"] is True
        assert "design: collision-free over the" in r.output
    else:
        assert r.exit_code == 1
        assert r.output.startswith("mpsynth: ") and "NOT collision-free" in r.output
        assert len(r.output.strip().splitlines()) == 1 and not out.exists()
    r = run("bennett", FIXTURE, "-o", tmp_path / "p")
    assert r.exit_code == 0 and re.search(r"design: (NOT )?collision-free", r.output)
    assert "4 link meshes and 4 pins" in r.output


# ------------------------------------------------------------------ URDF: pins and limits
def test_pins_are_links_fixed_to_their_carriers(tmp_path, linkage):
    import yourdfpy

    out = tmp_path / "o"
    write_output(linkage, out, robot_name="b", result=design_for(linkage))
    doc = json.loads((out / "linkage.json").read_text())
    urdf = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=True, build_collision_scene_graph=True)
    for pin in doc["design"]["pins"]:
        j = urdf.joint_map[f"pin_{pin['joint']}_mount"]
        assert j.type == "fixed" and j.parent == pin["carrier"] and j.child == pin["link"]
        assert (out / pin["mesh"]).is_file()
        # the pin frame sits at the pin's midpoint on the joint's axis
        line = next(x["line"] for x in doc["joints"] if x["name"] == pin["joint"])
        p = urdf.get_transform(pin["link"], "base")[:3, 3]
        assert np.linalg.norm(np.cross(p, line["direction"]) - line["moment"]) < 1e-12
    # mpsynth's own reader gives each carrier its pins' meshes: one rigid body for collide/render
    rb = read_output(out)
    carried = {p["carrier"] for p in doc["design"]["pins"]}
    for link in carried:
        assert any(v.path.name.startswith("pin_") for v in rb.visuals[link])


def test_driver_limits_hold_the_first_pose():
    rep = CollisionReport(True, "task", 1e-3, 2e-3, "h1", (5.0, 8.0))
    d, lo, hi = driver_limits(rep)
    assert d == "h1" and lo <= 0 <= hi and hi - lo == pytest.approx(3.0)
    assert driver_limits(rep.to_dict()) == (d, lo, hi)
    assert driver_limits(CollisionReport(True, "full", 0, 0, "h1", (0.0, TWO_PI))) is None
    _, lo, hi = driver_limits(CollisionReport(True, "task", 0, 0, "h1", (3.0, TWO_PI)))  # ends at pose 0
    assert lo == pytest.approx(3.0 - TWO_PI) and hi == pytest.approx(0.0, abs=1e-12)


def test_task_range_claim_limits_the_driver_and_verifies(tmp_path, linkage):
    """A task-range claim makes the driver revolute with the claim's limits (holding 0 and every pose's
    angle up to whole turns); the verifier (which sweeps whole turns for mobility) still passes."""
    lo, hi = task_arc(linkage, "h1")
    rep = CollisionReport(True, "task", 1e-3, 2e-3, "h1", (lo, hi), certified=True)
    out = tmp_path / "o"
    write_output(linkage, out, robot_name="b", result=straight_result(linkage, rep))
    root = ET.parse(out / "linkage.urdf").getroot()
    h1 = next(j for j in root.findall("joint") if j.get("name") == "h1")
    assert h1.get("type") == "revolute"
    lim = h1.find("limit")
    lower, upper = float(lim.get("lower")), float(lim.get("upper"))
    assert lower <= 0 <= upper and upper - lower == pytest.approx(hi - lo)
    for p in linkage.poses:
        a = float(p.joint_angles["h1"])
        assert any(lower - 1e-9 <= a + TWO_PI * k <= upper + 1e-9 for k in (-2, -1, 0, 1, 2))
    assert all(j.get("type") != "revolute" for j in root.findall("joint") if j.get("name") != "h1")
    assert json.loads((out / "linkage.json").read_text())["collision"]["range"] == "task"
    verdict = verify(FIXTURE, out)
    if verdict is not None:  # the shared verifier, when it is beside the repository
        assert verdict[0] == 0 and verdict[1].startswith("verify OK"), verdict[1]


# ------------------------------------------------------------------ the claim against the verifier
CLAIM_CASES = [("bennett", REPO / "fixtures" / "bennett_mm_deg.yaml"),
               ("bennett", REPO / "fixtures" / "bennett_quat.yaml")]


@pytest.mark.parametrize("command,fixture", CLAIM_CASES, ids=[f.stem for _, f in CLAIM_CASES])
def test_verifier_agrees_with_the_collision_claim(tmp_path, command, fixture):
    """With the real design search: a collision-free claim passes verify_output.py --collisions CLEARANCE
    --collision-range RANGE, and the verifier's smallest mesh distance is at least the claimed
    (certified, capsule-based) one."""
    pytest.importorskip("fcl")
    if not VERIFIER.exists():
        pytest.skip("../shared/tools/verify_output.py is not present")
    out = tmp_path / "o"
    r = run(command, fixture, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    col = json.loads((out / "linkage.json").read_text())["collision"]
    assert col["certified"], col
    code, last = verify(fixture, out, "--collisions", col["clearance"] if col["free"] else 0.0,
                        "--collision-range", col["range"])
    m = re.search(r"collision_min=(\S+)m", last)
    assert m, last
    measured = float(m.group(1))
    if col["free"]:
        assert code == 0, last
        assert measured >= col["min_distance"] - 1e-6 * abs(col["min_distance"]) - 1e-9
    else:
        assert measured < col["clearance"] + 1e-9 or col["min_distance"] < col["clearance"]


# ------------------------------------------------------------------ simulators with contacts
@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_contacts_seen_in_a_colliding_design(tmp_path, linkage, engine):
    """The straight design of the fixture folds base and coupler through each other: with --contacts the
    engine reports contacts; without, none are looked for."""
    if importlib.util.find_spec(engine) is None:
        pytest.skip(f"{engine} is not installed")
    out = tmp_path / "o"
    rep = CollisionReport(False, "full", 0.0, float("nan"), "h1", (0.0, TWO_PI), message="not searched")
    write_output(linkage, out, robot_name="b", result=straight_result(linkage, rep))
    r = run("simulate", out, "--engine", engine, "--contacts", "--json", "--seconds", "1")
    res = json.loads(r.stdout)
    assert res["contacts"] is True and res["contact_steps"] > 0 and res["max_contact_force"] > 0
    r = run("simulate", out, "--engine", engine, "--json", "--seconds", "1")
    res = json.loads(r.stdout)
    assert r.exit_code == 0 and res["contact_steps"] == 0


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_task_range_design_is_simulated_inside_its_limits(tmp_path, linkage, engine):
    """A driver limited to the task range is driven from its lower to its upper limit (starting on the
    exact motion there), and the other joints still follow the exact motion."""
    if importlib.util.find_spec(engine) is None:
        pytest.skip(f"{engine} is not installed")
    lo, hi = task_arc(linkage, "h1")
    rep = CollisionReport(True, "task", 1e-3, 2e-3, "h1", (lo, hi), certified=True)
    out = tmp_path / "o"
    write_output(linkage, out, robot_name="b", result=straight_result(linkage, rep))
    r = run("simulate", out, "--engine", engine, "--json", "--seconds", "1")
    assert r.exit_code == 0, r.output
    res = json.loads(r.stdout)
    _, lower, upper = driver_limits(rep)
    assert res["drive_range"] == pytest.approx([lower, upper])
    assert res["max_joint_deviation"] < 1e-3 and res["max_driver_error"] < 1e-2
    r = run("check", out, "--poses", FIXTURE)  # mpsynth check accepts the limits of the claim
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize("engine", ["mujoco", "pybullet"])
def test_collision_free_design_runs_without_contacts(tmp_path, engine):
    """With the real design search: a design claimed collision-free over its range keeps its capsules
    apart there, and --contacts collides exactly those capsules, so the engine drives the range without
    a contact and follows the exact motion. Skips while the placeholder makes no claim."""
    if importlib.util.find_spec(engine) is None:
        pytest.skip(f"{engine} is not installed")
    out = tmp_path / "o"
    r = run("bennett", FIXTURE, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    col = json.loads((out / "linkage.json").read_text())["collision"]
    if not (col["free"] and col["certified"]):
        pytest.skip("the design search is the placeholder (no collision-free claim to run)")
    r = run("simulate", out, "--engine", engine, "--contacts", "--json", "--seconds", "1")
    res = json.loads(r.stdout)
    assert r.exit_code == 0 and res["contact_steps"] == 0 and res["max_contact_force"] == 0, res


def test_contact_exclusions_merge_pins_and_welds(tmp_path, linkage):
    from synth.tools.sim import contact_exclusions, load_setup

    out = tmp_path / "o"
    write_output(linkage, out, robot_name="b", result=design_for(linkage))
    ex = contact_exclusions(load_setup(out))
    assert frozenset(("coupler", "coupler_k")) in ex and frozenset(("base", "pin_h1")) in ex
    assert frozenset(("pin_h2", "coupler")) in ex or frozenset(("pin_h2", "link_h1")) in ex
    assert frozenset(("base", "coupler")) not in ex and frozenset(("link_h1", "link_k1")) not in ex


@pytest.mark.parametrize("command, fixture, clearance", [
    ("bennett", FIXTURE, "2000"),  # mm; the linkage's size is ~200 mm
    ("sixbar", REPO / "fixtures" / "sixbar_example.yaml", "1"),  # m
])
def test_require_collision_free_refuses_an_impossible_clearance(tmp_path, command, fixture, clearance):
    """A clearance no design can keep (several times the linkage's size): exit 1, one line with the collision
    sentence, nothing written (sixbar: the design made while ranking is the one refused)."""
    out = tmp_path / "o"
    r = run(command, fixture, "-o", out, "--require-collision-free", "--clearance", clearance)
    assert r.exit_code == 1, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mpsynth: ") and "NOT collision-free" in lines[0]
    assert not out.exists()
