"""Reading an output directory back (synth.io.readback) and `mpsynth render` (PNG, GIF) without a display."""
from __future__ import annotations

import hashlib
import json
import math
import shutil

import numpy as np
import pytest

from synth.synthesis.bennett import bennett
from synth.errors import InputError
from synth.io.writer import write_output
from synth.design.choose import design_for
from synth.io.poses import load_poses
from synth.io.readback import angle_laws, cycle_parameters, mesh_path, phi_of, read_files, read_output

from conftest import REPO, run


@pytest.fixture(scope="module")
def out_quat(tmp_path_factory):
    ps = load_poses(str(REPO / "fixtures" / "bennett_quat.yaml"))
    out = tmp_path_factory.mktemp("render") / "bennett_quat"
    write_output(bennett(ps.matrices, ps.names), out, robot_name="bennett_quat", result=design_for(bennett(ps.matrices, ps.names)))
    return out


# ------------------------------------------------------------------ readback
def test_readback_reproduces_the_linkage(out_quat):
    rb = read_output(out_quat)
    doc = json.loads((out_quat / "linkage.json").read_text())
    assert rb.robot_name == "bennett_quat" and rb.kind == "bennett"
    assert [j.name for j in rb.linkage.joints] == [j["name"] for j in doc["joints"]]
    assert rb.mesh_links == ["base", "link_h1", "coupler", "link_k1"]
    # the tool frame reaches every task pose at the pose's t
    for rec in rb.linkage.poses:
        assert np.abs(rb.tool_poses(rec.t) - rec.matrix).max() < 1e-12
    # the loop stays closed over the motion: coupler_k's frame moves rigidly with coupler's
    t = cycle_parameters(rb.linkage, 50)
    P = rb.link_poses(t)
    rel = np.linalg.inv(P["coupler"]) @ P["coupler_k"]
    assert np.abs(rel - rel[-1]).max() < 1e-10
    # meshes are in metres in the link frames: at the reference configuration every pin of the
    # base lies on its joint axis (mesh vertices within a few radii of the axis)
    base = rb.meshes()["base"]
    world = base.vertices @ rb.frame_ref["base"][:3, :3].T + rb.frame_ref["base"][:3, 3]
    h1 = rb.linkage.joint("h1")
    d = np.linalg.norm(np.cross(world, h1.direction) - h1.moment, axis=1)
    assert d.min() < 0.05 * rb.linkage.extent()
    assert base.is_watertight


def test_adjacency_excludes_joint_neighbours_and_the_weld(out_quat):
    rb = read_output(out_quat)
    adj = rb.adjacent_pairs()
    for a, b in [("base", "link_h1"), ("link_h1", "coupler"), ("base", "link_k1"), ("link_k1", "coupler"),
                 ("coupler", "coupler_k"), ("link_k1", "coupler_k")]:
        assert frozenset((a, b)) in adj
    assert frozenset(("base", "coupler")) not in adj
    assert frozenset(("link_h1", "link_k1")) not in adj


def test_cycle_parameters_cover_one_cycle(out_quat):
    lk = read_output(out_quat).linkage
    for spacing in ("phi", "angle"):
        t = cycle_parameters(lk, 90, spacing=spacing)
        phi = phi_of(t)
        assert np.isinf(t[-1]) and np.all(np.diff(phi) > 0) and phi[0] > -math.pi / 2
    # "angle": the summed joint-angle step between consecutive samples is the same everywhere
    t = cycle_parameters(lk, 90)
    ang = np.array([j.angle(np.concatenate([[t[-1]], t])) for j in lk.joints])
    step = np.abs((np.diff(ang, axis=1) + math.pi) % (2 * math.pi) - math.pi).sum(0)
    assert step.max() / step.min() < 1.05
    assert abs(step.sum() - 2 * math.pi * len(lk.joints)) < 1e-6


