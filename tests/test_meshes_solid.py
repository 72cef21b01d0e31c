"""The trimesh-free mesh path (synth/io/solid.py, meshes.design_solids / stl_file) against trimesh:
the same cylinders, the same union, the same mass properties, STL files trimesh reads as the same
closed solids; the closed-surface check; and writing an output without importing trimesh."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO, random_poses  # noqa: E402
from linkage_fixtures import bennett_linkage  # noqa: E402

import synth  # noqa: E402
from synth.io import meshes as meshes_mod  # noqa: E402
from synth.io.writer import write_output  # noqa: E402
from synth.design.choose import design_for  # noqa: E402
from synth.frames import link_origins  # noqa: E402
from synth.io.solid import (Solid, axis_rotation, boolean, capsule, concatenate, cylinder, mass_properties,  # noqa: E402
                                read_stl_triangles, revolution, signed_volume, stl_bytes, surface_defect, union,
                                weld)
from synth.io.names import MESH_UNIT_SCALE  # noqa: E402
from synth.io.solid import READER_GRID  # noqa: E402
from synth.io.poses import load_poses  # noqa: E402

trimesh = pytest.importorskip("trimesh")


def linkages():
    """The hand-checked Bennett, the CLI fixtures' Bennett and 6R, and random Bennetts of several sizes,
    one far from the origin."""
    out = {"bennett_fixture": bennett_linkage()}
    out["bennett_mm_deg"] = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    out["sixbar"] = synth.sixbar(load_poses(str(REPO / "fixtures/sixbar_example.yaml")).matrices)
    rng = np.random.default_rng(11)
    for scale, offset in ((1e-3, 0.0), (1.0, 0.0), (30.0, 0.0), (1.0, 50.0)):
        out[f"random_{scale:g}m_at_{offset:g}"] = synth.bennett(random_poses(rng, 3, scale=scale,
                                                                              offset=(offset, -offset, offset)))
    return out


LINKAGES = linkages()


def trimesh_cylinder(a, b, radius, sections):
    """The way link parts were built with trimesh before: a revolved profile aligned with align_vectors."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    T = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], (b - a) / np.linalg.norm(b - a))
    T[:3, 3] = (a + b) / 2
    return trimesh.creation.cylinder(radius=radius, height=float(np.linalg.norm(b - a)), sections=sections,
                                     transform=T)


def trimesh_union(parts):
    """trimesh's manifold union of the parts at unit size (the previous exporter)."""
    lo = np.min([p.vertices.min(axis=0) for p in parts], axis=0)
    hi = np.max([p.vertices.max(axis=0) for p in parts], axis=0)
    centre, size = (lo + hi) / 2, float(np.max(hi - lo))
    unit = [trimesh.Trimesh((p.vertices - centre) / size, p.faces) for p in parts]
    mesh = trimesh.boolean.union(unit, engine="manifold")
    return Solid(np.asarray(mesh.vertices) * size + centre, np.asarray(mesh.faces, np.int64))


def trimesh_mass(triangles, density=meshes_mod.DENSITY):
    """trimesh's mass properties. Its sums run about the origin, so they are computed here about the
    bounding-box centre: a base link far from the world origin would otherwise lose digits to
    cancellation in trimesh (ours run about the mean corner)."""
    from trimesh.triangles import mass_properties as tm_mass

    triangles = np.asarray(triangles, float)
    flat = triangles.reshape(-1, 3)
    centre = (flat.min(axis=0) + flat.max(axis=0)) / 2
    mp = tm_mass(triangles=triangles - centre, density=density, skip_inertia=False)
    return float(mp["mass"]), np.asarray(mp["center_mass"]) + centre, np.asarray(mp["inertia"])


def assert_same_mass(ours, theirs, rtol, length):
    """Mass and inertia relative to their size, centre of mass relative to the body's ``length``."""
    (m1, c1, I1), (m2, c2, I2) = ours, theirs
    assert abs(m1 - m2) <= rtol * m2
    assert np.max(np.abs(c1 - c2)) <= rtol * length
    assert np.max(np.abs(I1 - I2)) <= rtol * np.max(np.abs(I2))


