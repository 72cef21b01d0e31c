"""The one reader of an output directory (docs/conventions.md): the linkage, its link frames, meshes and poses.

``read_files(OUT)`` parses linkage.json (plain JSON) and linkage.urdf (`synth.io.urdfmodel`) without
judging them: `mpsynth check` (`synth.tools.check.verify`) and `mpsynth simulate` start from it.
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
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.errors import InputError
from synth.io.urdfmodel import UrdfModel, read_urdf
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
    urdf: UrdfModel | None = None  # the parsed URDF (`synth.io.urdfmodel`)
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
                    problem, m = mesh_file_problem(v.path)
                    if problem:
                        raise InputError(f"{v.path}: mesh {problem} (see 'mpsynth check')")
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
@dataclass
class OutputFiles:
    """The two files of one output directory, parsed but not yet judged: `mpsynth check` lists what is
    wrong with them (``urdf.problems`` and its own checks), `read_output` refuses them on the first."""

    path: Path
    urdf: UrdfModel
    doc: dict


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


def solution_dirs(out) -> list[tuple[str, Path]]:
    """[(id, directory)] of OUT: OUT itself, or, for a multi-solution OUT (index.json, no linkage.urdf),
    every sub-directory holding a linkage.urdf, in name order."""
    out = Path(out)
    if (out / "linkage.urdf").exists() or not (out / "index.json").is_file():
        return [("", out)]
    subs = sorted(p for p in out.iterdir() if p.is_dir() and (p / "linkage.urdf").exists())
    if not subs:
        raise InputError(f"{out}: index.json but no solution directory with a linkage.urdf")
    return [(p.name, p) for p in subs]


def read_files(out) -> OutputFiles:
    """Parse OUT/linkage.json (plain JSON) and OUT/linkage.urdf (`synth.io.urdfmodel.read_urdf`).
    InputError (one line) only when a file is missing or unreadable, or not JSON / XML at all."""
    out = Path(out)
    if not out.exists():
        raise InputError(f"{out}: no such output directory")
    if not out.is_dir():
        raise InputError(f"{out}: not a directory")
    for name in ("linkage.json", "linkage.urdf"):
        if not (out / name).is_file():
            hint = " (a multi-solution output: give OUT/<id>)" if (out / "index.json").is_file() else ""
            raise InputError(f"{out}: no {name}{hint}")
    urdf = read_urdf(out / "linkage.urdf")
    return OutputFiles(out, urdf, read_document(out / "linkage.json"))


MAX_DOCUMENT_BYTES = 64 * 1024 * 1024  # a linkage.json holds no meshes: a few hundred kB at most
MAX_DOCUMENT_DEPTH = 64  # nesting of a linkage.json (mpsynth writes at most ~6 levels)


def read_document(path: Path) -> dict:
    """The JSON object in ``path``, bounded (MAX_DOCUMENT_BYTES, MAX_DOCUMENT_DEPTH); InputError (one
    line) when it is larger, nested deeper, unreadable, not JSON or not an object."""
    try:
        size = path.stat().st_size
        if size > MAX_DOCUMENT_BYTES:
            raise InputError(f"{path}: {size / 1e6:.0f} MB, larger than the {MAX_DOCUMENT_BYTES >> 20} MiB a "
                             "linkage document can be; refusing to read it")
        with open(path, "rb") as fh:
            raw = fh.read(MAX_DOCUMENT_BYTES + 1)
        text = raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot read ({getattr(e, 'strerror', None) or e})") from None
    if _depth(text) > MAX_DOCUMENT_DEPTH:
        raise InputError(f"{path}: JSON nested more than {MAX_DOCUMENT_DEPTH} levels deep; not a linkage document")
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError) as e:
        raise InputError(f"{path}: not valid JSON ({' '.join(str(e).split())[:200]})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{path}: not a JSON object")
    return doc


def _depth(text: str) -> int:
    """An upper bound of the bracket nesting of JSON ``text`` (brackets inside strings count too)."""
    opens = np.frombuffer(text.encode("utf-8", "replace"), np.uint8)
    step = np.where((opens == 0x5B) | (opens == 0x7B), 1, 0) - np.where((opens == 0x5D) | (opens == 0x7D), 1, 0)
    return int(np.cumsum(step).max(initial=0))


def is_number(v) -> bool:
    """A finite JSON number (not a boolean, not a string)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def mesh_file_problem(path: Path) -> tuple[str, object]:
    """("", the trimesh) for a whole binary STL file with triangles and finite vertices; else (the
    problem, None): truncated or not binary, unloadable, no triangles, NaN / infinite vertices."""
    import io

    import trimesh

    try:
        raw = Path(path).read_bytes()
    except OSError as e:
        return f"cannot read ({e.strerror or e})", None
    if len(raw) < 84:
        return "not an STL file", None
    n = int.from_bytes(raw[80:84], "little")
    if len(raw) != 84 + 50 * n:
        return "not a binary STL (truncated or of the wrong size)", None
    if n == 0:
        return "has no triangles", None
    tri = np.frombuffer(raw, dtype=np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]),
                        offset=84)
    if not np.all(np.isfinite(tri["v"])):
        return "has vertices that are not finite numbers", None
    try:
        mesh = trimesh.load(io.BytesIO(raw), file_type="stl", force="mesh")
    except Exception as e:  # noqa: BLE001 - any loader failure is a problem line
        return f"does not load ({type(e).__name__}: {e})", None
    if len(mesh.faces) == 0:
        return "has no triangles", None
    return "", mesh


