"""End-to-end: the drive report in every linkage.json, --driver, the task's constraints and --max-extent
(docs/drive.md), checked against the shared verifier when it is present."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from cli.main import mpsynth
from synth.checks import VERIFY_SAMPLES
from synth.algebra.geometry import line_box_distance
from synth.io.poses import load_poses
from synth.synthesis.points import oriented_item, point_candidates
from synth.task import Box

from conftest import REPO, VERIFIER

FIX = REPO / "fixtures"
QUICK = ["bennett_mm_deg.yaml", "bennett_points.yaml"]
SLOW = ["bennett_quat.yaml", "bennett_matrix.json", "bennett_planar.yaml", "bennett_spherical.yaml",
        "sixbar_example.yaml", "sixbar_points.yaml", "sixbar_planar.yaml", "sixbar_spherical.yaml",
        "bennett_fit.yaml"]  # (a fit in the listed order: the task range is the listed arc, 309 deg)


@pytest.fixture
def verifier():
    """The shared verifier (``$MPSYNTH_VERIFIER``, default ../shared/tools/verify_output.py), or None when
    it is absent (its checks are then skipped, the rest still runs)."""
    path = Path(os.environ.get("MPSYNTH_VERIFIER", VERIFIER))
    return path if path.is_file() else None


def run(*args):
    return CliRunner().invoke(mpsynth, [str(a) for a in args], catch_exceptions=False)


def command(fixture: str) -> str:
    return "sixbar" if fixture.startswith("sixbar") else "bennett" if fixture.startswith("bennett") else "curve"


def verifier_notes(verifier, task, out, *extra) -> str:
    r = subprocess.run([sys.executable, str(verifier), str(task), str(out), *map(str, extra)], capture_output=True,
                       text=True, timeout=600)
    last = r.stdout.strip().splitlines()[-1]
    assert r.returncode == 0 and last.startswith("verify OK"), r.stdout + r.stderr
    return last


def with_constraints(fixture, tmp_path, **constraints):
    """A copy of a fixture with ``constraints:`` (input units) as a YAML task file."""
    doc = yaml.safe_load((FIX / fixture).read_text())
    doc["constraints"] = constraints
    path = tmp_path / (fixture.rsplit(".", 1)[0] + "_task.yaml")
    path.write_text(yaml.safe_dump(doc))
    return path


def speed_ratio_agrees(fixture, tmp_path, verifier, *options):
    """linkage.json's drive.max_speed_ratio is within 1% of the verifier's measured speed ratio (its sweep
    at 720 steps a turn: a chord ratio, slightly below the exact maximum)."""
    task = with_constraints(fixture, tmp_path, max_speed_ratio=1e6)
    out = tmp_path / "out"
    r = run(command(fixture), task, "-o", out, *options)
    assert r.exit_code == 0, r.output
    drive = json.loads((out / "linkage.json").read_text())["drive"]
    assert "drive: " in r.output
    if verifier is None:
        return drive
    measured = float(re.search(r"speed_ratio=(\S+)", verifier_notes(verifier, task, out, "--steps", 720)).group(1))
    assert measured == pytest.approx(drive["max_speed_ratio"], rel=0.01)
    return drive


@pytest.mark.parametrize("fixture", QUICK + [pytest.param(f, marks=pytest.mark.slow) for f in SLOW])
def test_drive_in_linkage_json_agrees_with_the_verifier(fixture, tmp_path, verifier):
    drive = speed_ratio_agrees(fixture, tmp_path, verifier)
    assert drive["driver"] == "h1" and drive["range"][1] > drive["range"][0]


def test_driver_option_moves_the_drive_and_the_limits(tmp_path, verifier):
    """--driver k1: the URDF's first loop starts at k1 (what the verifier drives), the drive report and
    the task range follow, and the speed ratio still agrees."""
    drive = speed_ratio_agrees("bennett_mm_deg.yaml", tmp_path, verifier, "--driver", "k1")
    assert drive["driver"] == "k1" and drive["max_speed_ratio"] == pytest.approx(2.7693, rel=1e-4)
    doc = json.loads((tmp_path / "out" / "linkage.json").read_text())
    assert doc["closures"] == [["coupler_k", "coupler"]] and doc["collision"]["driver"] == "k1"
    r = run("bennett", FIX / "bennett_mm_deg.yaml", "--driver", "h2")
    assert r.exit_code == 2 and "--driver h2: not a joint on the base" in r.output


@pytest.mark.parametrize("spec", ["motion_circular.yaml", pytest.param("curve_circle.yaml", marks=pytest.mark.slow),
                                  pytest.param("motion_darboux_general.yaml", marks=pytest.mark.slow)])
def test_drive_for_curves_and_multiloop(spec, tmp_path):
    out = tmp_path / "out"
    r = run("curve", FIX / spec, "-o", out)
    assert r.exit_code == 0, r.output
    drive = json.loads((out / "linkage.json").read_text())["drive"]
    assert drive["max_speed_ratio"] > 0 and 0 <= drive["min_conditioning"] <= 1


def test_mount_fixture_meets_its_constraints(tmp_path, verifier):
    """fixtures/bennett_mount.yaml: base box, envelope and speed ratio, met and accepted by the verifier."""
    out = tmp_path / "out"
    r = run("bennett", FIX / "bennett_mount.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    assert "constraints: met" in r.output
    if verifier is not None:
        notes = verifier_notes(verifier, FIX / "bennett_mount.yaml", out)
        assert "base_box=checked" in notes and "envelope_excess=0m" in notes


@pytest.mark.parametrize("constraint, value, words", [
    ("base", {"box": [[500, 500, 500], [600, 600, 600]]},
     r"constraints\.base: the axis of h1 misses the base box by [0-9.]+ mm; constraints\.base: the axis of k1"),
    ("envelope", {"box": [[-100, -100, -100], [100, 100, 100]]},
     r"constraints\.envelope: \w+ leaves the envelope by [0-9.]+ mm"),
    ("max_speed_ratio", 2.5, r"constraints\.max_speed_ratio: k2 turns 2\.769 times as fast as k1 \(limit 2\.5"),
])
def test_unmet_constraints_exit_1_naming_them(constraint, value, words, tmp_path):
    """Nothing written; the message names each violated constraint and by how much (for the speed ratio:
    at the better of the two drivers, k1)."""
    task = with_constraints("bennett_mm_deg.yaml", tmp_path, **{constraint: value})
    out = tmp_path / "out"
    r = run("bennett", task, "-o", out)
    assert r.exit_code == 1, r.output
    assert re.search(words, r.output), r.output
    assert not out.exists()


def test_speed_ratio_limit_picks_the_driver(tmp_path, verifier):
    """h1 drives with ratio 2.842, k1 with 2.769: a limit of 2.8 is met by driving k1."""
    task = with_constraints("bennett_mm_deg.yaml", tmp_path, max_speed_ratio=2.8)
    out = tmp_path / "out"
    r = run("bennett", task, "-o", out)
    assert r.exit_code == 0, r.output
    assert json.loads((out / "linkage.json").read_text())["drive"]["driver"] == "k1"
    if verifier is not None:
        assert "speed_ratio=2.7" in verifier_notes(verifier, task, out)


def test_base_box_picks_the_point_task_solution(tmp_path, verifier):
    """The point task's scan gives several Bennett linkages; a mounting box around the ground axes of the
    third one selects it (the others' axes miss the box)."""
    ps = load_poses(str(FIX / "bennett_points.yaml"), points=((3, 5), "points"))
    oriented, rot = oriented_item(ps.matrices, ps.kinds, ps.names)
    cands = point_candidates(ps.positions, ps.names, degree=2, top=4, tool_rotation=rot, oriented=oriented,
                             check_samples=VERIFY_SAMPLES)
    sites = cands[2].joint_sites()
    P = np.array([sites["h1"], sites["k1"]])
    box = Box(P.min(0) - 1e-3, P.max(0) + 1e-3)

    def misses(lk):
        b = [j for j in lk.joints if j.parent == "base"]
        return line_box_distance(np.array([j.point for j in b]), np.array([j.direction for j in b]), box).max()

    assert misses(cands[2]) == 0 and misses(cands[0]) > 0.01
    task = with_constraints("bennett_points.yaml", tmp_path,
                            base={"box": (np.array([box.lo, box.hi]) / ps.length_scale).tolist()})
    out = tmp_path / "out"
    r = run("bennett", task, "-o", out)
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "linkage.json").read_text())
    h1 = next(j for j in doc["joints"] if j["name"] == "h1")
    np.testing.assert_allclose(h1["line"]["direction"], cands[2].joint("h1").direction, atol=1e-9)
    if verifier is not None:
        assert "base_box=checked" in verifier_notes(verifier, task, out)


