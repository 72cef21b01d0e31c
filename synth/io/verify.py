"""`mpsynth check`: read an output directory back and verify the whole claim it makes (OUTPUT.md).

Nothing here trusts the synthesis code: the URDF is parsed with ``xml.etree`` into our own small model
(forward kinematics by 4x4 products), linkage.json is read as plain JSON, meshes are loaded with
trimesh from the files. The checks, each adding one line per problem:

1. structure: one root ``base``, unique names, one parent per link, no cycle, joints name existing
   links, the ``<gazebo><joint type="fixed">`` welds (named ``loop_closure``, ``loop_closure_2``, ...)
   equal linkage.json's ``closures``, link ``tool`` on the tool link by a fixed joint when the output
   has poses, every joint of linkage.json is a revolute URDF joint with the same parent and child, and
   its world axis at all-zero angles is linkage.json's Plücker line;
2. meshes: every referenced mesh is a relative path (``package://NAME/...`` is resolved inside OUT),
   exists, is a binary STL that loads, is watertight with positive volume, and its size (after the
   URDF ``scale``) fits the linkage's size;
3. poses: at every pose's ``joint_angles`` the URDF's ``tool`` frame equals the pose matrix of
   linkage.json and, with ``poses``, the pose of the POSES file; every loop is closed there;
4. cycle, exact: the angle laws ``theta_j(t) = 2 atan2(b_j, t - a_j)`` (``joints[].angle_law``) give the
   pose angles at ``poses[].t``; sampled uniformly in the first joint's angle over a full turn they keep
   every loop closed, and the coupler follows ``motion_polynomial``;
5. cycle, independent: the first joint of the first branch is driven through a full turn in adaptive
   steps (tangent predictor, Gauss-Newton corrector on all loops together, step halved on failure and
   grown on success); it must complete the turn, come back to all-zero, and agree with the angle laws.

Tolerances: with L the linkage's size (RMS spread of joint feet and tool positions) and A the largest
coordinate, lengths must agree to ``rtol * L + 1e-13 * A`` and angles to ``rtol + 1e-13 * A / L``
(``rtol`` 1e-8 by default); the continuation must agree with the angle laws to ``max(1e-6, 100 * angle
tolerance)`` rad. Figures of every measurement are returned for ``--json``.
"""
from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.errors import InputError

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------- small rotations
def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rpy(roll, pitch, yaw):
    """URDF fixed-axis roll-pitch-yaw: Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def _axis_rotations(u, q):
    """Rotations (N, 3, 3) about unit axis u by angles q (N,) (Rodrigues)."""
    q = np.atleast_1d(np.asarray(q, float))
    K = _skew(u)
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def rot_angle(R):
    """Rotation angle of rotations (..., 3, 3), accurate near 0 and pi."""
    s = 0.5 * np.linalg.norm(np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                                       R[..., 1, 0] - R[..., 0, 1]], -1), axis=-1)
    return np.arctan2(s, 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0))


def _wrap(x):
    """Angles to (-pi, pi]."""
    return np.mod(np.asarray(x, float) + math.pi, TWO_PI) - math.pi


def _invert(T):
    Ti = np.zeros_like(T)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    Ti[..., :3, :3] = Rt
    Ti[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    Ti[..., 3, 3] = 1.0
    return Ti


# ----------------------------------------------------------------------------- URDF model
@dataclass
class UJoint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray  # 4x4, joint frame in the parent link frame
    axis: np.ndarray  # unit axis in the joint (= child link) frame
    axis_raw: np.ndarray
    limit: tuple | None = None  # (lower, upper) for revolute joints


@dataclass
class UMesh:
    link: str
    tag: str  # visual | collision
    filename: str
    scale: np.ndarray
    origin: np.ndarray = field(default_factory=lambda: np.eye(4))  # geometry frame in the link frame


@dataclass
class UrdfModel:
    """Just what the checks need from a URDF file."""

    name: str
    links: list[str]
    joints: dict[str, UJoint]
    closures: list[tuple[str, str, str]]  # (weld name, parent link, child link)
    meshes: list[UMesh]
    problems: list[str] = field(default_factory=list)
    order: list[str] = field(default_factory=list)  # joints in topological order from base
    inertials: dict = field(default_factory=dict)  # link -> (mass, 4x4 inertial frame, 3x3 inertia)
    parent_joint: dict[str, str] = field(default_factory=dict)  # child link -> joint name

    def path(self, link: str) -> list[str]:
        """Joint names from base to ``link``."""
        out, seen = [], set()
        while link in self.parent_joint and link not in seen:
            seen.add(link)
            jn = self.parent_joint[link]
            out.append(jn)
            link = self.joints[jn].parent
        return out[::-1]

    def fk(self, cfg: dict, n: int | None = None) -> dict[str, np.ndarray]:
        """World frames of every reachable link, (4, 4) or (n, 4, 4) when ``n`` is given; ``cfg`` maps
        joint names to angles (scalars or arrays of length n), missing joints are 0."""
        if n is None:
            return self._fk1(cfg)
        m = n
        frames = {"base": np.broadcast_to(np.eye(4), (m, 4, 4)).copy()}
        for jn in self.order:
            j = self.joints[jn]
            F = frames[j.parent] @ j.origin
            if j.kind in ("revolute", "continuous"):
                q = np.broadcast_to(np.asarray(cfg.get(jn, 0.0), float), (m,))
                M = np.zeros((m, 4, 4))
                M[:, :3, :3] = _axis_rotations(j.axis, q)
                M[:, 3, 3] = 1.0
                F = F @ M
            elif j.kind == "prismatic":
                q = np.broadcast_to(np.asarray(cfg.get(jn, 0.0), float), (m,))
                M = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
                M[:, :3, 3] = q[:, None] * j.axis
                F = F @ M
            frames[j.child] = F
        return frames

    def _fk1(self, cfg: dict) -> dict[str, np.ndarray]:
        """`fk` for one configuration (the continuation's inner loop: plain 4x4 products)."""
        frames = {"base": np.eye(4)}
        for jn in self.order:
            j = self.joints[jn]
            F = frames[j.parent] @ j.origin
            q = float(cfg.get(jn, 0.0))
            if j.kind in ("revolute", "continuous") and q != 0.0:
                x, y, z = j.axis
                c, s = math.cos(q), math.sin(q)
                C = 1.0 - c
                M = np.array([[c + x * x * C, x * y * C - z * s, x * z * C + y * s, 0.0],
                              [y * x * C + z * s, c + y * y * C, y * z * C - x * s, 0.0],
                              [z * x * C - y * s, z * y * C + x * s, c + z * z * C, 0.0],
                              [0.0, 0.0, 0.0, 1.0]])
                F = F @ M
            elif j.kind == "prismatic" and q != 0.0:
                M = np.eye(4)
                M[:3, 3] = q * j.axis
                F = F @ M
            frames[j.child] = F
        return frames


def _floats(text, count, what, problems):
    try:
        vals = [float(v) for v in (text or "").split()]
    except ValueError:
        vals = []
    if len(vals) != count or not all(math.isfinite(v) for v in vals):
        problems.append(f"URDF: {what} is {text!r}, expected {count} finite numbers")
        return None
    return vals


def _origin(el, what, problems) -> np.ndarray:
    """4x4 transform of an <origin xyz rpy> element (identity when absent)."""
    T = np.eye(4)
    if el is None:
        return T
    xyz = _floats(el.get("xyz", "0 0 0"), 3, f"{what} xyz", problems)
    rpy = _floats(el.get("rpy", "0 0 0"), 3, f"{what} rpy", problems)
    if xyz is not None and rpy is not None:
        T[:3, :3] = _rpy(*rpy)
        T[:3, 3] = xyz
    return T


def read_urdf(path) -> UrdfModel:
    """Parse a URDF file into a `UrdfModel`. An unreadable or non-XML file raises InputError; anything
    else wrong is listed in ``problems``."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror or e})") from None
    except ET.ParseError as e:
        raise InputError(f"{path}: not well-formed XML ({e})") from None
    if root.tag != "robot":
        raise InputError(f"{path}: root element is <{root.tag}>, expected <robot>")
    problems: list[str] = []
    links: list[str] = []
    meshes: list[UMesh] = []
    inertials: dict = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            problems.append("URDF: a <link> has no name")
            continue
        if name in links:
            problems.append(f"URDF: link {name} is defined twice")
            continue
        links.append(name)
        for tag in ("visual", "collision"):
            for part in el.findall(tag):
                m = part.find("geometry/mesh")
                if m is None:
                    continue
                scale = _floats(m.get("scale", "1 1 1"), 3, f"mesh scale of link {name}", problems)
                meshes.append(UMesh(name, tag, m.get("filename", ""), np.array(scale or [1.0, 1.0, 1.0]),
                                    _origin(part.find("origin"), f"{tag} origin of link {name}", problems)))
        inertial = el.find("inertial")
        if inertial is not None:
            mass_el, I_el = inertial.find("mass"), inertial.find("inertia")
            mass = _floats(mass_el.get("value") if mass_el is not None else None, 1, f"mass of link {name}", problems)
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            vals = _floats(" ".join(I_el.get(k, "0") for k in keys) if I_el is not None else None, 6,
                           f"inertia of link {name}", problems)
            if mass is not None and vals is not None:
                ixx, ixy, ixz, iyy, iyz, izz = vals
                I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
                inertials[name] = (mass[0], _origin(inertial.find("origin"), f"inertial origin of link {name}",
                                                    problems), I)
    joints: dict[str, UJoint] = {}
    parent_joint: dict[str, str] = {}
    for el in root.findall("joint"):
        name, kind = el.get("name"), el.get("type")
        if not name:
            problems.append("URDF: a <joint> has no name")
            continue
        if name in joints:
            problems.append(f"URDF: joint {name} is defined twice")
            continue
        p, c = el.find("parent"), el.find("child")
        parent = p.get("link") if p is not None else None
        child = c.get("link") if c is not None else None
        if not parent or not child:
            problems.append(f"URDF: joint {name} lacks a parent or child link")
            continue
        bad = [lk for lk in (parent, child) if lk not in links]
        if bad:
            problems.append(f"URDF: joint {name} names missing link(s) {', '.join(bad)}")
            continue
        if kind not in ("revolute", "continuous", "prismatic", "fixed"):
            problems.append(f"URDF: joint {name} has type {kind!r} (expected continuous, revolute or fixed)")
            continue
        n_before = len(problems)
        T = _origin(el.find("origin"), f"origin of joint {name}", problems)
        a = el.find("axis")
        axis = _floats(a.get("xyz", "1 0 0") if a is not None else "1 0 0", 3, f"axis of joint {name}", problems)
        if axis is None or len(problems) > n_before:
            continue
        axis = np.array(axis)
        if kind != "fixed" and not np.linalg.norm(axis) > 0:
            problems.append(f"URDF: joint {name} has a zero axis")
            continue
        limit = None
        lim = el.find("limit")
        if kind == "revolute" and lim is not None:
            limit = (float(lim.get("lower", "0")), float(lim.get("upper", "0")))
        if child in parent_joint:
            problems.append(f"URDF: link {child} has two parents (joints {parent_joint[child]} and {name})")
            continue
        parent_joint[child] = name
        unit = axis / np.linalg.norm(axis) if np.linalg.norm(axis) > 0 else axis
        joints[name] = UJoint(name, kind, parent, child, T, unit, axis, limit)
    roots = [lk for lk in links if lk not in parent_joint]
    if roots != ["base"]:
        problems.append(f"URDF: root link(s) {roots}, expected exactly ['base']")
    # topological order from base; links not reached hang in a cycle or under another root
    order, reached, frontier = [], {"base"}, ["base"]
    children: dict[str, list[str]] = {}
    for jn, j in joints.items():
        children.setdefault(j.parent, []).append(jn)
    while frontier:
        nxt = []
        for lk in frontier:
            for jn in children.get(lk, []):
                order.append(jn)
                reached.add(joints[jn].child)
                nxt.append(joints[jn].child)
        frontier = nxt
    lost = [lk for lk in links if lk not in reached]
    if lost and "base" in links:
        problems.append(f"URDF: link(s) {', '.join(lost)} not connected to base")
    closures = []
    for g in root.findall("gazebo"):
        for el in g.findall("joint"):
            if el.get("type") != "fixed":
                continue
            p, c = el.find("parent"), el.find("child")
            if p is None or c is None or not (p.text or "").strip() or not (c.text or "").strip():
                problems.append(f"URDF: <gazebo> joint {el.get('name')} lacks <parent> or <child>")
                continue
            closures.append((el.get("name") or "", p.text.strip(), c.text.strip()))
    return UrdfModel(root.get("name", ""), links, joints, closures, meshes, problems, order, inertials,
                     parent_joint)


# ----------------------------------------------------------------------------- reading OUT
@dataclass
class Output:
    path: Path
    urdf: UrdfModel
    doc: dict


def read_output(out) -> Output:
    """Read OUT/linkage.urdf and OUT/linkage.json; InputError (exit 2) when OUT is unreadable."""
    out = Path(out)
    if not out.is_dir():
        raise InputError(f"{out}: not a directory")
    for name in ("linkage.urdf", "linkage.json"):
        if not (out / name).is_file():
            hint = " (a multi-solution output: give OUT/<id>)" if (out / "index.json").is_file() else ""
            raise InputError(f"{out}: no {name}{hint}")
    urdf = read_urdf(out / "linkage.urdf")
    try:
        doc = json.loads((out / "linkage.json").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{out / 'linkage.json'}: cannot read ({e})") from None
    except ValueError as e:
        raise InputError(f"{out / 'linkage.json'}: not valid JSON ({e})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{out / 'linkage.json'}: not a JSON object")
    return Output(out, urdf, doc)


def solution_dirs(out) -> list[tuple[str, Path]]:
    """[(id, directory)] to check: OUT itself, or, for a multi-solution OUT (index.json, no
    linkage.urdf), every sub-directory holding a linkage.urdf, in name order."""
    out = Path(out)
    if (out / "linkage.urdf").exists() or not (out / "index.json").is_file():
        return [("", out)]
    subs = sorted(p for p in out.iterdir() if p.is_dir() and (p / "linkage.urdf").exists())
    if not subs:
        raise InputError(f"{out}: index.json but no solution directory with a linkage.urdf")
    return [(p.name, p) for p in subs]


# ----------------------------------------------------------------------------- checker
class _Checker:
    def __init__(self, output: Output, poses=None, rtol: float = 1e-8, steps: int = 360,
                 samples: int = 720, meshes: bool = True):
        self.o = output
        self.u = output.urdf
        self.doc = output.doc
        self.poses_file = poses
        self.rtol = rtol
        self.steps = steps
        self.samples = samples
        self.do_meshes = meshes
        self.problems: list[str] = list(self.u.problems)
        self.figures: dict = {}

    def fail(self, msg: str) -> None:
        self.problems.append(msg)

    # -------------------------------------------------------------- json helpers
    def _json_joints(self) -> list[dict]:
        js = self.doc.get("joints")
        if not isinstance(js, list):
            return []
        return [j for j in js if isinstance(j, dict) and isinstance(j.get("name"), str)]

    def _json_poses(self) -> list[dict]:
        ps = self.doc.get("poses")
        return [p for p in ps if isinstance(p, dict)] if isinstance(ps, list) else []

    def _angle_laws(self) -> dict[str, tuple[float, float]]:
        laws = {}
        for j in self._json_joints():
            law = j.get("angle_law") if isinstance(j.get("angle_law"), dict) else j
            a, b = law.get("a"), law.get("b")
            if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
                laws[j["name"]] = (float(a), float(b))
        return laws

    # -------------------------------------------------------------- scales
    def _scales(self):
        F0 = self.u.fk({})
        pts = [F0[j.child][:3, 3] for j in self.u.joints.values() if j.kind != "fixed"]
        for p in self._json_poses():
            M = _matrix(p.get("matrix"))
            if M is not None:
                pts.append(M[:3, 3])
        if "tool" in F0:
            pts.append(F0["tool"][:3, 3])
        pts = np.array(pts) if pts else np.zeros((1, 3))
        c = pts.mean(axis=0)
        L = float(max(np.sqrt(np.mean(np.sum((pts - c) ** 2, axis=1))), 1e-12))
        A = float(max(np.abs(pts).max(), L))
        self.L, self.A = L, A
        self.tol_len = self.rtol * L + 1e-13 * A
        self.tol_ang = self.rtol + 1e-13 * A / L
        self.figures["length_scale"] = L
        self.figures["tolerance"] = {"length": self.tol_len, "angle": self.tol_ang}

    # -------------------------------------------------------------- 1. structure
    def structure(self):
        u, doc = self.u, self.doc
        fmt = doc.get("format")
        if not (isinstance(fmt, str) and fmt.startswith("mpsynth.linkage/")):
            self.fail(f"linkage.json: format is {fmt!r}, expected 'mpsynth.linkage/1'")
        units = doc.get("units")
        if units != {"length": "m", "angle": "rad"}:
            self.fail(f"linkage.json: units are {units!r}, expected metres and radians")
        if not u.closures:
            self.fail("URDF: no loop closure (<gazebo><joint type=\"fixed\">)")
        names = [c[0] for c in u.closures]
        expected = ["loop_closure"] + [f"loop_closure_{i}" for i in range(2, len(names) + 1)]
        if names != expected[:len(names)]:
            self.fail(f"URDF: loop closures are named {names}, expected {expected}")
        pairs = [[c[1], c[2]] for c in u.closures]
        jc = doc.get("closures")
        if not isinstance(jc, list) or [list(c) for c in jc if isinstance(c, (list, tuple))] != pairs:
            self.fail(f"linkage.json closures {jc} differ from the URDF's welds {pairs}")
        for _, a, b in u.closures:
            for lk in (a, b):
                if lk not in u.links:
                    self.fail(f"URDF: loop closure names missing link {lk}")
        self.closures = [(a, b) for _, a, b in u.closures if a in u.links and b in u.links]
        # json joints vs URDF joints
        jj = self._json_joints()
        if not jj:
            self.fail("linkage.json: no joints")
        for j in jj:
            uj = u.joints.get(j["name"])
            if uj is None:
                self.fail(f"URDF: no joint {j['name']} (listed in linkage.json)")
                continue
            if uj.kind not in ("continuous", "revolute"):
                self.fail(f"URDF: joint {uj.name} is {uj.kind}, expected continuous")
            elif uj.limit is not None and uj.limit[1] - uj.limit[0] < TWO_PI - 1e-9:
                claim = _task_limits(doc)  # a task-range collision claim limits its driver to that range
                if claim is None or claim[0] != uj.name:
                    self.fail(f"URDF: joint {uj.name} is limited to [{uj.limit[0]:.4g}, {uj.limit[1]:.4g}] "
                              "but turns through a full cycle")
                elif max(abs(uj.limit[0] - claim[1]), abs(uj.limit[1] - claim[2])) > 1e-9:
                    self.fail(f"URDF: joint {uj.name} is limited to [{uj.limit[0]:.4g}, {uj.limit[1]:.4g}], "
                              f"linkage.json's task-range collision claim to [{claim[1]:.4g}, {claim[2]:.4g}]")
            for key in ("parent", "child"):
                if key in j and j[key] != getattr(uj, key):
                    self.fail(f"joint {uj.name}: {key} is {getattr(uj, key)} in the URDF, {j[key]} in linkage.json")
        moving = [jn for jn, j in u.joints.items() if j.kind != "fixed"]
        unlisted = [jn for jn in moving if jn not in {j["name"] for j in jj}]
        if unlisted:
            self.fail(f"URDF joint(s) {', '.join(unlisted)} missing from linkage.json")
        # branches: chains from base
        br = doc.get("branches")
        if not isinstance(br, list) or not br:
            self.fail("linkage.json: no branches")
        else:
            for b in br:
                if not isinstance(b, list) or not all(n in u.joints for n in b):
                    self.fail(f"linkage.json branch {b} names joints missing from the URDF")
                    continue
                link = "base"
                for n in b:
                    if u.joints[n].parent != link:
                        self.fail(f"linkage.json branch {b} is not a chain from base (at {n})")
                        break
                    link = u.joints[n].child
        # tool link
        if self._json_poses() or self.poses_file:
            tool_link = self.doc.get("tool_link", "coupler")
            if "tool" not in u.links:
                self.fail("URDF: no link tool (the task frame)")
            else:
                jn = u.parent_joint.get("tool")
                if jn is None or u.joints[jn].kind != "fixed":
                    self.fail("URDF: link tool does not hang on a fixed joint")
                elif u.joints[jn].parent != tool_link:
                    self.fail(f"URDF: link tool hangs on {u.joints[jn].parent}, expected {tool_link}")
        # axes: world Plücker lines at all-zero angles vs linkage.json
        F0 = u.fk({})
        worst = 0.0
        for j in jj:
            uj = u.joints.get(j["name"])
            line = j.get("line") if isinstance(j.get("line"), dict) else {}
            d, m = _vector(line.get("direction")), _vector(line.get("moment"))
            if uj is None or uj.kind == "fixed" or uj.child not in F0:
                continue
            if d is None or m is None:
                self.fail(f"linkage.json: joint {uj.name} has no line (direction, moment)")
                continue
            Fj = F0[uj.parent] @ uj.origin
            du = Fj[:3, :3] @ uj.axis
            mu = np.cross(Fj[:3, 3], du)
            err = max(float(np.linalg.norm(du - d)), float(np.linalg.norm(mu - m)) / self.L)
            worst = max(worst, err)
            if err > 10 * self.tol_ang:
                self.fail(f"joint {uj.name}: URDF axis differs from linkage.json's line by {err:.3g} "
                          "(direction + moment / size)")
        self.figures["axis_mismatch"] = worst

    # -------------------------------------------------------------- 2. meshes
    def meshes(self):
        import trimesh

        if not self.u.meshes:
            self.fail("URDF: references no meshes")
        good, seen = 0, {}
        F0 = self.u.fk({})
        origins = np.array([F0[j.child][:3, 3] for j in self.u.joints.values() if j.kind != "fixed"]
                           or [np.zeros(3)])
        spread = float(max(np.ptp(origins, axis=0).max(), self.L))
        for m in self.u.meshes:
            fn = m.filename
            where = f"mesh {fn} (link {m.link} {m.tag})"
            if fn.startswith("package://"):
                rel = fn[len("package://"):].split("/", 1)[1] if "/" in fn[len("package://"):] else ""
            elif fn.startswith("/") or "://" in fn or not fn:
                self.fail(f"{where}: not a path relative to the URDF")
                continue
            else:
                rel = fn
            p = self.o.path / rel
            if not p.is_file():
                self.fail(f"{where}: file not found")
                continue
            key = (str(p), tuple(m.scale))
            if key not in seen:
                seen[key] = self._mesh_problem(trimesh, p, m.scale, spread)
            if seen[key]:
                self.fail(f"{where}: {seen[key]}")
            else:
                good += 1
        # links that carry joints should have geometry
        links = self.doc.get("links")
        if isinstance(links, dict):
            with_mesh = {m.link for m in self.u.meshes}
            for lk, js in links.items():
                if js and lk in self.u.links and lk not in with_mesh:
                    self.fail(f"URDF: link {lk} carries joints {js} but has no mesh")
        self.figures["meshes"] = {"referenced": len(self.u.meshes), "good": good}

    def _mesh_problem(self, trimesh, path: Path, scale, spread) -> str:
        raw = path.read_bytes()
        if len(raw) < 84:
            return "not an STL file"
        n = int.from_bytes(raw[80:84], "little")
        if len(raw) != 84 + 50 * n:
            return "not a binary STL"
        try:
            mesh = trimesh.load(path, file_type="stl", force="mesh")
        except Exception as e:  # noqa: BLE001 - any loader failure is a problem line
            return f"does not load ({type(e).__name__}: {e})"
        if len(mesh.faces) == 0:
            return "has no triangles"
        if not mesh.is_watertight:
            return "is not watertight"
        vol = float(mesh.volume) * float(np.prod(scale))
        if not (vol > 0 and mesh.is_winding_consistent):
            return f"is not a solid of positive volume (volume {vol:.3g} m^3)"
        size = float(np.linalg.norm(mesh.extents * np.abs(scale)))
        if size > 100 * spread or size < 1e-4 * spread:
            return f"is {size:.3g} m across for a linkage {spread:.3g} m across (wrong unit or scale?)"
        return ""

    # -------------------------------------------------------------- 3. poses
    def poses(self):
        u = self.u
        recs = self._json_poses()
        self.figures["poses"] = len(recs)
        if not recs and not self.poses_file:
            return
        if not recs:
            self.fail("linkage.json: no poses")
        moving = [jn for jn, j in u.joints.items() if j.kind != "fixed"]
        ref = self._closure_refs()
        file_T = None
        if self.poses_file is not None:
            file_T = self.poses_file.matrices
            if len(file_T) != len(recs):
                self.fail(f"{self.poses_file.source}: {len(file_T)} poses, linkage.json has {len(recs)}")
        pt = pr = ft = fr = ct = cr = 0.0
        for i, rec in enumerate(recs):
            name = rec.get("name", f"p{i}")
            ang = rec.get("joint_angles")
            if not isinstance(ang, dict):
                self.fail(f"linkage.json: pose {i} ({name}) has no joint_angles")
                continue
            missing = [jn for jn in moving if jn not in ang]
            if missing:
                self.fail(f"linkage.json: pose {i} ({name}) lacks angles for {', '.join(missing)}")
            cfg = {k: float(v) for k, v in ang.items() if isinstance(v, (int, float))}
            F = u.fk(cfg)
            M = _matrix(rec.get("matrix"))
            if "tool" in F:
                if M is None:
                    self.fail(f"linkage.json: pose {i} ({name}) has no 4x4 matrix")
                else:
                    dt, dr = _pose_diff(F["tool"], M)
                    pt, pr = max(pt, dt), max(pr, dr)
                    if dt > self.tol_len or dr > self.tol_ang:
                        self.fail(f"tool frame misses pose {i} ({name}) of linkage.json by {dt:.3g} m, {dr:.3g} rad")
                if file_T is not None and i < len(file_T):
                    dt, dr = _pose_diff(F["tool"], file_T[i])
                    ft, fr = max(ft, dt), max(fr, dr)
                    if dt > self.tol_len or dr > self.tol_ang:
                        self.fail(f"tool frame misses pose {i} ({name}) of {self.poses_file.source} "
                                  f"by {dt:.3g} m, {dr:.3g} rad")
            for (a, b), R in zip(self.closures, ref):
                dt, dr = _pose_diff(F[a] @ R, F[b])
                ct, cr = max(ct, dt), max(cr, dr)
                if dt > self.tol_len or dr > self.tol_ang:
                    self.fail(f"loop {a}-{b} open at pose {i} ({name}) by {dt:.3g} m, {dr:.3g} rad")
        self.figures["pose_error"] = {"translation": pt, "rotation": pr}
        if file_T is not None:
            self.figures["pose_file_error"] = {"translation": ft, "rotation": fr}
        self.figures["closure_at_poses"] = {"translation": ct, "rotation": cr}

    def _closure_refs(self):
        F0 = self.u.fk({})
        return [_invert(F0[a]) @ F0[b] for a, b in self.closures]

    # -------------------------------------------------------------- 4. exact cycle from the angle laws
    def laws(self):
        laws = self._angle_laws()
        moving = [jn for jn in self.loop_joints]
        if not laws:
            self.figures["angle_laws"] = "absent"
            return
        missing = [jn for jn in moving if jn not in laws]
        if missing:
            self.fail(f"linkage.json: no angle law for joint(s) {', '.join(missing)}")
            return
        for jn, (a, b) in laws.items():
            if not (math.isfinite(a) and math.isfinite(b)) or b == 0:
                self.fail(f"linkage.json: joint {jn} has angle law a={a}, b={b} (b must be finite and non-zero)")
                return
        # pose angles from the laws
        worst = 0.0
        for i, rec in enumerate(self._json_poses()):
            if "t" not in rec or not isinstance(rec.get("joint_angles"), dict):
                continue
            t = rec["t"]
            t = math.inf if t is None else float(t)
            for jn, v in rec["joint_angles"].items():
                if jn in laws:
                    a, b = laws[jn]
                    th = 0.0 if math.isinf(t) else 2.0 * math.atan2(b, t - a)
                    worst = max(worst, abs(float(_wrap(th - float(v)))))
        if worst > self.tol_ang:
            self.fail(f"linkage.json: pose joint angles differ from the angle laws by {worst:.3g} rad")
        self.figures["law_vs_pose_angles"] = worst
        # loops along the motion, uniform in the driver's angle
        phi = np.linspace(0.0, TWO_PI, self.samples, endpoint=False)
        cfg = law_angles(laws, self.driver, phi)
        F = self.u.fk(cfg, n=len(phi))
        ct = cr = 0.0
        for (a, b), R in zip(self.closures, self._closure_refs()):
            dt, dr = _pose_diff(F[a] @ R, F[b])
            ct, cr = max(ct, float(dt.max())), max(cr, float(dr.max()))
        self.figures["law_closure_error"] = {"translation": ct, "rotation": cr, "samples": len(phi)}
        if ct > self.tol_len or cr > self.tol_ang:
            self.fail(f"loop open along the angle laws' motion by {ct:.3g} m, {cr:.3g} rad")
        # the coupler follows the motion polynomial (when it is given)
        C = self.doc.get("motion_polynomial")
        tool_link = self.doc.get("tool_link", "coupler")
        if isinstance(C, list) and C and tool_link in F:
            try:
                from synth.algebra.polynomial import pose_at

                Cn = np.array(C, float)
                a, b = laws[self.driver]
                s, c = np.sin(phi / 2), np.cos(phi / 2)
                with np.errstate(divide="ignore", invalid="ignore"):
                    t = np.where(s == 0, np.inf, a + b * c / s)
                target = pose_at(Cn, t)
                disp = F[tool_link] @ _invert(self.u.fk({})[tool_link])
                dt, dr = _pose_diff(disp, target)
                me = {"translation": float(dt.max()), "rotation": float(dr.max())}
            except Exception as e:  # noqa: BLE001
                self.fail(f"linkage.json: motion_polynomial cannot be evaluated ({type(e).__name__}: {e})")
                me = None
            if me is not None:
                self.figures["motion_polynomial_error"] = me
                if me["translation"] > 10 * self.tol_len or me["rotation"] > 10 * self.tol_ang:
                    self.fail(f"coupler leaves the motion polynomial by {me['translation']:.3g} m, "
                              f"{me['rotation']:.3g} rad")

    # -------------------------------------------------------------- 5. independent continuation
    def continuation(self):
        if not self.closures or self.driver is None:
            return
        others = [jn for jn in self.loop_joints if jn != self.driver]
        result = continue_loop(self.u, self.closures, self.driver, others, steps=self.steps,
                               length=self.L, tol=max(self.tol_ang, self.tol_len / self.L))
        laws = self._angle_laws()
        dev = None
        if laws and all(jn in laws for jn in self.loop_joints) and len(result["path"]):
            path = np.array(result["path"])
            exact = law_angles(laws, self.driver, path[:, 0])
            dev = 0.0
            for k, jn in enumerate(others):
                dev = max(dev, float(np.abs(_wrap(path[:, k + 1] - exact[jn])).max()))
        fig = {"driver": self.driver, "followed": result["followed"], "steps": result["accepted"],
               "rejected": result["rejected"], "max_residual": result["max_residual"]}
        if dev is not None:
            fig["max_deviation_from_laws"] = dev
        self.figures["continuation"] = fig
        if result["followed"] < 1.0:
            self.fail(f"linkage driven by {self.driver} stuck at {math.degrees(result['angle']):.4g} deg of a "
                      f"full turn (loop residual {result['stuck_residual']:.3g})")
        else:
            back = float(np.abs(_wrap(np.array(result["path"][-1][1:]))).max()) if others else 0.0
            fig["return_error"] = back
            if back > 1e-6:
                self.fail(f"after a full turn of {self.driver} the linkage is not back at all-zero (off by {back:.3g} rad)")
        tol_dev = max(1e-6, 100 * self.tol_ang)
        if dev is not None and dev > tol_dev:
            self.fail(f"continuation driven by {self.driver} deviates from the angle laws by {dev:.3g} rad")

    # -------------------------------------------------------------- run
    def run(self):
        self._scales()
        self.structure()
        # joints in the loops (those that move some closure pair relative to each other), driver
        loop = []
        for a, b in self.closures:
            pa, pb = self.u.path(a), self.u.path(b)
            loop += [j for j in pa + pb if (j in pa) != (j in pb)]
        self.loop_joints = [j for j in dict.fromkeys(loop) if self.u.joints[j].kind in ("revolute", "continuous")]
        self.driver = None
        if self.closures:
            first = [j for j in self.u.path(self.closures[0][0]) if j in self.loop_joints]
            br = self.doc.get("branches")
            if isinstance(br, list) and br and isinstance(br[0], list) and br[0] and br[0][0] in self.loop_joints:
                self.driver = br[0][0]
            elif first:
                self.driver = first[0]
        if self.do_meshes:
            self.meshes()
        self.poses()
        if self.closures and self.driver:
            self.laws()
            self.continuation()
        return self.problems, self.figures


def check_output(out, poses=None, *, rtol: float = 1e-8, steps: int = 360, samples: int = 720,
                 meshes: bool = True) -> dict:
    """Check one output directory; returns ``{"ok", "problems", "figures"}``. ``poses`` is an optional
    `synth.io.poses.PoseSet` to compare the tool frame with. Raises InputError when OUT is unreadable."""
    output = read_output(out)
    problems, figures = _Checker(output, poses, rtol, steps, samples, meshes).run()
    return {"ok": not problems, "problems": problems, "figures": figures}


def check_tree(out, poses=None, **kw) -> dict:
    """`check_output` on OUT or, for a multi-solution OUT, on each solution directory (problems are then
    prefixed with the solution id, figures keyed by it)."""
    dirs = solution_dirs(out)
    if len(dirs) == 1 and dirs[0][0] == "":
        return check_output(dirs[0][1], poses, **kw)
    problems, figures = [], {}
    for sid, d in dirs:
        r = check_output(d, poses, **kw)
        problems += [f"{sid}: {p}" for p in r["problems"]]
        figures[sid] = r["figures"]
    return {"ok": not problems, "problems": problems, "figures": figures}


# ----------------------------------------------------------------------------- angle laws
def law_angles(laws: dict, driver: str, phi) -> dict[str, np.ndarray]:
    """Exact joint angles when the driver joint is at angle(s) ``phi`` in [0, 2pi]: the driver's law
    theta = 2 atan2(b, t - a) gives t = a + b cot(phi/2); with s = sin(phi/2) >= 0, c = cos(phi/2),
    theta_j = 2 atan2(b_j s, (a_d - a_j) s + b_d c), which is exact at phi = 0 (t = infinity) too."""
    phi = np.asarray(phi, float)
    ad, bd = laws[driver]
    s, c = np.sin(phi / 2), np.cos(phi / 2)
    out = {}
    for jn, (a, b) in laws.items():
        out[jn] = phi.copy() if jn == driver else np.mod(2.0 * np.arctan2(b * s, (ad - a) * s + bd * c), TWO_PI)
    return out


# ----------------------------------------------------------------------------- continuation
def loop_residual(u: UrdfModel, closures, refs, cfg, unknowns, length, jacobian=True):
    """Residual of all loops (6 per loop: translation / length, rotation) and its Jacobian with respect
    to the ``unknowns`` joint angles (and, as a last column, nothing else)."""
    F = u.fk(cfg)
    rows, jac = [], []
    axes = {}
    paths = _path_sets(u, closures)
    if jacobian:
        for jn in unknowns:
            j = u.joints[jn]
            Fj = F[j.parent] @ j.origin
            axes[jn] = (Fj[:3, :3] @ j.axis, Fj[:3, 3])
    for (a, b), R in zip(closures, refs):
        G = F[b] @ _invert(R)  # where link a should be, according to branch b
        Fa = F[a]
        M = G[:3, :3] @ Fa[:3, :3].T
        e_p = (G[:3, 3] - Fa[:3, 3]) / length
        e_r = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
        rows.append(np.concatenate([e_p, e_r]))
        if jacobian:
            pa, pb = paths[(a, b)]
            J = np.zeros((6, len(unknowns)))
            for k, jn in enumerate(unknowns):
                w, c = axes[jn]
                sb, sa = jn in pb, jn in pa
                if sb == sa:
                    continue
                if sb:
                    J[:3, k] = _cross(w, G[:3, 3] - c) / length
                    J[3:, k] = w
                else:
                    J[:3, k] = -_cross(w, Fa[:3, 3] - c) / length
                    J[3:, k] = -w
            jac.append(J)
    r = np.concatenate(rows) if rows else np.zeros(0)
    return r, (np.vstack(jac) if jacobian and jac else None)


def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


_PATHS: dict = {}


def _path_sets(u, closures):
    key = (id(u), tuple(closures))
    if key not in _PATHS or _PATHS[key][0] is not u:
        _PATHS.clear()
        _PATHS[key] = (u, {(a, b): (set(u.path(a)), set(u.path(b))) for a, b in closures})
    return _PATHS[key][1]


def _gauss_newton(fun, x0, tol, max_iter=25):
    """Gauss-Newton with step halving (least squares through the SVD, so redundant loop equations and
    rank deficiency are fine). Returns (x, |r|)."""
    x = x0.copy()
    r, J = fun(x)
    nr = float(np.linalg.norm(r))
    for _ in range(max_iter):
        if nr <= 1e-3 * tol:
            break
        dx = np.linalg.lstsq(J, -r, rcond=1e-12)[0]
        lam, improved = 1.0, False
        for _ in range(8):
            xn = x + lam * dx
            rn, Jn = fun(xn)
            nrn = float(np.linalg.norm(rn))
            if nrn < nr:
                x, r, J, nr, improved = xn, rn, Jn, nrn, True
                break
            lam /= 2
        if not improved or float(np.abs(lam * dx).max()) < 1e-16:
            break
    return x, nr


def continue_loop(u: UrdfModel, closures, driver: str, others: list[str], *, steps: int = 360,
                  length: float = 1.0, tol: float = 1e-8, min_step: float = 1e-7) -> dict:
    """Drive ``driver`` from 0 through a full turn, solving ``others`` so every loop stays closed.

    Adaptive continuation: tangent predictor (from the loop Jacobian), Gauss-Newton corrector, the step
    (at most 2 pi / steps) halves when the corrector fails or moves a joint by more than a quarter of
    the step bound, and grows by 1.5 after a success; below ``min_step`` * 2 pi the linkage is stuck.
    Returns ``followed`` (fraction of the turn), ``path`` (rows: driver angle, others' angles),
    ``accepted``/``rejected`` step counts, ``max_residual`` (of accepted points) and, when stuck, the
    ``angle`` and ``stuck_residual``."""
    F0 = u.fk({})
    refs = [_invert(F0[a]) @ F0[b] for a, b in closures]
    all_j = [driver] + list(others)
    h_max = TWO_PI / steps
    h_min = TWO_PI * min_step

    def fun_at(phi):
        def f(x):
            cfg = {driver: phi, **dict(zip(others, x))}
            return loop_residual(u, closures, refs, cfg, others, length)
        return f

    def tangent(phi, x):
        cfg = {driver: phi, **dict(zip(others, x))}
        _, J = loop_residual(u, closures, refs, cfg, all_j, length)
        if J is None or not others:
            return np.zeros(len(others))
        return np.linalg.lstsq(J[:, 1:], -J[:, 0], rcond=1e-10)[0]

    phi, h = 0.0, h_max
    x = np.zeros(len(others))
    path = [np.concatenate([[0.0], x])]
    accepted = rejected = 0
    worst = float(np.linalg.norm(fun_at(0.0)(x)[0]))
    stuck_res = 0.0
    while phi < TWO_PI - 1e-13:
        step = min(h, TWO_PI - phi)
        guess = x + step * tangent(phi, x)
        xn, res = _gauss_newton(fun_at(phi + step), guess, tol)
        jump = float(np.abs(xn - guess).max()) if len(xn) else 0.0
        if res <= tol and jump <= 0.25 * h_max + 1e-12 and np.all(np.isfinite(xn)):
            phi += step
            x = xn
            worst = max(worst, res)
            path.append(np.concatenate([[phi], x]))
            accepted += 1
            h = min(h_max, 1.5 * step)
        else:
            rejected += 1
            stuck_res = res
            if step <= h_min:
                return {"followed": phi / TWO_PI, "path": path, "accepted": accepted, "rejected": rejected,
                        "max_residual": worst, "angle": phi, "stuck_residual": stuck_res}
            h = step / 2
    return {"followed": 1.0, "path": path, "accepted": accepted, "rejected": rejected, "max_residual": worst,
            "angle": TWO_PI, "stuck_residual": 0.0}


# ----------------------------------------------------------------------------- helpers
def _matrix(v):
    try:
        M = np.array(v, float)
    except (TypeError, ValueError):
        return None
    return M if M.shape == (4, 4) and np.all(np.isfinite(M)) else None


def _vector(v):
    try:
        x = np.array(v, float)
    except (TypeError, ValueError):
        return None
    return x if x.shape == (3,) and np.all(np.isfinite(x)) else None


def _task_limits(doc: dict):
    """(driver, lower, upper) that a task-range collision claim in linkage.json puts on its driver
    (`synth.io.urdf.driver_limits`), or None."""
    from synth.io.urdf import driver_limits

    c = doc.get("collision")
    try:
        return driver_limits(c) if isinstance(c, dict) else None
    except (KeyError, TypeError, ValueError):
        return None

def _pose_diff(A, B):
    dt = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    dr = rot_angle(np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3])
    if np.ndim(dt) == 0:
        return float(dt), float(dr)
    return dt, dr
