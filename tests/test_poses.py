"""Tests of synth.io.poses: the pose-file reader and validator (OUTPUT.md input contract)."""
from __future__ import annotations

import io
import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from synth.errors import InputError
from synth.io.poses import (
    PoseSet,
    axis_angle_matrix,
    load_poses,
    parse_pose_document,
    pose_from_spec,
    quaternion_matrix,
    rpy_matrix_exact,
)

FIXTURES = Path(__file__).resolve().parent.parent / "fixtures"

P = "{position: [0, 0, 0], quaternion: [1, 0, 0, 0]}"  # a valid pose in flow style


def doc(*poses: str, units: str | None = None) -> str:
    head = (f"units: {units}\n" if units else "") + "quaternion_order: wxyz\n"
    return head + "poses:\n" + "".join(f"  - {p}\n" for p in poses)


# (id, file name, text, kwargs, expected pose label or None, expected substrings)
BAD = [
    ("yaml-syntax", "poses.yaml", "poses:\n  - {position: [0, 0, 0]\n  - x\n", {}, None,
     ["YAML syntax error at line"]),
    ("yaml-syntax-indent", "poses.yaml", "poses:\n  - position: [0,0,0]\n quaternion: [1,0,0,0]\n", {}, None,
     ["YAML syntax error at line 3"]),
    ("json-syntax", "poses.json", '{"poses": [\n  {"position": [0, 0, 0],}\n]}', {}, None,
     ["JSON syntax error at line 2"]),
    ("json-looking-stdin", "-", '{"poses": [1, 2,, 3]}', {}, None, ["<stdin>", "JSON syntax error at line 1"]),
    ("json-duplicate", "poses.json", '{"poses": [], "poses": []}', {}, None, ["duplicate key", "poses"]),
    ("yaml-duplicate", "poses.yaml", "poses:\n  - position: [0,0,0]\n    position: [1,0,0]\n    rpy: [0,0,0]\n",
     {}, None, ["duplicate key 'position'", "line 3"]),
    ("empty-file", "poses.yaml", "", {}, None, ["empty"]),
    ("comment-only", "poses.yaml", "# nothing\n", {}, None, ["empty"]),
    ("top-list", "poses.yaml", "- position: [0,0,0]\n", {}, None, ["top level must be a mapping", "a list of 1 item"]),
    ("top-scalar", "poses.yaml", "hello\n", {}, None, ["top level must be a mapping", 'a string ("hello")']),
    ("missing-poses", "poses.yaml", "units: {length: m}\n", {}, None, ["missing 'poses'"]),
    ("poses-not-list", "poses.yaml", "poses: {position: [0,0,0]}\n", {}, None, ["'poses' must be a list", "a mapping"]),
    ("poses-null", "poses.yaml", "poses:\n", {}, None, ["'poses' must be a list", "null"]),
    ("poses-empty", "poses.yaml", "poses: []\n", {}, None, ["'poses' is empty"]),
    ("count-label", "poses.yaml", doc(P, P, P, P), {"count": (3, "mpsynth bennett")}, None,
     ["mpsynth bennett needs exactly 3 poses, got 4"]),
    ("count-int", "poses.yaml", doc(P), {"count": 4}, None, ["expected exactly 4 poses, got 1"]),
    ("count-range", "poses.yaml", doc(P, P), {"count": ((5, None), "mpsynth curve")}, None,
     ["mpsynth curve needs at least 5 poses, got 2"]),
    ("unknown-top-key", "poses.yaml", "pose:\n  - " + P + "\n", {}, None,
     ['unknown key "pose" at top level', 'did you mean "poses"']),
    ("unknown-top-key-nonstring", "poses.yaml", doc(P) + "1: 2\n", {}, None, ["unknown key 1 at top level"]),
    ("unknown-pose-key", "poses.yaml", doc("{position: [0,0,0], quaterion: [1,0,0,0]}"), {}, "pose 0",
     ['unknown key "quaterion"', 'did you mean "quaternion"']),
    ("unknown-units-key", "poses.yaml", doc(P, units="{lenght: mm}"), {}, None,
     ['unknown key "lenght" in units', 'did you mean "length"']),
    ("unknown-quat-key", "poses.yaml", doc(P, "{position: [0,0,0], quaternion: {w: 1, x: 0, y: 0, q: 0}}"), {},
     "pose 1", ['unknown key "q" in quaternion']),
    ("quat-missing-key", "poses.yaml", doc("{position: [0,0,0], quaternion: {w: 1, x: 0, y: 0}}"), {}, "pose 0",
     ['quaternion is missing "z"']),
    ("two-orientations", "poses.yaml", doc("{name: a, position: [0,0,0], quaternion: [1,0,0,0], rpy: [0,0,0]}"),
     {}, 'pose 0 ("a")', ["two orientations", "'quaternion'", "'rpy'"]),
    ("matrix-with-position", "poses.yaml",
     doc("{matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], position: [0,0,0]}"), {}, "pose 0",
     ["'matrix' must be alone", "'position'"]),
    ("matrix-with-orientation", "poses.yaml",
     doc("{matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], rpy: [0,0,0]}"), {}, "pose 0",
     ["'matrix' must be alone", "'rpy'"]),
    ("missing-position", "poses.yaml", doc(P, "{name: b, rpy: [0,0,0]}"), {}, 'pose 1 ("b")', ["missing 'position'"]),
    ("missing-orientation", "poses.yaml", doc("{position: [0,0,0]}"), {}, "pose 0", ["missing orientation"]),
    ("pose-not-mapping", "poses.yaml", doc(P, "[1, 2, 3]"), {}, "pose 1", ["a pose must be a mapping"]),
    ("position-short", "poses.yaml", doc("{position: [0, 0], rpy: [0,0,0]}"), {}, "pose 0",
     ["position must be a list of 3 numbers", "a list of 2 items"]),
    ("position-scalar", "poses.yaml", doc("{position: 5, rpy: [0,0,0]}"), {}, "pose 0",
     ["position must be a list of 3 numbers", "the number 5"]),
    ("rotation-shape", "poses.yaml", doc("{position: [0,0,0], rotation: [[1,0],[0,1]]}"), {}, "pose 0",
     ["rotation must be a 3x3 matrix"]),
    ("rotation-ragged", "poses.yaml", doc("{position: [0,0,0], rotation: [[1,0,0],[0,1],[0,0,1]]}"), {}, "pose 0",
     ["rotation must be a 3x3 matrix", "row 1"]),
    ("matrix-shape", "poses.yaml", doc("{matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}"), {}, "pose 0",
     ["matrix must be a 4x4 matrix"]),
    ("quat-list-3", "poses.yaml", doc("{position: [0,0,0], quaternion: [1,0,0]}"), {}, "pose 0",
     ["quaternion list must have 4 numbers"]),
    ("quat-scalar", "poses.yaml", doc("{position: [0,0,0], quaternion: 1}"), {}, "pose 0",
     ["quaternion must be a mapping"]),
    ("string-number", "poses.yaml", doc("{position: [0, abc, 0], rpy: [0,0,0]}"), {}, "pose 0",
     ['position[1] must be a number, got a string ("abc")']),
    ("quoted-number", "poses.yaml", doc("{position: [0, '1', 0], rpy: [0,0,0]}"), {}, "pose 0",
     ['position[1] must be a number, got a string ("1")']),
    ("bool-number", "poses.yaml", doc("{position: [0,0,0], rpy: [true, 0, 0]}"), {}, "pose 0",
     ["rpy[0] must be a number, got a boolean (true)"]),
    ("yes-number", "poses.yaml", doc("{position: [0,0,0], quaternion: {w: yes, x: 0, y: 0, z: 0}}"), {}, "pose 0",
     ["quaternion.w must be a number, got a boolean"]),
    ("null-number", "poses.yaml", doc("{position: [0,0,~], rpy: [0,0,0]}"), {}, "pose 0",
     ["position[2] must be a number, got null"]),
    ("nan", "poses.yaml", doc("{position: [0,0,.nan], rpy: [0,0,0]}"), {}, "pose 0", ["position[2] is not finite"]),
    ("inf", "poses.yaml", doc(P, P, "{position: [0,0,0], rpy: [0,-.inf,0]}"), {}, "pose 2", ["rpy[1] is not finite"]),
    ("json-nan", "poses.json", '{"poses": [{"position": [NaN, 0, 0], "rpy": [0, 0, 0]}]}', {}, "pose 0",
     ["not finite"]),
    ("non-unit-quat", "poses.yaml",
     doc(P, P, "{name: grasp, position: [0,0,0], quaternion: {w: 0.5, x: 0, y: 0, z: 0}}"), {}, 'pose 2 ("grasp")',
     ["quaternion has length 0.5, expected 1 (normalize it or use --normalize)"]),
    ("slightly-non-unit-quat", "poses.yaml", doc("{position: [0,0,0], quaternion: [1.00001, 0, 0, 0]}"), {},
     "pose 0", ["quaternion has length 1.00001, expected 1"]),
    ("zero-quat", "poses.yaml", doc("{position: [0,0,0], quaternion: [0, 0, 0, 0]}"), {}, "pose 0",
     ["quaternion is zero"]),
    ("zero-quat-normalize", "poses.yaml", doc("{position: [0,0,0], quaternion: [0, 0, 0, 0]}"),
     {"normalize": True}, "pose 0", ["quaternion is zero"]),
    ("non-orthonormal", "poses.yaml", doc("{position: [0,0,0], rotation: [[1,0,0],[0,1,0.0001],[0,0,1]]}"), {},
     "pose 0", ["rotation is not orthonormal", "--normalize"]),
    ("non-orthonormal-far", "poses.yaml", doc("{position: [0,0,0], rotation: [[1,0,0],[0,1,0.1],[0,0,1]]}"),
     {"normalize": True}, "pose 0", ["too far from orthonormal"]),
    ("reflection", "poses.yaml", doc("{position: [0,0,0], rotation: [[1,0,0],[0,1,0],[0,0,-1]]}"), {}, "pose 0",
     ["reflection", "determinant"]),
    ("reflection-normalize", "poses.yaml", doc("{position: [0,0,0], rotation: [[-1,0,0],[0,1,0],[0,0,1]]}"),
     {"normalize": True}, "pose 0", ["reflection"]),
    ("matrix-reflection", "poses.yaml", doc("{matrix: [[1,0,0,0],[0,-1,0,0],[0,0,1,0],[0,0,0,1]]}"), {}, "pose 0",
     ["matrix rotation block", "reflection"]),
    ("matrix-last-row", "poses.yaml", doc("{matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}"), {}, "pose 0",
     ["last row is [0, 0, 1, 1], expected [0, 0, 0, 1]"]),
    ("matrix-scale", "poses.yaml", doc("{matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,2]]}"), {}, "pose 0",
     ["last row"]),
    ("zero-axis", "poses.yaml", doc("{position: [0,0,0], axis_angle: {axis: [0,0,0], angle: 1}}"), {}, "pose 0",
     ["axis_angle.axis is zero"]),
    ("axis-angle-missing", "poses.yaml", doc("{position: [0,0,0], axis_angle: {axis: [0,0,1]}}"), {}, "pose 0",
     ['axis_angle is missing "angle"']),
    ("axis-angle-typo", "poses.yaml", doc("{position: [0,0,0], axis_angle: {axis: [0,0,1], angel: 1}}"), {},
     "pose 0", ['unknown key "angel" in axis_angle', 'did you mean "angle"']),
    ("axis-angle-list", "poses.yaml", doc("{position: [0,0,0], axis_angle: [0, 0, 1, 1]}"), {}, "pose 0",
     ["axis_angle must be a mapping"]),
    ("unknown-length-unit", "poses.yaml", doc(P, units="{length: ft}"), {}, None,
     ['unknown length unit "ft" (allowed: m, mm, cm, in)']),
    ("unknown-angle-unit", "poses.yaml", doc(P, units="{angle: grad}"), {}, None,
     ['unknown angle unit "grad" (allowed: rad, deg)']),
    ("unit-not-string", "poses.yaml", doc(P, units="{length: 1}"), {}, None, ["unknown length unit", "allowed"]),
    ("units-not-mapping", "poses.yaml", doc(P, units="mm"), {}, None, ["units must be a mapping"]),
    ("far-position", "poses.yaml", doc("{position: [2000000000, 0, 0], rpy: [0,0,0]}"), {}, "pose 0",
     ["too far from the origin"]),
    ("far-position-in-mm-ok-but-m-not", "poses.yaml",
     doc("{position: [0, 0, 900000000000], rpy: [0,0,0]}", units="{length: cm}"), {}, "pose 0",
     ["too far from the origin"]),
    ("huge-number", "poses.yaml", doc("{position: [0,0,0], rpy: [0, 1.0e13, 0]}"), {}, "pose 0",
     ["rpy[1] is too large"]),
    ("huge-int", "poses.yaml", doc("{position: [0,0,0], rpy: [0, 0, " + "9" * 40 + "]}"), {}, "pose 0",
     ["rpy[2] is too large"]),
    ("duplicate-names", "poses.yaml", doc("{name: a, position: [0,0,0], rpy: [0,0,0]}", "{name: a, " + P[1:]), {},
     'pose 1 ("a")', ['duplicate pose name "a" (pose 0 has it)']),
    ("duplicate-default-name", "poses.yaml", doc(P, "{name: p0, " + P[1:]), {}, 'pose 1 ("p0")',
     ['duplicate pose name "p0" (pose 0 has it by default)']),
    ("non-string-name", "poses.yaml", doc(P, "{name: 5, " + P[1:]), {}, "pose 1",
     ["name must be a string, got the number 5"]),
    ("list-name", "poses.yaml", doc("{name: [a], " + P[1:]), {}, "pose 0", ["name must be a string"]),
    ("empty-name", "poses.yaml", doc("{name: '', " + P[1:]), {}, "pose 0", ["name is empty"]),
    ("control-char-name", "poses.yaml", doc('{name: "a\\nb", ' + P[1:]), {}, 'pose 0 ("a\\nb")',
     ["name contains a control character"]),
    ("python-tag", "poses.yaml", "poses: !!python/object/apply:os.system ['true']\n", {}, None,
     ["YAML error at line 1", "python/object/apply"]),
    ("bad-timestamp", "poses.yaml", "poses: 2020-13-45\n", {}, None, ["YAML error"]),
    ("multi-document", "poses.yaml", doc(P) + "---\n" + doc(P), {}, None, ["YAML"]),
    ("too-many-poses", "poses.json", '{"poses": [' + ",".join(["{}"] * 10001) + "]}", {}, None,
     ["10001 poses is more than the limit of 10000"]),
    ("too-big-text", "poses.yaml", "#" * (10 * 1024 * 1024 + 1), {}, None, ["larger than 10 MB"]),
    ("deep-nesting", "poses.yaml", "poses: " + "[" * 600 + "]" * 600, {}, None, []),
    ("deep-nesting-json", "poses.json", '{"poses": ' + "[" * 100000 + "]" * 100000 + "}", {}, None, []),
    ("non-utf8", "poses.yaml", b"poses: \xff\xfe\n", {}, None, ["not UTF-8"]),
]