unit_vectors = st.tuples(*[st.floats(-1, 1)] * 3).map(np.array).filter(lambda v: np.linalg.norm(v) > 1e-3)
points = st.tuples(*[st.floats(-10, 10)] * 3).map(np.array)


# ------------------------------------------------------------------ primitives
@settings(max_examples=60, deadline=None)
@given(a=points, d=unit_vectors, length=st.floats(1e-3, 10), radius=st.floats(1e-3, 1),
       sections=st.sampled_from([3, 7, 32, 48]))
def test_cylinder_is_trimeshs_cylinder(a, d, length, radius, sections):
    b = a + length * d / np.linalg.norm(d)
    ours, theirs = cylinder(a, b, radius, sections), trimesh_cylinder(a, b, radius, sections)
    assert len(ours.vertices) == len(theirs.vertices) and len(ours.faces) == len(theirs.faces)
    gap = np.abs(ours.vertices[:, None] - theirs.vertices[None]).max(axis=2).min(axis=1)
    assert gap.max() <= 1e-14 * (1 + np.abs(a).max() + length)  # the same corners
    assert surface_defect(ours.faces) is None
    prism = sections / 2 * radius ** 2 * math.sin(2 * math.pi / sections) * length
    assert signed_volume(ours.triangles) == pytest.approx(prism, rel=1e-12)  # outward winding
    assert trimesh.Trimesh(ours.vertices, ours.faces).is_volume


@settings(max_examples=100, deadline=None)
@given(w=unit_vectors)
def test_axis_rotation_is_a_rotation_onto_the_line(w):
    w = w / np.linalg.norm(w)
    R = axis_rotation(w)
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-14) and np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
    assert np.linalg.norm(np.cross(R[:, 2], w)) < 1e-14


# ------------------------------------------------------------------ mass properties
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), far=st.sampled_from([0.0, 1.0, 100.0]))
def test_mass_properties_equal_trimeshs(seed, far):
    """On unions of random cylinders within 1e-9; moved far away, ours keep the inertia about the centre
    of mass to 1e-9."""
    rng = np.random.default_rng(seed)
    parts = [cylinder(a, a + rng.normal(size=3), rng.uniform(0.05, 0.3), int(rng.integers(8, 40)))
             for a in rng.normal(size=(int(rng.integers(1, 4)), 3)) * 0.3]
    solid = union(parts) if len(parts) > 1 else parts[0]
    assert surface_defect(solid.faces) is None
    length = float(np.max(np.ptp(solid.vertices, axis=0)))
    ours = mass_properties(solid.triangles, 1234.5)
    assert_same_mass(ours, trimesh_mass(solid.triangles, 1234.5), 1e-9, length)
    shift = far * np.array([1000.0, -700.0, 300.0])
    m, c, I = mass_properties(solid.translated(shift).triangles, 1234.5)
    assert_same_mass((m, c - shift, I), ours, 1e-9, length)


def _segment_distance(points, p0, p1):
    """Distance of each point (n, 3) from the segment p0-p1."""
    d = p1 - p0
    L2 = float(d @ d)
    s = np.clip((points - p0) @ d / L2, 0.0, 1.0) if L2 > 0 else np.zeros(len(points))
    return np.linalg.norm(points - (p0 + s[:, None] * d), axis=1)


@pytest.mark.parametrize("name", list(LINKAGES))
def test_design_solids_lie_inside_their_capsules(name):
    """Every vertex of a link's mesh lies within its capsules (bars, hubs) and every vertex of a pin's
    mesh within the pin's capsule or a hub's on its joint (the head): the collision search's capsules
    bound the written solids from outside. Each mesh is one closed solid whose mass properties agree with trimesh's."""
    from synth.design.model import capsules
    from synth.io.names import pin_link_name

    lk = LINKAGES[name]
    result = design_for(lk)
    solids = meshes_mod.design_solids(lk, result.design)
    origins = link_origins(lk)
    assert set(solids) == ({n for n in lk.link_names if lk.links.get(n)}
                           | {pin_link_name(p.joint) for p in result.design.pins})
    caps = capsules(lk, result.design)
    ours = meshes_mod.mesh_inertials(solids)
    for link, solid in solids.items():
        length = float(np.max(np.ptp(solid.vertices, axis=0)))
        assert_same_mass(ours[link], trimesh_mass(solid.triangles), 1e-9, length)
        if link in origins:
            world = solid.vertices + origins[link]
            mine = [c for c in caps if c.link == link and c.part != "pin"]
        else:
            joint = link[len("pin_"):]
            world = solid.vertices + meshes_mod.pin_origin(lk, result.design, joint)
            # the shaft in the pin's capsule; its head (and a clip's groove) sunk into a hub on its joint
            mine = [c for c in caps if c.part in ("pin", "hub") and c.joint == joint]
        excess = np.min([_segment_distance(world, c.p0, c.p1) - c.radius for c in mine], axis=0)
        assert excess.max() <= 1e-6 * length, (link, excess.max())


