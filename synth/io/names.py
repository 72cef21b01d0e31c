"""The names and units of the files in an output directory (the pin links and mesh files, the STL unit),
and the validation of the names mpsynth writes into its output: the URDF robot name (``--name``) and
the ROS package of the mesh URIs (``--package``, ``package://PACKAGE/meshes/...``)."""
from __future__ import annotations

import re
import unicodedata

from synth.errors import InputError

PACKAGE_RE = re.compile(r"[a-z][a-z0-9_]*\Z")  # ROS REP 144 package name
MAX_NAME = 200
MESH_UNIT_SCALE = 0.001  # metres per STL unit (STL files are written in millimetres)
PIN_PREFIX = "pin_"


def pin_link_name(joint: str) -> str:
    """The URDF link of the pin of ``joint``."""
    return f"{PIN_PREFIX}{joint}"


def mesh_filename(link: str, mesh_dir: str = "meshes", package: str | None = None) -> str:
    """The mesh file of ``link`` as the URDF names it: ``meshes/<link>.stl`` or ``package://PACKAGE/...``."""
    rel = f"{mesh_dir.strip('/')}/{link}.stl" if mesh_dir else f"{link}.stl"
    return f"package://{package}/{rel}" if package else rel


def _bad_char(text: str) -> str | None:
    for ch in text:
        cat = unicodedata.category(ch)
        if cat in ("Cc", "Cs", "Co", "Cn") or ch in "\ufffe\uffff":
            return ch
    return None


def check_robot_name(name, option: str = "--name") -> str:
    """``name`` when it can be the URDF robot name: non-empty, at most MAX_NAME characters, valid
    text (no control characters, no undecodable bytes, no leading/trailing blanks); else InputError."""
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"{option}: the robot name must not be empty")
    bad = _bad_char(name)
    if bad is not None:
        what = "undecodable (non-UTF-8) bytes" if unicodedata.category(bad) == "Cs" else \
            f"the control character U+{ord(bad):04X}"
        raise InputError(f"{option} {ascii(name)[:80]}: the robot name contains {what}")
    if name != name.strip():
        raise InputError(f"{option} {ascii(name)[:80]}: the robot name has leading or trailing blanks")
    if len(name) > MAX_NAME:
        raise InputError(f"{option}: the robot name is {len(name)} characters long, at most {MAX_NAME} allowed")
    return name


def safe_robot_name(text, default: str = "linkage") -> str:
    """A valid robot name made from ``text`` (e.g. a file's stem): bad characters become '_'."""
    if not isinstance(text, str):
        return default
    cleaned = "".join("_" if _bad_char(ch) is not None else ch for ch in text).strip()[:MAX_NAME].strip()
    return cleaned or default


def check_package(package, option: str = "--package") -> str | None:
    """``package`` when it is a ROS package name (a lowercase letter, then lowercase letters, digits
    and underscores) or None; else InputError."""
    if package is None:
        return None
    if not isinstance(package, str) or not PACKAGE_RE.match(package):
        raise InputError(f"{option} {ascii(package)[:80]}: not a ROS package name (a lowercase letter, "
                         "then lowercase letters, digits and underscores, e.g. my_linkage)")
    return package
