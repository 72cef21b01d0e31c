"""The linkage.json document read back (docs/conventions.md): its joints' angle laws and rates, and the
`synth.linkage.Linkage` it describes (`linkage_from_document`), each value checked (InputError naming
the place). The file itself is read by `synth.io.readback.read_document`."""
from __future__ import annotations

import math

import numpy as np

from synth.algebra.fourbar_loop import FourBarLaw
from synth.errors import InputError
from synth.info import LinkageInfo
from synth.linkage import Joint, Linkage, PoseRecord
from synth.task import default_name


def is_number(v) -> bool:
    """A finite JSON number (not a boolean, not a string)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


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


def _loop_law(law: dict, where: str) -> FourBarLaw | None:
    """The planar four-bar loop law of an ``angle_law`` entry (its ``fourbar`` key, docs/fourbar.md), or None."""
    if "fourbar" not in law:
        return None
    try:
        return FourBarLaw.from_dict(law["fourbar"])
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"{where}: bad four-bar loop law ({e})") from None


def loop_laws(doc: dict) -> dict[str, FourBarLaw]:
    """joint -> its planar four-bar loop law (``joints[].angle_law.fourbar``) for the joints of a linkage.json
    document that have a well-formed one (nothing is judged here)."""
    out = {}
    for name, law in _law_entries(doc):
        try:
            fb = _loop_law(law, name)
        except InputError:
            continue
        if fb is not None:
            out[name] = fb
    return out


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
            joints.append(Joint(str(jd["name"]), str(jd["parent"]), str(jd["child"]), u, m, a, b, rate,
                                _loop_law(law, f"{where}: joint {jd['name']}")))
        poses = []
        for i, pd in enumerate(doc.get("poses", [])):
            t = pd.get("t", None)
            poses.append(PoseRecord(str(pd.get("name", default_name(i))), _arr(pd["matrix"], (4, 4), f"{where}: pose {i}"),
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
                     info=LinkageInfo.from_dict(doc.get("info", {}) or {}))
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
