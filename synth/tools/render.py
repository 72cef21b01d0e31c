"""Headless pictures of a linkage read back from an output directory: a PNG and an animated GIF.

matplotlib draws through its Agg canvas directly (``matplotlib.figure.Figure`` + ``FigureCanvasAgg``),
so no display, GL or global pyplot state is involved; matplotlib is imported only here, inside the
functions (``pip install 'mpsynth[viz]'``). The GIF is written with Pillow.

The picture shows, in one 3D axes with equal scaling:
- the link meshes (the STL files of OUT, as the URDF places them), shaded by a light that sits above
  and to the left of the camera; all links go into one polygon collection so that matplotlib's
  depth sort orders the triangles of different links correctly;
- the path of the tool frame's origin over the whole cycle (grey), the tool frame (long RGB axes)
  and the task poses (short RGB axes with their names);
- a title with the robot name, the kind and, in the GIF, the motion parameter.

A frame is drawn by replacing the polygons of the same figure (no re-creation), which keeps a 60-frame
GIF at a few seconds.
"""
from __future__ import annotations

import math
import time

from pathlib import Path

import numpy as np

from synth.errors import InputError
from synth.io.readback import Readback, cycle_parameters
from synth.io.atomic import atomic_write
from synth.linkage import kind_label

DEFAULT_SIZE = (800, 600)
DPI = 100
GIF_CYCLE_SECONDS = 4.0
PALETTE = [(0.36, 0.55, 0.80), (0.30, 0.66, 0.52), (0.62, 0.47, 0.78), (0.80, 0.40, 0.45),
           (0.45, 0.70, 0.75), (0.70, 0.62, 0.35)]
BASE_COLOR = (0.42, 0.42, 0.46)
COUPLER_COLOR = (0.95, 0.55, 0.12)
AXIS_COLORS = ("#d62728", "#2ca02c", "#1f5fd6")


def matplotlib_available() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def _require_matplotlib():
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError("rendering needs matplotlib: pip install 'mpsynth[viz]'") from None


def link_colors(rb: Readback) -> dict[str, tuple]:
    """One RGB colour per mesh link: base grey, the tool link orange, the others from a palette."""
    out, k = {}, 0
    for name in rb.mesh_links:
        if name == "base":
            out[name] = BASE_COLOR
        elif name == rb.linkage.tool_link:
            out[name] = COUPLER_COLOR
        else:
            out[name] = PALETTE[k % len(PALETTE)]
            k += 1
    return out


