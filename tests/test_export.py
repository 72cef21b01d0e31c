"""Tests of synth.io: meshes, URDF, linkage.json and the atomic writer (OUTPUT.md)."""
from __future__ import annotations

import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from linkage_fixtures import H1, H2, K1, K2, bennett_linkage, exact_factors  # noqa: E402

from synth.algebra.dq import quat_to_matrix  # noqa: E402
from synth.errors import InputError  # noqa: E402
from synth.io.writer import atomic_directory, write_output  # noqa: E402
from synth.io.jsonout import linkage_document  # noqa: E402
from synth.io.urdf import urdf_text  # noqa: E402
from synth.io import atomic as atomic_mod  # noqa: E402
from synth.io import writer as writer_mod  # noqa: E402
from synth.io import step  # noqa: E402
from synth.frames import rpy_from_matrix, rpy_matrix  # noqa: E402
from synth.io.jsonout import FORMAT, plain, write_json  # noqa: E402
from synth.design.choose import default_sizes, design_for  # noqa: E402
from synth.io.meshes import link_meshes, mesh_inertials  # noqa: E402
from synth.linkage import Joint, Linkage  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
VERIFIER = Path(__file__).resolve().parents[2] / "shared/tools/verify_output.py"
GEOMETRIC = {"base", "link_h1", "link_k1", "coupler"}
PINS = {"pin_h1", "pin_h2", "pin_k1", "pin_k2"}


# ------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def bennett():
    return bennett_linkage()


@pytest.fixture(scope="module")
def design(bennett):
    return design_for(bennett).design


@pytest.fixture(scope="module")
def meshes(bennett, design):
    return link_meshes(bennett, design)


@pytest.fixture(scope="module")
def masses(meshes):
    return mesh_inertials(meshes)


@pytest.fixture(scope="module")
def written(bennett, tmp_path_factory):
    out = tmp_path_factory.mktemp("written") / "OUT"
    paths = write_output(bennett, out, robot_name="bennett", result=design_for(bennett))
    return out, paths


def load_urdf(path_or_text):
    import yourdfpy

    if isinstance(path_or_text, Path):
        src = str(path_or_text)
    else:
        src = io.BytesIO(path_or_text.encode("utf-8"))
    return yourdfpy.URDF.load(src, load_meshes=False, build_collision_scene_graph=False)


def fk(model, angles, frame="tool"):
    model.update_cfg({k: float(v) for k, v in angles.items() if k in model.actuated_joint_names})
    return model.get_transform(frame_to=frame, frame_from="base")


def entries(parent: Path) -> set[str]:
    return {p.name for p in parent.iterdir()}


# ------------------------------------------------------------------ the test linkage itself
def test_fixture_factors_match_math_md(bennett):
    for refined, printed in zip(exact_factors(), (H1, H2, K1, K2)):
        assert np.max(np.abs(refined - np.array(printed))) < 1e-9
    assert bennett.checks["max_pose_error"] < 1e-13
    assert bennett.checks["max_closure_error"] < 1e-13
    ten_digits = bennett_linkage(exact=False)
    assert 1e-12 < ten_digits.checks["max_closure_error"] < 1e-8  # why we refine


# ------------------------------------------------------------------ rpy
def test_rpy_round_trip_random_and_degenerate():
    rng = np.random.default_rng(1)
    Rs = [quat_to_matrix(q) for q in rng.normal(size=(500, 4))]
    for pitch in (math.pi / 2, -math.pi / 2, math.pi / 2 - 1e-9, -math.pi / 2 + 1e-13, math.pi / 2 - 1e-5):
        Rs += [rpy_matrix(rng.uniform(-4, 4), pitch, rng.uniform(-4, 4)) for _ in range(40)]
    for angle in (math.pi, math.pi - 1e-12, math.pi - 1e-7):
        for _ in range(40):
            a = rng.normal(size=3)
            Rs.append(quat_to_matrix(np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * a / np.linalg.norm(a)])))
    Rs += [np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1]),
           np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]), np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]])]
    worst = max(np.max(np.abs(rpy_matrix(*rpy_from_matrix(R)) - R)) for R in Rs)
    assert worst < 4e-15


