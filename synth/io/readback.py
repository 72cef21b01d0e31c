"""Read an output directory (OUTPUT.md) back: the linkage, its link frames, meshes and poses.

``read_output(OUT)`` rebuilds a `synth.linkage.Linkage` from ``OUT/linkage.json`` (joint lines, angle
laws, link tree, closures, poses, tool frame) and takes from ``OUT/linkage.urdf`` what only the URDF
holds: the link frames at the reference configuration, the mesh files with their scale and visual
origin, and the colours. The two files are cross-checked (every URDF joint axis must lie on its
linkage.json line), so a tool that reads an OUT back shows or tests what was really written.

The pose of a link's frame in the world at joint angles ``q`` is ``disp(link, q) @ frame_ref[link]``
(``Linkage.displacements``), and a link's mesh, in its own frame and in metres, is placed by it.

``cycle_parameters(linkage, n)`` samples one full cycle of the motion: every joint makes exactly one
turn as t runs over the real line, so the samples are taken along t = tan(phi), phi in (-pi/2, pi/2],
the last one t = inf (the reference configuration, pose 0). With ``spacing="angle"`` (the default)
the phi values are redistributed so that consecutive samples are equally far apart in joint space
(sum of the joints' angle changes): a joint that turns quickly over a short stretch of t is then
not skipped.

Nothing here needs trimesh until meshes are loaded.
"""
from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.errors import InputError
from synth.linkage import Joint, Linkage, PoseRecord

AXIS_TOL = 1e-6  # URDF vs linkage.json: direction (rad) and distance of the joint origin from the line
                 # (relative to the linkage's extent)


@dataclass
class Visual:
    """One ``<visual>`` of a URDF link: mesh file, scale, origin in the link frame, colour."""

    path: Path
    scale: np.ndarray  # (3,)
    origin: np.ndarray  # (4, 4) in the link frame
    rgba: tuple[float, float, float, float] | None = None


@dataclass
class Readback:
    """What an output directory holds, ready to be posed along the motion."""

    root: Path
    document: dict
    linkage: Linkage
    robot_name: str
    frame_ref: dict[str, np.ndarray]  # link -> (4, 4) world frame at the reference configuration
    visuals: dict[str, list[Visual]]  # link -> its visual meshes
    tool_frame_link: str = "tool"
    _meshes: dict | None = field(default=None, repr=False)

    # ------------------------------------------------------------------ structure
    @property
    def kind(self) -> str:
        return self.linkage.kind

    @property
    def closures(self) -> list[tuple[str, str]]:
        return list(self.linkage.closures)

    @property
    def mesh_links(self) -> list[str]:
        """Links with geometry, in tree order."""
        return [n for n in self.linkage.link_names if self.visuals.get(n)]

    def bodies(self) -> dict[str, str]:
        """link -> the rigid body it belongs to (a closure's duplicate belongs to its original)."""
        parent = {n: n for n in self.linkage.link_names}

        def find(x):
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for a, b in self.linkage.closures:
            ra, rb = find(a), find(b)
            if ra != rb:
                parent[rb] = ra
        return {n: find(n) for n in parent}

    def adjacent_pairs(self) -> set[frozenset]:
        """Pairs of links that share a joint or are welded (loop closures), as frozensets of names;
        a joint into a closure duplicate counts as a joint into its original."""
        body = self.bodies()
        members: dict[str, list[str]] = {}
        for n, b in body.items():
            members.setdefault(b, []).append(n)
        pairs = set()
        for j in self.linkage.joints:
            for a in members[body[j.parent]]:
                for b in members[body[j.child]]:
                    if a != b:
                        pairs.add(frozenset((a, b)))
        for b, ms in members.items():
            for i, x in enumerate(ms):
                for y in ms[i + 1:]:
                    pairs.add(frozenset((x, y)))
        return pairs

    # ------------------------------------------------------------------ meshes
    def meshes(self) -> dict:
        """{link: trimesh.Trimesh} in the link's own frame, metres (visual scale and origin applied);
        several visuals of one link are concatenated. Loaded once."""
        if self._meshes is None:
            import trimesh

            out = {}
            for link in self.mesh_links:
                parts = []
                for v in self.visuals[link]:
                    try:
                        m = trimesh.load_mesh(str(v.path))
                    except Exception as e:  # unreadable or malformed mesh file
                        raise InputError(f"{v.path}: cannot read mesh ({type(e).__name__}: {e})") from None
                    if isinstance(m, trimesh.Scene):
                        m = m.to_mesh() if hasattr(m, "to_mesh") else m.dump(concatenate=True)
                    m = m.copy()
                    S = np.eye(4)
                    S[:3, :3] = np.diag(v.scale)
                    m.apply_transform(v.origin @ S)
                    parts.append(m)
                out[link] = parts[0] if len(parts) == 1 else trimesh.util.concatenate(parts)
            self._meshes = out
        return self._meshes

    # ------------------------------------------------------------------ motion
    def link_poses(self, t) -> dict[str, np.ndarray]:
        """World pose of every link frame at parameter(s) t: (4, 4) or (n, 4, 4)."""
        shape = np.shape(t) + (4, 4)
        disp = self.linkage.displacements(self.linkage.angles_at(t))
        return {n: np.broadcast_to(disp[n] @ self.frame_ref[n], shape).copy() for n in disp}

    def tool_poses(self, t) -> np.ndarray:
        """World pose(s) of the tool frame at parameter(s) t."""
        disp = self.linkage.displacements(self.linkage.angles_at(t))
        return disp[self.linkage.tool_link] @ self.linkage.tool_ref

    def pose_matrices(self) -> np.ndarray:
        return np.array([p.matrix for p in self.linkage.poses], float).reshape(-1, 4, 4)


