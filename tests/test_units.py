"""Units stated and consistent: the summary gives lengths in the input unit and angles in degrees,
linkage.json says the STL unit and the density behind the inertias."""
from __future__ import annotations

import re

from click.testing import CliRunner

from cli.main import mpsynth
from synth.io.jsonout import linkage_document
from synth.io.meshes import DENSITY

from conftest import REPO
from linkage_fixtures import bennett_linkage


def test_bennett_summary_in_input_units_and_degrees():
    r = CliRunner().invoke(mpsynth, ["bennett", str(REPO / "fixtures" / "bennett_mm_deg.yaml")])
    assert r.exit_code == 0, r.output
    err = r.stderr
    assert re.search(r"alpha = -?\d+\.\d+ deg, b = [\d.]+ mm, beta = -?\d+\.\d+ deg", err), err
    assert " rad" not in err  # one angle unit in the summary
    assert err.count("angle law a, b:") == 1 and "2 atan2(b, t - a)" in err


def test_linkage_json_states_the_stl_unit_and_density():
    doc = linkage_document(bennett_linkage())
    assert doc["units"] == {"length": "m", "angle": "rad"}  # the contract, unchanged
    assert doc["stl"]["length_unit"] == "mm" and doc["stl"]["urdf_scale"] == 0.001
    assert doc["stl"]["density"] == DENSITY and doc["stl"]["density_unit"] == "kg/m^3"