def test_enough_bad_cases():
    assert len(BAD) >= 30


@pytest.mark.parametrize("case_id,fname,text,kwargs,label,subs", BAD, ids=[c[0] for c in BAD])
def test_malformed_documents(case_id, fname, text, kwargs, label, subs):
    with pytest.raises(InputError) as ei:
        load_poses(fname, text=text, **kwargs)
    msg = str(ei.value)
    assert "\n" not in msg and "\r" not in msg, msg
    shown = "<stdin>" if fname == "-" else fname
    assert msg.startswith(shown + ": "), msg
    if label is not None:
        assert msg.startswith(f"{shown}: {label}: "), msg
    else:
        assert ": pose " not in msg, msg
    for s in subs:
        assert s in msg, (s, msg)
    assert ei.value.exit_code == 2
    assert len(msg) < 400


def test_exact_message_format():
    text = doc(P, P, "{name: grasp, position: [0,0,0], quaternion: {w: 0.5, x: 0, y: 0, z: 0}}")
    with pytest.raises(InputError) as ei:
        load_poses("poses.yaml", text=text)
    assert str(ei.value) == (
        'poses.yaml: pose 2 ("grasp"): quaternion has length 0.5, expected 1 (normalize it or use --normalize)'
    )


# ------------------------------------------------------------------ files and streams
def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such file") as ei:
        load_poses(str(tmp_path / "nope.yaml"))
    assert str(ei.value).startswith(str(tmp_path / "nope.yaml") + ": ")