# ====================================================================== sampling
def cycle_parameters(linkage: Linkage, n: int, spacing: str = "angle") -> np.ndarray:
    """``n`` parameters t covering one full cycle, in the order of the motion, the last one inf.

    ``spacing="phi"``: t = tan(phi) with phi = -pi/2 + pi (k + 1) / n. ``spacing="angle"``: the same
    path, with the phi values chosen so that the sum over the joints of |angle change| is the same
    between consecutive samples."""
    n = int(n)
    if n < 1:
        raise ValueError("need at least one sample")
    if spacing == "phi":
        phi = -math.pi / 2 + math.pi * (np.arange(n) + 1) / n
    elif spacing == "angle":
        phi = _angle_spaced_phi(linkage, n)
    else:
        raise ValueError(f"unknown spacing {spacing!r}")
    t = np.tan(phi)
    t[-1] = np.inf
    return t


def phi_of(t) -> np.ndarray:
    """phi in (-pi/2, pi/2] with t = tan(phi) (inf -> pi/2)."""
    t = np.asarray(t, float)
    return np.where(np.isinf(t), math.pi / 2, np.arctan(t))


def _angle_spaced_phi(linkage: Linkage, n: int) -> np.ndarray:
    # a dense phi grid that resolves every joint: uniform in phi plus, for each joint, uniform in its
    # own angle (t = a + b tan(psi) makes theta linear in psi)
    m = 2048
    psi = -math.pi / 2 + math.pi * (np.arange(m) + 0.5) / m
    grids = [psi]
    for j in linkage.joints:
        if abs(j.b) > 0:
            grids.append(np.arctan(j.a + abs(j.b) * np.tan(psi)))
    grid = np.unique(np.concatenate(grids + [np.array([-math.pi / 2 + 1e-12, math.pi / 2])]))
    t = np.tan(grid)
    t[-1] = np.inf
    ang = np.array([j.angle(t) for j in linkage.joints])  # (J, m')
    d = np.diff(ang, axis=1)
    d = np.abs((d + math.pi) % (2 * math.pi) - math.pi)
    s = np.concatenate([[0.0], np.cumsum(d.sum(axis=0))])
    if not s[-1] > 0:  # no joint moves (cannot happen for a real linkage): fall back to phi spacing
        return -math.pi / 2 + math.pi * (np.arange(n) + 1) / n
    target = s[-1] * (np.arange(n) + 1) / n
    phi = np.interp(target, s, grid)
    phi[-1] = math.pi / 2
    return phi