class Scene:
    """The matplotlib figure of one linkage, redrawn at any motion parameter t."""

    def __init__(self, rb: Readback, size=DEFAULT_SIZE, elev=None, azim=None, title=None, path_samples=400):
        _require_matplotlib()
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the 3d projection)
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        self.rb = rb
        lk = rb.linkage
        w, h = size
        self.fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI, facecolor="white")
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = ax = self.fig.add_axes([0.02, 0.08, 0.96, 0.82], projection="3d", computed_zorder=False)

        # meshes in their link frames; posed, they go into one triangle list (one depth sort)
        meshes = rb.meshes()
        colors = link_colors(rb)
        self.links = [n for n in rb.mesh_links if n in meshes]
        self.tri_local, base_rgb = [], []
        for n in self.links:
            m = meshes[n]
            self.tri_local.append(np.asarray(m.triangles, float))
            base_rgb.append(np.tile(colors[n], (len(m.faces), 1)))
        self.tri_local_all = np.concatenate(self.tri_local) if self.tri_local else np.zeros((0, 3, 3))
        self.base_rgb = np.concatenate(base_rgb) if base_rgb else np.zeros((0, 3))

        # the whole cycle: tool path, bounds
        t_path = cycle_parameters(lk, path_samples)
        tool = rb.tool_poses(t_path)
        self.tool_path = np.concatenate([tool[-1:, :3, 3], tool[:, :3, 3]])  # closed: starts at t = inf
        poses = rb.pose_matrices()
        pts = [self.tool_path, poses[:, :3, 3]] if len(poses) else [self.tool_path]
        P = rb.link_poses(t_path[:: max(1, path_samples // 48)])
        for n in self.links:
            v = meshes[n].vertices[:: max(1, len(meshes[n].vertices) // 200)]
            world = np.einsum("sij,vj->svi", P[n][:, :3, :3], v) + P[n][:, None, :3, 3]
            pts.append(world.reshape(-1, 3))
        allp = np.concatenate(pts)
        lo, hi = allp.min(0), allp.max(0)
        self.centre = (lo + hi) / 2
        self.half = max(float(np.max(hi - lo)) / 2, 1e-9)
        self.frame_len = 0.12 * self.half

        # camera: orthographic, from the side that shows the whole motion spread widest
        for opt, v in (("--elev", elev), ("--azim", azim)):
            if v is not None and not (math.isfinite(v) and abs(v) <= 360):
                raise InputError(f"{opt} {v}: must be an angle in degrees between -360 and 360")
        if elev is None or azim is None:
            e0, a0 = planar_view(lk) or default_view(allp)
            elev = e0 if elev is None else elev
            azim = a0 if azim is None else azim
        ax.view_init(elev=elev, azim=azim)
        ax.set_proj_type("ortho")
        self.elev, self.azim = elev, azim
        self.eye = _eye(elev, azim)
        self.light = _light_direction(elev, azim)

        self._box(lo, hi, elev)

        self.mesh = Poly3DCollection(np.zeros((0, 3, 3)), linewidths=0.25, zorder=1)
        ax.add_collection3d(self.mesh)
        dyn = [self.mesh]
        # the tool hangs on the tool link: a dotted line from that link's mesh centre to the tool frame
        tl = lk.tool_link
        self.mount_local = (np.asarray(meshes[tl].centroid, float) if tl in meshes else None)
        (self.mount,) = ax.plot([], [], [], color=COUPLER_COLOR, lw=1.6, ls=(0, (1.5, 1.5)), zorder=2)
        (path_line,) = ax.plot(*self.tool_path.T, color="0.45", lw=1.0, ls=(0, (4, 2)), zorder=2)
        dyn += [self.mount, path_line]
        dyn += self._labels(lk, poses, meshes, elev, azim)
        self._titles(rb, lk, colors, title)
        # blitting: the axes (panes, grid, ticks) and titles are drawn once; a frame redraws only the
        # artists that move or change, in zorder, over that background
        self.dynamic = sorted(dyn, key=lambda a: a.get_zorder())
        for a in self.dynamic + [self.caption]:
            a.set_animated(True)
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(self.fig.bbox)

    def _box(self, lo, hi, elev) -> None:
        """The box of the whole motion at one scale on every axis (not a cube: a flat or long mechanism
        then fills the frame), with a small margin; axis labels and light panes."""
        ax, c = self.ax, self.centre
        ext = np.maximum((hi - lo) / 2, 0.08 * self.half) * 1.04
        ax.set_xlim(c[0] - ext[0], c[0] + ext[0])
        ax.set_ylim(c[1] - ext[1], c[1] + ext[1])
        ax.set_zlim(c[2] - ext[2], c[2] + ext[2])
        ax.set_box_aspect(tuple(ext / ext.max()), zoom=1.25)
        ax.set_xlabel("x [m]", labelpad=-6, fontsize=8)
        ax.set_ylabel("y [m]", labelpad=-6, fontsize=8)
        ax.set_zlabel("z [m]", labelpad=-6, fontsize=8)
        ax.tick_params(labelsize=7, pad=-2)
        if abs(elev) >= 90 - 1e-9:  # seen along z: its ticks would pile up in one spot
            ax.set_zticks([])
            ax.set_zlabel("")
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.pane.set_facecolor((0.96, 0.96, 0.97, 1.0))
            axis.pane.set_edgecolor((0.85, 0.85, 0.88, 1.0))
            axis._axinfo["grid"]["color"] = (0.88, 0.88, 0.9, 1.0)
            axis._axinfo["grid"]["linewidth"] = 0.5

    def _labels(self, lk, poses, meshes, elev, azim) -> list:
        """The task poses (short RGB axes and their names), the tool frame's axes and the joint names at
        their pins (moving with the joint's child link): the artists that move."""
        ax, dyn = self.ax, []
        from matplotlib import patheffects

        halo = patheffects.withStroke(linewidth=2.5, foreground="white")
        r_scr, u_scr = _screen_axes(elev, azim)
        self.label_offset = 0.06 * self.half * (0.6 * r_scr + u_scr)  # labels up and right of their point
        # task poses: short RGB axes and their names
        for rec, T in zip(lk.poses, poses):
            dyn += self._axes_lines(T, 0.75 * self.frame_len, lw=1.6, zorder=3)
            dyn.append(ax.text(*(T[:3, 3] + self.label_offset), rec.name, fontsize=8, color="0.15", zorder=7,
                               ha="center", va="center", path_effects=[halo]))
        self.tool_lines = self._axes_lines(np.eye(4), 1.6 * self.frame_len, lw=2.8, zorder=5)
        dyn += self.tool_lines
        # joint names at their pins (moving with the joint's child link)
        self.joint_labels = []
        for j in lk.joints:
            body = j.child if j.child in meshes else j.parent
            if body not in meshes:
                continue
            c = self.rb.frame_ref[body][:3, :3] @ meshes[body].centroid + self.rb.frame_ref[body][:3, 3]
            p = j.point + np.dot(c - j.point, j.direction) * j.direction
            txt = ax.text(*p, j.name, fontsize=8, color="0.05", zorder=6, ha="center", va="center",
                          fontstyle="italic", path_effects=[halo])
            self.joint_labels.append((txt, j.child, p))
            dyn.append(txt)
        return dyn

    def _titles(self, rb, lk, colors, title) -> None:
        """The legend of the links, the title, the caption line and the key to the axes."""
        from matplotlib.patches import Patch

        handles = [Patch(facecolor=colors[n], edgecolor="none", label=n) for n in self.links]
        self.fig.legend(handles=handles, loc="upper left", bbox_to_anchor=(0.01, 0.89), fontsize=7.5,
                        frameon=False, ncol=1, handlelength=1.2, title="links", title_fontsize=7.5)
        self.title = title or (f"{rb.robot_name} - {_kind_label(lk)}")
        self.suptitle = self.fig.suptitle(self.title, y=0.975, fontsize=12)
        self.caption = self.fig.text(0.5, 0.905, "", ha="center", fontsize=9, color="0.3")
        self.fig.text(0.01, 0.012, "tool frame: long axes; task poses: short axes (x red, y green, z blue); "
                      "grey dashes: tool path", fontsize=7, color="0.4")

    def _axes_lines(self, T, length, lw, zorder):
        lines = []
        for i in range(3):
            p = T[:3, 3]
            q = p + length * T[:3, i]
            (ln,) = self.ax.plot([p[0], q[0]], [p[1], q[1]], [p[2], q[2]], color=AXIS_COLORS[i], lw=lw,
                                 solid_capstyle="round", zorder=zorder)
            lines.append(ln)
        return lines

    def pose_at(self, t: float, caption: str = "") -> None:
        """Move the linkage to parameter t."""
        P = self.rb.link_poses(t)
        tris = np.empty_like(self.tri_local_all)
        start = 0
        for i, n in enumerate(self.links):
            loc = self.tri_local[i]
            T = P[n]
            tris[start:start + len(loc)] = loc @ T[:3, :3].T + T[:3, 3]
            start += len(loc)
        normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
        # closed meshes under an orthographic camera: triangles facing away are always hidden
        front = normals @ self.eye > -1e-6
        tris, normals = tris[front], normals[front]
        lam = np.clip(normals @ self.light, 0.0, 1.0)
        rgb = self.base_rgb[front] * (0.38 + 0.62 * lam[:, None]) + 0.12 * lam[:, None] ** 8
        rgb = np.clip(rgb, 0.0, 1.0)
        self.mesh.set_verts(tris)
        self.mesh.set_facecolor(rgb)
        self.mesh.set_edgecolor(rgb)
        T = self.rb.tool_poses(t)
        if self.mount_local is not None:
            M = P[self.rb.linkage.tool_link]
            c = M[:3, :3] @ self.mount_local + M[:3, 3]
            self.mount.set_data_3d([c[0], T[0, 3]], [c[1], T[1, 3]], [c[2], T[2, 3]])
        for i, ln in enumerate(self.tool_lines):
            q = T[:3, 3] + 1.6 * self.frame_len * T[:3, i]
            ln.set_data_3d([T[0, 3], q[0]], [T[1, 3], q[1]], [T[2, 3], q[2]])
        disp = self.rb.linkage.displacements(self.rb.linkage.angles_at(t))
        for txt, child, p in self.joint_labels:
            txt.set_position_3d(_apply(disp[child], p) + self.label_offset)
        self.caption.set_text(caption)

    def spread(self, t: float) -> float:
        """How open the mechanism looks at t: sqrt det of the screen covariance of its mesh vertices."""
        P = self.rb.link_poses(t)
        pts = []
        for i, n in enumerate(self.links):
            v = self.tri_local[i][::7, 0]
            pts.append(v @ P[n][:3, :3].T + P[n][:3, 3])
        X = np.concatenate(pts)
        X = X - X.mean(0)
        right, up = _screen_axes(self.elev, self.azim)
        B = np.array([right, up])
        return float(math.sqrt(max(np.linalg.det(B @ (X.T @ X / len(X)) @ B.T), 0.0)))

    def rgb(self) -> np.ndarray:
        """The current frame as an (h, w, 3) uint8 array."""
        self.canvas.restore_region(self.background)
        for a in self.dynamic:
            if a is self.mesh:
                a.do_3d_projection()
            self.ax.draw_artist(a)
        self.fig.draw_artist(self.caption)
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()

    def save_png(self, path) -> None:
        """Write the picture in the format its suffix names (`image_format`)."""
        from PIL import Image

        fmt = image_format(path)
        img = Image.fromarray(self.rgb())
        opts = {"optimize": True} if fmt == "PNG" else {"quality": 92}
        atomic_write(path, lambda tmp: img.save(tmp, format=fmt, **opts))


IMAGE_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG"}


def image_format(path, option: str = "--png") -> str:
    """The Pillow format named by the suffix of ``path`` (.png, .jpg, .jpeg); InputError otherwise."""
    suffix = Path(path).suffix.lower()
    if suffix not in IMAGE_FORMATS:
        raise InputError(f"{option} {path}: unknown picture format {suffix or '(no suffix)'!r}; "
                         "use .png, .jpg or .jpeg")
    return IMAGE_FORMATS[suffix]


def _apply(T, p):
    return T[:3, :3] @ p + T[:3, 3]


def _kind_label(lk) -> str:
    n = len(lk.joints)
    k = kind_label(lk.kind)
    loops = len(lk.closures)
    return f"{k} linkage ({n} revolute joints, {loops} loop{'s' if loops != 1 else ''})"


def planar_view(lk) -> tuple[float, float] | None:
    """(elev, azim) looking along the common direction of the joint axes of a planar linkage (all axes
    parallel within 1e-9: the mechanism moves in planes normal to them), seen face-on; None otherwise."""
    u = np.array([j.direction for j in lk.joints], float)
    if len(u) == 0 or np.abs(np.cross(u, u[0])).max() > 1e-9:
        return None
    n = u[0] if u[0][2] >= 0 else -u[0]
    if n[2] > 1 - 1e-9:  # the xy plane: x to the right, y up
        return 90.0, -90.0
    return float(math.degrees(math.asin(min(1.0, n[2])))), float(math.degrees(math.atan2(n[1], n[0])))


def default_view(points) -> tuple[float, float]:
    """(elev, azim) in degrees of the orthographic camera that shows the points spread widest (largest
    projected area, sqrt of the determinant of the screen covariance), elevation in [10, 50] degrees
    so that z stays up; the areas of all candidate views within 3 % of the best one are equal in
    practice, and of those the one closest to the classic 30/-60 view is taken."""
    X = points - points.mean(0)
    C = X.T @ X / max(len(X), 1)
    best = []
    for el in range(10, 51, 5):
        for az in range(0, 360, 10):
            right, up = _screen_axes(el, az)
            B = np.array([right, up])
            S = B @ C @ B.T
            best.append((math.sqrt(max(np.linalg.det(S), 0.0)), el, az))
    top = max(b[0] for b in best)
    near = [b for b in best if b[0] >= 0.97 * top]
    _, el, az = min(near, key=lambda b: abs(b[1] - 30) + 0.5 * abs(((b[2] + 60 + 180) % 360) - 180))
    return float(el), float(az)


def _screen_axes(elev, azim):
    e, a = math.radians(elev), math.radians(azim)
    eye = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    right = np.array([-math.sin(a), math.cos(a), 0.0])
    up = np.cross(eye, right)
    return right, up


def _eye(elev, azim) -> np.ndarray:
    """Unit vector from the scene towards the (orthographic) camera."""
    e, a = math.radians(elev), math.radians(azim)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def _light_direction(elev, azim) -> np.ndarray:
    right, up = _screen_axes(elev, azim)
    light = _eye(elev, azim) + 0.6 * up - 0.45 * right
    return light / np.linalg.norm(light)


def _resolve_at(rb: Readback, scene: Scene, at) -> float:
    poses = rb.linkage.poses
    if at is None:
        if not poses:
            return math.inf
        return max((p.t for p in poses), key=scene.spread)
    for p in poses:
        if str(at) == p.name:
            return p.t
    try:
        t = float(at)
    except (TypeError, ValueError):
        names = ", ".join(p.name for p in poses)
        raise InputError(f"--at {at!r}: neither a pose name ({names}) nor a number") from None
    if math.isnan(t):
        raise InputError("--at: t must be a number or inf")
    return t


def _fmt_t(t: float) -> str:
    return "inf" if np.isinf(t) else f"{t:.4g}"


def render(rb: Readback, *, png=None, gif=None, frames: int = 60, size=DEFAULT_SIZE, elev=None, azim=None,
           spacing: str = "angle", at=None) -> dict:
    """Write a PNG and/or a GIF of one full cycle with ``frames`` frames. Returns timings and counts.

    The PNG shows the linkage at ``at``: a task pose name or a parameter t (number or "inf"); by
    default at the task pose where the mechanism looks most spread out (least folded)."""
    if frames < 2:
        raise InputError("--frames must be at least 2")
    if png is not None:
        image_format(png)  # before any work: nothing is written for an unknown suffix
    if gif is not None and Path(gif).suffix.lower() != ".gif":
        raise InputError(f"--gif {gif}: an animation is written as GIF; give a .gif file name")
    stats = {}
    t0 = time.perf_counter()
    scene = Scene(rb, size=size, elev=elev, azim=azim)
    stats["setup_s"] = time.perf_counter() - t0
    if png is not None:
        t1 = time.perf_counter()
        t_png = _resolve_at(rb, scene, at)
        name = next((p.name for p in rb.linkage.poses if p.t == t_png), None)
        first = rb.linkage.joints[0]
        deg = f"{first.name} = {math.degrees(float(first.angle(t_png))):.1f}\N{DEGREE SIGN}"
        scene.pose_at(t_png, f"task pose {name}, {deg}" if name else f"{deg} (motion parameter t = {_fmt_t(t_png)})")
        stats["png_t"] = None if math.isinf(t_png) else float(t_png)
        scene.save_png(png)
        stats["png_s"] = time.perf_counter() - t1
    if gif is not None:
        from PIL import Image

        t1 = time.perf_counter()
        ts = cycle_parameters(rb.linkage, frames, spacing=spacing)
        ts = np.roll(ts, 1)  # start at t = inf: the first pose, where the PNG is drawn
        images = []
        angles = rb.linkage.angles_at(ts)
        first = rb.linkage.joints[0].name
        for k, t in enumerate(ts):
            at_pose = next((p.name for p in rb.linkage.poses if p.t == t), None)
            scene.pose_at(t, f"frame {k + 1}/{len(ts)}   {first} = {math.degrees(float(angles[first][k])):6.1f}"
                             f"\N{DEGREE SIGN}" + (f"   task pose {at_pose}" if at_pose else ""))
            images.append(Image.fromarray(scene.rgb()))
        ms = max(20, int(round(GIF_CYCLE_SECONDS * 1000 / len(images))))
        atomic_write(gif, lambda tmp: images[0].save(tmp, format="GIF", save_all=True,
                                                      append_images=images[1:], duration=ms, loop=0))
        stats["gif_s"] = time.perf_counter() - t1
        stats["frames"] = len(images)
    stats["total_s"] = time.perf_counter() - t0
    return stats


def exploded_view(rb: Readback, file, size=(900, 700), spread: float = 0.6) -> None:
    """A PNG of the parts of ``rb`` at the home configuration pulled apart (for the assembly sheet of
    `synth.tools.plates`): every part moved ``spread`` times its centre's distance from the assembly's
    centre, each pin with its carrier link and 1.5 pin lengths out along its axis, a dashed line along the
    axis back to its bores, every part named. ``file``: a path or a binary file object."""
    _require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from synth.io.readback import mesh_path
    from synth.io.solid import read_stl_triangles

    frames, parts = rb.urdf.fk({}), {}
    for m in rb.urdf.meshes:
        path = mesh_path(m.filename, rb.root) if m.tag == "visual" else None
        if path is not None and path.is_file():
            tri = read_stl_triangles(path.read_bytes()).astype(float) * m.scale
            T = frames[m.link] @ m.origin
            parts[m.link] = tri @ T[:3, :3].T + T[:3, 3]
    centre = np.mean([t.reshape(-1, 3).mean(0) for t in parts.values()], axis=0)
    fig = Figure(figsize=(size[0] / DPI, size[1] / DPI), dpi=DPI, facecolor="white")
    FigureCanvasAgg(fig)
    ax = fig.add_axes([0, 0, 1, 0.94], projection="3d")
    elev, azim = default_view(np.concatenate([t.reshape(-1, 3) for t in parts.values()]))
    light, colours, polys, shades, pts = _light_direction(elev, azim), link_colors(rb), [], [], []
    moves = {n: spread * (t.reshape(-1, 3).mean(0) - centre) for n, t in parts.items()}
    carriers = {f"pin_{p['joint']}": p["carrier"] for p in (rb.document.get("design") or {}).get("pins", [])}
    for k, (name, tri) in enumerate(parts.items()):
        c, move = tri.reshape(-1, 3).mean(0), moves[name]
        if name in carriers and carriers[name] in moves:  # out of its carrier's bore along the axis
            u = rb.linkage.joint(name[4:]).direction
            move = moves[carriers[name]] + 1.5 * np.ptp(tri.reshape(-1, 3) @ u) * u
            ax.plot(*np.stack([c + moves[carriers[name]], c + move]).T, color="0.4", lw=0.8, ls="--")
        tri = tri + move
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        rgb = np.array(colours.get(name, PALETTE[k % len(PALETTE)]))
        shades.append(np.clip(rgb * (0.45 + 0.55 * np.clip(n @ light, 0, 1))[:, None], 0, 1))
        polys.append(tri)
        pts.append(tri.reshape(-1, 3))
        ax.text(*(c + move), name, fontsize=8, zorder=10)
    ax.add_collection3d(Poly3DCollection(np.concatenate(polys), facecolors=np.concatenate(shades), linewidths=0))
    allp = np.concatenate(pts)
    lo, hi = allp.min(0), allp.max(0)
    half = max(float(np.max(hi - lo)) / 2, 1e-9)
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), (lo + hi) / 2):
        set_lim(c - half, c + half)
    ax.view_init(elev=elev, azim=azim)
    ax.set_proj_type("ortho")
    ax.set_axis_off()
    fig.suptitle(f"{rb.robot_name}: exploded view (home configuration)", fontsize=11)
    fig.savefig(file, format="png")
