"""`mpsynth check`: good outputs pass; deliberately broken ones are caught, one line per problem."""
from __future__ import annotations

import importlib.util
import json
import re
import shutil

import numpy as np
import pytest

from linkage_fixtures import move_urdf_axis
from synth.tools.check.continuation import continue_loop, law_angles
from synth.io.urdfmodel import read_urdf
from synth.tools.check.verify import check_output

from conftest import REPO, run

BENNETT = REPO / "fixtures" / "bennett_quat.yaml"
SIXBAR = REPO / "fixtures" / "sixbar_example.yaml"


@pytest.fixture(scope="module")
def bennett_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("check") / "bennett"
    r = run("bennett", BENNETT, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    return out


@pytest.fixture(scope="module")
def sixbar_out(tmp_path_factory):
    if importlib.util.find_spec("cli.sixbar") is None:
        pytest.skip("mpsynth sixbar is not available")
    out = tmp_path_factory.mktemp("check") / "sixbar"
    r = run("sixbar", SIXBAR, "-o", out, "-q")
    assert r.exit_code == 0, r.output
    return out


@pytest.fixture
def copy(bennett_out, tmp_path):
    dst = tmp_path / "out"
    shutil.copytree(bennett_out, dst)
    return dst


def check_json(out, *extra):
    r = run("check", out, "--json", *extra)
    doc = json.loads(r.stdout)
    assert set(doc) == {"ok", "problems", "figures"}
    assert r.exit_code == (0 if doc["ok"] else 1)
    return r, doc


# ------------------------------------------------------------------------------------------ good outputs
def test_bennett_passes(bennett_out):
    r, doc = check_json(bennett_out, "--poses", BENNETT)
    assert doc["ok"], doc["problems"]
    f = doc["figures"]
    assert f["pose_error"]["translation"] < 1e-12 and f["pose_file_error"]["rotation"] < 1e-12
    assert f["law_closure_error"]["translation"] < 1e-12
    assert f["motion_polynomial_error"]["rotation"] < 1e-12
    c = f["continuation"]
    assert c["followed"] == 1.0 and c["driver"] == "h1"
    assert c["max_deviation_from_laws"] < 1e-8
    assert f["meshes"] == {"referenced": 16, "good": 16}  # visual + collision of 4 links and 4 pins


def test_sixbar_passes(sixbar_out):
    r, doc = check_json(sixbar_out, "--poses", SIXBAR)
    assert doc["ok"], doc["problems"]
    assert doc["figures"]["continuation"]["followed"] == 1.0
    assert doc["figures"]["continuation"]["max_deviation_from_laws"] < 1e-8


def test_human_output(bennett_out):
    r = run("check", bennett_out)
    assert r.exit_code == 0
    assert r.stdout == ""
    assert "OK" in r.stderr


# ------------------------------------------------------------------------------------------ broken outputs
def _edit(path, old, new, count=1):
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, count))


def _problems(out, *extra):
    r = run("check", out, *extra)
    assert r.exit_code == 1, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("FAIL ")]
    assert lines
    return "\n".join(lines)


def test_perturbed_axis_is_caught(copy):
    move_urdf_axis(copy / "linkage.urdf", "h2")
    msg = _problems(copy)
    assert "joint h2: URDF axis differs" in msg
    assert "tool frame misses pose" in msg
    assert "loop coupler-coupler_k open" in msg
    assert "stuck" in msg  # a perturbed Bennett is rigid: the continuation cannot turn it