# ====================================================================== reading
def resolve_output(out) -> Path:
    """The directory holding linkage.json: OUT itself, or its only solution subdirectory."""
    root = Path(out)
    if not root.exists():
        raise InputError(f"{out}: no such output directory")
    if root.is_file():
        if root.name in ("linkage.json", "linkage.urdf"):
            return root.parent
        raise InputError(f"{out}: expected an output directory (with linkage.json and linkage.urdf)")
    if (root / "linkage.json").is_file():
        return root
    subs = sorted(p.parent.name for p in root.glob("*/linkage.json"))
    if len(subs) == 1:
        return root / subs[0]
    if subs:
        shown = ", ".join(subs[:5]) + (", ..." if len(subs) > 5 else "")
        raise InputError(f"{out}: holds {len(subs)} linkages ({shown}); give one of them, e.g. {root / subs[0]}")
    raise InputError(f"{out}: no linkage.json here; expected an mpsynth output directory")


def read_output(out) -> Readback:
    """Read OUT (see the module docstring). Raises InputError (one line) on any problem."""
    root = resolve_output(out)
    doc = _read_json(root / "linkage.json")
    linkage = linkage_from_document(doc, where=str(root / "linkage.json"))
    urdf = root / "linkage.urdf"
    if not urdf.is_file():
        raise InputError(f"{root}: no linkage.urdf")
    robot_name, frame_ref, visuals, urdf_joints = _read_urdf(urdf, linkage)
    _cross_check(linkage, frame_ref, urdf_joints, urdf)
    _fold_fixed_parts(visuals, urdf_joints, linkage)
    return Readback(root=root, document=doc, linkage=linkage, robot_name=robot_name, frame_ref=frame_ref,
                    visuals=visuals)


def _read_json(path: Path) -> dict:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror or e})") from None
    except ValueError as e:
        raise InputError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(doc, dict) or not str(doc.get("format", "")).startswith("mpsynth.linkage/"):
        raise InputError(f"{path}: not an mpsynth linkage.json (no 'format': 'mpsynth.linkage/1')")
    return doc


def _arr(x, shape, where):
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected numbers of shape {shape}") from None
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise InputError(f"{where}: expected finite numbers of shape {shape}, got {a.shape}")
    return a


