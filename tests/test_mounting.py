"""The ground link's mounting plate (issue 33, synth/design/mounting.py): a flat face parallel to both base
axes (or a flange on a base hub) with screw holes through it along its normal, clear of the bores, the
outermost face of the base part, clear of the moving links; in the STL (one closed body), the STEP, the
print report (face down), linkage.json and the judge's checks."""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO, assert_verified, run  # noqa: E402

import synth  # noqa: E402
from synth.design.choose import design_for  # noqa: E402
from synth.design.model import Mounting, PhysicalDesign, plate_capsules  # noqa: E402
from synth.design.model import DesignResult  # noqa: E402
from synth.design.mounting import SCREWS, candidates, place_mounting, plate_gap, screw_for  # noqa: E402
from synth.task import Box  # noqa: E402
from synth.io.meshes import design_solids  # noqa: E402
from synth.io.poses import load_poses  # noqa: E402
from synth.io.solid import box, signed_volume, surface_defect  # noqa: E402
from synth.frames import link_origins  # noqa: E402


@pytest.fixture(scope="module")
def bennett():
    """The shipped Bennett (mm task) with its default design: (linkage, DesignResult, base Solid in world)."""
    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    result = design_for(lk)
    solid = design_solids(lk, result.design)["base"]
    return lk, result, solid.translated(link_origins(lk)["base"])


def test_box_is_a_closed_solid_of_its_volume():
    b = box([1.0, 2.0, 3.0], [1.0, 2.0, 3.5], [[2.0, 0, 0], [0, 0.5, 0]])  # 4 x 1 x 0.5
    assert surface_defect(b.faces) is None
    assert signed_volume(b.triangles) == pytest.approx(2.0, rel=1e-12)
    flipped = box([1.0, 2.0, 3.5], [1.0, 2.0, 3.0], [[2.0, 0, 0], [0, 0.5, 0]])  # extruded the other way
    assert signed_volume(flipped.triangles) == pytest.approx(2.0, rel=1e-12)


def test_screw_by_the_pin():
    d = PhysicalDesign(pin_radius=3e-3, bar_radius=5e-3, hub_radius=6e-3, hub_length=1e-2, hole_clearance=2e-4,
                       clearance=1e-3, mounts=[], bars=[], pins=[])
    assert screw_for(d).name == "M4"  # hole 4.5 mm <= pin diameter 6 mm
    d.pin_radius = 2e-3
    assert screw_for(d).name == "M3"  # 3.4 <= 4 < 4.5
    d.pin_radius = 1.5e-3
    assert screw_for(d) is None  # 3 mm pins: not even an M3 hole
    assert [s.hole for s in SCREWS] == [4.5e-3, 3.4e-3]  # ISO 273 medium series


def test_plate_capsules_hold_the_plate():
    m = Mounting("base", "h1", "parallel", np.array([0.0, 0.0, -0.02]), np.array([0.0, 0.0, -1.0]),
                 np.array([[1.0, 0, 0], [0, -1.0, 0]]), np.array([0.011, 0.03]), 0.0075, np.zeros((0, 3)), 4.5e-3, "M4")
    caps = plate_capsules(m)
    rng = np.random.default_rng(1)
    # points of the box (face at z = -0.02, normal -z: the plate from z = -0.0125 to -0.02)
    pts = np.column_stack([rng.uniform(-0.011, 0.011, 2000), rng.uniform(-0.03, 0.03, 2000),
                           rng.uniform(-0.02, -0.0125, 2000)])
    inside = np.zeros(len(pts), bool)
    for c in caps:
        d = c.p1 - c.p0
        s = np.clip((pts - c.p0) @ d / (d @ d), 0, 1)
        inside |= np.linalg.norm(pts - (c.p0 + s[:, None] * d), axis=1) <= c.radius + 1e-12
    assert inside.all()
    assert max(c.radius for c in caps) <= m.thickness / np.sqrt(2) + 1e-12  # strips no wider than thick


