"""The typed `Linkage.info` (synth/info.py, synth/infoparts.py): each synthesis fills its own record, the
document it writes reads back into the same record (key order included), and the records are frozen."""
from __future__ import annotations

import json

import numpy as np
import pytest

import synth
from conftest import REPO
from synth.info import (Factorization, FamilyMember, GivenMotion, LinkageInfo, Marker, MultiLoop, Orders,
                        SixbarCandidate)
from synth.infoparts import DHRow, FitRecord, ScoreParts
from synth.io.curvespec import load_spec
from synth.io.jsonout import linkage_document, plain
from synth.io.linkagedoc import linkage_from_document
from synth.io.poses import load_poses
from synth.synthesis.conic import Conditioning
from synth.synthesis.curve import spec_linkage


def _poses(name):
    ps = load_poses(str(REPO / "fixtures" / name))
    return ps.matrices, ps.names


@pytest.fixture(scope="module")
def linkages():
    """One linkage of each record kind that is cheap to make (fixtures of the repository)."""
    return {"bennett": synth.bennett(*_poses("bennett_matrix.json")),
            "planar": synth.bennett(*_poses("bennett_planar.yaml")),
            "sixbar": synth.sixbar(*_poses("sixbar_example.yaml")),
            "motion": spec_linkage(load_spec(str(REPO / "fixtures" / "motion_circular.yaml"))),
            "curve": spec_linkage(load_spec(str(REPO / "fixtures" / "curve_circle.yaml")))}


def test_each_synthesis_fills_its_record(linkages):
    kinds = {k: type(lk.info.synthesis) for k, lk in linkages.items()}
    assert kinds == {"bennett": Factorization, "planar": FamilyMember, "sixbar": SixbarCandidate,
                     "motion": MultiLoop, "curve": MultiLoop}
    b = linkages["bennett"].info
    assert b.bennett.bennett_condition_residual < 1e-9 and len(b.dh) == 4 and b.warnings == ()
    assert b.fit is None and b.fit_summary is None
    assert isinstance(linkages["motion"].info.synthesis.motion, GivenMotion)
    assert linkages["motion"].info.synthesis.parallelogram is not None
    tracer = linkages["curve"].info.synthesis.markers["tracer"]
    assert isinstance(tracer, Marker) and tracer.link == "coupler"


@pytest.mark.parametrize("kind", ["bennett", "planar", "sixbar", "motion", "curve"])
def test_the_document_reads_back_into_the_same_info(linkages, kind):
    """linkage.json's info -> `LinkageInfo.from_dict` -> to_dict gives the same text (keys in the same order)."""
    lk = linkages[kind]
    doc = linkage_document(lk)
    back = linkage_from_document(json.loads(json.dumps(doc)))
    assert type(back.info.synthesis) is type(lk.info.synthesis)
    assert json.dumps(plain(back.info.to_dict())) == json.dumps(doc["info"])


def test_keys_follow_the_fields_and_optional_ones_are_left_out():
    """A worked record: the keys in field order, None optional fields absent, a Hermite 6R's fit right after
    its record (before the DH table) and every other kind's fit after the warnings."""
    record = SixbarCandidate(task="hermite", pair=3, score=0.5, score_parts=ScoreParts.of({"conditioning": 0.1}),
                             orders=Orders(h=(0, 1, 2), k=(2, 1, 0)), norm_roots=((0.0, 1.0),),
                             factorization_residual=1e-15, conditioning=Conditioning(np.zeros(3), 2.0))
    fit = FitRecord(method="hermite", seeds=0, refined=0, iterations=0, order="any", visit_order=("a", "b"),
                    rms_position_error=0.0, max_position_error=0.0, rms_angle_error=0.0, max_angle_error=0.0,
                    within_tolerance=True, failing=())
    row = DHRow(joint="h1", next="h2", a=1.0, alpha=0.5, d=0.0, theta=0.0)
    info = LinkageInfo(synthesis=record, dh=(row,), warnings=(), fit=fit)
    doc = plain(info.to_dict())
    assert list(doc) == ["task", "pair", "score", "score_parts", "orders", "norm_roots", "factorization_residual",
                         "conditioning", "fit", "dh", "warnings"]
    assert doc["orders"] == {"h": [0, 1, 2], "k": [2, 1, 0]} and "dyads" not in doc["fit"]
    assert doc["conditioning"] == {"centre": [0.0, 0.0, 0.0], "scale": 2.0}
    other = info.replace(synthesis=record.replace(task="fit"))
    assert list(other.to_dict())[-3:] == ["dh", "warnings", "fit"]


def test_a_value_field_is_written_even_when_none(linkages):
    """``expression`` of a given motion is a value (null when the motion came without text), not optional."""
    given = linkages["motion"].info.synthesis.motion.replace(expression=None)
    assert "expression" in given.to_dict() and given.to_dict()["expression"] is None


def test_replace_copies_and_leaves_the_record_as_it_was(linkages):
    """Records are plain dataclasses (a frozen one costs three times as much to build, on every synthesis's
    path); ``replace`` gives a copy with the changes and the original keeps its values."""
    info = linkages["bennett"].info
    before = info.to_dict()
    other = info.replace(warnings=("x",), bennett=info.bennett.replace(a=0.0))
    assert other.warnings == ("x",) and other.bennett.a == 0.0 and other.dh is info.dh
    assert info.to_dict() == before and info.bennett.a != 0.0
    with pytest.raises(TypeError, match="no fields"):
        info.replace(nonsense=1)


def test_the_fit_summary_is_not_written():
    from synth.infoparts import FitSummary

    info = LinkageInfo(fit_summary=FitSummary("fit", seeds=3))
    assert info.to_dict() == {} and LinkageInfo.from_dict({}).fit_summary is None