def test_directory(tmp_path):
    with pytest.raises(InputError, match="directory"):
        load_poses(tmp_path)


def test_unreadable_file(tmp_path):
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        pytest.skip("root can read anything")
    f = tmp_path / "secret.yaml"
    f.write_text(doc(P))
    f.chmod(0)
    try:
        with pytest.raises(InputError, match="permission denied"):
            load_poses(f)
    finally:
        f.chmod(0o644)


def test_big_file_refused_before_reading(tmp_path):
    f = tmp_path / "big.yaml"
    with open(f, "wb") as fh:
        fh.truncate(10 * 1024 * 1024 + 10)  # sparse: cheap to make
    with pytest.raises(InputError, match="10 MB"):
        load_poses(f)


def test_file_name_as_given(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("my poses.yaml").write_text(doc(P, "{position: [0,0,0], quaternion: [2,0,0,0]}"))
    with pytest.raises(InputError) as ei:
        load_poses("my poses.yaml")
    assert str(ei.value).startswith("my poses.yaml: pose 1: quaternion has length 2")
    ps = load_poses(Path("my poses.yaml"), normalize=True)
    assert ps.source == "my poses.yaml"


def test_python_object_tag_creates_no_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    f = tmp_path / "evil.yaml"
    f.write_text('poses: !!python/object/apply:os.system ["touch pwned"]\n')
    with pytest.raises(InputError):
        load_poses(str(f))
    for tag in ("!!python/object/apply:os.system", "!!python/object/new:os.system", "!!python/name:os.system"):
        with pytest.raises(InputError):
            load_poses("evil.yaml", text=f'units: {tag} ["touch pwned"]\nposes: [{P}]\n')
    assert not (tmp_path / "pwned").exists()
    assert os.listdir(tmp_path) == ["evil.yaml"]


def test_stdin_text():
    ps = load_poses("-", text=doc(P, P))
    assert ps.source == "<stdin>"
    assert ps.names == ["p0", "p1"]


def test_stdin_stream(monkeypatch):
    data = json.dumps({"poses": [{"position": [1, 2, 3], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}}]}).encode()
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))
    ps = load_poses("-")
    assert ps.source == "<stdin>"
    np.testing.assert_array_equal(ps.matrices[0][:3, 3], [1, 2, 3])