def test_the_bennett_base_has_a_plate_with_holes_through_it(bennett):
    lk, result, base = bennett
    m = result.design.mounting
    assert m is not None and m.link == "base" and m.screw == "M4" and len(m.holes) >= 2
    n, axes = m.normal, m.axes
    assert np.linalg.norm(n) == pytest.approx(1) and np.allclose(axes @ axes.T, np.eye(2)) and np.allclose(axes @ n, 0)
    if m.kind == "parallel":  # the face parallel to both base axes
        for j in lk.links["base"]:
            assert abs(np.dot(lk.joint(j).direction, n)) < 1e-9
    # the face is the base part's outermost face along its normal: it sits flat on a table
    assert (base.vertices @ n).max() == pytest.approx(np.dot(m.origin, n), abs=1e-9)
    tm = base.to_trimesh()
    assert tm.is_watertight and tm.is_volume and len(tm.split(only_watertight=False)) == 1
    r = m.hole_diameter / 2
    for h in m.holes:
        assert abs(np.dot(h - m.origin, n)) < 1e-12  # on the face
        assert np.all(np.abs((h - m.origin) @ axes.T) <= m.half - r)  # inside it
        depth = np.linspace(0.05, 0.95, 7)[:, None] * m.thickness
        on_axis = h - depth * n  # through the plate along the normal: no material on the hole's axis
        assert not tm.contains(on_axis).any()
        side = axes[0] if abs(np.dot(h - m.origin, axes[0])) < 1e-9 else axes[1]
        assert tm.contains(on_axis + 1.6 * r * np.sign(np.dot(m.origin - h, side) or 1.0) * side).all()  # a plate around
        for j in lk.links["base"]:  # clear of the bores: the hole's axis keeps off the joint's axis
            u, p = lk.joint(j).direction, lk.joint(j).point
            w = np.cross(u, n)
            gap = abs(np.dot(h - p, w)) / np.linalg.norm(w) if np.linalg.norm(w) > 1e-9 else np.linalg.norm(
                np.cross(h - p, u))
            assert gap >= result.design.pin_radius + result.design.hole_clearance + r


def test_the_base_prints_on_its_mounting_face_where_it_fits(bennett):
    from synth.io.printreport import print_part

    _, result, base = bennett
    n = result.design.mounting.normal
    height = float(np.ptp(base.vertices @ n)) * 1000  # mm
    big = print_part("base", base, bed=(2000.0, 2000.0, 2000.0), down=n)
    assert big.fits_bed and big.extents[2] == pytest.approx(height, rel=1e-9)  # the face down
    lowest = print_part("base", base, bed=(2000.0, 2000.0, 2000.0))
    small = print_part("base", base, bed=(lowest.extents[0] + 1, lowest.extents[1] + 1, height - 1), down=n)
    assert small.fits_bed and small.extents[2] == pytest.approx(lowest.extents[2])  # too tall so: the lowest way


def test_the_plate_keeps_clear_of_the_moving_links(bennett):
    lk, result, _ = bennett
    m, report = result.design.mounting, result.collision
    cert = plate_gap(lk, result.design, m, report.range, report.clearance)
    assert cert["certified"] and cert["lower"] >= report.clearance
    assert report.min_distance <= cert["lower"] + 1e-15  # the claim covers the plate


def test_mounting_round_trips_through_json(bennett):
    _, result, _ = bennett
    d = json.loads(json.dumps(result.design.to_dict()))
    back = PhysicalDesign.from_dict(d).mounting
    m = result.design.mounting
    assert back.kind == m.kind and back.screw == m.screw
    for a in ("origin", "normal", "axes", "half", "holes"):
        assert np.allclose(getattr(back, a), getattr(m, a), rtol=0, atol=1e-15)


def test_a_base_box_picks_the_plate_nearest_it(bennett):
    lk, result, _ = bennett
    design = result.design
    first = design.mounting
    kept = []
    for m in candidates(lk, design, screw_for(design)):  # the candidates that pass every check
        if m.kind != first.kind or m.joint != first.joint or not np.allclose(m.normal, first.normal):
            r = place_mounting(lk, DesignResult(design, replace(result.collision)),
                               base=Box(m.origin - 1e-4, m.origin + 1e-4))
            if r.design.mounting is not None and np.allclose(r.design.mounting.origin, m.origin):
                kept.append(m)
    design.mounting = first
    assert kept  # another plate than the default one is chosen when a base box holds its face