def test_tool_mount_reproduces_tool_ref_through_urdf(bennett, design, masses):
    """The URDF's own FK (yourdfpy) at all-zero angles gives tool_ref to 1e-12, for random and
    near-gimbal-lock / near-180-degree tool orientations."""
    import copy

    rng = np.random.default_rng(7)
    rotations = [quat_to_matrix(q) for q in rng.normal(size=(6, 4))]
    rotations += [rpy_matrix(0.3, math.pi / 2 - 1e-12, -1.2), rpy_matrix(-2.0, -math.pi / 2, 0.7),
                  rpy_matrix(1.0, math.pi / 2 - 1e-6, 3.0), quat_to_matrix([1e-9, 0.6, 0.0, 0.8]),
                  np.diag([-1.0, -1, 1]), quat_to_matrix([0.0, 0.0, 1.0, 0.0])]
    for R in rotations:
        lk = copy.copy(bennett)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, rng.normal(size=3)
        lk.tool_ref = T
        model = load_urdf(urdf_text(lk, "t", design, masses))
        assert np.max(np.abs(fk(model, {}) - T)) < 1e-12


# ------------------------------------------------------------------ meshes
def test_meshes_watertight_single_solid(bennett, meshes):
    assert set(meshes) == GEOMETRIC | PINS  # coupler_k has no joints, so no mesh; one pin per joint
    for name, mesh in meshes.items():
        assert mesh.is_watertight, name
        assert mesh.is_volume, name
        assert mesh.volume > 0
        assert mesh.body_count == 1, name  # one solid: bar and hubs united, bores cut


def test_meshes_in_link_frame_cover_joint_feet(bennett, meshes):
    """The middle between a link's two mounts (where the design attaches it to its axes) lies inside its
    mesh (in link frame); the mounts themselves lie on the axes, in the bores, outside."""
    from synth.design.model import axis_point
    from synth.frames import link_origins

    design = design_for(bennett).design
    origins = link_origins(bennett)
    for name in GEOMETRIC:
        mesh = meshes[name]
        f1, f2 = (axis_point(bennett, n, design.mount(name, n).offset) for n in bennett.links[name])
        assert mesh.contains(np.array([(f1 + f2) / 2]) - origins[name]).all(), name
        assert not mesh.contains(np.array([f1, f2]) - origins[name]).any(), name
        # and the mesh sits in the link frame, not in world coordinates (unless the frame is the world's)
        if name != "base":
            assert np.linalg.norm(mesh.bounds.mean(axis=0) - ((f1 + f2) / 2 - origins[name])) < 0.2


def test_mesh_sizes_default_and_override(bennett):
    e = bennett.extent()
    assert default_sizes(bennett) == pytest.approx((0.02 * e, 0.015 * e, 0.06 * e))
    assert default_sizes(bennett, 0.01, 0.005, 0.05) == (0.01, 0.005, 0.05)
    thin = link_meshes(bennett, design_for(bennett, pin_radius=0.01, link_radius=0.005, pin_length=0.05).design)
    thick = link_meshes(bennett, design_for(bennett).design)
    for name in GEOMETRIC:
        assert 0 < thin[name].volume < thick[name].volume
    for bad in (0, -1.0, float("nan"), float("inf"), "x"):
        with pytest.raises(InputError):
            default_sizes(bennett, pin_radius=bad)


def _odd_linkage():
    """Not a mechanism: one link whose consecutive axes are parallel, intersecting and coincident."""
    def J(name, parent, child, u, point):
        u = np.array(u, float) / np.linalg.norm(u)
        return Joint(name, parent, child, u, np.cross(np.array(point, float), u), 0.0, 1.0)

    joints = [J("j1", "base", "a", [0, 0, 1], [0, 0, 0]),
              J("j2", "a", "b", [0, 0, 1], [0.5, 0.2, 0.3]),      # parallel to j1
              J("j3", "b", "c", [1, 0, 0], [0.5, 0.2, 0.0]),      # meets j2 at (0.5, 0.2, 0)
              J("j4", "c", "d", [-1, 0, 0], [0.9, 0.2, 0.0])]     # the same line as j3
    return Linkage(kind="test", joints=joints, links={"base": ["j1"], "a": ["j1", "j2", "j3", "j4"], "b": [],
                   "c": ["j3", "j4"], "d": ["j4"]},
                   branches=[["j1", "j2", "j3", "j4"]], closures=[("d", "base")], tool_ref=np.eye(4),
                   motion=np.zeros((2, 8)))