@pytest.mark.parametrize("name", ["bennett_fixture", "sixbar"])
def test_bores_run_through_the_hubs(name):
    """A point on a joint's axis inside a hub is outside the link's solid (the bore), a point in the hub's
    wall (between bore and hub radius) is inside; the bore of the link that turns on the pin is wider
    than the pin by the hole clearance, the carrier's bore fits it."""
    lk = LINKAGES[name]
    design = design_for(lk).design
    solids = meshes_mod.design_solids(lk, design)
    origins = link_origins(lk)
    carriers = {p.joint: p.carrier for p in design.pins}
    for m in design.mounts:
        mesh = solids[m.link].to_trimesh()
        j = lk.joint(m.joint)
        centre = lk.joint_sites()[m.joint] + m.offset * j.direction - origins[m.link]
        side = np.cross(j.direction, [1.0, 0, 0] if abs(j.direction[0]) < 0.9 else [0, 1.0, 0])
        side /= np.linalg.norm(side)
        wall = design.pin_radius + design.hole_clearance + 0.5 * (design.hub_radius - design.pin_radius
                                                                    - design.hole_clearance)
        assert not mesh.contains([centre, centre + 0.3 * design.hub_length * j.direction]).any(), m
        assert mesh.contains([centre + wall * side]).all(), m
        gap = design.pin_radius + 0.5 * design.hole_clearance
        assert mesh.contains([centre + gap * side]).all() == (carriers[m.joint] == m.link), m


# ------------------------------------------------------------------ closed-surface check
def test_surface_defects_are_found():
    c = cylinder([0, 0, 0], [0, 0, 1], 0.5, 12)
    assert surface_defect(c.faces) is None
    assert "hole" in surface_defect(c.faces[1:])
    flipped = c.faces.copy()
    flipped[3] = flipped[3, ::-1]
    assert surface_defect(flipped) is not None
    assert surface_defect(np.concatenate([c.faces, c.faces[:1]])) is not None  # an edge used thrice
    two = concatenate([c, c.translated([0, 0, 1])])
    assert surface_defect(two.faces) is None  # two closed shells
    welded = weld(two.triangles)  # ... which touch along a whole cap: no longer a 2-manifold
    assert surface_defect(welded.faces) is not None
    degenerate = c.faces.copy()
    degenerate[0, 1] = degenerate[0, 0]
    assert "repeated" in surface_defect(degenerate)
    assert surface_defect(np.zeros((0, 3), int)) == "no triangles"
    inside_out = Solid(c.vertices, c.faces[:, ::-1].copy())
    assert surface_defect(inside_out.faces) is None and signed_volume(inside_out.triangles) < 0
    with pytest.raises(RuntimeError, match="not a closed solid"):
        meshes_mod.check_closed(inside_out, "x")
    with pytest.raises(RuntimeError, match="not a closed solid"):
        meshes_mod.stl_file(Solid(c.vertices, c.faces[1:]), "x")


def test_weld_merges_bit_equal_corners_and_signed_zeros():
    tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]], [[-0.0, 0, 0], [0, 1, 0], [1, 0, 0]]], np.float32)
    w = weld(tri)
    assert len(w.vertices) == 3 and sorted(w.faces[0]) == sorted(w.faces[1])


