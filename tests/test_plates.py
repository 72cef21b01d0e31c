"""`mpsynth parts OUT` (synth/tools/plates.py): shelf packing, parts in print orientation on plates of the
bed, plates as closed shells of the written parts, the assembly sheet."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO  # noqa: E402

import synth  # noqa: E402
from cli.main import mpsynth  # noqa: E402
from synth.design.choose import design_for  # noqa: E402
from synth.io.poses import load_poses  # noqa: E402
from synth.io.solid import cylinder, read_stl_triangles, signed_volume, surface_defect, weld  # noqa: E402
from synth.io.writer import write_output  # noqa: E402
from synth.tools.plates import lay_out, shelf_pack  # noqa: E402


def test_shelf_pack_worked_example():
    feet = {"a": (100.0, 50.0), "b": (100.0, 40.0), "c": (100.0, 30.0), "d": (200.0, 150.0)}
    got = {n: (k, x, y) for n, k, x, y in shelf_pack(feet, bed=(220.0, 220.0, 100.0), gap=5.0)}
    # deepest first: d fills the first shelf (5..205 x 5..155); a does not fit x beside it (210 + 100 + 5 >
    # 220): a new shelf at y = 160 (160 + 50 + 5 <= 220), b beside a at x = 110; c fits neither x beside b
    # (215) nor a third shelf (215 + 30 + 5 > 220): the next plate
    assert got["d"] == (0, 5.0, 5.0)
    assert got["a"] == (0, 5.0, 160.0)
    assert got["b"] == (0, 110.0, 160.0)
    assert got["c"] == (1, 5.0, 5.0)


def test_parts_lie_flat_apart_and_on_the_bed():
    rng = np.random.default_rng(3)
    parts = {}
    for k in range(12):
        a = rng.normal(size=3) * 20
        b = a + rng.normal(size=3) * 30
        parts[f"p{k}"] = cylinder(a, b, rng.uniform(2, 8), 24).triangles
    parts["huge"] = cylinder([0, 0, 0], [400.0, 0, 0], 5.0, 24).triangles
    bed = (150.0, 120.0, 100.0)
    layout = lay_out(parts, bed=bed)
    assert set(layout.too_large) == {"huge"} and layout.too_large["huge"] == pytest.approx(140 / 400, rel=1e-3)
    boxes = {}
    for p in layout.placements:
        o = layout.oriented[p.name].reshape(-1, 3)
        assert o.min(axis=0)[2] == pytest.approx(0.0, abs=1e-9)
        ext = np.ptp(o, axis=0)
        assert ext[2] <= ext[1] + 1e-6 or ext[2] <= ext[0] + 1e-6  # lying down, not standing on a cap
        x0, y0 = p.offset
        assert x0 >= 5 - 1e-9 and y0 >= 5 - 1e-9 and x0 + ext[0] <= bed[0] - 5 + 1e-6 and y0 + ext[1] <= bed[1] - 5 + 1e-6
        boxes.setdefault(p.plate, []).append((x0, y0, x0 + ext[0], y0 + ext[1]))
    for rects in boxes.values():
        for i, r in enumerate(rects):
            for s in rects[i + 1:]:
                assert r[2] <= s[0] or s[2] <= r[0] or r[3] <= s[1] or s[3] <= r[1]  # footprints apart
    assert layout.plates == 1 + max(p.plate for p in layout.placements)


def test_parts_command_writes_plates_of_the_parts_and_the_sheet(tmp_path):
    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    out = tmp_path / "b"
    write_output(lk, out, robot_name="b", result=design_for(lk, pin_length=0.01))
    r = CliRunner().invoke(mpsynth, ["parts", str(out), "--bed", "500", "500", "300", "--json"])
    assert r.exit_code == 0, r.output
    plates = sorted((out / "plates").glob("plate_*.stl"))
    assert plates
    parts = {f.stem: read_stl_triangles(f.read_bytes()) for f in (out / "meshes").glob("*.stl")}
    total = 0.0
    for f in plates:
        tri = read_stl_triangles(f.read_bytes())
        assert surface_defect(weld(tri).faces) is None  # closed shells, side by side
        assert tri[..., 2].min() == pytest.approx(0.0, abs=1e-3)
        total += signed_volume(tri.astype(float))
    assert total == pytest.approx(sum(signed_volume(t.astype(float)) for t in parts.values()), rel=1e-4)
    page = (out / "plates" / "assembly.html").read_text()
    for p in ("pin_h1", "pin_h2", "pin_k1", "pin_k2", "link_h1", "coupler"):
        assert p in page
    assert "data:image/png;base64," in page
    bad = CliRunner().invoke(mpsynth, ["parts", str(tmp_path / "nothing")])
    assert bad.exit_code == 2


def test_3mf_plates_hold_the_parts_named_and_placed(tmp_path):
    import io

    import trimesh

    from synth.tools.plates import write_parts

    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    out = tmp_path / "b"
    write_output(lk, out, robot_name="b", result=design_for(lk, pin_length=0.01))
    r = CliRunner().invoke(mpsynth, ["parts", str(out), "--bed", "500", "500", "300", "--format", "3mf", "--json"])
    assert r.exit_code == 0, r.output
    plates = sorted((out / "plates").glob("plate_*.3mf"))
    assert plates and not list((out / "plates").glob("plate_*.stl"))
    layout, _ = write_parts(out, (500.0, 500.0, 300.0), "3mf")
    assert plates[0].read_bytes() == (out / "plates" / "plate_1.3mf").read_bytes()  # same parts, same bytes
    seen = {}
    for k, f in enumerate(plates):
        scene = trimesh.load(io.BytesIO(f.read_bytes()), file_type="3mf")  # an independent reader
        for node in scene.graph.nodes_geometry:
            T, geom = scene.graph[node]
            mesh = scene.geometry[geom].copy()
            mesh.apply_transform(T)
            seen[geom] = (k, mesh)
    placed = {p.name: p for p in layout.placements}
    assert set(seen) == set(placed)  # every part once, named as its link
    for name, (k, mesh) in seen.items():
        p = placed[name]
        assert k == p.plate and mesh.is_watertight and mesh.volume > 0
        lo, hi = mesh.bounds
        assert np.allclose(lo, [p.offset[0], p.offset[1], 0.0], atol=1e-3)  # placed on the plate, on the bed
        assert np.allclose(hi - lo, p.extents, atol=1e-3)
        stl = read_stl_triangles((out / "meshes" / f"{name}.stl").read_bytes()).astype(float)
        assert mesh.volume == pytest.approx(signed_volume(stl), rel=1e-4)
    bad = CliRunner().invoke(mpsynth, ["parts", str(out), "--format", "obj"])
    assert bad.exit_code == 2
