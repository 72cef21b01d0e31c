"""`mpsynth view`: one offline HTML file with the meshes, the motion and a WebGL viewer inside."""
from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from synth.synthesis.bennett import bennett
from synth.io.writer import write_output
from synth.design.choose import design_for
from synth.io.poses import load_poses
from synth.io.readback import read_output

from conftest import REPO, run


@pytest.fixture(scope="module")
def out_quat(tmp_path_factory):
    ps = load_poses(str(REPO / "fixtures" / "bennett_quat.yaml"))
    out = tmp_path_factory.mktemp("view") / "bennett_quat"
    write_output(bennett(ps.matrices, ps.names), out, robot_name="bennett_quat", result=design_for(bennett(ps.matrices, ps.names)))
    return out


@pytest.fixture(scope="module")
def page(out_quat, tmp_path_factory):
    html = tmp_path_factory.mktemp("page") / "view.html"
    r = run("view", out_quat, "-o", html, "--frames", 90, "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["bytes"] == html.stat().st_size
    return html


def scripts(text):
    """(attributes, body) of every <script> element."""
    return re.findall(r"<script\b([^>]*)>(.*?)</script\s*>", text, flags=re.S | re.I)


def test_page_is_self_contained(page):
    text = page.read_text(encoding="utf-8")
    assert page.stat().st_size < 10 * 1024 * 1024
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, flags=re.I)
    found = scripts(text)
    assert len(found) == 2  # the data block and the viewer
    for attrs, body in found:
        assert "://" not in attrs + body and "http" not in attrs.lower()
        assert not re.search(r"\bimport\s*\(|\bfetch\s*\(|XMLHttpRequest|importScripts", body)
    assert not re.search(r"<(link|img|iframe)\b[^>]*\b(href|src)\s*=", text, flags=re.I)


def test_page_carries_the_meshes_and_the_motion(page, out_quat):
    text = page.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="mpsynth-data">(.*?)</script>', text, flags=re.S)
    data = json.loads(m.group(1))
    rb = read_output(out_quat)
    meshes = rb.meshes()
    assert [L["name"] for L in data["links"]] == rb.mesh_links
    assert data["frames"] == 90 and len(data["t"]) == 90 and data["t"][0] is None  # frame 0: t = inf
    for L in data["links"]:
        tri = np.frombuffer(base64.b64decode(L["triangles"]), "<f4").reshape(-1, 3, 3)
        assert len(tri) == L["count"] == len(meshes[L["name"]].faces)
        assert np.allclose(tri, meshes[L["name"]].triangles, atol=1e-6)
        frames = np.frombuffer(base64.b64decode(L["frames"]), "<f4").reshape(90, 4, 4).transpose(0, 2, 1)
        # frame 0 is the reference configuration: the link frame (shifted to the scene centre)
        ref = rb.frame_ref[L["name"]]
        shift = np.array(data["world"], float).reshape(4, 4).T
        assert np.allclose(frames[0], shift @ ref, atol=1e-6)
    tool = np.frombuffer(base64.b64decode(data["tool"]), "<f4").reshape(90, 4, 4).transpose(0, 2, 1)
    assert len({tuple(np.round(T[:3, 3], 5)) for T in tool}) == 90  # the tool moves in every frame
    assert [p["name"] for p in data["poses"]] == ["T0", "T1", "T2"]


def test_viewer_script_parses():
    node = shutil.which("node")
    from synth.tools.viewer_page import VIEWER_JS

    assert "requestAnimationFrame" in VIEWER_JS and "getContext(\"webgl\"" in VIEWER_JS
    if node:  # syntax check with node when it is there
        r = subprocess.run([node, "--check", "-"], input=VIEWER_JS, capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stderr


def test_view_errors(tmp_path, out_quat):
    r = run("view", tmp_path / "missing", "-o", tmp_path / "v.html")
    assert r.exit_code == 2 and "no such output directory" in r.stderr
    r = run("view", out_quat)
    assert r.exit_code == 2  # -o is required
    r = run("view", out_quat, "-o", tmp_path / "nodir" / "v.html")
    assert r.exit_code == 2 and "does not exist" in r.stderr
    assert not (tmp_path / "v.html").exists()


def test_joint_labels_and_scale_bar_in_node(page):
    """The page's script, run in node with a stub DOM and WebGL, places a label for every joint and task
    pose on the canvas and draws a scale bar of a round length in m or mm."""
    import shutil
    import subprocess

    node = shutil.which("node")
    if not node:
        pytest.skip("node is not installed")
    r = subprocess.run([node, str(REPO / "tests" / "data" / "viewer_stub.js"), str(page)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    labels = dict(re.findall(r"(\w+)@([-\d.]+)px", r.stdout.splitlines()[0]))
    assert {"h1", "h2", "k1", "k2", "T0", "T1", "T2"} <= set(labels)
    assert all(0 <= float(x) <= 800 for x in labels.values())
    m = re.search(r"scale (\d+)px (\d+) (m|mm)", r.stdout)
    assert m and 20 <= int(m.group(1)) <= 400 and m.group(2)[0] in "125", r.stdout
