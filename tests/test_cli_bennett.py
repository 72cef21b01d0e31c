"""End-to-end: `mpsynth bennett` writes files that yourdfpy and the shared verifier accept."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from cli.main import mpsynth
from synth.io.poses import load_poses

from conftest import REPO, assert_verified, random_poses, run, write_pose_yaml

TASKS = ("bennett_fit", "bennett_hermite", "bennett_fit_mount")  # fits, Hermite pairs: test_bennett_fit.py, test_steer.py
FIXTURES = sorted(p for p in (REPO / "fixtures").glob("bennett_*") if p.suffix in (".yaml", ".json")
                  and "points" not in p.name and p.stem not in TASKS)  # point tasks: tests/test_points.py


def fk_check(out, pose_file, tol=1e-9):
    """yourdfpy FK from base to tool at every pose's joint angles equals the input pose: rotation within
    tol, position within tol of the poses' spread plus 64 ulps of the pose coordinates (yourdfpy composes
    the chain's transforms in floats: a small set far from the origin, e.g. 1 mm at 2 km, is at that
    rounding floor)."""
    import yourdfpy

    doc = json.loads((out / "linkage.json").read_text())
    urdf = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False, build_collision_scene_graph=False)
    poses = load_poses(str(pose_file)).matrices
    spread = max(np.sqrt(np.mean(np.sum((poses[:, :3, 3] - poses[:, :3, 3].mean(0)) ** 2, 1))), 1e-300)
    floor = 64 * np.finfo(float).eps * float(np.abs(poses[:, :3, 3]).max())
    for rec, T in zip(doc["poses"], poses):
        urdf.update_cfg({k: v for k, v in rec["joint_angles"].items() if k in urdf.actuated_joint_names})
        M = urdf.get_transform("tool", "base")
        assert np.abs(M[:3, :3] - T[:3, :3]).max() < tol
        assert np.linalg.norm(M[:3, 3] - T[:3, 3]) < tol * spread + floor


@pytest.mark.parametrize("fixture", FIXTURES, ids=[p.name for p in FIXTURES])
def test_fixture_end_to_end(fixture, tmp_path):
    out = tmp_path / "out"
    r = run("bennett", fixture, "-o", out)
    assert r.exit_code == 0, r.output
    assert (out / "linkage.urdf").exists() and (out / "linkage.json").exists()
    assert len(list((out / "meshes").glob("*.stl"))) == 8  # 4 links, 4 pins
    assert "design: NOT collision-free" in r.output or "design: collision-free" in r.output
    fk_check(out, fixture)
    assert_verified(fixture, out)


@pytest.mark.parametrize("case", ["plain", "far", "tiny", "near_pi"])
def test_random_sets_end_to_end(case, tmp_path):
    rng = np.random.default_rng({"plain": 1, "far": 2, "tiny": 3, "near_pi": 4}[case])
    kw = {"plain": {}, "far": dict(offset=(1000.0, 1000.0, -1000.0)), "tiny": dict(scale=1e-3),
          "near_pi": dict(near_pi=True)}[case]
    poses = write_pose_yaml(tmp_path / "poses.yaml", random_poses(rng, 3, **kw))
    out = tmp_path / "out"
    r = run("bennett", poses, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    fk_check(out, poses)
    assert_verified(poses, out)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(40))
def test_random_sets_end_to_end_sweep(seed, tmp_path):
    rng = np.random.default_rng(500 + seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 1000,
                     near_pi=bool(seed % 3 == 0))
    poses = write_pose_yaml(tmp_path / "poses.yaml", T)
    out = tmp_path / "out"
    assert run("bennett", poses, "-o", out, "-q").exit_code == 0
    fk_check(out, poses)
    assert_verified(poses, out)


def test_json_on_stdout_and_nothing_written_without_out(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(mpsynth, ["bennett", str(FIXTURES[0]), "--json", "-q"])
    assert r.exit_code == 0
    doc = json.loads(r.stdout)
    assert doc["format"] == "mpsynth.linkage/1" and doc["kind"] == "bennett"
    assert doc["checks"]["max_pose_error"] < 1e-9
    assert list(tmp_path.iterdir()) == []


def test_stdin(tmp_path):
    out = tmp_path / "o"
    r = run("bennett", "-", "-o", out, "-q", input=FIXTURES[0].read_text())
    assert r.exit_code == 0, r.output
    assert (out / "linkage.urdf").exists()


def test_wrong_pose_count_exit_2(tmp_path):
    fx = REPO / "fixtures" / "sixbar_example.yaml"
    out = tmp_path / "o"
    r = CliRunner().invoke(mpsynth, ["bennett", str(fx), "-o", str(out)])
    assert r.exit_code == 1  # four exact poses over-determine a Bennett motion: fitted and refused
    assert "cannot all be met by a Bennett motion" in r.output and len(r.output.strip().splitlines()) == 1
    assert not out.exists()


def test_degenerate_exit_1_and_no_output(tmp_path):
    poses = tmp_path / "translations.yaml"
    poses.write_text("""poses:
  - {position: [0, 0, 0], rpy: [0, 0, 0]}
  - {position: [1, 0, 0], rpy: [0, 0, 0]}
  - {position: [0, 2, 0], rpy: [0, 0, 0]}
""")
    out = tmp_path / "o"
    r = CliRunner().invoke(mpsynth, ["bennett", str(poses), "-o", str(out)])
    assert r.exit_code == 1
    assert "pure translations" in r.output and r.output.startswith("mpsynth: ")
    assert not out.exists() and list(tmp_path.iterdir()) == [poses]


def test_mesh_size_options_and_units(tmp_path):
    fx = REPO / "fixtures" / "bennett_mm_deg.yaml"
    out = tmp_path / "o"
    r = run("bennett", fx, "-o", out, "-q", "--pin-radius", "3", "--link-radius", "2", "--pin-length", "40")
    assert r.exit_code == 0, r.output
    import trimesh

    m = trimesh.load(out / "meshes" / "link_h1.stl")
    assert m.is_watertight
    # STL files are in millimetres (slicer convention) and the URDF scales them to metres
    assert 'scale="0.001 0.001 0.001"' in (out / "linkage.urdf").read_text()
    # the pins are 6 mm thick: a bar of 4 mm alone could not make every extent >= 6 mm
    assert min(m.extents) >= 6.0 - 1e-6
    r = run("bennett", fx, "-o", tmp_path / "thin", "-q", "--pin-radius", "1", "--link-radius", "0.5")
    thin = trimesh.load(tmp_path / "thin" / "meshes" / "link_h1.stl")
    assert thin.volume < m.volume / 4
    r = CliRunner().invoke(mpsynth, ["bennett", str(fx), "-o", str(tmp_path / "x"), "--pin-radius", "-1"])
    assert r.exit_code == 2


def test_subprocess_console_script(tmp_path):
    exe = REPO / ".venv" / "bin" / "mpsynth"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "cli.main"]
    r = subprocess.run(cmd + ["bennett", str(FIXTURES[0]), "-o", str(tmp_path / "o")], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "self-check" in r.stderr and r.stdout == ""
    r = subprocess.run(cmd + ["--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "mpsynth" in r.stdout