def linkage_from_document(doc: dict, where: str = "linkage.json") -> Linkage:
    """A `Linkage` from a linkage.json document (the keys jsonout.linkage_document writes)."""
    try:
        joints = []
        for i, jd in enumerate(doc["joints"]):
            law = jd.get("angle_law")
            if not isinstance(law, dict) or "a" not in law or "b" not in law:
                raise InputError(f"{where}: joint {jd.get('name', i)!r} has no angle_law "
                                 "(this linkage.json was not written by mpsynth's exporter)")
            for key in ("parent", "child"):
                if key not in jd:
                    raise InputError(f"{where}: joint {jd.get('name', i)!r} has no {key!r}")
            u = _arr(jd["line"]["direction"], (3,), f"{where}: joint {jd['name']} direction")
            m = _arr(jd["line"]["moment"], (3,), f"{where}: joint {jd['name']} moment")
            a, b = float(law["a"]), float(law["b"])
            if not (math.isfinite(a) and math.isfinite(b)):
                raise InputError(f"{where}: joint {jd['name']}: angle law is not finite")
            joints.append(Joint(str(jd["name"]), str(jd["parent"]), str(jd["child"]), u, m, a, b))
        poses = []
        for i, pd in enumerate(doc.get("poses", [])):
            t = pd.get("t", None)
            poses.append(PoseRecord(str(pd.get("name", f"p{i}")), _arr(pd["matrix"], (4, 4), f"{where}: pose {i}"),
                                    float("inf") if t is None else float(t),
                                    {k: float(v) for k, v in pd.get("joint_angles", {}).items()}))
        links = {str(k): [str(x) for x in v] for k, v in doc.get("links", {}).items()}
        if not links:  # older documents: every link carries the joints it touches
            for j in joints:
                links.setdefault(j.parent, []).append(j.name)
                links.setdefault(j.child, []).append(j.name)
        closures = [(str(a), str(b)) for a, b in doc.get("closures", [])]
        tool_ref = doc.get("tool_ref")
        tool_ref = np.eye(4) if tool_ref is None else _arr(tool_ref, (4, 4), f"{where}: tool_ref")
        motion = doc.get("motion_polynomial") or [[1, 0, 0, 0, 0, 0, 0, 0]]
        motion = np.array([[np.nan if v is None else v for v in row] for row in motion], float)
        lk = Linkage(kind=str(doc.get("kind", "?")), joints=joints, links=links,
                     branches=[list(b) for b in doc.get("branches", [])], closures=closures,
                     tool_ref=tool_ref, motion=motion, poses=poses,
                     tool_link=str(doc.get("tool_link", "coupler")),
                     checks={k: v for k, v in doc.get("checks", {}).items()},
                     info=dict(doc.get("info", {}) or {}))
    except InputError:
        raise
    except (KeyError, TypeError, ValueError, AttributeError) as e:
        raise InputError(f"{where}: malformed linkage document ({type(e).__name__}: {e})") from None
    seen = {"base"}
    for j in lk.joints:
        if j.parent not in seen:
            raise InputError(f"{where}: joint {j.name}: parent link {j.parent!r} is not defined before it")
        if j.child in seen:
            raise InputError(f"{where}: joint {j.name}: link {j.child!r} has two parents")
        seen.add(j.child)
    for a, b in lk.closures:
        if a not in seen or b not in seen:
            raise InputError(f"{where}: closure ({a}, {b}) names an unknown link")
    return lk


