"""URDF text of a `Linkage`, following the closed-loop convention of docs/conventions.md ("two branches, one weld").

- root link ``base`` (the world frame of the poses); every tree joint is ``continuous``: each joint of
  a motion-polynomial linkage makes exactly one full turn over the motion (docs/conventions.md), so no
  joint limit exists kinematically. The one exception: when the design is collision-free only over the
  task range (``collision["range"] == "task"``), the driving joint is ``revolute`` with the limits of
  that range (shifted by whole turns to hold 0, the first pose), so that simulators stay inside it;
- each pin of the physical design is a link ``pin_<joint>`` (frame at the pin's midpoint) fixed to its
  carrier link by the joint ``pin_<joint>_mount``, with visual and collision mesh ``meshes/pin_<joint>.stl``;
- link frames are translated copies of the world frame (see synth/frames.py), so a joint's origin is the
  difference of the child's and parent's frame origins with rpy "0 0 0", and its axis is the joint's
  world direction at the reference configuration;
- link ``tool`` hangs on ``linkage.tool_link`` by the fixed joint ``tool_mount``;
- each loop cut is a ``<gazebo><joint type="fixed">`` weld named ``loop_closure``, ``loop_closure_2``...;
- links with geometry get visual and collision meshes ``meshes/<link>.stl`` (or
  ``package://NAME/meshes/<link>.stl``) and an inertial from the mesh (aluminium by default); links
  without geometry get a tiny inertial (1e-6 kg, 1e-9 kg m^2);
- STL files are in millimetres (what slicers assume) and referenced with ``scale="0.001 0.001 0.001"``;
  a metre-unit STL of a 30 cm linkage would open in a slicer as a 0.3 mm part, and micrometre-sized
  features of small linkages would fall below mesh tools' vertex-merge tolerances.

All floats are written with ``repr`` (shortest round-trip form), so the file is exact to the last bit.
"""
from __future__ import annotations

import math
from pathlib import Path
import xml.etree.ElementTree as ET

import numpy as np

from synth.design.model import axis_point
from synth.frames import link_origins, rpy_from_matrix, tool_mount_origin
from synth.info import MultiLoop
from synth.io.names import MESH_UNIT_SCALE, PIN_PREFIX, mesh_filename, pin_link_name

_MESH_SCALE = f"{MESH_UNIT_SCALE!r} {MESH_UNIT_SCALE!r} {MESH_UNIT_SCALE!r}"

TINY_MASS = 1e-6
TINY_INERTIA = 1e-9
TOOL_LINK = "tool"
TOOL_JOINT = "tool_mount"
LIMIT_EFFORT = 1000.0  # N m: a bound for planners and simulators, not a property of the linkage
LIMIT_VELOCITY = 10.0  # rad/s

_COLORS = {"base": "0.35 0.35 0.38 1", "coupler": "0.95 0.55 0.1 1"}
_DEFAULT_COLOR = "0.45 0.6 0.8 1"
_PIN_COLOR = "0.75 0.75 0.78 1"


def _f(x) -> str:
    x = float(x)
    if not np.isfinite(x):
        raise ValueError(f"non-finite number {x} in URDF")
    return repr(x + 0.0)  # + 0.0 turns -0.0 into 0.0


def _vec(v) -> str:
    return " ".join(_f(x) for x in v)


def driver_limits(collision) -> tuple[str, float, float] | None:
    """(driver joint, lower, upper) radians for a task-range collision claim (a `CollisionReport` or its
    dict), shifted by whole turns so that 0 (the first pose) lies inside; None for a full-cycle claim."""
    if collision is None:
        return None
    c = collision if isinstance(collision, dict) else collision.to_dict()
    if c.get("range") != "task":
        return None
    lo, hi = (float(v) for v in c["driver_range"])
    k = math.floor((hi + 1e-9) / (2 * math.pi))  # lo - 2 pi k <= 0 <= hi - 2 pi k when the range visits 0 mod 2 pi
    return str(c["driver"]), lo - 2 * math.pi * k, hi - 2 * math.pi * k


def closure_names(n: int) -> list[str]:
    """Names of the loop-closure welds: loop_closure, loop_closure_2, ..."""
    return ["loop_closure"] + [f"loop_closure_{i}" for i in range(2, n + 1)]


def _inertial(parent, mass, com, inertia):
    el = ET.SubElement(parent, "inertial")
    ET.SubElement(el, "origin", xyz=_vec(com), rpy="0.0 0.0 0.0")
    ET.SubElement(el, "mass", value=_f(mass))
    I = np.asarray(inertia, float)
    ET.SubElement(el, "inertia", ixx=_f(I[0, 0]), ixy=_f(I[0, 1]), ixz=_f(I[0, 2]),
                  iyy=_f(I[1, 1]), iyz=_f(I[1, 2]), izz=_f(I[2, 2]))