def _law_entries(doc: dict):
    """(joint name, its angle-law dict) for the well-formed joints of a linkage.json document
    (``joints[].angle_law``; older documents carry ``a`` and ``b`` on the joint itself)."""
    joints = doc.get("joints")
    for j in joints if isinstance(joints, list) else []:
        if isinstance(j, dict) and isinstance(j.get("name"), str):
            yield j["name"], (j["angle_law"] if isinstance(j.get("angle_law"), dict) else j)


def angle_laws(doc: dict) -> dict[str, tuple[float, float]]:
    """joint -> (a, b) of its angle law theta(t) = 2 atan2(b, t - a), for the joints of a linkage.json
    document that have numeric ones; nothing is judged here (`mpsynth check` reports missing or bad laws)."""
    laws = {}
    for name, law in _law_entries(doc):
        a, b = law.get("a"), law.get("b")
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (a, b)):
            laws[name] = (float(a), float(b))
    return laws


def angle_rates(doc: dict) -> dict[str, int]:
    """joint -> rate of its angle law (``joints[].angle_law.rate``, theta(t) = rate * 2 atan2(b, t - a);
    1 when absent or not a positive integer) for the joints of a linkage.json document."""
    rates = {}
    for name, law in _law_entries(doc):
        r = law.get("rate", 1)
        rates[name] = r if isinstance(r, int) and not isinstance(r, bool) and r >= 1 else 1
    return rates


def read_output(out) -> Readback:
    """Read OUT (see the module docstring) and judge it strictly: raises InputError (one line) on the
    first problem of either file, a missing mesh or a URDF axis off its linkage.json line."""
    root = resolve_output(out)
    files = read_files(root)
    doc, model = files.doc, files.urdf
    where = str(root / "linkage.json")
    if not str(doc.get("format", "")).startswith("mpsynth.linkage/"):
        raise InputError(f"{where}: not an mpsynth linkage.json (no 'format': 'mpsynth.linkage/1')")
    linkage = linkage_from_document(doc, where=where)
    urdf = root / "linkage.urdf"
    if model.problems:
        raise InputError(f"{urdf}: {model.problems[0].removeprefix('URDF: ')}")
    frame_ref = model.fk({})
    for n in linkage.link_names:
        if n not in frame_ref:
            raise InputError(f"{urdf}: link {n!r} of linkage.json is missing")
    visuals: dict[str, list[Visual]] = {}
    for m in model.meshes:
        if m.tag == "visual" and m.filename:
            visuals.setdefault(m.link, []).append(Visual(path=_mesh_file(m.filename, urdf), scale=m.scale,
                                                         origin=m.origin, rgba=m.rgba))
    _cross_check(linkage, frame_ref, model, urdf)
    _fold_fixed_parts(visuals, model, linkage)
    return Readback(root=root, document=doc, linkage=linkage, robot_name=model.name or "linkage",
                    frame_ref=frame_ref, visuals=visuals, urdf=model)


