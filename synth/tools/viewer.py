"""A self-contained, offline HTML page that shows a written linkage in 3D and animates its motion.

The page carries everything it needs: the link meshes (triangle soups, float32, base64), the world
pose of every link for N frames of one full cycle, the tool frame, the task poses and the tool path,
in a ``<script type="application/json">`` block, and a small WebGL viewer written for mpsynth
(``viewer_page.VIEWER_JS``: orbit, pan and zoom with the mouse or touch, a play button and a
frame slider). No script is loaded from anywhere: the page works from a file:// URL without a network.

Why not three.js: trimesh's ``scene_to_html`` template does inline a three.js build, but it shows a
static glTF scene; animating the links would mean patching its script by string replacement. The
viewer here needs only lit triangle meshes, lines and an orbit camera, which WebGL 1 gives in a few
hundred lines, and it keeps the page small (about 100 kB of data for a Bennett linkage).

Coordinates: everything is shifted so that the centre of the motion's bounding box is at the origin
(float32 keeps micrometres for metre-sized linkages far from the world origin); the world frame is
drawn where it is. Lengths are metres.
"""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

import numpy as np

from synth.io.readback import Readback, cycle_parameters
from synth.io.atomic import atomic_write
from synth.linkage import kind_label
from synth.tools.render import BASE_COLOR, default_view, link_colors
from synth.tools.viewer_page import VIEWER_CSS, VIEWER_JS

DEFAULT_FRAMES = 120


def _b64(a) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def _colmajor(T) -> np.ndarray:
    """(..., 4, 4) row-major matrices -> (..., 16) column-major (WebGL's order)."""
    T = np.asarray(T, float)
    return np.swapaxes(T, -1, -2).reshape(T.shape[:-2] + (16,))


def scene_data(rb: Readback, frames: int = DEFAULT_FRAMES, spacing: str = "angle") -> dict:
    """The JSON document the page's viewer reads."""
    lk = rb.linkage
    meshes = rb.meshes()
    colors = link_colors(rb)
    ts = np.roll(cycle_parameters(lk, frames, spacing=spacing), 1)  # frame 0: t = inf, the first pose
    P = rb.link_poses(ts)
    tool = rb.tool_poses(ts)
    path = rb.tool_poses(cycle_parameters(lk, 600))[:, :3, 3]
    path = np.concatenate([path[-1:], path])
    poses = rb.pose_matrices()

    # bounds of everything over the motion -> centre and radius
    pts = [path, poses[:, :3, 3].reshape(-1, 3)]
    for n, m in meshes.items():
        v = m.vertices[:: max(1, len(m.vertices) // 100)]
        pts.append((np.einsum("sij,vj->svi", P[n][::4, :3, :3], v) + P[n][::4, None, :3, 3]).reshape(-1, 3))
    allp = np.concatenate(pts)
    lo, hi = allp.min(0), allp.max(0)
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-9)
    shift = np.eye(4)
    shift[:3, 3] = -centre

    links = []
    for n in rb.mesh_links:
        m = meshes[n]
        links.append({
            "name": n,
            "color": [round(float(c), 4) for c in colors.get(n, BASE_COLOR)],
            "triangles": _b64(np.asarray(m.triangles, float).reshape(-1)),
            "count": int(len(m.faces)),
            "frames": _b64(_colmajor(shift @ P[n]).reshape(-1)),
        })
    # the tool hangs on the tool link: a segment from that link's mesh centre to the tool origin
    mount = None
    if lk.tool_link in meshes:
        c = np.asarray(meshes[lk.tool_link].centroid, float)
        Pt = P[lk.tool_link]
        a = np.einsum("sij,j->si", Pt[:, :3, :3], c) + Pt[:, :3, 3]
        mount = _b64(np.concatenate([a, tool[:, :3, 3]], axis=1) - np.tile(centre, 2))
    elev, azim = default_view(allp)
    angles = lk.angles_at(ts)
    # joint names at their sites (`Linkage.joint_sites`), moving with each joint's child link
    disp = lk.displacements(angles)
    sites = lk.joint_sites()
    joints = [{"name": j.name,
               "pos": _b64(np.einsum("sij,j->si", disp[j.child][:, :3, :3], sites[j.name])
                           + disp[j.child][:, :3, 3] - centre)}
              for j in lk.joints]
    first_pose_t = {p.name: p.t for p in lk.poses}
    return {
        "format": "mpsynth.viewer/1",
        "title": f"{rb.robot_name}",
        "subtitle": _subtitle(lk),
        "frames": int(len(ts)),
        "t": [None if np.isinf(t) else float(t) for t in ts],
        "angles": {k: [round(float(np.degrees(x)), 2) for x in v] for k, v in angles.items()},
        "links": links,
        "tool": _b64(_colmajor(shift @ tool).reshape(-1)),
        "mount": mount,
        "view": {"elev": elev, "azim": azim},
        "poses": [{"name": rec.name, "matrix": _colmajor(shift @ T).round(9).tolist(),
                   "t": None if np.isinf(first_pose_t[rec.name]) else float(first_pose_t[rec.name])}
                  for rec, T in zip(lk.poses, poses)],
        "world": _colmajor(shift).round(9).tolist(),
        "world_label": not any(np.linalg.norm(T[:3, 3]) <= 1e-9 * radius for T in poses),
        "path": _b64((path - centre).reshape(-1)),
        "radius": radius,
        "joints": joints,
        "length_unit": "m",
        "floor": float(lo[2] - centre[2]),
        "frame_length": 0.09 * radius,
    }


def _subtitle(lk) -> str:
    kind = kind_label(lk.kind)
    return f"{kind} linkage: {len(lk.joints)} revolute joints, {len(lk.closures)} loop(s), {len(lk.poses)} task poses"


def viewer_html(rb: Readback, frames: int = DEFAULT_FRAMES, spacing: str = "angle") -> str:
    """The whole page as a string."""
    data = json.dumps(scene_data(rb, frames, spacing), separators=(",", ":"), allow_nan=False)
    data = data.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    js, css = VIEWER_JS, VIEWER_CSS
    title = html.escape(f"{rb.robot_name} - mpsynth viewer")
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="mpsynth">
<title>{title}</title>
<style>
{css}
</style>
</head>
<body>
<canvas id="view"></canvas>
<div id="info"><div id="title"></div><div id="subtitle"></div><div id="state"></div></div>
<div id="help">drag: rotate &middot; shift-drag or right-drag: pan &middot; wheel or pinch: zoom &middot; double-click: reset view</div>
<div id="labels"></div>
<div id="scale"><div id="scale-bar"></div><span id="scale-text"></span></div>
<div id="bar">
  <button id="play" type="button" title="play / pause (space)">&#9654;</button>
  <input id="slider" type="range" min="0" max="0" value="0" step="1" aria-label="frame">
  <span id="frame"></span>
  <label><input id="show-path" type="checkbox" checked> tool path</label>
  <label><input id="show-poses" type="checkbox" checked> task poses</label>
</div>
<div id="nogl" hidden>This page needs WebGL, which this browser has switched off.</div>
<script type="application/json" id="mpsynth-data">{data}</script>
<script>
{js}
</script>
</body>
</html>
"""


def write_viewer(rb: Readback, path, frames: int = DEFAULT_FRAMES, spacing: str = "angle") -> int:
    """Write the page atomically; returns its size in bytes."""
    text = viewer_html(rb, frames, spacing)
    data = text.encode("utf-8")
    atomic_write(path, lambda tmp: Path(tmp).write_bytes(data))
    return len(data)
