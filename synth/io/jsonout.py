"""linkage.json: the machine-readable description of a `Linkage` (schema in docs/conventions.md).

Beyond the contract's required keys we add (the contract allows new keys): ``poses[].t`` (the motion
parameter of the pose, null for t = infinity), ``poses[].kind = "point"`` and ``poses[].position`` for the points
of a point task (docs/points.md), ``joints[].parent/child/angle_law`` (theta(t) =
rate * 2 atan2(b, t - a); ``rate`` written only when it is not 1; ``fourbar``: a planar four-bar's loop law of
the crank's angle, docs/fourbar.md), ``links`` (link -> joints it carries), ``tool_link``, ``tool_ref`` and ``info``
(the linkage's kind-specific extras: `synth.info.LinkageInfo.to_dict`), ``design`` (the physical design: `PhysicalDesign.to_dict`, with
every pin's length and mesh file: the bill of materials) and ``collision`` (what the design achieves:
`CollisionReport.to_dict`) and ``stl`` (the STL files' unit, millimetres, with the URDF mesh scale 0.001,
and the density behind the URDF's inertias) and ``print`` (each part in its print orientation on the bed,
its volume and mass: `synth.io.printreport`). Lengths in metres, angles in radians. Only plain JSON types are written;
non-finite numbers become null.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from synth.drive import drive_report
from synth.io.meshes import DENSITY
from synth.io.names import MESH_UNIT_SCALE, mesh_filename, pin_link_name
from synth.io.printreport import print_section

FORMAT = "mpsynth.linkage/1"


def plain(obj, where: str = "document"):
    """``obj`` with numpy arrays and scalars and tuples turned into plain JSON
    types; non-finite floats become None. Raises TypeError naming the place of anything else."""
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist(), where)
    if isinstance(obj, dict):
        return {str(k): plain(v, f"{where}.{k}") for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    raise TypeError(f"{where}: {type(obj).__name__} is not JSON-serializable")


def design_section(design) -> dict:
    """The ``design`` section: `PhysicalDesign.to_dict` plus each pin's ``link`` and ``mesh`` file."""
    d = design.to_dict()
    for p in d["pins"]:
        p["link"] = pin_link_name(p["joint"])
        p["mesh"] = mesh_filename(p["link"])
    return d


def stl_section() -> dict:
    """The ``stl`` section: the STL files' length unit and URDF scale, and the density the URDF's masses
    and inertias assume (uniform solid parts)."""
    return {"length_unit": "mm", "urdf_scale": MESH_UNIT_SCALE, "density": DENSITY, "density_unit": "kg/m^3",
            "material": "aluminium", "masses": "URDF <inertial>: kg, kg m^2, solid parts of this density"}


def linkage_document(linkage, design=None, collision=None, drive=None, slenderness=None) -> dict:
    """The linkage.json document (a dict of plain JSON types); ``design`` (`PhysicalDesign`),
    ``collision`` (`CollisionReport`) and ``drive`` (`synth.drive.DriveReport`) add their sections when
    given; ``slenderness`` (`synth.design.sturdy.Slenderness`, the bars as written) the design's
    ``slenderness``."""
    doc = {
        "format": FORMAT,
        "kind": linkage.kind,
        "units": {"length": "m", "angle": "rad"},
        "poses": [
            {"name": p.name, "matrix": np.asarray(p.matrix, float), "t": p.t,
             "joint_angles": {k: float(v) for k, v in p.joint_angles.items()},
             **({"kind": "point", "position": np.asarray(p.matrix, float)[:3, 3]} if p.kind == "point" else {}),
             **_fit_fields(p)}
            for p in linkage.poses
        ],
        "joints": [
            {"name": j.name,
             "line": {"direction": np.asarray(j.direction, float), "moment": np.asarray(j.moment, float)},
             "parent": j.parent, "child": j.child,
             "angle_law": {"a": float(j.a), "b": float(j.b), **({"rate": int(j.rate)} if j.rate != 1 else {}),
                           **({"fourbar": j.law.to_dict()} if j.law is not None else {})}}
            for j in linkage.joints
        ],
        "branches": [list(b) for b in linkage.branches],
        "closures": [list(c) for c in linkage.closures],
        "motion_polynomial": None if linkage.motion is None else np.asarray(linkage.motion, float),
        "checks": dict(linkage.checks),
        "links": {k: list(v) for k, v in linkage.links.items()},
        "tool_link": linkage.tool_link,
        "tool_ref": np.asarray(linkage.tool_ref, float),
        "info": linkage.info.to_dict(),  # (`synth.info.LinkageInfo`)
    }
    if linkage.info.fit is not None:  # a task's result (docs/fit.md): said at the top too
        doc["within_tolerance"] = bool(linkage.info.fit.within_tolerance)
    doc["stl"] = stl_section()
    if design is not None:
        doc["design"] = design_section(design)
        if slenderness is not None:
            doc["design"]["slenderness"] = slenderness.to_dict()
    if collision is not None:
        doc["collision"] = collision if isinstance(collision, dict) else collision.to_dict()
    if drive is not None:
        doc["drive"] = drive if isinstance(drive, dict) else drive.to_dict()
    return plain(doc)


def _fit_fields(p) -> dict:
    """A fitted pose's ``error`` and ``tolerance`` (metres, radians; null = unconstrained) or ``exact``."""
    out = {}
    if p.error is not None:
        out["error"] = {"position": float(p.error[0]), "angle": float(p.error[1])}
    if p.exact:
        out["exact"] = True
    elif p.tolerance is not None:
        out["tolerance"] = {k: (float(v) if np.isfinite(v) else None) for k, v in zip(("position", "angle"), p.tolerance)}
    return out


def _dumps(obj, indent: int = 0) -> str:
    """Indented JSON where lists of scalars (vectors, matrix rows) stay on one line."""
    pad, inner = "  " * indent, "  " * (indent + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{inner}{json.dumps(str(k))}: {_dumps(v, indent + 1)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(obj, list):
        if all(not isinstance(v, (dict, list)) for v in obj):
            return "[" + ", ".join(json.dumps(v, allow_nan=False) for v in obj) + "]"
        if all(isinstance(v, list) and all(not isinstance(w, (dict, list)) for w in v) for v in obj):
            rows = [inner + _dumps(v) for v in obj]  # a matrix: one row per line
        else:
            rows = [inner + _dumps(v, indent + 1) for v in obj]
        return "[\n" + ",\n".join(rows) + "\n" + pad + "]"
    return json.dumps(obj, allow_nan=False)


def write_json(doc: dict, path) -> Path:
    """Write ``doc`` (plain JSON types) to ``path`` with a trailing newline; returns the path."""
    path = Path(path)
    text = _dumps(plain(doc)) + "\n"
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    return path


def write_linkage_json(job, directory: Path) -> list[Path]:
    """The ``json`` exporter (`synth.io.export`): ``linkage.json`` of ``job``'s linkage and design."""
    r = job.result
    drive = r.drive if r is not None and r.drive is not None else drive_report(job.linkage)
    doc = linkage_document(job.linkage, r.design if r else None, r.collision if r else None, drive,
                           r.slenderness if r else None)
    if r is not None:
        m = r.design.mounting  # the base printed on its mounting face
        down = {m.link: m.normal} if m is not None else None
        doc["print"] = print_section(job.solids, down=down)  # issue 33: each part on the bed (synth.io.printreport)
        doc["step"] = job.step is not None  # linkage.step written with this output (synth.io.step.built_step)
    write_json(doc, directory / "linkage.json")
    return [Path("linkage.json")]