def test_max_extent_refuses_huge_near_planar_linkages(tmp_path):
    """Three poses planar up to 1e-4 rad give a Bennett linkage hundreds of times the task's size: refused
    by default with the reason and what to change; --max-extent inf accepts it."""
    task = tmp_path / "near_planar.yaml"
    task.write_text("units: {length: mm, angle: deg}\nposes:\n  - {position: [0, 0, 0], rpy: [0, 0, 0]}\n"
                    "  - {position: [100, 20, 0], rpy: [0.00573, 0, 40]}\n"
                    "  - {position: [150, 90, 0], rpy: [0, -0.00573, 95]}\n")
    out = tmp_path / "out"
    r = run("bennett", task, "-o", out)
    assert r.exit_code == 1 and not out.exists()
    assert re.search(r"the linkage's extent is [0-9.e+]+ mm, more than --max-extent [0-9.]+ mm \([0-9]+ x the "
                     r"task's spread: .*raise --max-extent", r.output), r.output
    r = run("bennett", task, "--max-extent", "inf")
    assert r.exit_code == 0 and "warning: poor drive:" in r.output
    r = run("bennett", FIX / "bennett_mm_deg.yaml", "--max-extent", "100")
    assert r.exit_code == 1 and "more than --max-extent 100 mm" in r.output
    assert run("bennett", FIX / "bennett_mm_deg.yaml", "--max-extent", "-1").exit_code == 2


