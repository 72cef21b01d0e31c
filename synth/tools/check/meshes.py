"""Check 2 of `mpsynth check` (`synth.tools.check.verify`): every referenced mesh file is a watertight
binary STL of a plausible size, one body (a part in pieces cannot be printed or assembled as one)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from synth.io.readback import mesh_file_problem, mesh_path
from synth.io.solid import shell_count


class MeshChecks:
    """Check 2, mixed into the checker (`synth.tools.check.verify`): uses its ``u``, ``o``, ``doc``, ``L``
    and ``fail``."""

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
            p = mesh_path(fn, self.o.path)
            if p is None:
                self.fail(f"{where}: not a path relative to the URDF")
                continue
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
        problem, mesh = mesh_file_problem(path)
        if problem:
            return problem
        if not mesh.is_watertight:
            return "is not watertight"
        vol = float(mesh.volume) * float(np.prod(scale))
        if not (vol > 0 and mesh.is_winding_consistent):
            return f"is not a solid of positive volume (volume {vol:.3g} m^3)"
        pieces = shell_count(mesh.faces)
        if pieces != 1:
            return f"is {pieces} separate bodies, not one part"
        size = float(np.linalg.norm(mesh.extents * np.abs(scale)))
        if size > 100 * spread or size < 1e-4 * spread:
            return f"is {size:.3g} m across for a linkage {spread:.3g} m across (wrong unit or scale?)"
        return ""