def _box_distance(p, lo, hi):
    return float(np.linalg.norm(np.maximum(np.asarray(lo) - p, 0) + np.maximum(p - np.asarray(hi), 0)))


def test_written_output_has_the_plate_everywhere_and_the_judge_passes(tmp_path):
    out = tmp_path / "mount"
    r = run("bennett", REPO / "fixtures/bennett_mount.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "linkage.json").read_text())
    m = doc["design"]["mounting"]
    assert set(m) >= {"origin", "normal", "holes", "hole_diameter", "screw", "size", "thickness", "kind"}
    # the task's base box is [[-50, -50, -100], [200, 200, 250]] mm and holds both base hubs' sites, but every
    # plate nearer it is refused (4 are not the base's outermost face, one comes within the clearance of the
    # coupler over the full cycle, one leaves no room for two screw heads): the plate parallel to k1's hub,
    # 7.6 mm outside it (measured; the flange on h1's hub 24 mm above it before issue 33's stacks for links
    # that share a joint), with the reasons recorded and printed
    far = _box_distance(np.array(m["origin"]) * 1000, [-50, -50, -100], [200, 200, 250])
    assert 0 < far < 30 and m["base_box"]["distance"] * 1000 == pytest.approx(far)
    assert any("coupler" in why for why in m["base_box"]["nearer_refused"])
    assert f"mounting: the mounting face is {far:.3g} mm outside the base box" in r.output
    import trimesh

    assert (out / "linkage.urdf").read_text().count("meshes/base.stl") == 2  # visual and collision
    if (out / "linkage.step").exists():  # the cad extra: the STEP's base holds the plate (volumes within 3 %)
        from synth.io.step import load_kernel

        gmsh = load_kernel()
        gmsh.initialize(readConfigFiles=False, interruptible=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.open(str(out / "linkage.step"))
            vols = {gmsh.model.getEntityName(3, t).rsplit("/", 1)[-1]: gmsh.model.occ.getMass(3, t)
                    for _, t in gmsh.model.getEntities(3)}
        finally:
            gmsh.finalize()
        stl = {f.stem: trimesh.load(f).volume for f in (out / "meshes").glob("*.stl")}
        assert set(vols) == set(stl) and all(vols[n] == pytest.approx(stl[n], rel=0.03) for n in stl)
    assert_verified(REPO / "fixtures/bennett_mount.yaml", out, "--collisions", doc["collision"]["clearance"],
                    "--collision-range", doc["collision"]["range"])


def test_a_foot_reaches_a_base_box_beyond_the_face(bennett):
    lk, result, _ = bennett
    design = result.design
    first = design.mounting
    n, o = first.normal, first.origin
    target = o + 0.005 * n  # a box 5 mm beyond the face, along its normal
    box = Box(target - 0.002, target + 0.002)
    try:
        place_mounting(lk, DesignResult(design, replace(result.collision)), base=box)
        m = design.mounting
        assert m is not None and _box_distance(m.origin, box.lo, box.hi) < 1e-12
        extra = m.counterbore[1]
        assert m.thickness == pytest.approx(first.thickness + extra) and 0.001 < extra <= 0.005
        assert m.counterbore[0] == pytest.approx(next(s.head for s in SCREWS if s.name == m.screw) + 1e-3)
        solid = design_solids(lk, design)["base"].translated(link_origins(lk)["base"]).to_trimesh()
        assert solid.is_watertight and len(solid.split(only_watertight=False)) == 1
        seat = first.thickness - 0.0005  # the plate's former thickness above the face holds the head
        r_head = 0.5 * m.counterbore[0]
        for h in m.holes:
            side = m.axes[0] if abs(np.dot(h - m.origin, m.axes[1])) > 1e-9 else m.axes[1]
            assert not solid.contains([h - 0.5 * first.thickness * n]).any()  # the hole
            assert solid.contains([h - 0.5 * first.thickness * n + 0.8 * r_head * side]).any()  # plate beside it
            assert not solid.contains([h - (seat + 0.5 * extra) * n + 0.8 * r_head * side]).any()  # counterbore
    finally:
        design.mounting = first