def marker_frames(linkage, origins=None) -> dict:
    """The markers of a multi-loop linkage (``info.synthesis.markers``: {name: `synth.info.Marker`}) -- extra frames
    (e.g. the ``tracer`` of ``mpsynth curve``) fixed to a link, with world-parallel axes and their origin
    at the world ``position`` at the reference configuration. Returns {name: {"link", "xyz"}} with xyz
    in the link's frame; each becomes a link and a fixed joint ``<name>_mount``."""
    origins = link_origins(linkage) if origins is None else origins
    out = {}
    record = linkage.info.synthesis
    for name, spec in ((record.markers if isinstance(record, MultiLoop) else None) or {}).items():
        if name in origins or name == TOOL_LINK:
            raise ValueError(f"marker {name!r} clashes with a link name")
        if spec.link not in origins:
            raise ValueError(f"marker {name!r} hangs on unknown link {spec.link!r}")
        xyz = np.asarray(spec.position, float) - origins[spec.link]
        out[str(name)] = {"link": spec.link, "xyz": xyz}
    return out


def _share_welded_masses(linkage, masses, origins, geometric) -> dict:
    """Split the mass of each welded link with geometry equally with its geometry-less duplicate
    (e.g. coupler / coupler_k). The welded pair keeps the same total mass, centre of mass and
    inertia, but neither body is nearly massless: a 1e-6 kg body on a weld constraint makes physics
    engines (PyBullet) open the weld. Frames are translated copies of the world frame, so a point
    moves between the two link frames by the difference of their origins."""
    out = dict(masses)
    for a, b in linkage.closures:
        if a in geometric and b not in geometric and a in out:
            mass, com, inertia = out[a]
            com = np.asarray(com, float)
            out[a] = (mass / 2, com, np.asarray(inertia, float) / 2)
            out[b] = (mass / 2, com + np.asarray(origins[a]) - np.asarray(origins[b]), np.asarray(inertia, float) / 2)
    return out


def _mesh_geometry(link, n, fn, offset):
    for tag in ("visual", "collision"):
        el = ET.SubElement(link, tag)
        ET.SubElement(el, "origin", xyz=_vec(offset), rpy="0.0 0.0 0.0")
        geom = ET.SubElement(el, "geometry")
        ET.SubElement(geom, "mesh", filename=fn, scale=_MESH_SCALE)
        if tag == "visual":
            mat = ET.SubElement(el, "material", name=f"mpsynth_{n}")
            ET.SubElement(mat, "color", rgba=_COLORS.get(n, _PIN_COLOR if n.startswith(PIN_PREFIX) else _DEFAULT_COLOR))


def _pin_frames(linkage, design, origins) -> dict:
    """{pin link: (carrier link, (3,) origin of the pin frame in the carrier's frame)}."""
    out = {}
    sites = linkage.joint_sites() if design is not None and design.pins else None
    for p in design.pins if design is not None else ():
        if p.carrier not in origins:
            raise ValueError(f"pin {p.joint} is carried by unknown link {p.carrier!r}")
        mid = axis_point(linkage, p.joint, (p.start + p.end) / 2, sites)
        out[pin_link_name(p.joint)] = (p.carrier, mid - origins[p.carrier])
    return out


def urdf_text(linkage, robot_name: str, design, masses: dict, *, mesh_dir: str = "meshes", package: str | None = None,
              mesh_offsets: dict | None = None, collision=None) -> str:
    """The URDF document (str, with XML declaration) of ``linkage`` with its finished physical design.

    ``design``: the `PhysicalDesign` whose pins become links ``pin_<joint>``; ``masses``: {link: (mass kg,
    centre of mass (3,) in the link frame, 3x3 inertia about the centre of mass)} for the links with
    geometry and the pins, as returned by ``meshes.mesh_inertials``. Links with geometry are those with a
    non-empty joint list in ``linkage.links``. ``mesh_offsets``: {link: (3,) position (metres, link frame)
    of the STL file's origin}; the writer stores each STL about its own centre so that single-precision
    STL coordinates stay accurate far from the origin. ``collision``: the design's collision claim
    (`CollisionReport` or dict), for the driver's limits. ``design`` None: the kinematic URDF (no meshes,
    no pins, every link the tiny inertial; README "Batch and shell pipelines", ``--no-design``)."""
    origins = link_origins(linkage)
    geometric = [n for n in origins if linkage.links.get(n)] if design is not None else []
    pins = _pin_frames(linkage, design, origins)
    _check_names(linkage, origins, pins, geometric, masses)
    masses = _share_welded_masses(linkage, masses, origins, geometric)

    robot = ET.Element("robot", name=str(robot_name))
    robot.append(ET.Comment(
        " written by mpsynth: a closed-loop linkage cut into a tree (docs/conventions.md, 'two branches, one weld');"
        " the fixed joints in the gazebo elements weld the cut links back together "))
    for n in list(origins) + list(pins):
        link = ET.SubElement(robot, "link", name=n)
        if n in masses:
            _inertial(link, *masses[n])
        if n in geometric or n in pins:
            _mesh_geometry(link, n, mesh_filename(n, mesh_dir, package), (mesh_offsets or {}).get(n, np.zeros(3)))
        elif n not in masses:
            _inertial(link, TINY_MASS, np.zeros(3), np.eye(3) * TINY_INERTIA)
    tool = ET.SubElement(robot, "link", name=TOOL_LINK)
    _inertial(tool, TINY_MASS, np.zeros(3), np.eye(3) * TINY_INERTIA)
    _joints(robot, linkage, origins, pins, driver_limits(collision))
    ET.indent(robot, space="  ")
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def _check_names(linkage, origins, pins, geometric, masses) -> None:
    """ValueError for a reserved or clashing link name, a closure naming an unknown link, a missing mass."""
    if TOOL_LINK in origins:
        raise ValueError(f"link name {TOOL_LINK!r} is reserved for the tool frame")
    for a, b in linkage.closures:
        for link in (a, b):
            if link not in origins:
                raise ValueError(f"closure ({a}, {b}) names unknown link {link!r}")
    for n in pins:
        if n in origins or n == TOOL_LINK:
            raise ValueError(f"pin link {n!r} clashes with a link name")
    for n in geometric + list(pins):
        if n not in masses:
            raise ValueError(f"no mass properties for link {n!r}")