def test_stdin_error_names_stdin():
    with pytest.raises(InputError) as ei:
        load_poses("-", text="poses: []")
    assert str(ei.value).startswith("<stdin>: ")


def test_json_file(tmp_path):
    f = tmp_path / "p.json"
    f.write_text(json.dumps({"units": {"length": "mm"}, "poses": [
        {"name": "a", "position": [100, 0, 0], "rpy": [0, 0, 1]},
        {"position": [0, 0, 0], "quaternion": {"w": 0, "x": 1, "y": 0, "z": 0}},
    ]}))
    ps = load_poses(str(f))
    assert ps.names == ["a", "p1"]
    np.testing.assert_allclose(ps.matrices[0][:3, 3], [0.1, 0, 0])
    np.testing.assert_allclose(ps.matrices[1][:3, :3], np.diag([1.0, -1, -1]))


def test_json_content_in_yaml_file():
    text = '{"poses": [{"position": [1, 2, 3], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}}]}'
    assert len(load_poses("x.yaml", text=text)) == 1


def test_yaml_flow_document_that_is_not_json():
    text = "{units: {length: mm}, poses: [{position: [1, 2, 3], rpy: [0, 0, 0]}]}"
    ps = load_poses("x.yaml", text=text)
    np.testing.assert_allclose(ps.positions[0], [0.001, 0.002, 0.003])