@pytest.mark.parametrize("manifold", [True, False])
def test_meshes_degenerate_axis_pairs(monkeypatch, manifold):
    import synth.io.meshes as meshes_mod

    if not manifold:
        monkeypatch.setattr(meshes_mod, "have_manifold", lambda: False)
    from synth.design.model import straight_design
    from synth.design.choose import default_hole_clearance, default_sizes

    lk = _odd_linkage()
    pin_radius, bar_radius, hub_length = default_sizes(lk)
    design = straight_design(lk, pin_radius=pin_radius, bar_radius=bar_radius, hub_length=hub_length,
                             hole_clearance=default_hole_clearance(pin_radius))
    out = link_meshes(lk, design)  # (not a mechanism: the straight design, no search)
    assert set(out) == {"base", "a", "c", "d", "pin_j1", "pin_j2", "pin_j3", "pin_j4"}
    for name, mesh in out.items():
        assert mesh.is_watertight and mesh.volume > 0, name
    if manifold:
        assert out["c"].body_count == 1  # (in "a" the bar along the j3-j4 line lies inside their bores)


# ------------------------------------------------------------------ URDF
def test_urdf_structure(bennett, design, masses):
    root = ET.fromstring(urdf_text(bennett, 'name <&"> x', design, masses))
    assert root.get("name") == 'name <&"> x'
    links = {l.get("name"): l for l in root.findall("link")}
    assert set(links) == GEOMETRIC | PINS | {"coupler_k", "tool"}
    joints = {j.get("name"): j for j in root.findall("joint")}
    assert {n: j.get("type") for n, j in joints.items()} == {
        "h1": "continuous", "h2": "continuous", "k1": "continuous", "k2": "continuous", "tool_mount": "fixed",
        **{f"{p}_mount": "fixed" for p in PINS}}
    assert joints["tool_mount"].find("parent").get("link") == "coupler"
    assert joints["tool_mount"].find("child").get("link") == "tool"
    for n in ("h1", "h2", "k1", "k2"):
        assert joints[n].find("origin").get("rpy") == "0.0 0.0 0.0"
        axis = [float(v) for v in joints[n].find("axis").get("xyz").split()]
        assert axis == list(bennett.joint(n).direction)  # written exactly (repr)
    gz = root.findall("gazebo")
    assert len(gz) == 1
    cl = gz[0].find("joint")
    assert (cl.get("name"), cl.get("type"), cl.find("parent").text, cl.find("child").text) == (
        "loop_closure", "fixed", "coupler", "coupler_k")
    for name, link in links.items():
        inertial = link.find("inertial")
        assert inertial is not None
        mass = float(inertial.find("mass").get("value"))
        if name in PINS:
            assert mass == pytest.approx(masses[name][0], rel=1e-15)
            for tag in ("visual", "collision"):
                assert link.find(f"{tag}/geometry/mesh").get("filename") == f"meshes/{name}.stl"
        elif name in GEOMETRIC:
            # the coupler shares its mass equally with its welded duplicate coupler_k
            expect = masses[name][0] / (2 if name == "coupler" else 1)
            assert mass == pytest.approx(expect, rel=1e-15) and mass > 0.01
            for tag in ("visual", "collision"):
                assert link.find(f"{tag}/geometry/mesh").get("filename") == f"meshes/{name}.stl"
        elif name == "coupler_k":
            assert mass == pytest.approx(masses["coupler"][0] / 2, rel=1e-15)
            assert link.find("visual") is None
        else:
            assert mass == 1e-6
            assert link.find("visual") is None


def test_urdf_package_paths(bennett, design, masses):
    root = ET.fromstring(urdf_text(bennett, "b", design, masses, package="my_robot"))
    names = {m.get("filename") for m in root.iter("mesh")}
    assert names == {f"package://my_robot/meshes/{n}.stl" for n in GEOMETRIC | PINS}


def test_urdf_several_closures_are_numbered(bennett, design, masses):
    import copy

    lk = copy.copy(bennett)
    lk.closures = [("coupler", "coupler_k"), ("link_h1", "link_k1")]
    root = ET.fromstring(urdf_text(lk, "b", design, masses))
    assert [g.find("joint").get("name") for g in root.findall("gazebo")] == ["loop_closure", "loop_closure_2"]


