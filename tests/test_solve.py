"""synth.solve: the entry points decide what the CLI shows (a notebook gets the CLI's answers), typed
options with one validation of sizes, the Kind enum and its labels."""
from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import synth
from cli.main import mpsynth
from conftest import REPO
from synth.errors import InputError, SynthesisError
from synth.io.jsonout import linkage_document, plain
from synth.io.poses import load_poses
from synth.linkage import Kind, kind_label
from synth.solve import DesignOptions, SynthesisOptions, solve_bennett, solve_sixbar

FIX = REPO / "fixtures"


def _cli_json(*args) -> dict:
    res = CliRunner().invoke(mpsynth, [*args, "--json"], catch_exceptions=False)
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _same(a, b, path="doc"):
    """Equal JSON documents, floats to 1e-12 relative (the same computation twice)."""
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for k in a:
            _same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-15), path
    else:
        assert a == b, path


def test_notebook_gets_the_clis_planar_member_and_design():
    """The planar family: the choice of member (collision-free first) and the design are the library's,
    so solve_bennett's linkage.json is the CLI's."""
    path = str(FIX / "bennett_planar.yaml")
    ps = load_poses(path, count=3)
    res = solve_bennett(ps, SynthesisOptions(physical=True))
    assert res.linkage.kind == Kind.PLANAR_4R and res.design is not None
    assert res.linkage.info.design_choice is not None and res.sentence().startswith(("collision-free", "NOT"))
    doc = plain(linkage_document(res.linkage, res.design.design, res.design.collision, res.drive, res.design.slenderness))
    _same(json.loads(json.dumps(doc)), _cli_json("bennett", path))


def test_library_applies_the_transmission_gate():
    """synth.bennett and solve_bennett refuse what the CLI refuses: a ratio above 1e4 (conditioning.py)."""
    from hard_poses import hard_set

    T = hard_set(20, 3)[1]
    with pytest.raises(SynthesisError, match="transmission ratio"):
        synth.bennett(T)
    ps = load_poses("x.yaml", text="units: {length: m}\nposes:\n" + "".join(
        f"  - matrix: {json.dumps(M.tolist())}\n" for M in T), count=3)
    with pytest.raises(SynthesisError, match=r"^x\.yaml: .*transmission ratio"):
        solve_bennett(ps)


def test_sizes_are_validated_once_in_the_input_unit():
    assert DesignOptions(pin_radius=4, clearance=0).sizes(0.001) == {"pin_radius": 0.004, "clearance": 0.0}
    with pytest.raises(InputError, match="^--link-radius must be a positive length, got -1"):
        DesignOptions(link_radius=-1).sizes(1.0)
    with pytest.raises(InputError, match="^'pin_length' must be a positive length, got 0"):
        DesignOptions(pin_length=0).sizes(1.0, label=repr)
    with pytest.raises(InputError, match="hole-clearance must be a non-negative"):
        DesignOptions(hole_clearance=float("inf")).sizes(1.0)  # absurd finite sizes: check_sizes


def test_option_combinations_are_refused_by_the_library():
    ps = load_poses(str(FIX / "bennett_quat.yaml"), count=3)
    with pytest.raises(InputError, match="--top applies to point tasks and fits only"):
        solve_bennett(ps, SynthesisOptions(top=2))
    pts = load_poses(str(FIX / "bennett_points.yaml"), points=((3, 5), "mpsynth bennett"))
    with pytest.raises(InputError, match="--member selects among"):
        solve_bennett(pts, SynthesisOptions(member=(1.0, 2.0)))


def test_ranked_sixbar_index_without_designs():
    """--top without a physical design: ranked solutions, ids and index document, scores non-increasing."""
    ps = load_poses(str(FIX / "sixbar_example.yaml"), count=4)
    res = solve_sixbar(ps, SynthesisOptions(top=3))
    doc = res.index
    assert doc["format"] == "mpsynth.sixbar-index/1" and doc["poses"] == ps.source
    assert [s["rank"] for s in doc["solutions"]] == list(range(1, len(res.solutions) + 1))
    assert [s.id for s in res.solutions] == [s["id"] for s in doc["solutions"]]
    assert all(s.design is None for s in res.solutions) and res.linkage is res.solutions[0].linkage
    scores = [s["score"] for s in doc["solutions"]]
    assert scores == sorted(scores, reverse=True) and "collision" not in doc["solutions"][0]
    assert res.solutions[0].id.startswith("01-f")


def test_kind_values_are_the_json_strings():
    assert [k.value for k in Kind] == ["bennett", "6r", "planar_4r", "spherical_4r", "planar_sixbar",
                                       "spherical_sixbar", "motion", "curve", "planar_fourbar"]
    assert json.dumps(Kind.SIXBAR) == '"6r"' and f"{Kind.PLANAR_4R}" == "planar_4r"
    assert kind_label("6r") == Kind.SIXBAR.label == "spatial 6R" and kind_label("other") == "other"
    L = synth.bennett(load_poses(str(FIX / "bennett_quat.yaml")).matrices)
    assert L.kind is Kind.BENNETT and linkage_document(L)["kind"] == "bennett"
    assert np.isfinite(L.extent())


def test_batch_job_gets_the_entry_points_linkage():
    """`mpsynth batch` calls the same entry point: its linkage (checks included: the 200-sample
    verification) is solve_bennett's."""
    from synth.tools.batchjobs import run_job

    path = FIX / "bennett_quat.yaml"
    doc = {"kind": "bennett", "poses": [
        {"position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
        {"position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}},
        {"position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}}]}
    res = run_job((1, json.dumps(doc)), full=True)
    assert res["ok"], res
    ps = load_poses(str(path), count=3)
    ref = plain(linkage_document(solve_bennett(ps).linkage))
    _same(ref["checks"], res["checks"])
    _same(ref["joints"], res["linkage"]["joints"])
