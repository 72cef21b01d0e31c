"""The chunked batch path (issue 36): `run_chunk` runs the three-pose Bennett jobs of a chunk through one
`synth.solve.many.solve_bennett_many` call and must print the result lines the per-job reference path
(`run_job`) prints, byte for byte; `-j 1`, `-j 2` and `--scheduler local` print the same bytes."""
from __future__ import annotations

import importlib.util
import json
import random

import numpy as np
import pytest

from synth.algebra.algorithm1 import norm_roots
from synth.io.outputs import Outputs
from synth.solve.many import solve_bennett_many
from synth.synthesis.bennett_core import solve
from synth.tools.batchjobs import dumps, run_chunk, run_job

from conftest import random_poses, run


def readme_job(rnd, i: int) -> dict:
    """A job of README's generator (positions in mm, rpy in degrees)."""
    poses = [{"position": [rnd.uniform(-200, 200) for _ in range(3)],
              "rpy": [rnd.uniform(-180, 180) for _ in range(3)]} for _ in range(3)]
    return {"id": i, "kind": "bennett", "units": {"length": "mm", "angle": "deg"}, "poses": poses}


def near_degenerate(rng, i: int) -> list:
    """Three poses (4x4, metres) near a degenerate configuration, of one of several sorts in turn."""
    T = random_poses(rng, 3, scale=0.2)
    eps = 10.0 ** -rng.uniform(4, 11)
    sort = i % 5
    if sort == 0:  # two poses nearly coincide
        T[1] = T[0]
        T[1, :3, 3] += eps
    elif sort == 1:  # two poses nearly related by a pure translation
        T[2, :3, :3] = T[0, :3, :3]
        T[2, 0, 1] += eps
        T[2, 1, 0] -= eps
    elif sort == 2:  # planar poses (a family of motions: the per-set path), slightly lifted
        for M in T:
            c, s = np.cos(rng.uniform(0, 6)), np.sin(rng.uniform(0, 6))
            M[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
            M[2, 3] = eps * rng.normal()
    elif sort == 3:  # rotations nearly about one axis
        T[:, :3, :3] = T[0, :3, :3]
        for M in T[1:]:
            c, s = np.cos(rng.uniform(0, 6)), np.sin(rng.uniform(0, 6))
            M[:3, :3] = M[:3, :3] @ [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        T[2, :3, :3] += eps * rng.normal(size=(3, 3))
        u, _, vt = np.linalg.svd(T[2, :3, :3])
        T[2, :3, :3] = u @ vt
    else:  # a tiny pose spread far from the origin
        T[:, :3, 3] = T[:, :3, 3] * 1e-3 + 1e3
    return [{"matrix": M.tolist()} for M in T]


def mixed_lines(n: int, seed: int = 3) -> list[str]:
    """Job lines: README jobs, near-degenerate sets, bad lines, blank lines, other kinds, jobs with
    options (sizes, normalize, names), a task job, a point job."""
    import random

    rnd, rng = random.Random(seed), np.random.default_rng(seed)
    out = []
    for i in range(n):
        r = i % 20
        if r < 11:
            job = readme_job(rnd, i)
            if r == 3:
                job.update(pin_radius=2, name=f"r{i}", normalize=True)
            out.append(json.dumps(job))
        elif r < 15:
            out.append(json.dumps({"id": f"d{i}", "kind": "bennett", "poses": near_degenerate(rng, i)}))
        elif r == 15:
            out.append(['{"id": 1, "kind": "bennett", "poses": [', "", "  \t", '"a string"',
                        json.dumps({"id": i, "kind": "bennett", "poses": [], "colour": 1})][(i // 20) % 5])
        elif r == 16:  # a bad pose among good ones, a bad size
            job = readme_job(rnd, i)
            if (i // 20) % 2:
                job["poses"][1]["rpy"] = [1, 2]
            else:
                job["pin_radius"] = -1
            out.append(json.dumps(job))
        elif r == 17:  # a task job (tolerance): the per-job path
            job = readme_job(rnd, i)
            job["tolerance"] = {"position": 1.0, "angle": 1.0}
            out.append(json.dumps(job))
        elif r == 18:  # a pose set given twice: identical lines
            out.append(out[-7])
        else:
            out.append(json.dumps({"id": i, "kind": "sixbar", "poses": [{"matrix": M.tolist()}
                                                                        for M in random_poses(rng, 4, 0.2)]}))
    return out


def test_as_single_gives_the_bits_of_a_batch_of_one():
    """`solve(..., as_single=True)` on N sets equals N batches of one (the per-job path's numbers): the norm
    roots start from companion matrices at every size and `polish` steps each row as it would alone."""
    rng = np.random.default_rng(5)
    T = np.array([random_poses(rng, 3, scale=0.3) for _ in range(64)])
    many = solve(T, 0, as_single=True)
    for n in range(0, 64, 7):
        one = solve(T[n : n + 1], 0)
        assert np.array_equal(many.lines[n], one.lines[0]) and np.array_equal(many.laws[n], one.laws[0])
        assert many.good[n] == one.good[0]
    z = norm_roots(np.array([[5.0, 0.0, 3.0, 0.0, 1.0]] * 40), ferrari=False)
    assert np.allclose(z[0] ** 4 + 3 * z[0] ** 2 + 5, 0, atol=1e-12)


def test_a_sets_twists_do_not_depend_on_the_other_sets_of_its_batch():
    """The Bennett parameters of a set (the twists: `synth.algebra.geometry.ring_normals`) are the same bits
    in a batch where another set's axes meet (spherical poses: pure rotations, every axis through the
    origin) as alone: the signed twist of two skew lines was computed another way in such a batch, so -j 1
    and -j 2 (other chunks) printed twists an ulp apart (seen with OPENBLAS_CORETYPE=Haswell)."""
    rng = np.random.default_rng(9)
    T = np.array([random_poses(rng, 3, scale=0.3) for _ in range(40)])
    T[7, :, :3, 3] = 0.0  # a spherical set among them
    T[23, :, :3, 3] = 0.0
    batch = solve(T, 0, as_single=True)
    for n in range(40):
        if n in (7, 23):
            continue
        one = solve(T[n : n + 1], 0, as_single=True)
        for k in ("a", "alpha", "b", "beta"):
            assert np.array_equal(batch.bennett[k][n], one.bennett[k][0], equal_nan=True), (n, k)


def test_chunk_lines_equal_the_per_job_lines():
    """A few hundred mixed jobs: the chunked path prints the per-job path's lines byte for byte, and
    decides most Bennett jobs in the batch (the rest go one by one)."""
    lines = mixed_lines(300)
    items = list(enumerate(lines, 1))
    reference = [dumps(run_job(it)) for it in items]
    chunked = [dumps(r) for k in range(0, len(items), 64) for r in run_chunk(items[k : k + 64], False, None)]
    assert chunked == reference
    res = [json.loads(s) for s in reference]
    assert sum(r.get("ok") is False for r in res) >= 40  # bad lines and refused sets are there
    assert sum(r.get("skipped") is not None for r in res) >= 2
    assert sum(r.get("kind") == "bennett" and r["ok"] for r in res) >= 150


def test_summaries_decide_the_common_sets():
    """`solve_bennett_many` decides random sets (a set it leaves goes through the per-job path) and refuses
    none that the per-job path accepts or the other way round (checked above); its figures are small."""
    rng = np.random.default_rng(11)
    T = np.array([random_poses(rng, 3, scale=0.2) for _ in range(200)])
    S = solve_bennett_many(T)
    assert S.decided.mean() > 0.95
    n = int(np.flatnonzero(S.decided)[0])
    checks = S.checks(n)
    assert checks["samples"] == 200 and checks["max_pose_error"] < 1e-9 and checks["length_scale"] == S.extent[n]


def test_sets_near_and_beyond_the_transmission_gate_are_decided_in_the_batch():
    """The transmission gate needs no margin (the batch's ratio is `verify`'s, bit for bit) and its refusals
    get their message in the batch: README jobs whose ratio is above half the limit (refused, or accepted
    near the gate), some with pose names, print the per-job path's lines, and none goes one by one."""
    import random

    from synth.synthesis.conditioning import TRANSMISSION_LIMIT, worst_pairs
    from synth.tools.jobspec import read_common_bennett

    rnd = random.Random(1)
    jobs = [readme_job(rnd, i) for i in range(3000)]
    T = read_common_bennett([json.dumps(j) for j in jobs]).poses
    out = solve(T, 0, as_single=True)
    rho = worst_pairs(out.laws[..., 0], out.laws[..., 1])[0]
    near = np.flatnonzero(out.good & (rho > 0.5 * TRANSMISSION_LIMIT)).tolist()
    assert sum(rho[near] > TRANSMISSION_LIMIT) >= 3 and sum(rho[near] <= TRANSMISSION_LIMIT) >= 3
    for k, n in enumerate(near[::2]):  # named poses: the job takes the (non-common) reader's path
        for i, p in enumerate(jobs[n]["poses"]):
            p["name"] = f"q{k}_{i}"
    items = [(n + 1, json.dumps(jobs[n])) for n in near]
    assert [dumps(r) for r in run_chunk(items, False, None)] == [dumps(run_job(it)) for it in items]
    S = solve_bennett_many(T[near])
    assert S.decided.all() and S.refused.sum() == sum(rho[near] > TRANSMISSION_LIMIT)


def test_full_and_outputs_take_the_per_job_path(tmp_path):
    """--full (the whole linkage.json) and jobs with out (here kinematic outputs; one OUT named by several
    jobs, each rewriting it after the one before, as job by job): the per-job path's lines."""
    lines = mixed_lines(40, seed=4)[:11]
    items = list(enumerate(lines, 1))
    assert [dumps(r) for r in run_chunk(items, True, None)] == [dumps(run_job(it, full=True)) for it in items]
    outs = [json.dumps({**json.loads(s), "out": f"o{min(i, 2)}"}) if s.startswith("{") else s for i, s in enumerate(lines)]
    items = list(enumerate(outs, 1))
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    chunked = [dumps(r) for r in run_chunk(items, False, tmp_path / "a", Outputs.KINEMATIC)]
    single = [dumps(run_job(it, out_dir=tmp_path / "b", outputs=Outputs.KINEMATIC)) for it in items]
    assert [s.replace(str(tmp_path / "a"), "B") for s in chunked] == [s.replace(str(tmp_path / "b"), "B") for s in single]
    assert sum('"out":"o2"' in s for s in single) >= 2  # (mpsynth rewrites its own OUT)


def test_workers_and_the_local_cluster_print_the_same_bytes(tmp_path):
    """`mpsynth batch` with -j 1, -j 2 and --scheduler local (when dask is installed): the same bytes."""
    path = tmp_path / "jobs.jsonl"
    path.write_text("\n".join(mixed_lines(160, seed=9)) + "\n")
    outs = {j: run("batch", path, "-j", j, "-q", "--chunksize", 24).stdout for j in (1, 2)}
    assert outs[1] == outs[2] and len(outs[1].splitlines()) == 160
    if importlib.util.find_spec("distributed") is None:
        pytest.skip("dask.distributed is not installed (mpsynth[cluster])")
    assert run("batch", path, "--scheduler", "local", "-j", 2, "-q", "--chunksize", 24).stdout == outs[1]


def test_no_design_writes_the_kinematic_outputs(tmp_path):
    """--no-design: OUT holds linkage.json (no design section) and a URDF without meshes that yourdfpy
    loads and the shared verifier accepts (--no-meshes-ok); the result lines are those without OUT but
    for "out"."""
    import random

    import yourdfpy

    from conftest import assert_verified

    rnd = random.Random(2)
    jobs = [readme_job(rnd, i) for i in range(3)]
    path = tmp_path / "jobs.jsonl"
    path.write_text("".join(json.dumps({**j, "out": f"o{j['id']}"}) + "\n" for j in jobs))
    r = run("batch", path, "--out-dir", tmp_path, "--no-design", "-q")
    assert r.exit_code == 0, r.output
    plain_lines = run("batch", "-", "-q", input="".join(json.dumps(j) + "\n" for j in jobs)).stdout.splitlines()
    for j, line, ref in zip(jobs, r.stdout.splitlines(), plain_lines):
        assert json.loads(line) == {**json.loads(ref), "out": f"o{j['id']}"}
        out = tmp_path / f"o{j['id']}"
        assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["linkage.json", "linkage.urdf"]
        doc = json.loads((out / "linkage.json").read_text())
        assert "design" not in doc and doc["kind"] == "bennett"
        robot = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False)
        assert len(robot.actuated_joints) == 4 and "mesh" not in (out / "linkage.urdf").read_text()
        task = tmp_path / f"task{j['id']}.json"
        task.write_text(json.dumps({"units": j["units"], "poses": j["poses"]}))
        assert_verified(task, out, "--no-meshes-ok")


def test_no_step_writes_the_designed_outputs_without_linkage_step(tmp_path):
    """--no-step: OUT holds the URDF, linkage.json (``step`` false) and the meshes, the bytes of a run
    without the flag but for linkage.step and that key; the result lines are the same; with --no-design it
    is the kinematic outputs."""
    rnd = random.Random(5)
    jobs = [readme_job(rnd, i) for i in range(2)]
    path = tmp_path / "jobs.jsonl"
    path.write_text("".join(json.dumps({**j, "out": f"o{j['id']}"}) + "\n" for j in jobs))
    results = {}
    for flag in ("--no-step", None):
        base = tmp_path / (flag or "full")
        base.mkdir()
        r = run("batch", path, "--out-dir", base, "-q", *([flag] if flag else []))
        assert r.exit_code == 0, r.output
        results[flag] = r.stdout
    assert results["--no-step"] == results[None]
    for j in jobs:
        lean, full = tmp_path / "--no-step" / f"o{j['id']}", tmp_path / "full" / f"o{j['id']}"
        assert not (lean / "linkage.step").exists() and (lean / "meshes" / "coupler.stl").exists()
        for name in ["linkage.urdf"] + [f"meshes/{p.name}" for p in (full / "meshes").iterdir()]:
            assert (lean / name).read_bytes() == (full / name).read_bytes(), name
        doc, ref = (json.loads((d / "linkage.json").read_text()) for d in (lean, full))
        assert doc.pop("step") is False and (ref.pop("step") is (full / "linkage.step").exists()) and doc == ref
    assert Outputs.chosen(design=False, step=False) is Outputs.KINEMATIC
    assert "step" not in Outputs.NO_STEP.formats and "step" in Outputs.FULL.formats


def json_line(result) -> str:
    """The result line as the json module writes it (the reference of `dumps`)."""
    return json.dumps(result, separators=(",", ":"), allow_nan=False)


@pytest.mark.parametrize("value", [1e-05, 1.5e-07, 3e-9, 0.0001, 9.99e-05, 1e16, 1e-300, -0.0, 5e-324, 0.1, 2**63,
                                   2**70, "é", "\u2028", "a\x00b", "0.00001", [1e-5, {"x": 1.5e-7}]])
def test_result_lines_are_the_json_modules_bytes(value):
    """`dumps` (orjson where it is the same text) writes json.dumps' bytes, also for the floats and
    strings where orjson's own text differs; a non-finite float is the internal-error line."""
    from synth.tools.batchjobs import dumps

    res = {"id": value if not isinstance(value, list) else "x", "line": 3, "ok": True, "extent": 0.25,
           "checks": {"v": value}}
    assert dumps(res) == json_line(res)
    bad = dumps({"id": 1, "line": 4, "ok": True, "extent": float("nan")})
    assert json.loads(bad)["exit_code"] == 3


def test_result_lines_match_on_random_floats():
    """Property: random floats over 600 decades, both signs: `dumps` = json.dumps."""
    from hypothesis import given, settings, strategies as st

    from synth.tools.batchjobs import dumps

    @settings(max_examples=300, deadline=None)
    @given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=6), st.text(max_size=8))
    def check(xs, text):
        res = {"id": text, "line": 1, "ok": True, "extent": xs[0], "checks": dict(zip("abcdef", xs))}
        assert dumps(res) == json_line(res)

    check()


@pytest.mark.parametrize("text", ["\x7f", "a\x7fb", "\x1f", "\u00e9"])
def test_result_lines_match_on_the_characters_json_escapes(text):
    """DEL (0x7f) is ASCII, yet json.dumps escapes it and orjson does not (hypothesis found it in an id)."""
    from synth.tools.batchjobs import dumps

    res = {"id": text, "line": 1, "ok": True, "extent": 0.5}
    assert dumps(res) == json_line(res)


def test_orjson_writes_the_common_lines():
    """With orjson installed the usual result line (floats ~1e-15 and ~0.1, ASCII) is written by it."""
    pytest.importorskip("orjson")
    from synth.tools.resultlines import _orjson_line

    line = run_chunk([(1, mixed_lines(1)[0])], False, None)[0]
    assert line["ok"] and _orjson_line(line) == json_line(line)


def test_a_chunk_through_a_shared_slot_answers_as_through_the_pipe(monkeypatch):
    """`synth.tools.chunking`: a chunk put in a shared slot and run there (`run_in_slot`, here in this process)
    gives run_chunk_lines' text and codes; a chunk with a line over the limit, or one larger than a slot, is
    not put there; a result larger than a slot comes back as run_chunk_lines' own answer."""
    from synth.tools import chunking
    from synth.tools.batchjobs import run_chunk_lines

    rng = random.Random(5)
    raw = [json.dumps(readme_job(rng, i)).encode() for i in range(30)] + [b"", b"{bad"]
    want = run_chunk_lines((7, raw), False, None)
    slots = chunking.SharedSlots(2)
    try:
        where = slots.put((7, raw))
        assert where[0] in (0, 1) and where[1:] == (7, len(b"\n".join(raw)))
        text, codes = slots.answer(where[0], chunking.run_in_slot(run_chunk_lines, *where, False, None, True))
        assert (text, codes) == (want.text, want.codes)
        assert slots.put((1, raw[:3] + [None])) is None  # (a line over the limit: the pipe, as before)
        monkeypatch.setattr(chunking, "OUT_BYTES", 100)
        where = slots.put((7, raw))
        got = slots.answer(where[0], chunking.run_in_slot(run_chunk_lines, *where, False, None, True))
        assert (got.text, got.codes) == (want.text, want.codes)
        assert sorted(slots.free) == [0, 1]
        monkeypatch.setattr(chunking, "IN_BYTES", 100)
        assert slots.put((7, raw)) is None
    finally:
        slots.close()