def test_utf8_bom_and_bytes():
    ps = load_poses("b.yaml", text=b"\xef\xbb\xbf" + doc(P).encode())
    assert len(ps) == 1


# ------------------------------------------------------------------ orientations
RNG = np.random.default_rng(12345)


def _yaml_pose(order="wxyz", **kw) -> str:
    return yaml.safe_dump({"quaternion_order": order, "poses": [kw]})


@pytest.mark.parametrize("seed", range(5))
def test_quaternion_forms_match_scipy(seed):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = (float(v) for v in q)
    pos = [float(v) for v in rng.normal(size=3)]
    ref = Rotation.from_quat([x, y, z, w]).as_matrix()
    forms = [("wxyz", "quaternion", {"w": w, "x": x, "y": y, "z": z}), ("wxyz", "quaternion", [w, x, y, z]),
             ("xyzw", "quaternion", [x, y, z, w]), ("xyzw", "orientation", {"x": x, "y": y, "z": z, "w": w})]
    for order, key, quat in forms:
        ps = load_poses("q.yaml", text=_yaml_pose(order, position=pos, **{key: quat}))
        T = ps.matrices[0]
        np.testing.assert_allclose(T[:3, :3], ref, atol=1e-14)
        np.testing.assert_allclose(T[:3, 3], pos, atol=0)
        np.testing.assert_array_equal(T[3], [0, 0, 0, 1])


@pytest.mark.parametrize("seed", range(5))
def test_rpy_matches_scipy_fixed_axes(seed):
    rng = np.random.default_rng(100 + seed)
    rpy = [float(v) for v in rng.uniform(-np.pi, np.pi, 3)]
    ps = load_poses("r.yaml", text=_yaml_pose(position=[0, 0, 0], rpy=rpy))
    ref = Rotation.from_euler("xyz", rpy).as_matrix()  # extrinsic x, y, z = Rz Ry Rx
    np.testing.assert_allclose(ps.matrices[0][:3, :3], ref, atol=1e-14)


def test_rpy_is_urdf_order():
    # yaw 90 deg after roll 90 deg (fixed axes): x -> y, and z -> -x... check explicitly
    R = rpy_matrix_exact(90, 0, 90, unit="deg")
    Rx = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    Rz = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_array_equal(R, Rz @ Rx)


@pytest.mark.parametrize("seed", range(5))
def test_axis_angle_matches_scipy(seed):
    rng = np.random.default_rng(200 + seed)
    axis = rng.normal(size=3) * 3  # not unit: accepted and normalized
    angle = float(rng.uniform(-4, 4))
    ps = load_poses("a.yaml", text=_yaml_pose(position=[0, 0, 0],
                                              axis_angle={"axis": [float(a) for a in axis], "angle": angle}))
    ref = Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle).as_matrix()
    np.testing.assert_allclose(ps.matrices[0][:3, :3], ref, atol=1e-14)


@pytest.mark.parametrize("seed", range(5))
def test_rotation_and_matrix_forms(seed):
    R = Rotation.random(random_state=300 + seed).as_matrix()
    d = RNG.normal(size=3)
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = d
    text = json.dumps({"poses": [
        {"position": d.tolist(), "rotation": R.tolist()},
        {"matrix": M.tolist()},
    ]})
    ps = load_poses("m.json", text=text)
    for T in ps.matrices:
        np.testing.assert_allclose(T, M, atol=1e-15)


def test_all_forms_give_same_pose():
    w, x, y, z = 0.5, 0.5, 0.5, 0.5  # 120 deg about (1,1,1)/sqrt3
    R = quaternion_matrix(w, x, y, z)
    rpy = [float(a) for a in Rotation.from_matrix(R).as_euler("xyz", degrees=True)]
    text = doc(
        "{position: [1, 2, 3], quaternion: {w: 0.5, x: 0.5, y: 0.5, z: 0.5}}",
        "{position: [1, 2, 3], quaternion: [0.5, 0.5, 0.5, 0.5]}",
        f"{{position: [1, 2, 3], rpy: [{rpy[0]!r}, {rpy[1]!r}, {rpy[2]!r}]}}",
        "{position: [1, 2, 3], axis_angle: {axis: [1, 1, 1], angle: 120}}",
        "{position: [1, 2, 3], rotation: [[0, 0, 1], [1, 0, 0], [0, 1, 0]]}",
        "{matrix: [[0, 0, 1, 1], [1, 0, 0, 2], [0, 1, 0, 3], [0, 0, 0, 1]]}",
        units="{angle: deg}",
    )
    ps = load_poses("same.yaml", text=text)
    for T in ps.matrices:
        np.testing.assert_allclose(T, ps.matrices[-1], atol=1e-14)
    np.testing.assert_array_equal(ps.matrices[-1][:3, :3], [[0, 0, 1], [1, 0, 0], [0, 1, 0]])