def test_urdf_fk_reaches_poses_and_closes_loop(bennett, written):
    out, _ = written
    model = load_urdf(out / "linkage.urdf")
    for pose in bennett.poses:
        assert np.max(np.abs(fk(model, pose.joint_angles) - pose.matrix)) < 1e-9
    # along the whole motion: tool = linkage.tool_pose, coupler-to-coupler_k transform constant
    ref = np.linalg.inv(fk(model, {}, "coupler")) @ fk(model, {}, "coupler_k")
    for t in (-7.0, -1.3, 0.2, 0.5, 2.0, 40.0):
        angles = {k: float(v) for k, v in bennett.angles_at(t).items()}
        assert np.max(np.abs(fk(model, angles) - bennett.tool_pose(angles))) < 1e-12
        rel = np.linalg.inv(fk(model, angles, "coupler")) @ fk(model, angles, "coupler_k")
        assert np.max(np.abs(rel - ref)) < 1e-12


# ------------------------------------------------------------------ linkage.json
def test_linkage_document(bennett):
    doc = linkage_document(bennett)
    assert doc["format"] == FORMAT == "mpsynth.linkage/1"
    assert doc["kind"] == "bennett" and doc["units"] == {"length": "m", "angle": "rad"}
    assert [p["name"] for p in doc["poses"]] == ["T0", "T1", "T2"]
    assert [p["t"] for p in doc["poses"]] == [None, 0.0, 1.0]
    assert doc["poses"][1]["joint_angles"]["h1"] == pytest.approx(4.1628830873, abs=1e-9)
    assert doc["poses"][2]["joint_angles"]["k1"] == pytest.approx(2.1869341004, abs=1e-9)
    h1 = doc["joints"][0]
    assert h1["name"] == "h1" and h1["parent"] == "base" and h1["child"] == "link_h1"
    assert h1["line"]["direction"] == pytest.approx([-0.2327764841, -0.9407168724, -0.2467121287], abs=1e-9)
    assert h1["line"]["moment"] == pytest.approx([0.6227965221, -0.02904718285, -0.4768602594], abs=1e-9)
    assert h1["angle_law"] == {"a": bennett.joint("h1").a, "b": bennett.joint("h1").b}
    assert doc["branches"] == [["h1", "h2"], ["k1", "k2"]]
    assert doc["closures"] == [["coupler", "coupler_k"]]
    assert len(doc["motion_polynomial"]) == 3 and doc["motion_polynomial"][2] == [1.0] + [0.0] * 7
    assert set(doc["checks"]) == {"max_pose_error", "max_closure_error"}
    assert doc["links"]["coupler_k"] == [] and doc["links"]["coupler"] == ["h2", "k2"]
    assert set(doc["info"]) == {"bennett"} and abs(doc["info"]["bennett"]["bennett_condition_residual"]) < 1e-9
    # plain JSON only, and it survives a strict round trip
    assert json.loads(json.dumps(doc, allow_nan=False)) == doc


def test_plain_and_write_json(tmp_path):
    doc = plain({"a": np.arange(3), "b": np.float32(0.5), "c": (1, float("inf"), np.nan), "d": np.bool_(True),
                 "e": {"m": np.eye(2)}, 3: None})
    assert doc == {"a": [0, 1, 2], "b": 0.5, "c": [1, None, None], "d": True, "e": {"m": [[1.0, 0.0], [0.0, 1.0]]},
                   "3": None}
    with pytest.raises(TypeError, match=r"document\.x"):
        plain({"x": object()})
    x = 0.1 + 0.2
    write_json({"v": [x, -1e-300], "m": [[1.0, 2.0], [3.0, 4.0]], "s": "é", "e": {}, "l": []}, tmp_path / "d.json")
    back = json.loads((tmp_path / "d.json").read_text())
    assert back == {"v": [x, -1e-300], "m": [[1.0, 2.0], [3.0, 4.0]], "s": "é", "e": {}, "l": []}