# ------------------------------------------------------------------ STL
@pytest.mark.parametrize("name", ["bennett_fixture", "random_0.001m_at_0", "random_1m_at_50"])
def test_stl_file_is_trimeshs_stl_of_the_centred_mm_mesh(name):
    """Byte layout as trimesh's exporter writes it (corners and count bit-equal, normals to float32
    rounding); trimesh reads each file as a watertight volume of the same size; the offset is the
    bounding-box centre."""
    for link, solid in meshes_mod.design_solids(LINKAGES[name], design_for(LINKAGES[name]).design).items():
        data, offset = meshes_mod.stl_file(solid)
        assert np.array_equal(offset, solid.bounds.mean(axis=0))
        mm = trimesh.Trimesh((solid.vertices - offset) * (1.0 / MESH_UNIT_SCALE), solid.faces, process=False)
        theirs = mm.export(file_type="stl")
        assert len(data) == len(theirs) and data[:84] == theirs[:84]
        ours_rec = np.frombuffer(data, dtype=np.uint8, offset=84).reshape(-1, 50)
        theirs_rec = np.frombuffer(theirs, dtype=np.uint8, offset=84).reshape(-1, 50)
        assert np.array_equal(ours_rec[:, 12:], theirs_rec[:, 12:])  # corners and attribute
        n1 = ours_rec[:, :12].copy().view("<f4")
        n2 = theirs_rec[:, :12].copy().view("<f4")
        assert np.max(np.abs(n1 - n2)) < 1e-6
        loaded = trimesh.load(trimesh.util.wrap_as_stream(data), file_type="stl", force="mesh")
        assert loaded.is_watertight and loaded.is_volume and loaded.body_count == 1, link
        volume = signed_volume(solid.triangles) / MESH_UNIT_SCALE ** 3
        assert loaded.volume == pytest.approx(volume, rel=1e-5)  # float32 corners
        assert np.array_equal(read_stl_triangles(data), np.asarray(loaded.triangles, np.float32))


def test_hubs_as_wide_as_their_bars_write_closed_stls():
    """A hub cylinder as wide as its bar (a sturdy bar reaches the hub's radius) is tangent to the bar's
    round end and crosses the bar at equal radii: the single-precision boolean wrote zero-area triangles
    there (2 of these 40 links were not closed STLs); the double-precision one must give closed ones of
    the same volume to the facets' accuracy."""
    rng = np.random.default_rng(0)
    R, bore = 0.0295, 0.0148
    for _ in range(40):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        v = np.cross(u, rng.normal(size=3))
        v /= np.linalg.norm(v)
        a = rng.normal(size=3) * 0.3
        b = a + rng.uniform(0.2, 0.7) * v
        h = rng.uniform(0.01, 0.05)
        parts = [capsule(a, b, R, meshes_mod.BAR_SECTIONS), capsule(b, b + 0.3 * u, R, meshes_mod.BAR_SECTIONS)]
        parts += [cylinder(c - h * u, c + h * u, R, meshes_mod.PIN_SECTIONS, phase=0.5) for c in (a, b)]
        half = 1.01 * max(h, R) + 0.01 * R
        bores = [cylinder(c - half * u, c + half * u, bore, meshes_mod.PIN_SECTIONS) for c in (a, b)]
        link = boolean(parts, bores)
        data, _ = meshes_mod.stl_file(link)  # raises unless the file is a closed solid
        stored = weld(read_stl_triangles(data))
        assert surface_defect(stored.faces) is None
        hull = signed_volume(concatenate(parts[:1]).triangles)  # the first bar alone: a lower bound
        assert signed_volume(link.triangles) > hull - 2 * np.pi * bore ** 2 * half


def test_stl_round_trip_and_truncation():
    c = cylinder([1, 2, 3], [2, 2, 3], 0.25, 16)
    data = stl_bytes(c.triangles)
    assert len(data) == 84 + 50 * len(c.faces)
    assert np.array_equal(read_stl_triangles(data), c.triangles.astype(np.float32))
    with pytest.raises(ValueError):
        read_stl_triangles(data[:-1])
    with pytest.raises(ValueError):
        read_stl_triangles(data[:50])