# ---------------------------------------------------------------------- URDF
def _floats(text, n, where, default):
    if text is None:
        return np.array(default, float)
    try:
        v = np.array([float(x) for x in text.split()], float)
    except ValueError:
        raise InputError(f"{where}: expected {n} numbers, got {text!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InputError(f"{where}: expected {n} finite numbers, got {text!r}")
    return v


def _origin(el, where) -> np.ndarray:
    from synth.io.frames import rpy_matrix

    T = np.eye(4)
    o = el.find("origin") if el is not None else None
    if o is not None:
        T[:3, 3] = _floats(o.get("xyz"), 3, f"{where} origin xyz", [0, 0, 0])
        T[:3, :3] = rpy_matrix(*_floats(o.get("rpy"), 3, f"{where} origin rpy", [0, 0, 0]))
    return T


def _mesh_path(filename: str, urdf: Path) -> Path:
    root = urdf.parent
    if filename.startswith("package://"):
        rest = filename[len("package://"):].split("/", 1)
        candidates = [root / rest[1]] if len(rest) == 2 else []
    elif filename.startswith("file://"):
        candidates = [Path(filename[len("file://"):])]
    else:
        candidates = [root / filename]
    for c in candidates:
        if c.is_file():
            return c
    raise InputError(f"{urdf}: mesh {filename!r} not found (looked for {candidates[0] if candidates else filename})")


def _read_urdf(urdf: Path, linkage: Linkage):
    try:
        robot = ET.parse(urdf).getroot()
    except (ET.ParseError, OSError) as e:
        raise InputError(f"{urdf}: cannot parse URDF ({e})") from None
    if robot.tag != "robot":
        raise InputError(f"{urdf}: root element is <{robot.tag}>, expected <robot>")
    materials = {}
    for m in robot.findall("material"):
        c = m.find("color")
        if m.get("name") and c is not None:
            materials[m.get("name")] = tuple(_floats(c.get("rgba"), 4, f"{urdf}: material", [0.5] * 4))
    visuals: dict[str, list[Visual]] = {}
    for link in robot.findall("link"):
        name = link.get("name")
        for vis in link.findall("visual"):
            mesh = vis.find("geometry/mesh")
            if mesh is None or not mesh.get("filename"):
                continue
            where = f"{urdf}: link {name} visual"
            rgba = None
            mat = vis.find("material")
            if mat is not None:
                c = mat.find("color")
                if c is not None:
                    rgba = tuple(_floats(c.get("rgba"), 4, f"{where} color", [0.5] * 4))
                else:
                    rgba = materials.get(mat.get("name"))
            visuals.setdefault(name, []).append(Visual(
                path=_mesh_path(mesh.get("filename"), urdf),
                scale=_floats(mesh.get("scale"), 3, f"{where} mesh scale", [1, 1, 1]),
                origin=_origin(vis, where), rgba=rgba))
    joints = {}
    for j in robot.findall("joint"):
        p, c = j.find("parent"), j.find("child")
        if p is None or c is None:
            raise InputError(f"{urdf}: joint {j.get('name')} lacks <parent> or <child>")
        axis = j.find("axis")
        joints[j.get("name")] = dict(type=j.get("type"), parent=p.get("link"), child=c.get("link"),
                                     origin=_origin(j, f"{urdf}: joint {j.get('name')}"),
                                     axis=_floats(axis.get("xyz") if axis is not None else None, 3,
                                                  f"{urdf}: joint {j.get('name')} axis", [1, 0, 0]))
    # link frames at the reference configuration (all joint angles zero): forward kinematics from base
    frame = {"base": np.eye(4)}
    by_child = {d["child"]: (n, d) for n, d in joints.items()}
    pending = [n for n in by_child]
    for _ in range(len(pending) + 1):
        left = []
        for child in pending:
            n, d = by_child[child]
            if d["parent"] in frame:
                frame[child] = frame[d["parent"]] @ d["origin"]
            else:
                left.append(child)
        if not left or len(left) == len(pending):
            pending = left
            break
        pending = left
    if pending:
        raise InputError(f"{urdf}: links {', '.join(pending)} are not connected to 'base'")
    for n in linkage.link_names:
        if n not in frame:
            raise InputError(f"{urdf}: link {n!r} of linkage.json is missing")
    return robot.get("name", "linkage"), frame, visuals, joints


def _fold_fixed_parts(visuals: dict, joints: dict, linkage: Linkage) -> None:
    """Give each link of the linkage the visuals of the parts fixed to it that are not links of the
    linkage themselves (the pins ``pin_<joint>``), placed by their fixed joint's origin: one rigid body."""
    names = set(linkage.link_names)
    for d in joints.values():
        if d["type"] == "fixed" and d["parent"] in names and d["child"] not in names and d["child"] in visuals:
            for v in visuals[d["child"]]:
                visuals.setdefault(d["parent"], []).append(
                    Visual(path=v.path, scale=v.scale, origin=d["origin"] @ v.origin, rgba=v.rgba))


def _cross_check(linkage: Linkage, frame: dict, joints: dict, urdf: Path) -> None:
    scale = linkage.extent()
    for j in linkage.joints:
        d = joints.get(j.name)
        if d is None:
            raise InputError(f"{urdf}: joint {j.name} of linkage.json is missing")
        if (d["parent"], d["child"]) != (j.parent, j.child):
            raise InputError(f"{urdf}: joint {j.name} connects {d['parent']}->{d['child']}, "
                             f"linkage.json says {j.parent}->{j.child}")
        F = frame[j.child]
        u = F[:3, :3] @ d["axis"]
        u = u / max(np.linalg.norm(u), 1e-300)
        p = F[:3, 3]
        ang = math.asin(min(1.0, float(np.linalg.norm(np.cross(u, j.direction)))))
        dist = float(np.linalg.norm(np.cross(p, j.direction) - j.moment))
        if np.dot(u, j.direction) < 0 or ang > AXIS_TOL or dist > AXIS_TOL * scale:
            raise InputError(f"{urdf}: joint {j.name}'s axis differs from linkage.json's line "
                             f"(angle {ang:.2e} rad, offset {dist:.2e} m)")