# ------------------------------------------------------------------ the output directory
def test_write_output_files(bennett, written):
    import trimesh

    out, paths = written
    assert paths[:2] == [out / "linkage.urdf", out / "linkage.json"]
    assert sorted(p.name for p in paths[2:] if p.suffix == ".stl") == sorted(f"{n}.stl" for n in GEOMETRIC | PINS)
    assert (Path("linkage.step") in [p.relative_to(out) for p in paths]) == step.have_kernel()  # with the cad extra
    assert all(p.is_file() for p in paths)

    result = design_for(bennett)
    doc = json.loads((out / "linkage.json").read_text())
    from synth.drive import drive_report

    printed = doc.pop("print")  # the parts on the bed (tests/test_printreport.py)
    assert doc.pop("step") is step.have_kernel()  # linkage.step written (tests/test_step.py)
    assert sorted(p["mesh"] for p in printed["parts"]) == sorted(f"meshes/{n}.stl" for n in GEOMETRIC | PINS)
    assert doc == linkage_document(bennett, result.design, result.collision, drive_report(bennett), result.slenderness)
    assert doc["design"]["slenderness"]["met"]  # the bars as written (tests/test_sturdy.py)
    assert doc["drive"]["driver"] == "h1" and doc["drive"]["max_speed_ratio"] > 0
    assert set(doc["design"]) >= {"pin_radius", "bar_radius", "hub_radius", "hub_length", "hole_clearance",
                                  "clearance", "mounts", "bars", "pins"}
    assert {p["link"] for p in doc["design"]["pins"]} == PINS
    assert all(p["length"] > 0 and p["mesh"] == f"meshes/{p['link']}.stl" for p in doc["design"]["pins"])
    assert set(doc["collision"]) >= {"free", "range", "clearance", "min_distance", "driver_range"}
    for p in [p for p in paths[2:] if p.suffix == ".stl"]:
        data = p.read_bytes()
        n = int.from_bytes(data[80:84], "little")
        assert len(data) == 84 + 50 * n and n > 100  # binary STL
        mesh = trimesh.load(p, force="mesh")
        assert mesh.is_watertight and mesh.volume > 0
    assert not [e for e in entries(out.parent) if "mpsynth-" in e]  # no temp or old dir left


def test_exception_mid_write_leaves_nothing(bennett, tmp_path, monkeypatch):
    import synth.io.urdf as urdf_mod

    def boom(*a, **k):  # meshes are already written to the temp dir when this runs
        raise RuntimeError("boom")

    monkeypatch.setattr(urdf_mod, "urdf_text", boom)
    with pytest.raises(RuntimeError, match="boom"):
        write_output(bennett, tmp_path / "OUT", robot_name="b", result=design_for(bennett))
    assert entries(tmp_path) == set()


def test_exception_mid_write_keeps_previous_output(bennett, tmp_path, monkeypatch):
    import synth.io.urdf as urdf_mod

    out = tmp_path / "OUT"
    write_output(bennett, out, robot_name="first", result=design_for(bennett))
    before = (out / "linkage.urdf").read_text()
    monkeypatch.setattr(urdf_mod, "urdf_text", lambda *a, **k: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        write_output(bennett, out, robot_name="second", result=design_for(bennett))
    assert (out / "linkage.urdf").read_text() == before
    assert entries(tmp_path) == {"OUT"}


def test_replace_mpsynth_output(bennett, tmp_path):
    out = tmp_path / "OUT"
    write_output(bennett, out, robot_name="first", result=design_for(bennett))
    (out / "notes.txt").write_text("the user's")
    (out / "meshes" / "link_h1.stl").write_text("stale mesh of the old run")
    (out / "meshes" / "link_gone.stl").write_text("")  # pretend the old run wrote a link this one does not
    doc = json.loads((out / writer_mod.MARKER).read_text())
    doc["files"].append("meshes/link_gone.stl")
    (out / writer_mod.MARKER).write_text(json.dumps(doc))
    write_output(bennett, out, robot_name="second", result=design_for(bennett))
    assert 'name="second"' in (out / "linkage.urdf").read_text()
    assert (out / "notes.txt").read_text() == "the user's"  # not mpsynth's: kept
    assert (out / "meshes" / "link_h1.stl").read_bytes().startswith(b"solid") or \
        len((out / "meshes" / "link_h1.stl").read_bytes()) > 100  # replaced
    assert not (out / "meshes" / "link_gone.stl").exists()  # listed by the old manifest, not rewritten
    assert "notes.txt" not in json.loads((out / writer_mod.MARKER).read_text())["files"]
    assert entries(tmp_path) == {"OUT"}
    # only the manifest proves ownership: a linkage.json with an mpsynth format is not enough (#35)
    (out / writer_mod.MARKER).unlink()
    with pytest.raises(InputError, match="not written by mpsynth"):
        write_output(bennett, out, robot_name="third", result=design_for(bennett))
    assert 'name="second"' in (out / "linkage.urdf").read_text()
    assert (out / "notes.txt").read_text() == "the user's"


def test_foreign_directory_refused_unless_forced(bennett, tmp_path):
    out = tmp_path / "OUT"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match="not written by mpsynth") as e:
        write_output(bennett, out, robot_name="b", result=design_for(bennett))
    assert str(out) in str(e.value) and "\n" not in str(e.value)
    assert (out / "thesis.tex").read_text() == "precious"
    assert entries(tmp_path) == {"OUT"}
    write_output(bennett, out, robot_name="b", force=True, result=design_for(bennett))  # --force writes beside, never deletes
    assert (out / "thesis.tex").read_text() == "precious" and (out / "linkage.urdf").is_file()
    assert entries(tmp_path) == {"OUT"}


