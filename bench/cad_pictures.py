"""The README's pictures of issue 33 (docs/cad_step.png, docs/cad_plate.png, docs/cad_assembly.png):

    .venv/bin/python bench/cad_pictures.py STEP_OUT PLATE_OUT

STEP_OUT: an output with linkage.step (the cad extra); its STEP is read back with gmsh's OpenCASCADE,
tessellated and drawn one colour per solid with the solid's name from the file (what a CAD program's
tree shows). PLATE_OUT: an output after `mpsynth parts`: its first plate, and the exploded view of
STEP_OUT's assembly sheet.
"""
from __future__ import annotations

import base64
import re
import sys
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from synth.io.solid import read_stl_triangles
from synth.tools.render import PALETTE

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _draw(groups, title, path, elev=30, azim=-60, labels=True, bed=None):
    fig = Figure(figsize=(7, 5), dpi=80, facecolor="white")
    FigureCanvasAgg(fig)
    ax = fig.add_axes([0, 0, 1, 0.93], projection="3d")
    light = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    polys, cols, pts = [], [], []
    for k, (name, tri) in enumerate(groups.items()):
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        rgb = np.array(PALETTE[k % len(PALETTE)])
        cols.append(np.clip(rgb * (0.45 + 0.55 * np.abs(n @ light))[:, None], 0, 1))
        polys.append(tri)
        pts.append(tri.reshape(-1, 3))
        if labels:
            ax.text(*tri.reshape(-1, 3).mean(0), name, fontsize=8, zorder=10)
    ax.add_collection3d(Poly3DCollection(np.concatenate(polys), facecolors=np.concatenate(cols), linewidths=0))
    if bed is not None:  # the bed's outline
        x, y = bed
        ax.plot([0, x, x, 0, 0], [0, 0, y, y, 0], [0, 0, 0, 0, 0], color="0.3", lw=1)
        pts.append(np.array([[0, 0, 0], [x, y, 0]]))
    allp = np.concatenate(pts)
    lo, hi = allp.min(0), allp.max(0)
    half = float(np.max(hi - lo)) / 2
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), (lo + hi) / 2):
        set_lim(c - half, c + half)
    ax.view_init(elev=elev, azim=azim)
    ax.set_proj_type("ortho")
    ax.set_axis_off()
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, format="png")


def step_solids(path: Path) -> dict:
    """{solid name: (m, 3, 3) triangles mm} of a STEP file tessellated by gmsh."""
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(str(path))
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 16)
    gmsh.model.mesh.generate(2)
    out = {}
    for _, v in gmsh.model.getEntities(3):
        name = gmsh.model.getEntityName(3, v).rsplit("/", 1)[-1]
        tris = []
        for _, s in gmsh.model.getBoundary([(3, v)], oriented=False):
            _, tags, nodes = gmsh.model.mesh.getElements(2, abs(s))
            if not len(tags):
                continue
            ntags, coords, _ = gmsh.model.mesh.getNodes(2, abs(s), includeBoundary=True)
            where = {t: i for i, t in enumerate(ntags)}
            xyz = coords.reshape(-1, 3)
            tris.append(xyz[[where[t] for t in nodes[0]]].reshape(-1, 3, 3))
        out[name] = np.concatenate(tris)
    gmsh.finalize()
    return out


def main(step_out: str, plate_out: str) -> None:
    step_out, plate_out = Path(step_out), Path(plate_out)
    _draw(step_solids(step_out / "linkage.step"), "linkage.step read back: one named B-rep solid per part",
          DOCS / "cad_step.png")
    plate = read_stl_triangles((plate_out / "plates" / "plate_1.stl").read_bytes()).astype(float)
    _draw({"plate 1": plate}, f"{plate_out.name}: plates/plate_1.stl (220 x 220 mm bed)", DOCS / "cad_plate.png",
          elev=65, azim=-90, labels=False, bed=(220.0, 220.0))
    page = (step_out / "plates" / "assembly.html").read_text()
    (DOCS / "cad_assembly.png").write_bytes(base64.b64decode(re.search(r"base64,([^\"]+)\"", page).group(1)))


if __name__ == "__main__":
    main(*sys.argv[1:3])
