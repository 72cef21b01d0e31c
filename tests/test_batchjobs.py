"""`mpsynth batch` (synth.tools.batchjobs): JSON-lines jobs in, one JSON result line per job out, in input order."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from synth.errors import InputError, SynthesisError
from synth.io.docload import open_lines, read_lines
from synth.synthesis.bennett import bennett
from synth.synthesis.conditioning import TRANSMISSION_LIMIT
from synth.tools.batchjobs import run_job, run_jobs

from conftest import REPO, random_poses, run


def matrix_specs(T):
    return [{"matrix": M.tolist()} for M in T]


def make_jobs(n=200, seed=7):
    """n job lines and, for each, (expected ok, expected exit code); ok None: a linkage or exit code 1."""
    rng = np.random.default_rng(seed)
    lines, expect = [], []
    for i in range(n):
        r = i % 10
        if r in (0, 1, 2, 3, 4):  # valid Bennett, millimetres
            T = random_poses(rng, 3, scale=200.0)
            poses = [{"name": f"q{k}", "position": (M[:3, 3]).tolist(), "rotation": M[:3, :3].tolist()}
                     for k, M in enumerate(T)]
            # a linkage, unless refused as ill-conditioned (synth.synthesis.conditioning; 0.3 % of random sets;
            # synth.bennett applies the gate and names the ratio)
            try:
                exp = (True, None) if bennett(T) else None
            except SynthesisError as e:
                assert f"at most {TRANSMISSION_LIMIT:.0e} is accepted" in str(e)
                exp = (False, 1)
            job = {"id": f"b{i}", "kind": "bennett", "units": {"length": "mm"}, "poses": poses}
        elif r == 5:  # 6R: about 85 % of random pose sets have a real one, the others are exit code 1
            job, exp = {"id": i, "kind": "sixbar", "poses": matrix_specs(random_poses(rng, 4))}, (None, 1)
        elif r == 6:  # degenerate: two coincident poses -> no linkage (1)
            T = random_poses(rng, 3)
            T[1] = T[0]
            job, exp = {"id": i, "kind": "bennett", "poses": matrix_specs(T)}, (False, 1)
        elif r == 7:  # malformed JSON
            lines.append('{"id": %d, "kind": "bennett", "poses": [' % i)
            expect.append((False, 2))
            continue
        elif r == 8:  # a bad pose: non-unit quaternion
            job = {"id": i, "kind": "bennett",
                   "poses": [{"position": [0, 0, 0], "quaternion": {"w": 2, "x": 0, "y": 0, "z": 0}}] * 3}
            exp = (False, 2)
        else:  # wrong pose count, unknown kind, unknown key, missing poses in turn
            bad = [{"id": i, "kind": "bennett", "poses": matrix_specs(random_poses(rng, 4))},
                   {"id": i, "kind": "fivebar", "poses": []},
                   {"id": i, "kind": "bennett", "pose": []},
                   {"id": i, "kind": "sixbar"}][(i // 10) % 4]
            job, exp = bad, (False, 2)
        lines.append(json.dumps(job))
        expect.append(exp)
    return lines, expect


@pytest.fixture(scope="module")
def jobs(tmp_path_factory):
    lines, expect = make_jobs()
    path = tmp_path_factory.mktemp("batch") / "jobs.jsonl"
    # a blank line is not a job: its result line says "skipped", so results and lines stay 1:1
    path.write_text("\n".join(lines[:100]) + "\n\n" + "\n".join(lines[100:]) + "\n")
    return path, lines, expect


def check_results(stdout, lines, expect):
    results = [json.loads(s) for s in stdout.splitlines()]
    assert len(results) == len(lines) + 1 == 201
    assert results[100] == {"id": None, "line": 101, "ok": True, "skipped": "blank line"}
    results = results[:100] + results[101:]
    assert [r["line"] for r in results] == list(range(1, 101)) + list(range(102, 202))
    for k, (res, (ok, code)) in enumerate(zip(results, expect)):
        assert res["line"] == k + 1 + (k >= 100), res
        if ok is None:  # either a linkage or "no real linkage"
            ok, code = res["ok"], 1
        assert res["ok"] is ok, res
        if ok:
            assert res["joints"] == (6 if res["kind"] == "sixbar" else 4)
            assert res["checks"]["max_pose_error"] < 1e-9 and res["out"] is None
        else:
            assert res["exit_code"] == code, res
            assert res["error"] and "\n" not in res["error"]
        if k % 10 != 7:
            assert res["id"] == json.loads(lines[k])["id"]
        else:
            assert res["id"] is None
    return results


def test_200_jobs_in_order_with_failures_inline(jobs):
    path, lines, expect = jobs
    r = run("batch", path)
    assert r.exit_code == 1  # some jobs failed
    results = check_results(r.stdout, lines, expect)
    assert sum(res["ok"] for res in results if res.get("kind") == "sixbar") >= 10
    msgs = {res["error"] for res in results if not res["ok"]}
    assert any("invalid JSON" in m for m in msgs) and any("quaternion" in m for m in msgs)
    assert any("coincide" in m for m in msgs) and any("unknown kind 'fivebar'" in m for m in msgs)
    assert any("unknown key 'pose' (did you mean 'poses'?)" in m for m in msgs)
    assert any("needs exactly 3 poses, got 4" in m for m in msgs)
    assert "200 jobs, " in r.stderr and "failed" in r.stderr


def test_parallel_gives_the_same_results(jobs):
    path, lines, expect = jobs
    r1 = run("batch", path, "-j", 1, "-q")
    r2 = run("batch", path, "-j", 2, "--chunksize", 7, "-q")
    assert r2.exit_code == r1.exit_code == 1
    assert r2.stdout == r1.stdout
    assert r1.stderr == ""


def test_stdin_pipeline_and_outputs(tmp_path):
    """End to end through a pipe, writing two linkages; exit 0 when every job succeeds."""
    rng = np.random.default_rng(3)
    jobs = [{"id": "a", "kind": "bennett", "poses": matrix_specs(random_poses(rng, 3)), "out": "a"},
            {"id": "b", "kind": "sixbar",
             "poses": [{"position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
                       {"position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}},
                       {"position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}},
                       {"position": [-1, 0.5, 0], "quaternion": {"w": 0.2, "x": 0.4, "y": 0.4, "z": 0.8}}],
             "out": "sub/b", "name": "six"}]
    text = "".join(json.dumps(j) + "\n" for j in jobs)
    exe = REPO / ".venv" / "bin" / "mpsynth"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "cli.main"]
    p = subprocess.run(cmd + ["batch", "-", "-j", "2", "--out-dir", str(tmp_path)], input=text, capture_output=True, text=True, timeout=120,
                       cwd=REPO)
    assert p.returncode == 0, p.stderr
    res = [json.loads(s) for s in p.stdout.splitlines()]
    assert [(r["id"], r["ok"], r["out"]) for r in res] == [("a", True, "a"), ("b", True, "sub/b")]
    for d, name in (("a", "a"), ("sub/b", "six")):
        doc = json.loads((tmp_path / d / "linkage.json").read_text())
        assert doc["format"] == "mpsynth.linkage/1"
        assert f'<robot name="{name}">' in (tmp_path / d / "linkage.urdf").read_text()
    assert "\r" not in p.stderr  # no progress bar when stderr is not a terminal


def test_failed_job_writes_nothing(tmp_path):
    job = {"id": 1, "kind": "bennett", "out": "x",
           "poses": [{"matrix": np.eye(4).tolist()}] * 3}
    res = run_job((1, json.dumps(job)), out_dir=tmp_path)
    assert res["ok"] is False and res["exit_code"] == 1
    assert not list(tmp_path.iterdir())


def test_full_result_and_mesh_sizes(tmp_path):
    rng = np.random.default_rng(5)
    job = {"id": 1, "kind": "bennett", "units": {"length": "mm"},
           "poses": matrix_specs(random_poses(rng, 3, scale=200.0)), "pin_radius": 5, "out": "o"}
    (res,) = list(run_jobs([json.dumps(job)], full=True, out_dir=tmp_path))
    assert res["ok"], res
    assert res["linkage"]["format"] == "mpsynth.linkage/1" and len(res["linkage"]["joints"]) == 4
    assert res["bennett"]["a"] > 0
    import trimesh

    base = trimesh.load_mesh(str(tmp_path / "o" / "meshes" / "base.stl"))  # millimetres
    assert base.bounding_box.extents.min() >= 10 - 1e-6  # its pins are 5 mm in radius


def test_missing_sixbar_is_a_result_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "synth.synthesis.sixbar", None)  # the import fails as if the module were absent
    job = {"id": "s", "kind": "sixbar", "poses": matrix_specs(random_poses(np.random.default_rng(1), 4))}
    res = run_job((1, json.dumps(job)))
    assert res["ok"] is False and res["exit_code"] == 2 and "sixbar" in res["error"]


def test_all_ok_exits_0_and_unreadable_jobs_exit_2(tmp_path):
    rng = np.random.default_rng(9)
    r = run("batch", "-", "-q", input=json.dumps({"kind": "bennett", "poses": matrix_specs(random_poses(rng, 3))}))
    assert r.exit_code == 0 and json.loads(r.stdout)["id"] is None
    r = run("batch", tmp_path / "nope.jsonl")
    assert r.exit_code == 2 and "no such file" in r.stderr


def test_open_lines_counts_jobs_and_names_unreadable_files(tmp_path):
    f = tmp_path / "jobs.jsonl"
    f.write_bytes(b'{"a": 1}\n\n   \n{"b": \xff}\n')
    stream, total = open_lines(str(f))
    with stream:
        lines = list(read_lines(stream))
    assert total == 4 and len(lines) == 4 and "\ufffd" in lines[3][1]  # undecodable bytes replaced
    with pytest.raises(InputError, match="it is a directory"):
        open_lines(str(tmp_path))
    with pytest.raises(InputError, match="no such file"):
        open_lines(str(tmp_path / "nope.jsonl"))


def test_cluster_options_without_the_cluster_extra(monkeypatch, tmp_path):
    """Without dask / pyarrow (the optional extra mpsynth[cluster]) the options are one-line input errors."""
    jobs = tmp_path / "jobs.jsonl"
    jobs.write_text("\n")
    monkeypatch.setitem(sys.modules, "distributed", None)  # the import fails as if it were not installed
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    r = run("batch", jobs, "--scheduler", "local")
    assert r.exit_code == 2 and r.stdout == "" and "mpsynth[cluster]" in r.stderr and r.stderr.count("\n") == 1
    r = run("batch", jobs, "--results", tmp_path / "r.parquet")
    assert r.exit_code == 2 and "pyarrow" in r.stderr and "mpsynth[cluster]" in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.jsonl"]


def test_fourbar_job_matches_the_command(tmp_path):
    """kind "fourbar": the four-bar `mpsynth fourbar` writes for the same poses (fixtures/fourbar_5.yaml), and
    with a velocity (two poses and the tool's twist at one: three conditions)."""
    import yaml

    from fourbar_tasks import coupler_poses, coupler_twist, random_crank_rocker

    doc = yaml.safe_load((REPO / "fixtures" / "fourbar_5.yaml").read_text())
    res = run_job((1, json.dumps({"id": "fb", "kind": "fourbar", "poses": doc["poses"], "out": "fb"})), out_dir=tmp_path)
    assert res["ok"] and res["kind"] == "fourbar" and res["joints"] == 4, res
    written = json.loads((tmp_path / "fb" / "linkage.json").read_text())
    assert res["fourbar"]["lengths"] == written["info"]["fourbar"]["lengths"]
    assert run("fourbar", REPO / "fixtures" / "fourbar_5.yaml", "-o", tmp_path / "cli").exit_code == 0
    cli = json.loads((tmp_path / "cli" / "linkage.json").read_text())
    assert cli["info"]["fourbar"]["lengths"] == written["info"]["fourbar"]["lengths"]
    L = random_crank_rocker(np.random.default_rng(1))
    T, _, _ = coupler_poses(L, [0.3, 2.0], plane_seed=1, scale=0.1)
    w, v = coupler_twist(L, 0.3, plane_seed=1, scale=0.1)
    poses = [{"matrix": T[0].tolist(), "velocity": {"angular": w.tolist(), "linear": v.tolist()}},
             {"matrix": T[1].tolist()}]
    res = run_job((2, json.dumps({"kind": "fourbar", "poses": poses, "units": {"length": "m", "angle": "rad"}})))
    assert res["ok"] and res["fourbar"]["grashof"] == "crank-rocker", res
    res = run_job((3, json.dumps({"kind": "fourbar", "poses": [{"matrix": M.tolist()} for M in T]})))
    assert not res["ok"] and res["exit_code"] == 2 and "needs at least 3 poses (or 2 with a velocity)" in res["error"]