def test_empty_directory_and_file_targets(bennett, tmp_path):
    (tmp_path / "EMPTY").mkdir()
    write_output(bennett, tmp_path / "EMPTY", robot_name="b", result=design_for(bennett))
    assert (tmp_path / "EMPTY" / "linkage.json").is_file()
    (tmp_path / "FILE").write_text("x")
    with pytest.raises(InputError, match="FILE"):
        write_output(bennett, tmp_path / "FILE", robot_name="b", result=design_for(bennett))
    assert (tmp_path / "FILE").read_text() == "x"
    write_output(bennett, tmp_path / "FILE", robot_name="b", force=True, result=design_for(bennett))
    assert (tmp_path / "FILE" / "linkage.urdf").is_file()
    assert entries(tmp_path) == {"EMPTY", "FILE"}


def test_missing_or_bad_parent(bennett, tmp_path):
    missing = tmp_path / "no" / "such"
    with pytest.raises(InputError, match="does not exist") as e:
        write_output(bennett, missing / "OUT", robot_name="b", result=design_for(bennett))
    assert str(missing) in str(e.value) and "\n" not in str(e.value)
    (tmp_path / "plain").write_text("")
    with pytest.raises(InputError, match="not a directory"):
        write_output(bennett, tmp_path / "plain" / "OUT", robot_name="b", result=design_for(bennett))


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root may write to read-only dirs")
def test_read_only_parent(bennett, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(InputError, match="not writable"):
            write_output(bennett, ro / "OUT", robot_name="b", result=design_for(bennett))
    finally:
        ro.chmod(0o755)


def test_unwritable_parent_simulated(bennett, tmp_path, monkeypatch):
    """Runs as root too: fake the permission check, then a failing mkdtemp (e.g. read-only file system)."""
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **k: False if Path(p) == tmp_path else real_access(p, mode, **k))
    with pytest.raises(InputError, match="not writable") as e:
        write_output(bennett, tmp_path / "OUT", robot_name="b", result=design_for(bennett))
    assert str(tmp_path) in str(e.value)
    monkeypatch.setattr(os, "access", real_access)

    def no_mkdtemp(*a, **k):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(atomic_mod.tempfile, "mkdtemp", no_mkdtemp)
    with pytest.raises(InputError, match="Read-only file system") as e:
        write_output(bennett, tmp_path / "OUT", robot_name="b", result=design_for(bennett))
    assert str(tmp_path) in str(e.value) and "\n" not in str(e.value)
    assert entries(tmp_path) == set()


def test_atomic_directory_generic_layout(tmp_path):
    out = tmp_path / "MULTI"
    with atomic_directory(out) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".MULTI.mpsynth-tmp-")
        assert not out.exists()
        (tmp / "sol1").mkdir()
        (tmp / "index.json").write_text(json.dumps({"format": "mpsynth.index/1"}))
    assert (out / "sol1").is_dir() and (out / writer_mod.MARKER).is_file()
    assert entries(tmp_path) == {"MULTI"}
    with pytest.raises(ValueError):
        with atomic_directory(out) as tmp:
            (tmp / "half").write_text("")
            raise ValueError("no")
    assert (out / "sol1").is_dir() and not (out / "half").exists()
    assert entries(tmp_path) == {"MULTI"}


@pytest.fixture
def cli_guard():
    """The CLI's signal policy for writes (cli/signals.py), as `mpsynth` registers it; the library's
    own default installs nothing."""
    from cli.signals import WriteGuard
    from synth.io import interrupts

    interrupts.use(WriteGuard)
    yield
    interrupts.use(interrupts.NoGuard)