def noisy_bennett_task(path, box=None):
    """Seven poses sampled (seeded) from bennett_mm_deg's Bennett motion with 0.1 mm / 0.05 deg noise,
    tolerance 0.5 mm / 0.3 deg; ``box`` (mm) as constraints.base. Returns the true linkage."""
    import synth
    from synth.frames import rpy_from_matrix

    ps = load_poses(str(FIX / "bennett_mm_deg.yaml"))
    lk = synth.bennett(ps.matrices, ps.names)
    rng = np.random.default_rng(5)
    poses = []
    for t in (np.inf, -1.5, -0.6, 0.0, 0.5, 1.0, 2.2):
        T = lk.tool_pose(lk.angles_at(t))
        poses.append({"position": (T[:3, 3] * 1000 + rng.normal(size=3) * 0.1).round(4).tolist(),
                      "rpy": (np.degrees(rpy_from_matrix(T[:3, :3])) + rng.normal(size=3) * 0.05).round(4).tolist()})
    doc = {"units": {"length": "mm", "angle": "deg"}, "tolerance": {"position": 0.5, "angle": 0.3}, "poses": poses}
    if box is not None:
        doc["constraints"] = {"base": {"box": box}}
    path.write_text(yaml.safe_dump(doc))
    return lk


@pytest.mark.parametrize("shift, ok", [(0.0, True), (300.0, False)])
def test_noisy_bennett_task_with_a_mounting_box(shift, ok, tmp_path, verifier):
    """A fitted Bennett linkage (7 noisy poses) whose ground axes must pass through a box around the true
    solution's: met and verified (tolerances and base box); the box moved 300 mm away: exit 1 naming it."""
    lk = noisy_bennett_task(tmp_path / "probe.yaml")
    sites = lk.joint_sites()
    P = np.array([sites["h1"], sites["k1"]]) * 1000 + shift
    box = [(P.min(0) - 5).tolist(), (P.max(0) + 5).tolist()]
    task = tmp_path / "noisy.yaml"
    noisy_bennett_task(task, box)
    out = tmp_path / "out"
    r = run("bennett", task, "-o", out)
    if not ok:
        assert r.exit_code == 1 and re.search(r"constraints\.base: the axis of (h1|k1) misses the base box by", r.output)
        assert not out.exists()
        return
    assert r.exit_code == 0, r.output
    assert "constraints: met: base box" in r.output
    if verifier is not None:
        assert "base_box=checked" in verifier_notes(verifier, task, out)


@pytest.mark.slow
def test_sixbar_driver_option_agrees_with_the_verifier(tmp_path, verifier):
    drive = speed_ratio_agrees("sixbar_example.yaml", tmp_path, verifier, "--driver", "k1")
    assert drive["driver"] == "k1"