def test_perturbed_axis_caught_without_linkage_json_lines(copy):
    """Even when linkage.json is edited to agree with the bad axis, the motion gives it away."""
    urdf = copy / "linkage.urdf"
    text = urdf.read_text()
    m = re.search(r'(<joint name="k1" type="continuous">.*?<axis xyz=")([^"]+)"', text, re.S)
    axis = np.array([float(v) for v in m.group(2).split()])
    axis[2] += 1e-3
    urdf.write_text(text[:m.start(2)] + " ".join(repr(float(v)) for v in axis) + text[m.end(2):])
    doc = json.loads((copy / "linkage.json").read_text())
    for j in doc["joints"]:
        if j["name"] == "k1":
            d = axis / np.linalg.norm(axis)
            # the URDF rotates about its joint frame origin; k1's parent is base (the world frame)
            p = np.array([float(v) for v in re.search(
                r'<joint name="k1" type="continuous">.*?<origin xyz="([^"]+)"', text, re.S).group(1).split()])
            j["line"] = {"direction": d.tolist(), "moment": np.cross(p, d).tolist()}
    (copy / "linkage.json").write_text(json.dumps(doc))
    msg = _problems(copy, "--no-meshes")
    assert "URDF axis differs" not in msg
    assert "stuck" in msg and "open" in msg


def test_deleted_mesh_is_caught(copy):
    (copy / "meshes" / "link_k1.stl").unlink()
    msg = _problems(copy)
    assert "mesh meshes/link_k1.stl (link link_k1 visual): file not found" in msg


def test_open_mesh_is_caught(copy):
    import trimesh

    path = copy / "meshes" / "coupler.stl"
    mesh = trimesh.load(path, force="mesh")
    mesh.update_faces(np.arange(len(mesh.faces)) != 0)  # drop one triangle
    path.write_bytes(mesh.export(file_type="stl"))
    assert "coupler.stl (link coupler visual): is not watertight" in _problems(copy)


def test_missing_mesh_scale_is_caught(copy):
    _edit(copy / "linkage.urdf", 'filename="meshes/base.stl" scale="0.001 0.001 0.001"', 'filename="meshes/base.stl"')
    assert "wrong unit or scale" in _problems(copy)


def test_absolute_mesh_path_is_caught(copy):
    _edit(copy / "linkage.urdf", 'filename="meshes/base.stl"', f'filename="{copy}/meshes/base.stl"')
    assert "not a path relative to the URDF" in _problems(copy)


def test_removed_gazebo_tag_is_caught(copy):
    urdf = copy / "linkage.urdf"
    urdf.write_text(re.sub(r"<gazebo>\s*<joint.*?</gazebo>", "", urdf.read_text(), flags=re.S))
    msg = _problems(copy)
    assert "no loop closure" in msg
    assert "differ from the URDF's welds" in msg


def test_wrong_closure_name_is_caught(copy):
    _edit(copy / "linkage.urdf", 'name="loop_closure"', 'name="weld"')
    assert "loop closures are named ['weld']" in _problems(copy, "--no-meshes")


def test_wrong_pose_is_caught(copy, tmp_path):
    poses = tmp_path / "poses.yaml"
    text = BENNETT.read_text()
    poses.write_text(text)
    from synth.io.poses import load_poses

    good = load_poses(str(poses))
    # move the last pose by 1 mm: a valid pose file that the linkage does not reach
    T = good.matrices.copy()
    T[2, 0, 3] += 1e-3
    from conftest import write_pose_yaml

    write_pose_yaml(poses, T, names=good.names)
    msg = _problems(copy, "--poses", poses, "--no-meshes")
    assert msg.count("tool frame misses pose") == 1 and "pose 2 (T2)" in msg
    # the pose is named as the POSES file names it, and linkage.json's name is given when it differs
    write_pose_yaml(poses, T, names=["a", "b", "c"])
    msg = _problems(copy, "--poses", poses, "--no-meshes")
    assert "pose 2 (c) of" in msg and "linkage.json calls pose 2 T2" in msg


def test_wrong_pose_in_linkage_json_is_caught(copy):
    doc = json.loads((copy / "linkage.json").read_text())
    doc["poses"][1]["joint_angles"]["h1"] += 1e-6
    (copy / "linkage.json").write_text(json.dumps(doc))
    msg = _problems(copy, "--no-meshes")
    assert "tool frame misses pose 1 (T1)" in msg
    assert "loop coupler-coupler_k open at pose 1" in msg
    assert "differ from the angle laws" in msg


