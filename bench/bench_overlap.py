"""Volume overlap of the written solids at the home configuration (issue 33, "links that share a joint
overlap").

    python bench/bench_overlap.py OUT [OUT ...]

For every output directory: every part of the URDF that has a mesh (links and pins, each in its own
URDF frame at all joint angles zero, i.e. the reference configuration), placed in the world, and the
volume (mm^3) of the boolean intersection of every pair whose bounding boxes meet (manifold3d, double
precision). Pairs are classed

- ``joint``: two links that share a joint (not tested by the design search nor by the judge);
- ``press``: a pin with the carrier it is pressed into (a press fit overlaps by design: about
  2 pi r L x 0.05 mm for pin radius r and hub length L; a plain or clip pin should not);
- ``bore``: a pin with the link that turns on it (the bore clears it: should be 0);
- ``other``: every other pair (the search keeps these a clearance apart).

Prints one line per pair above 1e-3 mm^3 and one summary line per output (the largest overlap of each
class). Exit 1 when a ``joint``, ``bore`` or ``other`` pair overlaps by more than ``--tol`` mm^3.
"""
from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

from synth.io import solid
from synth.io.readback import mesh_file_problem, mesh_path, read_files, resolve_output


def placed_parts(out) -> tuple[dict, dict, dict]:
    """({part: (vertices (n, 3) in mm, faces (m, 3))}, {pin part: (carrier, other link)},
    {frozenset(link pair): joint}) of the output ``out`` at the reference configuration."""
    root = resolve_output(out)
    files = read_files(root)
    model = files.urdf
    frames = model.fk({})
    parts = {}
    for m in model.meshes:
        if m.tag != "visual" or not m.filename:
            continue
        problem, mesh = mesh_file_problem(mesh_path(m.filename, root))
        if problem:
            raise SystemExit(f"{root}: {m.filename}: {problem}")
        S = np.eye(4)
        S[:3, :3] = np.diag(m.scale)
        mesh.apply_transform(frames[m.link] @ m.origin @ S)
        v, f = np.asarray(mesh.vertices) * 1000.0, np.asarray(mesh.faces)
        if m.link in parts:
            pv, pf = parts[m.link]
            v, f = np.vstack([pv, v]), np.vstack([pf, f + len(pv)])
        parts[m.link] = (v, f)
    revolute = {n: (j.parent, j.child) for n, j in model.joints.items() if j.kind != "fixed"}
    duplicate = {child: parent for _, parent, child in model.closures}
    shared = {}
    for n, (a, b) in revolute.items():
        a, b = duplicate.get(a, a), duplicate.get(b, b)
        shared[frozenset((a, b))] = n
    pins = {}
    for n, j in model.joints.items():
        if j.kind == "fixed" and j.child.startswith("pin_"):
            joint = j.child[len("pin_"):]
            if joint in revolute:
                a, b = (duplicate.get(x, x) for x in revolute[joint])
                carrier = duplicate.get(j.parent, j.parent)
                pins[j.child] = (carrier, b if carrier == a else a)
    return parts, pins, shared


def intersection_volume(p, q) -> float:
    """Volume of the intersection of two closed meshes (vertices, faces), in their units cubed
    (`synth.io.solid.intersection_volume`)."""
    return solid.intersection_volume(solid.Solid(*p), solid.Solid(*q))


def overlaps(out) -> list[tuple[str, str, str, float]]:
    """[(class, part a, part b, volume mm^3)] of every pair of parts of ``out`` whose boxes meet."""
    parts, pins, shared = placed_parts(out)
    boxes = {n: (v.min(axis=0), v.max(axis=0)) for n, (v, _) in parts.items()}
    rows = []
    for a, b in itertools.combinations(sorted(parts), 2):
        if np.any(boxes[a][1] < boxes[b][0]) or np.any(boxes[b][1] < boxes[a][0]):
            continue
        pin, link = (a, b) if a in pins else (b, a)
        if pin in pins and link in pins[pin]:
            kind = "press" if link == pins[pin][0] else "bore"
        elif frozenset((a, b)) in shared:
            kind = "joint"
        else:
            kind = "other"
        rows.append((kind, a, b, intersection_volume(parts[a], parts[b])))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outs", nargs="+")
    ap.add_argument("--tol", type=float, default=1e-3, help="mm^3 allowed for joint/other pairs")
    args = ap.parse_args(argv)
    bad = 0
    for out in [o for o in args.outs if Path(o).is_dir()]:
        rows = overlaps(out)
        worst = {"joint": 0.0, "bore": 0.0, "other": 0.0, "press": 0.0}
        for kind, a, b, vol in rows:
            worst[kind] = max(worst[kind], vol)
            if vol > 1e-3:
                print(f"  {Path(out).name}: {kind:6s} {a} x {b}: {vol:,.1f} mm^3")
        flag = max(worst["joint"], worst["bore"], worst["other"]) > args.tol
        bad += flag
        print(f"{Path(out).name}: " + "  ".join(f"{k} {v:,.1f}" for k, v in worst.items())
              + f" mm^3{'  OVERLAP' if flag else ''}", flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
