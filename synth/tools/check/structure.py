"""Check 1 of `mpsynth check` (`synth.tools.check.verify`): the structure of an output directory (the URDF
against linkage.json: closures, joints, branches, the tool link, the joint axes), and the readers of
linkage.json's values the checks share."""
from __future__ import annotations

import numpy as np

from synth.frames import TWO_PI
from synth.io.urdf import driver_limits


class StructureChecks:
    """Check 1, mixed into the checker (`synth.tools.check.verify`): uses its ``u`` (the URDF model),
    ``doc`` (linkage.json), ``fail``, ``L`` and ``tol_ang``; sets ``closures``."""

    # -------------------------------------------------------------- 1. structure
    def structure(self):
        """Check 1 (the module docstring of `synth.tools.check.verify`): format, closures, joints,
        branches, the tool link and the axes."""
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
        jj = self._json_joints()
        self._joints(jj)
        self._branches()
        self._tool_link()
        self._axes(jj)

    def _joints(self, jj):
        """linkage.json's joints against the URDF's: kind, limits, parent and child, none missing."""
        u, doc = self.u, self.doc
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
                claim = task_limits(doc)  # a task-range collision claim limits its driver to that range
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

    def _branches(self):
        """linkage.json's branches: chains of URDF joints from base."""
        u = self.u
        br = self.doc.get("branches")
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

    def _tool_link(self):
        """Link ``tool`` on the tool link by a fixed joint, when the output has poses."""
        u = self.u
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

    def _axes(self, jj):
        """The URDF's world axes at all-zero angles against linkage.json's Plücker lines."""
        u = self.u
        F0 = u.fk({})
        worst = 0.0
        for j in jj:
            uj = u.joints.get(j["name"])
            line = j.get("line") if isinstance(j.get("line"), dict) else {}
            d, m = vector_or_none(line.get("direction")), vector_or_none(line.get("moment"))
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


def matrix_or_none(v):
    """A finite 4x4 matrix from a JSON value, or None."""
    try:
        M = np.array(v, float)
    except (TypeError, ValueError):
        return None
    return M if M.shape == (4, 4) and np.all(np.isfinite(M)) else None


def vector_or_none(v):
    """A finite 3-vector from a JSON value, or None."""
    try:
        x = np.array(v, float)
    except (TypeError, ValueError):
        return None
    return x if x.shape == (3,) and np.all(np.isfinite(x)) else None


def task_limits(doc: dict):
    """(driver, lower, upper) that a task-range collision claim in linkage.json puts on its driver
    (`synth.io.urdf.driver_limits`), or None."""
    c = doc.get("collision")
    try:
        return driver_limits(c) if isinstance(c, dict) else None
    except (KeyError, TypeError, ValueError):
        return None