def test_wrong_angle_law_is_caught(copy):
    doc = json.loads((copy / "linkage.json").read_text())
    doc["joints"][1]["angle_law"]["b"] *= 1.001
    (copy / "linkage.json").write_text(json.dumps(doc))
    msg = _problems(copy, "--no-meshes")
    assert "open along the angle laws' motion" in msg
    assert "deviates from the angle laws" in msg


def test_two_parents_and_extra_root_are_caught(copy):
    _edit(copy / "linkage.urdf", "</robot>",
          '<link name="stray" /><joint name="extra" type="fixed"><parent link="link_h1" />'
          '<child link="coupler_k" /></joint></robot>')
    msg = _problems(copy, "--no-meshes")
    assert "link coupler_k has two parents" in msg
    assert "root link(s) ['base', 'stray']" in msg


def test_tool_link_missing_is_caught(copy):
    urdf = copy / "linkage.urdf"
    text = re.sub(r'<joint name="tool_mount".*?</joint>', "", urdf.read_text(), flags=re.S)
    urdf.write_text(re.sub(r'<link name="tool">.*?</link>', "", text, flags=re.S))
    assert "no link tool" in _problems(copy, "--no-meshes")


# ------------------------------------------------------------------------------------------ unreadable OUT
def test_unreadable_outputs_exit_2(tmp_path, copy):
    r = run("check", tmp_path / "nowhere")
    assert r.exit_code == 2 and "no such output directory" in r.stderr
    (copy / "linkage.json").write_text("{not json")
    r = run("check", copy)
    assert r.exit_code == 2 and "not valid JSON" in r.stderr
    (copy / "linkage.urdf").write_text("<robot><link")
    r = run("check", copy)
    assert r.exit_code == 2 and "not well-formed XML" in r.stderr
    (copy / "linkage.urdf").unlink()
    r = run("check", copy)
    assert r.exit_code == 2 and "no linkage.urdf" in r.stderr


def test_unreadable_pose_file_exits_2(copy, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("poses: [{position: [0, 0], quaternion: {w: 1, x: 0, y: 0, z: 0}}]\n")
    r = run("check", copy, "--poses", bad)
    assert r.exit_code == 2


# ------------------------------------------------------------------------------------------ multi-solution
def test_multi_solution_directory(bennett_out, tmp_path):
    out = tmp_path / "multi"
    out.mkdir()
    for sid in ("s1", "s2"):
        shutil.copytree(bennett_out, out / sid)
    (out / "index.json").write_text(json.dumps({"format": "mpsynth.index/1", "solutions": ["s1", "s2"]}))
    r, doc = check_json(out, "--no-meshes")
    assert doc["ok"] and set(doc["figures"]) == {"s1", "s2"}
    (out / "s2" / "meshes" / "base.stl").unlink()
    r, doc = check_json(out)
    assert not doc["ok"] and all(p.startswith("s2: ") for p in doc["problems"])


# ------------------------------------------------------------------------------------------ library pieces
def test_continuation_matches_laws_and_reports_progress(bennett_out):
    u = read_urdf(bennett_out / "linkage.urdf")
    doc = json.loads((bennett_out / "linkage.json").read_text())
    laws = {j["name"]: (j["angle_law"]["a"], j["angle_law"]["b"]) for j in doc["joints"]}
    res = continue_loop(u, [("coupler", "coupler_k")], "h1", ["h2", "k1", "k2"], steps=90, length=0.5)
    assert res["followed"] == 1.0 and res["max_residual"] < 1e-8
    path = np.array(res["path"])
    exact = law_angles(laws, "h1", path[:, 0])
    for k, jn in enumerate(["h2", "k1", "k2"]):
        d = np.mod(path[:, k + 1] - exact[jn] + np.pi, 2 * np.pi) - np.pi
        assert np.abs(d).max() < 1e-8


def test_check_output_library_call(bennett_out):
    res = check_output(bennett_out, meshes=False)
    assert res["ok"] and "meshes" not in res["figures"]