def test_readback_errors(tmp_path, out_quat):
    with pytest.raises(InputError, match="no such output directory"):
        read_output(tmp_path / "missing")
    with pytest.raises(InputError, match="no linkage.json"):
        read_output(tmp_path)
    bad = tmp_path / "bad"
    shutil.copytree(out_quat, bad)
    (bad / "meshes" / "coupler.stl").unlink()
    with pytest.raises(InputError, match="coupler.stl"):
        read_output(bad)
    moved = tmp_path / "moved"
    shutil.copytree(out_quat, moved)
    doc = json.loads((moved / "linkage.json").read_text())
    doc["joints"][1]["line"]["moment"] = [m + 0.01 for m in doc["joints"][1]["line"]["moment"]]
    (moved / "linkage.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="h2's axis differs"):
        read_output(moved)


def test_mesh_path_is_one_rule_for_every_reader(tmp_path):
    assert mesh_path("meshes/a.stl", tmp_path) == tmp_path / "meshes" / "a.stl"
    assert mesh_path("package://robot/meshes/a.stl", tmp_path) == tmp_path / "meshes" / "a.stl"
    for bad in ("", "/abs/a.stl", "file:///abs/a.stl", "http://host/a.stl", "package://robot", "package://robot/"):
        assert mesh_path(bad, tmp_path) is None, bad


def test_angle_laws_of_a_document():
    doc = {"joints": [{"name": "h1", "angle_law": {"a": 1, "b": 2}}, {"name": "h2", "a": 0.5, "b": -1.0},
                      {"name": "h3", "angle_law": {"a": True, "b": 1}}, {"name": "h4"}, "junk", {"a": 1, "b": 1}]}
    assert angle_laws(doc) == {"h1": (1.0, 2.0), "h2": (0.5, -1.0)}
    assert angle_laws({}) == {} and angle_laws({"joints": "x"}) == {}


def test_strict_reader_refuses_what_the_lenient_one_lists(tmp_path, out_quat):
    """read_files (check, simulate) lists a malformed URDF value as a problem; read_output (render, view,
    collide) refuses the directory with that same line."""
    bad = tmp_path / "bad"
    shutil.copytree(out_quat, bad)
    urdf = bad / "linkage.urdf"
    text = urdf.read_text()
    i = text.index('<axis xyz="')
    urdf.write_text(text[:i] + '<axis xyz="1 0"' + text[text.index("/>", i):])
    problems = read_files(bad).urdf.problems
    assert "axis of joint h1" in problems[0] and "expected 3 finite numbers" in problems[0]
    with pytest.raises(InputError, match="axis of joint h1 .* expected 3 finite numbers"):
        read_output(bad)


# ------------------------------------------------------------------ render
def test_png_and_gif_without_a_display(out_quat, tmp_path, monkeypatch):
    from PIL import Image, ImageSequence

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    png, gif = tmp_path / "b.png", tmp_path / "b.gif"
    r = run("render", out_quat, "--png", png, "--gif", gif, "--frames", 32, "--size", "320x240", "--json")
    assert r.exit_code == 0, r.output
    stats = json.loads(r.stdout)
    assert stats["frames"] == 32
    with Image.open(png) as im:
        assert im.size == (320, 240)
        a = np.asarray(im.convert("RGB"))
    assert len(np.unique(a.reshape(-1, 3), axis=0)) > 50  # a picture, not a blank canvas
    with Image.open(gif) as im:
        assert im.size == (320, 240)
        frames = [hashlib.sha1(f.convert("RGB").tobytes()).hexdigest() for f in ImageSequence.Iterator(im)]
    assert len(frames) >= 30 and len(set(frames)) >= 30


def test_render_at_a_pose_name_and_a_parameter(out_quat, tmp_path):
    for at in ("T1", "0.5", "inf"):
        r = run("render", out_quat, "--png", tmp_path / f"{at}.png", "--at", at, "--size", "200x160", "-q")
        assert r.exit_code == 0, r.output
    r = run("render", out_quat, "--png", tmp_path / "x.png", "--at", "T9")
    assert r.exit_code == 2 and "T9" in r.stderr


@pytest.mark.parametrize("args, message", [
    ([], "nothing to do"),
    (["--png", "x.png", "--size", "big"], "WIDTHxHEIGHT"),
    (["--gif", "x.gif", "--frames", "1"], "--frames"),
    (["--png", "x.bmp"], "use .png, .jpg or .jpeg"),
    (["--png", "x.png", "--gif", "x.mp4"], "give a .gif file name"),
])
def test_render_usage_errors(out_quat, args, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = run("render", out_quat, *args)
    assert r.exit_code == 2 and message in r.stderr
    assert not list(tmp_path.iterdir())


def test_png_suffix_names_the_format(out_quat, tmp_path):
    """--png x.jpg writes JPEG bytes, x.png PNG bytes."""
    for name, magic in (("x.jpg", b"\xff\xd8\xff"), ("x.JPEG", b"\xff\xd8\xff"), ("x.png", b"\x89PNG")):
        r = run("render", out_quat, "--png", tmp_path / name, "--size", "160x120", "-q")
        assert r.exit_code == 0, r.output
        assert (tmp_path / name).read_bytes()[:len(magic)] == magic


def test_render_missing_output_directory(tmp_path):
    r = run("render", tmp_path / "nope", "--png", tmp_path / "x.png")
    assert r.exit_code == 2 and "no such output directory" in r.stderr
    assert not (tmp_path / "x.png").exists()


def test_planar_linkages_are_seen_face_on():
    """All joint axes along z: the camera looks down z (x right, y up); a spatial linkage: no planar view."""
    from types import SimpleNamespace

    from synth.tools.render import planar_view

    def lk(*dirs):
        return SimpleNamespace(joints=[SimpleNamespace(direction=np.array(d, float)) for d in dirs])

    assert planar_view(lk([0, 0, 1], [0, 0, -1], [0, 0, 1])) == (90.0, -90.0)
    el, az = planar_view(lk([1, 0, 0], [-1, 0, 0]))
    assert el == pytest.approx(0) and az == pytest.approx(0)
    assert planar_view(lk([0, 0, 1], [0, 1, 0])) is None