def test_dual_quaternion_of_math_example_b():
    ps = load_poses("b.yaml", text=doc("{position: [1, 2, 3], quaternion: [0.5, 0.5, 0.5, 0.5]}"))
    np.testing.assert_allclose(ps.dual_quaternions()[0], [0.5, 0.5, 0.5, 0.5, 1.5, 0, -1, -0.5], atol=1e-15)


def test_matrices_orthonormal_to_double_precision():
    text = doc(
        "{position: [0,0,0], quaternion: [0.1, 0.7, -0.3, 0.64]}",
        "{position: [0,0,0], rpy: [0.3, -1.2, 2.9]}",
        "{position: [0,0,0], axis_angle: {axis: [1, -2, 0.5], angle: 2.5}}",
    )
    ps = load_poses("o.yaml", text=text, normalize=True)
    for R in ps.rotations:
        assert np.abs(R.T @ R - np.eye(3)).max() < 1e-15
        assert abs(np.linalg.det(R) - 1) < 1e-15


def test_exact_right_angles_in_degrees():
    ps = load_poses("d.yaml", text=doc("{position: [0,0,0], rpy: [90, -180, 270]}", units="{angle: deg}"))
    R = ps.matrices[0][:3, :3]
    assert set(np.unique(R)) <= {-1.0, 0.0, 1.0}
    np.testing.assert_allclose(R, Rotation.from_euler("xyz", [90, -180, 270], degrees=True).as_matrix(), atol=1e-15)
    np.testing.assert_array_equal(axis_angle_matrix([0, 0, 1], 90, "deg"), [[0, -1, 0], [1, 0, 0], [0, 0, 1]])


def test_normalize_quaternion():
    text = doc("{position: [0,0,0], quaternion: [2, 0, 0, 2]}")
    with pytest.raises(InputError, match="length 2.828"):
        load_poses("n.yaml", text=text)
    ps = load_poses("n.yaml", text=text, normalize=True)
    np.testing.assert_allclose(ps.rotations[0], Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix(), atol=1e-15)


def test_quaternion_within_tolerance_is_accepted_and_normalized():
    ps = load_poses("n.yaml", text=doc("{position: [0,0,0], quaternion: [1.0000005, 0, 0, 0]}"))
    np.testing.assert_array_equal(ps.rotations[0], np.eye(3))


def test_normalize_projects_nearly_orthonormal_rotation():
    R = Rotation.from_rotvec([0.3, -0.2, 0.9]).as_matrix()
    Rn = R + 2e-4 * np.random.default_rng(0).normal(size=(3, 3))
    text = json.dumps({"poses": [{"position": [0, 0, 0], "rotation": Rn.tolist()}]})
    with pytest.raises(InputError, match="not orthonormal"):
        load_poses("p.json", text=text)
    ps = load_poses("p.json", text=text, normalize=True)
    Rp = ps.rotations[0]
    assert np.abs(Rp.T @ Rp - np.eye(3)).max() < 1e-15
    assert np.abs(Rp - R).max() < 1e-3


def test_rotation_within_tolerance_is_cleaned():
    R = Rotation.from_rotvec([0.3, -0.2, 0.9]).as_matrix()
    Rn = np.round(R, 8)  # 8 digits: within 1e-6 but not orthonormal to double precision
    text = json.dumps({"poses": [{"position": [0, 0, 0], "rotation": Rn.tolist()}]})
    Rp = load_poses("p.json", text=text).rotations[0]
    assert np.abs(Rp.T @ Rp - np.eye(3)).max() < 1e-15
    assert np.abs(Rp - R).max() < 1e-8


# ------------------------------------------------------------------ units
@pytest.mark.parametrize("unit,scale", [("m", 1.0), ("mm", 1e-3), ("cm", 1e-2), ("in", 0.0254)])
def test_length_units(unit, scale):
    text = doc(
        "{position: [10, -20, 30], rpy: [0, 0, 0]}",
        "{matrix: [[1, 0, 0, 5], [0, 1, 0, 6], [0, 0, 1, 7], [0, 0, 0, 1]]}",
        units=f"{{length: {unit}}}",
    )
    ps = load_poses("u.yaml", text=text)
    assert ps.length_unit == unit and ps.length_scale == scale and ps.angle_unit == "rad"
    np.testing.assert_allclose(ps.positions[0], np.array([10, -20, 30]) * scale, rtol=1e-15)
    np.testing.assert_allclose(ps.positions[1], np.array([5, 6, 7]) * scale, rtol=1e-15)


def test_defaults_are_metres_and_radians():
    ps = load_poses("d.yaml", text=doc("{position: [1, 0, 0], rpy: [0, 0, 1.5707963267948966]}"))
    assert (ps.length_unit, ps.angle_unit, ps.length_scale) == ("m", "rad", 1.0)
    np.testing.assert_allclose(ps.rotations[0], Rotation.from_euler("z", np.pi / 2).as_matrix(), atol=1e-15)