def _joints(robot, linkage, origins, pins, limits) -> None:
    """The URDF joints: the linkage's (``continuous``, the driver ``revolute`` within ``limits`` of a
    task-range claim), the pin and tool mounts, the markers' mounts and the loop-closure welds."""
    for j in linkage.joints:
        limited = limits is not None and limits[0] == j.name
        el = ET.SubElement(robot, "joint", name=j.name, type="revolute" if limited else "continuous")
        ET.SubElement(el, "parent", link=j.parent)
        ET.SubElement(el, "child", link=j.child)
        ET.SubElement(el, "origin", xyz=_vec(origins[j.child] - origins[j.parent]), rpy="0.0 0.0 0.0")
        ET.SubElement(el, "axis", xyz=_vec(j.direction))
        if limited:
            ET.SubElement(el, "limit", lower=_f(limits[1]), upper=_f(limits[2]), effort=_f(LIMIT_EFFORT),
                          velocity=_f(LIMIT_VELOCITY))

    for n, (carrier, xyz) in pins.items():
        el = ET.SubElement(robot, "joint", name=f"{n}_mount", type="fixed")
        ET.SubElement(el, "parent", link=carrier)
        ET.SubElement(el, "child", link=n)
        ET.SubElement(el, "origin", xyz=_vec(xyz), rpy="0.0 0.0 0.0")

    T = tool_mount_origin(linkage)
    el = ET.SubElement(robot, "joint", name=TOOL_JOINT, type="fixed")
    ET.SubElement(el, "parent", link=linkage.tool_link)
    ET.SubElement(el, "child", link=TOOL_LINK)
    ET.SubElement(el, "origin", xyz=_vec(T[:3, 3]), rpy=_vec(rpy_from_matrix(T[:3, :3])))

    for name, spec in marker_frames(linkage, origins).items():  # the markers: fixed point frames
        _inertial(ET.SubElement(robot, "link", name=name), TINY_MASS, np.zeros(3), np.eye(3) * TINY_INERTIA)
        el = ET.SubElement(robot, "joint", name=f"{name}_mount", type="fixed")
        ET.SubElement(el, "parent", link=spec["link"])
        ET.SubElement(el, "child", link=name)
        ET.SubElement(el, "origin", xyz=_vec(spec["xyz"]), rpy="0.0 0.0 0.0")

    for name, (a, b) in zip(closure_names(len(linkage.closures)), linkage.closures):
        gz = ET.SubElement(robot, "gazebo")
        el = ET.SubElement(gz, "joint", name=name, type="fixed")
        ET.SubElement(el, "parent").text = a
        ET.SubElement(el, "child").text = b


def write_urdf(job, directory: Path) -> list[Path]:
    """The ``urdf`` exporter (`synth.io.export`): ``linkage.urdf`` of ``job``'s linkage and design."""
    r = job.result
    if r is None:  # kinematic outputs only
        text = urdf_text(job.linkage, job.robot_name, None, {}, package=job.package)
    else:
        text = urdf_text(job.linkage, job.robot_name, r.design, job.masses, mesh_dir="meshes", package=job.package,
                         mesh_offsets=job.mesh_offsets, collision=r.collision)
    (directory / "linkage.urdf").write_text(text, encoding="utf-8")
    return [Path("linkage.urdf")]
