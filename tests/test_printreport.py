"""The ``print`` section (issue 33): parts in their print orientation, fit on the bed, volume and mass."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from synth.algebra.geometry import rotation_about_axis
from synth.io.printreport import fit_scale, print_part, print_section, too_large
from synth.io.solid import cylinder, read_stl_triangles, signed_volume

from conftest import REPO, run


def rod(R=np.eye(3), length=0.3, radius=0.01):
    """A 300 mm rod of 10 mm radius (metres), turned by R about the origin."""
    s = cylinder(np.zeros(3), np.array([length, 0.0, 0.0]), radius, 48)
    return type(s)(s.vertices @ R.T, s.faces)


def test_a_rod_lies_flat_along_x():
    p = print_part("base", rod())
    x, y, z = p.extents
    assert x == pytest.approx(300.0)
    assert 19.9 < y < 20.0 + 1e-9 and 19.9 < z < 20.0 + 1e-9  # a 48-gon in a 20 mm circle
    assert p.volume == pytest.approx(math.pi * 10 ** 2 * 300, rel=3e-3)
    assert p.mass == pytest.approx(p.volume * 1.24e-3)
    assert not p.fits_bed and p.scale == pytest.approx(220 / 300)
    assert p.mesh == "meshes/base.stl"


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) > 0.1),
       st.floats(0, 2 * math.pi))
def test_orientation_does_not_depend_on_how_the_part_is_turned(axis, angle):
    R = rotation_about_axis(np.asarray(axis) / np.linalg.norm(axis), angle)
    a, b = print_part("x", rod()), print_part("x", rod(R))
    assert np.allclose(a.extents, b.extents, atol=1e-6 * 300)


def test_fit_scale_turns_the_part_and_takes_the_tightest_axis():
    assert fit_scale((200, 100, 10), (100, 220, 250)) == 1.0  # turned 90 degrees it fits
    assert fit_scale((440, 20, 20)) == pytest.approx(0.5)
    assert fit_scale((100, 100, 500)) == pytest.approx(0.5)


def test_section_names_what_does_not_fit():
    sec = print_section({"base": rod(), "pin_h1": rod(length=0.02, radius=0.004)}, bed=(220, 220, 250))
    assert sec["bed"] == [220.0, 220.0, 250.0] and sec["material"] == {"name": "PLA", "density": 1.24}
    base, pin = sec["parts"]
    assert not base["fits_bed"] and pin["fits_bed"] and "scale" not in pin
    (line,) = too_large(sec)
    assert line.startswith("meshes/base.stl does not fit the 220 x 220 x 250 mm bed") and "0.733" in line


def test_cli_output_reports_every_mesh_and_its_volume(tmp_path):
    out = tmp_path / "o"
    r = run("bennett", REPO / "fixtures" / "bennett_mm_deg.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    doc = json.loads((out / "linkage.json").read_text())
    parts = doc["print"]["parts"]
    assert sorted(p["mesh"] for p in parts) == sorted(f"meshes/{f.name}" for f in (out / "meshes").iterdir())
    for p in parts:
        tri = read_stl_triangles((out / p["mesh"]).read_bytes())  # mm
        assert p["volume"] == pytest.approx(signed_volume(tri), rel=1e-4)
        ext = np.ptp(tri.reshape(-1, 3), axis=0)
        assert max(p["extents"]) <= np.linalg.norm(ext) + 1e-6  # never longer than the box's diagonal
        assert p["fits_bed"] == (fit_scale(p["extents"]) == 1.0)
    assert sum("does not fit" in line for line in r.output.splitlines()) == sum(not p["fits_bed"] for p in parts)


@pytest.mark.parametrize("offset", [0.0, 2e9])
def test_hull_vertices_hold_every_extreme_of_the_points(offset):
    """`solid.hull_vertices` (what `print_orientation` projects): fewer points with the same maximum and
    minimum in every direction, to the bit, also 2e9 from the origin (a far linkage's mesh in mm)."""
    from synth.io.solid import hull_vertices

    rng = np.random.default_rng(5)
    pts = np.concatenate([rng.normal(size=(300, 3)), rng.uniform(-0.5, 0.5, size=(300, 3))]) + offset
    idx = hull_vertices(pts)
    assert 4 <= len(idx) < 300 and np.all(np.diff(idx) > 0)
    d = rng.normal(size=(3, 500))
    np.testing.assert_array_equal((pts[idx] @ d).max(axis=0), (pts @ d).max(axis=0))
    np.testing.assert_array_equal((pts[idx] @ d).min(axis=0), (pts @ d).min(axis=0))