def test_library_installs_no_signal_handler(tmp_path):
    from synth.io import interrupts

    before = interrupts._factory
    interrupts.use(interrupts.NoGuard)
    try:
        with atomic_directory(tmp_path / "OUT") as tmp:
            assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL or \
                signal.getsignal(signal.SIGTERM) is not None
            handler = signal.getsignal(signal.SIGINT)
            (tmp / "a").write_text("")
        assert handler is signal.default_int_handler
    finally:
        interrupts.use(before)


@pytest.mark.parametrize("sig,exc", [(signal.SIGTERM, SystemExit), (signal.SIGINT, KeyboardInterrupt)])
def test_signal_during_write_cleans_up_and_restores_handlers(tmp_path, sig, exc, cli_guard):
    previous = signal.getsignal(sig)
    with pytest.raises(exc) as e:
        with atomic_directory(tmp_path / "OUT") as tmp:
            (tmp / "part").write_text("")
            os.kill(os.getpid(), sig)
            for _ in range(1000):  # the handler runs at the next bytecode boundary
                pass
            pytest.fail("signal not delivered")
    if exc is SystemExit:
        assert e.value.code == 143
    assert entries(tmp_path) == set()
    assert signal.getsignal(sig) is previous


def test_signal_during_commit_is_deferred(tmp_path, monkeypatch, cli_guard):
    real_commit = atomic_mod._commit

    def commit(tmp, out):
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass
        real_commit(tmp, out)

    monkeypatch.setattr(atomic_mod, "_commit", commit)
    with pytest.raises(SystemExit) as e:
        with atomic_directory(tmp_path / "OUT") as tmp:
            (tmp / "done").write_text("")
    assert e.value.code == 143
    assert entries(tmp_path) == {"OUT"} and (tmp_path / "OUT" / "done").is_file()


def test_sigint_subprocess_exit_status(tmp_path):
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(REPO / 'tests')!r})
        from linkage_fixtures import bennett_linkage
        import synth.io.urdf as urdf_mod
        from synth.design.choose import design_for
        from synth.io.writer import write_output
        def slow(*a, **k):
            print("ready", flush=True)
            time.sleep(30)
        urdf_mod.urdf_text = slow
        lk = bennett_linkage()
        write_output(lk, {str(tmp_path / 'OUT')!r}, robot_name="b", result=design_for(lk))
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            cwd=REPO, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode in (-signal.SIGINT, 130), proc.stderr.read()
    assert entries(tmp_path) == set()


# ------------------------------------------------------------------ independent tools
def test_import_is_light():
    code = "import sys, synth.io.writer; print('trimesh' in sys.modules)"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    assert res.stdout.strip() == "False"


@pytest.mark.skipif(not VERIFIER.is_file(), reason="shared/tools/verify_output.py not found")
def test_verify_output_end_to_end(bennett, written, tmp_path):
    import yaml

    out, _ = written
    poses = tmp_path / "poses.yaml"
    poses.write_text(yaml.safe_dump({"poses": [{"name": p.name, "matrix": np.asarray(p.matrix).tolist()}
                                                for p in bennett.poses]}))
    res = subprocess.run([sys.executable, str(VERIFIER), str(poses), str(out)], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.strip().splitlines()[-1].startswith("verify OK")


@pytest.mark.skipif(shutil.which("check_urdf") is None, reason="check_urdf (liburdfdom-tools) not installed")
def test_check_urdf(written):
    out, _ = written
    res = subprocess.run(["check_urdf", str(out / "linkage.urdf")], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Successfully Parsed XML" in res.stdout
    assert "root Link: base" in res.stdout


def test_welded_duplicate_shares_the_coupler_mass(tmp_path):
    """coupler_k gets half of the coupler's mass (a 1e-6 kg body on a weld opens PyBullet's weld)."""
    import xml.etree.ElementTree as ET

    from linkage_fixtures import bennett_linkage
    from synth.io.writer import write_output

    out = tmp_path / "o"
    write_output(bennett_linkage(), out, robot_name="b", result=design_for(bennett_linkage()))
    root = ET.parse(out / "linkage.urdf").getroot()
    mass = {l.get("name"): float(l.find("inertial/mass").get("value")) for l in root.findall("link")}
    assert mass["coupler_k"] == pytest.approx(mass["coupler"]) and mass["coupler"] > 1e-3