def test_degrees_apply_to_rpy_and_axis_angle_only():
    text = doc(
        "{position: [0, 0, 0], rpy: [10, 20, 30]}",
        "{position: [0, 0, 0], axis_angle: {axis: [0, 1, 0], angle: 45}}",
        units="{angle: deg, length: mm}",
    )
    ps = load_poses("deg.yaml", text=text)
    np.testing.assert_allclose(ps.rotations[0], Rotation.from_euler("xyz", [10, 20, 30], degrees=True).as_matrix(),
                               atol=1e-15)
    np.testing.assert_allclose(ps.rotations[1], Rotation.from_rotvec([0, np.pi / 4, 0]).as_matrix(), atol=1e-15)


def test_scientific_notation_without_dot_is_a_number():
    ps = load_poses("s.yaml", text=doc("{position: [1e-3, 2E2, -3e+1], rpy: [0, 0, 0]}"))
    np.testing.assert_allclose(ps.positions[0], [1e-3, 200, -30])


def test_names_and_counts():
    text = doc("{name: pick, " + P[1:], P, "{name: place, " + P[1:])
    ps = load_poses("n.yaml", text=text, count=(3, "mpsynth bennett"))
    assert ps.names == ["pick", "p1", "place"]
    assert ps.named == [True, False, True]
    assert len(load_poses("n.yaml", text=text, count=3)) == 3
    assert len(load_poses("n.yaml", text=text, count=((2, 4), "x"))) == 3


def test_pose_from_spec():
    T = pose_from_spec({"name": "x", "position": [100, 0, 0], "rpy": [0, 0, 90]}, length_unit="mm", angle_unit="deg")
    np.testing.assert_array_equal(T, [[0, -1, 0, 0.1], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    with pytest.raises(InputError, match="^missing orientation"):
        pose_from_spec({"position": [0, 0, 0]})
    with pytest.raises(InputError, match="unknown length unit"):
        pose_from_spec({"position": [0, 0, 0], "rpy": [0, 0, 0]}, length_unit="km")


def test_parse_pose_document_direct():
    ps = parse_pose_document({"quaternion_order": "wxyz",
                              "poses": [{"position": (0, 0, 0), "quaternion": (1, 0, 0, 0)}]}, source="mem")
    assert isinstance(ps, PoseSet) and ps.source == "mem"


# ------------------------------------------------------------------ fixtures
def test_fixture_bennett_mm_deg():
    ps = load_poses(FIXTURES / "bennett_mm_deg.yaml", count=(3, "mpsynth bennett"))
    assert ps.names == ["pick", "via", "place"]
    assert (ps.length_unit, ps.angle_unit) == ("mm", "deg")
    assert np.all(np.abs(ps.positions) < 0.4)
    # general: pairwise relative motions are screws with nonparallel axes, nonzero angle and translation
    axes = []
    for a, b in [(0, 1), (0, 2), (1, 2)]:
        rel = np.linalg.inv(ps.matrices[a]) @ ps.matrices[b]
        rv = Rotation.from_matrix(rel[:3, :3]).as_rotvec()
        assert 20 < np.degrees(np.linalg.norm(rv)) < 100
        assert np.linalg.norm(rel[:3, 3]) > 0.05
        axes.append(rv / np.linalg.norm(rv))
    assert abs(np.linalg.det(np.array(axes))) > 0.1


def test_fixture_bennett_quat_is_math_11d():
    ps = load_poses(FIXTURES / "bennett_quat.yaml", count=3)
    expected = [([0, 0, 0], [1, 0, 0, 0]), ([1, 0, 0.5], [0.6, 0, 0, 0.8]), ([0.25, 1, 0.2], [0.6, 0.8, 0, 0])]
    for T, (d, (w, x, y, z)) in zip(ps.matrices, expected):
        np.testing.assert_array_equal(T[:3, 3], d)
        np.testing.assert_allclose(T[:3, :3], Rotation.from_quat([x, y, z, w]).as_matrix(), atol=1e-15)
    D = ps.dual_quaternions()
    np.testing.assert_allclose(D[1], [0.6, 0, 0, 0.8, 0.2, -0.3, 0.4, -0.15], atol=1e-15)  # D1 of MATH 11 D


def test_fixture_sixbar():
    ps = load_poses(FIXTURES / "sixbar_example.yaml", count=(4, "mpsynth sixbar"))
    np.testing.assert_array_equal(ps.positions[3], [-1, 0.5, 0])
    np.testing.assert_allclose(ps.rotations[3], Rotation.from_quat([0.4, 0.4, 0.8, 0.2]).as_matrix(), atol=1e-15)
    np.testing.assert_allclose(ps.matrices[:3], load_poses(FIXTURES / "bennett_quat.yaml").matrices)


def test_fixture_matrix_json():
    ps = load_poses(FIXTURES / "bennett_matrix.json", count=3)
    assert ps.names == ["start", "middle", "end"]
    for R in ps.rotations:
        assert np.abs(R.T @ R - np.eye(3)).max() < 1e-15


def test_fixtures_are_strictly_unit():
    for f in ("bennett_quat.yaml", "sixbar_example.yaml"):
        for p in yaml.safe_load((FIXTURES / f).read_text())["poses"]:
            q = p["quaternion"]
            assert abs(math.sqrt(sum(v * v for v in q.values())) - 1) < 1e-9


# ------------------------------------------------------------------ fuzz
VALID_KEYS = ["units", "poses", "length", "angle", "name", "position", "quaternion", "rpy", "axis_angle",
              "rotation", "matrix", "w", "x", "y", "z", "axis"]
scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-10**15, 10**15), st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 0.5, 90, 1e-7, "m", "mm", "deg", "rad", "in", "ft"]), st.text(max_size=8),
)
keys = st.one_of(st.sampled_from(VALID_KEYS), st.text(max_size=6), st.integers(-3, 3))
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=5), st.dictionaries(keys, inner, max_size=5)),
    max_leaves=25,
)
numbers = st.one_of(st.integers(-5, 5), st.floats(-2, 2), st.sampled_from([0.6, 0.8, 0.0, 1.0]))
vec = lambda n: st.lists(numbers, min_size=n - 1, max_size=n + 1)  # noqa: E731
pose_like = st.fixed_dictionaries(
    {},
    optional={
        "name": st.one_of(st.text(max_size=5), st.integers(0, 3)),
        "position": st.one_of(vec(3), values),
        "quaternion": st.one_of(vec(4), st.fixed_dictionaries({"w": numbers, "x": numbers, "y": numbers, "z": numbers}),
                                values),
        "rpy": st.one_of(vec(3), values),
        "axis_angle": st.one_of(st.fixed_dictionaries({"axis": vec(3), "angle": numbers}), values),
        "rotation": st.one_of(st.lists(vec(3), min_size=2, max_size=4), values),
        "matrix": st.one_of(st.lists(vec(4), min_size=3, max_size=5), values),
        "garbage": values,
    },
)
documents = st.one_of(
    values,
    st.fixed_dictionaries(
        {"poses": st.one_of(st.lists(pose_like, max_size=4), values)},
        optional={"units": st.one_of(st.fixed_dictionaries({}, optional={"length": scalars, "angle": scalars}),
                                     values), "extra": values},
    ),
)


