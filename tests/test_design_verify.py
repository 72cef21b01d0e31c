"""End-to-end: the collision claim in linkage.json holds for the independent verifier (fcl on the written
meshes, same clearance, same range). Active once the exporter writes the searched design
(synth.io.meshes.design_for)."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from conftest import REPO

meshes = pytest.importorskip("synth.io.meshes")
pytestmark = pytest.mark.skipif(not hasattr(meshes, "design_for"), reason="the exporter does not write designs yet")
pytest.importorskip("fcl")


def run(*args):
    return subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, cwd=REPO, timeout=600)


def check_claim(verifier, poses, out):
    c = json.loads((out / "linkage.json").read_text())["collision"]
    assert c["free"] and c["certified"], c
    r = run(verifier, poses, out, "--steps", "90", "--collisions", repr(c["clearance"]),
            "--collision-range", c["range"])
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.parametrize("command, fixture", [
    ("bennett", "bennett_mm_deg.yaml"),
    pytest.param("sixbar", "sixbar_example.yaml", marks=pytest.mark.slow),
])
def test_fixture_claim_holds(tmp_path, verifier, command, fixture):
    poses = REPO / "fixtures" / fixture
    out = tmp_path / "out"
    r = run("-m", "cli.main", command, poses, "-o", out, "-q")
    assert r.returncode == 0, r.stderr
    check_claim(verifier, poses, out)