def _arr(x, shape, where):
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: expected numbers of shape {shape}") from None
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise InputError(f"{where}: expected finite numbers of shape {shape}, got {a.shape}")
    return a


def _number(v, where: str) -> float:
    if not is_number(v):
        raise InputError(f"{where}: expected a finite number, got {str(v)[:40]!r}")
    return float(v)


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
            a, b = _number(law["a"], f"{where}: joint {jd['name']}: angle law a"), \
                _number(law["b"], f"{where}: joint {jd['name']}: angle law b")
            if not (math.isfinite(a) and math.isfinite(b)):
                raise InputError(f"{where}: joint {jd['name']}: angle law is not finite")
            rate = law.get("rate", 1)
            if isinstance(rate, bool) or not isinstance(rate, int) or rate < 1:
                raise InputError(f"{where}: joint {jd['name']}: angle law rate {rate!r} is not a positive integer")
            joints.append(Joint(str(jd["name"]), str(jd["parent"]), str(jd["child"]), u, m, a, b, rate))
        poses = []
        for i, pd in enumerate(doc.get("poses", [])):
            t = pd.get("t", None)
            poses.append(PoseRecord(str(pd.get("name", f"p{i}")), _arr(pd["matrix"], (4, 4), f"{where}: pose {i}"),
                                    float("inf") if t is None else _number(t, f"{where}: pose {i}: t"),
                                    {k: _number(v, f"{where}: pose {i}: joint angle {k}")
                                     for k, v in pd.get("joint_angles", {}).items()},
                                    "point" if pd.get("kind") == "point" else "pose"))
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
def mesh_path(filename: str, root) -> Path | None:
    """Where a URDF mesh ``filename`` lives in the output directory ``root`` (docs/conventions.md: mesh paths are
    relative to the URDF; ``package://NAME/x`` means ``root/x``), or None when it is not such a path
    (empty, absolute, another URL scheme). Whether the file exists is not checked."""
    root = Path(root)
    if filename.startswith("package://"):
        rest = filename[len("package://"):].split("/", 1)
        return root / rest[1] if len(rest) == 2 and rest[1] else None
    if not filename or filename.startswith("/") or "://" in filename:
        return None
    return root / filename


def _mesh_file(filename: str, urdf: Path) -> Path:
    p = mesh_path(filename, urdf.parent)
    if p is None:
        raise InputError(f"{urdf}: mesh {filename!r} is not a path relative to the URDF")
    if not p.is_file():
        raise InputError(f"{urdf}: mesh {filename!r} not found (looked for {p})")
    return p


def _fold_fixed_parts(visuals: dict, model: UrdfModel, linkage: Linkage) -> None:
    """Give each link of the linkage the visuals of the parts fixed to it that are not links of the
    linkage themselves (the pins ``pin_<joint>``), placed by their fixed joint's origin: one rigid body."""
    names = set(linkage.link_names)
    for d in model.joints.values():
        if d.kind == "fixed" and d.parent in names and d.child not in names and d.child in visuals:
            for v in visuals[d.child]:
                visuals.setdefault(d.parent, []).append(
                    Visual(path=v.path, scale=v.scale, origin=d.origin @ v.origin, rgba=v.rgba))


def _cross_check(linkage: Linkage, frame: dict, model: UrdfModel, urdf: Path) -> None:
    scale = linkage.extent()
    for j in linkage.joints:
        d = model.joints.get(j.name)
        if d is None:
            raise InputError(f"{urdf}: joint {j.name} of linkage.json is missing")
        if (d.parent, d.child) != (j.parent, j.child):
            raise InputError(f"{urdf}: joint {j.name} connects {d.parent}->{d.child}, "
                             f"linkage.json says {j.parent}->{j.child}")
        F = frame[j.child]
        u = F[:3, :3] @ d.axis
        u = u / max(np.linalg.norm(u), 1e-300)
        p = F[:3, 3]
        ang = math.asin(min(1.0, float(np.linalg.norm(np.cross(u, j.direction)))))
        dist = float(np.linalg.norm(np.cross(p, j.direction) - j.moment))
        if np.dot(u, j.direction) < 0 or ang > AXIS_TOL or dist > AXIS_TOL * scale:
            raise InputError(f"{urdf}: joint {j.name}'s axis differs from linkage.json's line "
                             f"(angle {ang:.2e} rad, offset {dist:.2e} m)")