def test_written_output_matches_its_stl_files(tmp_path):
    """URDF inertials of a written output are the mass properties of the meshes in its STL files as
    trimesh loads them (float32 millimetre corners about the visual origin) to float32 rounding."""
    import xml.etree.ElementTree as ET

    lk = LINKAGES["bennett_mm_deg"]
    out = tmp_path / "OUT"
    result = design_for(lk)
    write_output(lk, out, robot_name="t", result=result)
    robot = ET.parse(out / "linkage.urdf").getroot()
    masses = meshes_mod.mesh_inertials(meshes_mod.design_solids(lk, result.design))
    seen = 0
    for link in robot.findall("link"):
        vis = link.find("visual")
        if vis is None:
            continue
        seen += 1
        offset = np.array([float(x) for x in vis.find("origin").get("xyz").split()])
        mesh = trimesh.load(str(out / vis.find("geometry/mesh").get("filename")), force="mesh")
        assert mesh.is_watertight and mesh.is_volume
        mass, com, inertia = trimesh_mass(mesh.triangles * MESH_UNIT_SCALE + offset)
        el = link.find("inertial")
        urdf_mass = float(el.find("mass").get("value"))
        urdf_com = np.array([float(x) for x in el.find("origin").get("xyz").split()])
        name = link.get("name")
        if name in masses:  # a welded pair (coupler / coupler_k) shares the mass; see urdf.py
            assert urdf_mass == pytest.approx(masses[name][0] / (2 if name in dict(lk.closures) else 1))
        assert mass == pytest.approx(masses[name][0], rel=1e-5)
        assert np.max(np.abs(com - urdf_com)) < 1e-5 * np.ptp(mesh.vertices).max() * MESH_UNIT_SCALE
    assert seen == 8  # 4 links and 4 pins


