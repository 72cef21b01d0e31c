"""mpsynth design without a browser: the task document written back in place, the session (live
synthesis, undo, kinds, bad positions in words, save, write output as the CLI), the cancellable design
search, the JSON API over a real local server, and `mpsynth --help` not loading the designer."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
import threading
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from synth.design.work import Cancelled, Work, cancellable
from synth.errors import InputError
from synth.tools.designer import document
from synth.tools.designer.session import Session
from synth.tools.designer.synth_view import Kind, synthesize

ROOT = Path(__file__).resolve().parents[1]
BENNETT = ROOT / "fixtures" / "bennett_mm_deg.yaml"
SIXBAR = ROOT / "fixtures" / "sixbar_example.yaml"


@pytest.fixture
def task(tmp_path):
    p = tmp_path / "task.yaml"
    shutil.copy(BENNETT, p)
    return p


def lines_of(linkage):
    """The joint axes (direction, moment) of a linkage, for comparing two syntheses."""
    return np.array([np.concatenate([j.direction, j.moment]) for j in linkage.joints])


# ---------------------------------------------------------------------- the document
def test_write_back_replaces_only_the_changed_number(task):
    text = task.read_text()
    doc = document.parse(text, str(task))
    new = document.with_value(doc, ("poses", 1, "position", 0), 95.25)
    out, kept = document.write_back(text, doc, new, str(task))
    assert kept
    assert out == text.replace("position: [90, 180, 180]", "position: [95.25, 180, 180]")
    assert out.startswith("# A pick-and-place task")  # comments stay


def test_write_back_of_an_unchanged_document_is_the_same_text(task):
    text = task.read_text()
    doc = document.parse(text, str(task))
    assert document.write_back(text, doc, doc, str(task)) == (text, True)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2), st.sampled_from(["position", "rpy"]), st.integers(0, 2),
                          st.floats(-1e4, 1e4, allow_nan=False)), min_size=1, max_size=6))
def test_write_back_reads_back_as_the_edited_document(edits):
    text = BENNETT.read_text()
    doc = new = document.parse(text, str(BENNETT))
    for item, key, k, x in edits:
        new = document.with_value(new, ("poses", item, key, k), x)
    out, kept = document.write_back(text, doc, new, str(BENNETT))
    assert kept
    back = document.parse(out, str(BENNETT))
    got = [v.value for v in document.leaves(back)]
    want = [v.value for v in document.leaves(new)]
    assert got[:1] == want[:1]
    assert np.allclose([x for x in got if not isinstance(x, (str, dict))],
                       [x for x in want if not isinstance(x, (str, dict))], rtol=1e-9, atol=1e-12)


def test_with_value_refuses_a_wrong_type_and_a_missing_leaf(task):
    doc = document.parse(task.read_text(), str(task))
    with pytest.raises(InputError, match=r"poses\.0\.rpy\.0 must be a finite number"):
        document.with_value(doc, ("poses", 0, "rpy", 0), "x")
    with pytest.raises(InputError, match="no value at poses.7"):
        document.with_value(doc, ("poses", 7, "rpy", 0), 1.0)


# ---------------------------------------------------------------------- the session
def test_a_move_resynthesizes_an_exact_bennett_through_the_moved_pose(task):
    s = Session(task, background_design=False)
    before = s.state()
    assert before["kind"] == "bennett" and before["problem"] is None and before["unit"] == "mm"
    after = s.move(1, [95, 180, 180])
    assert after["revision"] == before["revision"] + 1
    assert after["poses"][1][0][3] == pytest.approx(95.0)
    assert all(e["within"] and e["position"] < 1e-6 for e in after["errors"])  # mm
    assert not np.allclose(after["scene"]["links"][0]["points"], before["scene"]["links"][0]["points"])
    assert s.undo()["poses"][1][0][3] == pytest.approx(90.0)


def test_a_bad_position_is_a_reason_in_words_and_undo_recovers(task):
    s = Session(task, background_design=False)
    for k, x in enumerate([0, 0, 200]):  # pose 1 onto pose 0: no linkage
        st_ = s.edit(["poses", 1, "position", k], x)
    s.edit(["poses", 1, "rpy", 0], 0)
    s.edit(["poses", 1, "rpy", 1], 0)
    st_ = s.edit(["poses", 1, "rpy", 2], 0)
    assert st_["problem"] and "task.yaml" in st_["problem"] and st_["scene"] is None
    for _ in range(6):
        st_ = s.undo()
    assert st_["problem"] is None and st_["undo"] == 0


def test_kinds_sixbar_task_and_a_kind_that_does_not_fit(tmp_path):
    p = tmp_path / "six.yaml"
    shutil.copy(SIXBAR, p)
    s = Session(p, background_design=False)
    st_ = s.state()
    assert st_["kind"] == "sixbar" and len(st_["candidates"]) == 5 and st_["linkage"]["joints"] == 6
    picked = s.set_pick(2)
    assert picked["pick"] == 2 and picked["scene"] != st_["scene"]
    bad = s.set_kind("fourbar")
    assert bad["problem"] and bad["candidates"] == []
    with pytest.raises(InputError, match="unknown kind"):
        s.set_kind("eightbar")


def test_saving_after_moving_nothing_gives_the_same_linkage(task, tmp_path):
    s = Session(task, background_design=False)
    out = tmp_path / "saved.yaml"
    assert s.save(out)["comments_kept"]
    assert out.read_text() == task.read_text()
    a = synthesize(document.parse(task.read_text(), "a"), "a", None)
    b = synthesize(document.parse(out.read_text(), "b"), "b", None)
    assert a.kind is b.kind is Kind.BENNETT
    assert np.allclose(lines_of(a.linkages[0]), lines_of(b.linkages[0]), atol=1e-12)


def test_save_after_a_move_writes_the_number_in_place(task):
    s = Session(task, background_design=False)
    s.move(2, [-181.5, -160, -40])
    s.save()
    assert "position: [-181.5, -160, -40]" in task.read_text()
    assert task.read_text().startswith("# A pick-and-place task")


def test_write_output_is_what_the_cli_writes(task, tmp_path):
    s = Session(task)
    res = s.write_output(tmp_path / "designer")
    assert res["design"].startswith("collision-free")
    cli = subprocess.run([sys.executable, "-m", "cli.main", "bennett", str(task), "-o", str(tmp_path / "cli")],
                         capture_output=True, text=True, cwd=ROOT)
    assert cli.returncode == 0, cli.stderr
    a = json.loads((tmp_path / "designer" / "linkage.json").read_text())
    b = json.loads((tmp_path / "cli" / "linkage.json").read_text())
    assert a == b
    assert (tmp_path / "designer" / "linkage.urdf").read_text() == (tmp_path / "cli" / "linkage.urdf").read_text()


def test_background_design_reports_and_a_new_change_cancels_it(task):
    s = Session(task)
    first = s.job
    s.move(1, [92, 180, 180])
    assert first.flag.is_set()
    assert s.job.wait(120)
    bg = s.state()["background"]
    assert bg["stage"] == "done" and bg["free"] is True and bg["drive"].startswith("h1 from")
    assert bg["scene"]["links"]


def test_cancellable_work_stops_at_the_next_charge():
    flag = threading.Event()
    w = Work()
    with cancellable(flag):
        w.charge(10)
        flag.set()
        with pytest.raises(Cancelled):
            w.charge(10)
    w.charge(10)  # outside the block: no cancellation
    assert w.done == 30


# ---------------------------------------------------------------------- the server and the CLI
def _call(url, name, body=None):
    req = urllib.request.Request(url + "api/" + name, data=None if body is None else json.dumps(body).encode(),
                                 headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=60) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read())


def test_the_api_over_a_local_server(task, tmp_path):
    pytest.importorskip("uvicorn")
    pytest.importorskip("starlette")
    from synth.tools.designer.server import Server

    srv = Server(Session(task, background_design=False), port=0, out=str(tmp_path / "out"))
    url = srv.start()
    try:
        assert url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(url, timeout=30) as r:
            assert b"mpsynthDesigner" in r.read()
        code, st_ = _call(url, "move", {"item": 0, "position": [1, 2, 200]})
        assert code == 200 and st_["revision"] == 2
        code, err = _call(url, "edit", {"path": ["poses", 0, "rpy", 0], "value": "x"})
        assert code == 400 and "must be a finite number" in err["error"]
        code, err = _call(url, "kind", {})
        assert code == 400 and "lacks" in err["error"]
        code, _ = _call(url, "save", {})
        assert code == 200 and "position: [1, 2, 200]" in task.read_text()
        code, w = _call(url, "write", {})
        assert code == 200 and (tmp_path / "out" / "linkage.urdf").exists()
    finally:
        srv.stop()


def test_help_does_not_load_the_designer():
    code = ("import sys, runpy; sys.argv = ['mpsynth', '--help']\n"
            "try:\n    runpy.run_module('cli.main', run_name='__main__')\nexcept SystemExit:\n    pass\n"
            "bad = [m for m in sys.modules if m.startswith(('uvicorn', 'starlette', 'synth.tools.designer'))]\n"
            "print(json.dumps(bad) if False else repr(bad), file=sys.stderr)")
    r = subprocess.run([sys.executable, "-c", "import json\n" + code], capture_output=True, text=True, cwd=ROOT)
    assert "design" in r.stdout
    assert r.stderr.strip().splitlines()[-1] == "[]"


def test_design_refuses_a_missing_task(tmp_path):
    r = subprocess.run([sys.executable, "-m", "cli.main", "design", str(tmp_path / "nope.yaml"), "--no-browser"],
                       capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert r.returncode == 2 and "nope.yaml" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_task_fields_are_given_edited_and_taken_back(task):
    s = Session(task, background_design=False)
    st_ = s.state()["items"][0]
    assert st_["addable"] == ["tolerance", "order"] and st_["rows"][1]["addable"] == ["tolerance", "exact", "velocity"]
    s.add_field(None, "tolerance")  # a task tolerance: a fit of the three poses
    st_ = s.add_field(1, "exact")
    assert st_["items"][0]["rows"][1]["removable"] == ["exact"]
    cells = {c["label"]: c["value"] for c in st_["items"][0]["settings"]}
    assert cells == {"tolerance.position": 1.0, "tolerance.angle": 1}  # 1 % of 380 mm -> 1 mm; 1 deg
    assert st_["problem"] is None and all(e["within"] for e in st_["errors"])
    st_ = s.edit(["tolerance", "angle"], 0.5)
    assert st_["errors"][0]["tolerance"] == [1.0, 0.5] and st_["errors"][1]["tolerance"] is None  # via: exact
    st_ = s.remove_field(1, "exact")
    assert st_["errors"][1]["tolerance"] == [1.0, 0.5]
    with pytest.raises(InputError, match="cannot be given 'exact'"):
        s.add_field(None, "exact")
    s.save()
    assert "tolerance:" in task.read_text()  # a new key: the document is written anew
    s.undo()
    s.undo()
    s.undo()
    s.undo()
    s.save()
    assert task.read_text() == BENNETT.read_text()  # back to the original text, comments included


@pytest.mark.parametrize("fixture, kind, count", [("bennett_points.yaml", "bennett", 5), ("fourbar_5.yaml", "fourbar", 2),
                                                  ("bennett_fit.yaml", "bennett", 1)])
def test_the_default_kind_reads_the_task_as_its_command_does(fixture, kind, count):
    s = Session(ROOT / "fixtures" / fixture, background_design=False)
    st_ = s.state()
    assert (st_["kind"], st_["problem"], len(st_["candidates"])) == (kind, None, count)
    if fixture == "bennett_points.yaml":  # points: drawn without frames, moved by their position
        assert all(st_["points"]) and st_["items"][0]["rows"][1]["movable"]
        assert all(e["angle"] is None and e["within"] for e in st_["errors"])


def test_a_kind_given_at_the_start_and_one_that_is_unknown(task):
    assert Session(task, background_design=False, kind="fourbar").state()["kind"] == "fourbar"
    with pytest.raises(InputError, match="unknown kind 'eightbar'"):
        Session(task, background_design=False, kind="eightbar")


def test_the_command_serves_on_localhost_and_stops_on_interrupt(task):
    pytest.importorskip("uvicorn")
    import signal

    proc = subprocess.Popen([sys.executable, "-m", "cli.main", "design", str(task), "--no-browser", "--port", "0"],
                            cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stderr.readline()
        assert line.startswith("mpsynth design: http://127.0.0.1:"), line
        url = line.split()[2]
        code, st_ = _call(url, "state")
        assert code == 200 and st_["kind"] == "bennett"
    finally:
        proc.send_signal(signal.SIGINT)
        rest = proc.communicate(timeout=60)[1]
    assert proc.returncode == 0 and "Traceback" not in rest, (proc.returncode, rest)