def _check_loader_outcome(name, text, **kw):
    try:
        ps = load_poses(name, text=text, **kw)
    except InputError as e:
        assert "\n" not in str(e)
        assert str(e).startswith(name + ": ")
        return
    assert isinstance(ps, PoseSet)
    assert ps.matrices.shape == (len(ps.names), 4, 4)
    assert np.all(np.isfinite(ps.matrices))
    for T in ps.matrices:
        assert np.abs(T[:3, :3].T @ T[:3, :3] - np.eye(3)).max() < 1e-12
        np.testing.assert_array_equal(T[3], [0, 0, 0, 1])


FUZZ = settings(max_examples=200, deadline=None, suppress_health_check=list(HealthCheck))


@FUZZ
@given(documents, st.booleans())
def test_fuzz_structured_documents(d, normalize):
    _check_loader_outcome("fuzz.yaml", yaml.safe_dump(d, allow_unicode=True), normalize=normalize)
    try:
        text = json.dumps(d)
    except (TypeError, ValueError):
        return  # non-string keys etc. are not JSON
    _check_loader_outcome("fuzz.json", text, normalize=normalize)


yaml_chars = st.sampled_from(list("poses:units-[]{},\"'!&*#|>%@`?\n\t 0123456789.eE+xyzw") + [
    "poses:", "position:", "quaternion:", "rpy:", "matrix:", "name:", "\n  - ", "!!python/object:os.system",
    "!!binary", "!!set", "&a", "*a", "<<:", ".nan", ".inf", "2020-01-01", "yes", "~", "null", "1e5", "{w: 1}"])


@FUZZ
@given(st.lists(yaml_chars, max_size=60).map("".join))
def test_fuzz_raw_text(text):
    _check_loader_outcome("raw.yaml", text)
    _check_loader_outcome("raw.json", text)


def test_sincos_exact_of_many_angles_is_each_angles_own():
    """Property: `sincos_exact` of an array gives every angle the bits of its own call (the batch reader
    and the per-job reader agree), within 1 ulp of math.sin / math.cos, exact at quarter turns."""
    import math

    from hypothesis import given, settings, strategies as st

    from synth.io.posespec import sincos_exact

    @settings(max_examples=200, deadline=None)
    @given(st.lists(st.one_of(st.floats(-1e4, 1e4), st.integers(-40, 40).map(lambda k: 90.0 * k)), min_size=1,
                    max_size=9), st.sampled_from(["deg", "rad"]))
    def check(angles, unit):
        s, c = sincos_exact(np.array(angles), unit)
        for a, si, ci in zip(angles, s.tolist(), c.tolist()):
            one = sincos_exact(a, unit)
            assert (float(one[0]), float(one[1])) == (si, ci)
            r = math.radians(a) if unit == "deg" else a
            assert abs(si - math.sin(r)) <= 2e-16 * max(1.0, abs(r)) and abs(ci - math.cos(r)) <= 2e-16 * max(1.0, abs(r))
            if unit == "deg" and a % 90 == 0:
                assert (si, ci) in ((0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0))

    check()