# ------------------------------------------------------------------ no trimesh on the write path
def test_writing_an_output_does_not_import_trimesh(tmp_path):
    code = ("import sys\n"
            "from cli.main import main\n"
            f"sys.argv = ['mpsynth', 'bennett', {str(REPO / 'fixtures/bennett_mm_deg.yaml')!r}, '-o', "
            f"{str(tmp_path / 'OUT')!r}, '-q']\n"
            "try:\n    main()\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
            "heavy = sorted({m.split('.')[0] for m in sys.modules} & {'trimesh', 'scipy', 'networkx', 'yourdfpy'})\n"
            "print(','.join(heavy))\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ""
    assert (tmp_path / "OUT" / "meshes" / "base.stl").is_file()


# ------------------------------------------------------------------ signals during import manifold3d
@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_signal_during_manifold3d_import_arrives_after_it(tmp_path, sig):
    """A signal that lands while manifold3d initialises is delivered when the import is done (inside
    nanobind's module init a KeyboardInterrupt aborts the process). A stand-in manifold3d signals
    itself halfway through its import."""
    (tmp_path / "manifold3d.py").write_text(
        "import os, signal\n"
        f"os.kill(os.getpid(), signal.{sig})\n"
        "total = sum(range(100000))  # bytecode during which a Python handler would run\n"
        "finished = True\n")
    code = ("import signal, sys\n"
            "import cli.signals; cli.signals.install()  # the CLI's policy: signals wait during the import\n"
            "from synth.io.solid import import_manifold3d\n"
            "def term(signum, frame):\n    raise SystemExit(143)\n"
            "signal.signal(signal.SIGTERM, term)\n"
            "try:\n    import_manifold3d()\n"
            "except (KeyboardInterrupt, SystemExit) as e:\n"
            "    print(type(e).__name__, sys.modules['manifold3d'].finished)\n"
            "    print(signal.getsignal(signal.SIGINT) is signal.default_int_handler, signal.getsignal(signal.SIGTERM) is term)\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(REPO)]))
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == [{"SIGINT": "KeyboardInterrupt", "SIGTERM": "SystemExit"}[sig], "True", "True", "True"]


@pytest.mark.parametrize("name", ["bennett_fixture", "sixbar"])
def test_cranked_bars_and_shifted_mounts(name):
    """A design as the search makes them: mounts moved along the axes and bars cranked through via points.
    Every part stays one closed solid inside its capsules, and the written STL reads back closed."""
    from synth.design.model import axis_point, capsules, pins_for

    lk = LINKAGES[name]
    design = design_for(lk).design
    e = lk.extent()
    rng = np.random.default_rng(3)
    for m in design.mounts:
        m.offset += float(rng.uniform(-0.1, 0.1)) * e
    design.pins = pins_for(lk, design)
    for b in design.bars:
        p0 = axis_point(lk, b.joints[0], design.mount(b.link, b.joints[0]).offset)
        p1 = axis_point(lk, b.joints[1], design.mount(b.link, b.joints[1]).offset)
        b.via = [p0 + (p1 - p0) / 3 + rng.normal(size=3) * 0.1 * e, p0 + 2 * (p1 - p0) / 3]
    solids = meshes_mod.design_solids(lk, design)
    caps = capsules(lk, design)
    origins = link_origins(lk)
    for link, solid in solids.items():
        length = float(np.max(np.ptp(solid.vertices, axis=0)))
        if link in origins:
            world = solid.vertices + origins[link]
            mine = [c for c in caps if c.link == link and c.part != "pin"]
        else:
            joint = link[len("pin_"):]
            world = solid.vertices + meshes_mod.pin_origin(lk, design, joint)
            # the shaft in the pin's capsule; its head (and a clip's groove) sunk into a hub on its joint
            mine = [c for c in caps if c.part in ("pin", "hub") and c.joint == joint]
        excess = np.min([_segment_distance(world, c.p0, c.p1) - c.radius for c in mine], axis=0)
        assert excess.max() <= 1e-6 * length, (link, excess.max())
        meshes_mod.stl_file(solid, link)  # raises unless the STL reads back as a closed solid


@settings(max_examples=40, deadline=None)
@given(st.floats(-9.5, 3), st.floats(0, 7), st.integers(3, 40), st.integers(0, 2 ** 31))
def test_either_readers_merge_of_an_stl_file_is_the_mesh_checked(log_size, log_far, sections, seed):
    """`stl_file` checks one mesh (the stored corners and faces): a reader's bit-equal merge of the file and
    its 8-decimal merge (`solid.READER_GRID`) give that mesh, but for the numbering of its vertices, also
    for parts nanometres small (where the merge collapses edges) or kilometres away."""
    rng = np.random.default_rng(seed)
    size, far = 10.0 ** log_size, 10.0 ** log_far * rng.normal(size=3)
    a = far + size * rng.normal(size=3)
    try:
        data, _ = meshes_mod.stl_file(capsule(a, a + size * rng.normal(size=3), size * 0.3, sections))
    except RuntimeError:  # a part the float32 file cannot hold (collapsed to nothing): nothing written
        return
    read = read_stl_triangles(data)
    bit, merged = weld(read), weld(read, READER_GRID)
    assert len(bit.vertices) == len(merged.vertices) == len(np.unique(read.reshape(-1, 3), axis=0))
    assert np.array_equal(bit.triangles, merged.triangles)  # (the same corners: no two cells share one)
    assert surface_defect(bit.faces) is None and signed_volume(bit.triangles) > 0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0.01, 3), st.floats(0.05, 2)), min_size=1, max_size=5), st.integers(3, 64),
       st.floats(0, 1), st.integers(0, 2 ** 31))
def test_a_revolved_stepped_profile_is_closed_with_the_faceted_volume(steps, sections, phase, seed):
    """`solid.revolution` of a stepped profile (lengths, radii): a closed solid whose volume is the sum of its
    n-gon prisms, (n / 2) sin(2 pi / n) r^2 h each, every ring corner at its radius from the axis."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    o = rng.normal(size=3) * 10
    s = np.concatenate([[0.0], np.cumsum([h for h, _ in steps])])
    profile = [(0.0, 0.0)] + [(x, r) for (a, b), (_, r) in zip(zip(s, s[1:]), steps) for x in (a, b)] + [(s[-1], 0.0)]
    mesh = revolution(o, u, profile, sections, phase)
    assert surface_defect(mesh.faces) is None
    prism = sections / 2 * np.sin(2 * np.pi / sections)
    assert math.isclose(signed_volume(mesh.triangles), prism * sum(r * r * h for h, r in steps), rel_tol=1e-9)
    d = mesh.vertices - o
    radial = np.linalg.norm(d - np.outer(d @ u, u), axis=1)
    assert np.allclose(np.sort(np.unique(np.round(radial, 9))), np.unique(np.round([0.0] + [r for _, r in steps], 9)),
                       atol=1e-9)
