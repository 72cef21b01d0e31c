"""Issue #35, "nothing lost, nothing hung, nothing ambiguous": one regression test per root cause, and a
seeded hostile sweep (a sample in the default run, the rest marked slow).

Every hostile input must end as a clean exit 1 or 2 with one stderr line, or a correct output: never exit 3,
a hang, a lost or clobbered file, or a partial output."""
from __future__ import annotations

import json
import os
import random
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO, invoke, run_process

FIXTURE = REPO / "fixtures" / "bennett_quat.yaml"
POSES3 = [{"position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
          {"position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}},
          {"position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}}]


def one_line(code: int, err: str, expected=(2,)) -> None:
    assert code in expected, err
    assert "Traceback" not in err and "internal error" not in err, err
    assert len(err.strip().splitlines()) == 1, err


@pytest.fixture(scope="module")
def good_out(tmp_path_factory) -> Path:
    """A real output directory of the Bennett fixture (read-only for the tests: copy it to change it)."""
    root = tmp_path_factory.mktemp("good")
    code, _, err = invoke(["bennett", str(FIXTURE), "-o", "out", "-q"], root)
    assert code == 0, err
    return root / "out"


def copy_out(src: Path, dst: Path) -> Path:
    import shutil

    shutil.copytree(src, dst)
    return dst


# ------------------------------------------------------------------ the YAML loader
def test_base_60_scalar_is_a_string_read_in_linear_time():
    """PyYAML's YAML 1.1 base-60 integers took quadratic time (1M parts > 60 s)."""
    from synth.io.docload import load_document

    text = "a: " + ":".join(["1"] + ["0"] * 1_000_000)
    t0 = time.process_time()
    doc = load_document(text, "x.yaml", False)
    assert isinstance(doc["a"], str) and len(doc["a"]) == 2_000_001
    assert time.process_time() - t0 < 20  # seconds; quadratic parsing took > 60
    assert load_document("a: 1:30", "x", False) == {"a": "1:30"}  # YAML 1.2: a string, never 90
    assert load_document("a: [1e-3, 0x1f, 1_000, .5]", "x", False) == {"a": [0.001, 31, 1000, 0.5]}


def test_overlong_number_is_one_line_error():
    from synth.errors import InputError
    from synth.io.docload import load_document

    with pytest.raises(InputError, match="a number with 5000 characters"):
        load_document("a: " + "1" * 5000, "x.yaml", False)


def test_base_60_pose_file_and_curve_spec_exit_2(tmp_path):
    (tmp_path / "p.yaml").write_text("poses:\n  - position: [" + ":".join(["1"] + ["0"] * 200_000) + ", 0, 0]\n")
    (tmp_path / "c.yaml").write_text("curve:\n  x: " + ":".join(["1"] + ["0"] * 200_000) + "\n")
    for argv in (["bennett", "p.yaml"], ["curve", "c.yaml"], ["check", "nothing", "--poses", "p.yaml"]):
        code, _, err = run_process(argv, tmp_path, timeout=60)
        one_line(code, err)


@pytest.mark.parametrize("text", ['curve:\n  x: "1e400 - t^2"\n  y: "2*t"\n  z: "0"\n  w: "1 + t^2"\n',
                                  'motion:\n  expression: "t^2 + 1e400 + eps*(i + j*t)"\n'])
def test_1e400_in_curve_and_motion_specs_exit_2(tmp_path, text):
    (tmp_path / "s.yaml").write_text(text)
    code, _, err = invoke(["curve", "s.yaml", "-q"], tmp_path)
    one_line(code, err)
    assert "too large" in err


# ------------------------------------------------------------------ ownership and atomic replacement
def test_mpsynth_format_without_manifest_is_not_ours(good_out, tmp_path):
    out = copy_out(good_out, tmp_path / "out")
    (out / ".mpsynth-output").unlink()
    meshes = sorted(os.listdir(out / "meshes"))
    code, _, err = invoke(["bennett", str(FIXTURE), "-o", "out", "-q"], tmp_path)
    one_line(code, err)
    assert "not written by mpsynth" in err and sorted(os.listdir(out / "meshes")) == meshes


KILL_AT = {
    # where the writer dies (os._exit, as a SIGKILL would) -> which output must be there afterwards
    "carry_over": ("synth.io.atomic", "_carry_over", "old"),
    "after_swap": ("synth.io.atomic", "_remove", "new"),
}


@pytest.mark.parametrize("moment", sorted(KILL_AT))
def test_killed_replacement_leaves_old_or_new_never_a_mix(good_out, tmp_path, moment):
    """A rerun into an existing OUT killed at a moment of the commit: OUT is the old output or the new one,
    whole (the manifest lists exactly what is there), and the next run clears the temporaries."""
    module, name, expect = KILL_AT[moment]
    out = copy_out(good_out, tmp_path / "out")
    (out / "notes.txt").write_text("mine")
    script = textwrap.dedent(f"""
        import os, sys
        sys.argv = ["mpsynth", "bennett", {str(FIXTURE)!r}, "-o", "out", "-q", "--name", "second"]
        import {module} as m
        def die(*a, **k):
            os._exit(9)
        setattr(m, {name!r}, die)
        from cli.main import main
        main()
    """)
    p = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=dict(os.environ, PYTHONPATH=str(REPO)),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 9, p.stderr
    name_in_urdf = 'name="second"' in (out / "linkage.urdf").read_text()
    assert name_in_urdf == (expect == "new")
    manifest = json.loads((out / ".mpsynth-output").read_text())["files"]
    for rel in manifest:
        assert (out / rel).is_file(), rel
    stl = {f"meshes/{p.name}" for p in (out / "meshes").iterdir()}
    assert stl == {f for f in manifest if f.startswith("meshes/")}
    assert (out / "notes.txt").read_text() == "mine"
    code, _, err = invoke(["bennett", str(FIXTURE), "-o", "out", "-q", "--name", "third"], tmp_path)
    assert code == 0, err
    assert sorted(os.listdir(tmp_path)) == ["out"]  # the dead writer's temporaries are gone
    assert (out / "notes.txt").read_text() == "mine"


def test_two_rename_fallback_is_repaired_by_the_next_run(good_out, tmp_path, monkeypatch):
    """Without RENAME_EXCHANGE the swap takes two renames; a writer killed between them leaves OUT missing
    beside its -old- directory, which the next writer puts back before anything else."""
    from synth.io import atomic

    out = copy_out(good_out, tmp_path / "out")
    before = (out / "linkage.urdf").read_text()
    aside = tmp_path / f".out.mpsynth-old-{2**22 + 12345}-x"  # a pid that does not run
    aside.mkdir()
    os.rename(out, aside / "old")
    removed = atomic.remove_stale_temporaries(out)
    assert removed == [aside] and (out / "linkage.urdf").read_text() == before
    monkeypatch.setattr(atomic, "exchange", lambda a, b: False)
    with atomic.atomic_directory(out) as tmp:
        (tmp / "x.txt").write_text("new")
    assert (out / "x.txt").read_text() == "new" and sorted(os.listdir(tmp_path)) == ["out"]


def test_working_directory_is_never_swapped(tmp_path):
    (tmp_path / "keep.txt").write_text("keep")
    code, _, err = run_process(["bennett", str(FIXTURE), "-o", ".", "-q", "--force"], tmp_path)
    one_line(code, err)
    assert "working directory" in err and os.listdir(tmp_path) == ["keep.txt"]


# ------------------------------------------------------------------ single-file outputs
@pytest.mark.parametrize("kind", ["symlink", "fifo", "directory", "device"])
def test_single_file_output_never_replaces_a_non_regular_file(tmp_path, kind):
    from synth.errors import InputError
    from synth.io.atomic import atomic_write

    target = tmp_path / "target"
    if kind == "symlink":
        (tmp_path / "real").write_text("real")
        target.symlink_to(tmp_path / "real")
    elif kind == "fifo":
        os.mkfifo(target)
    elif kind == "directory":
        target.mkdir()
    else:
        target = Path("/dev/null")
    with pytest.raises(InputError):
        atomic_write(target, lambda tmp: Path(tmp).write_text("x"))
    assert os.path.lexists(target) and not stat.S_ISREG(os.lstat(target).st_mode)
    assert [p for p in os.listdir(tmp_path) if p.endswith(".tmp")] == []


def test_single_file_output_honours_the_umask(tmp_path):
    from synth.io.atomic import atomic_write

    old = os.umask(0o027)
    try:
        atomic_write(tmp_path / "f.txt", lambda tmp: Path(tmp).write_text("x"))
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "f.txt").st_mode) == 0o640


@pytest.mark.parametrize("argv", [["view", "OUT", "-o", "/dev/null"], ["trajectory", "OUT", "-o", "/dev/null"],
                                  ["render", "OUT", "--png", "/dev/null"], ["view", "OUT", "-o", "sub"],
                                  ["bennett", str(FIXTURE), "-o", ""], ["view", "OUT", "-o", ""],
                                  ["view", "OUT", "-o", "x" * 300 + ".html"]])
def test_single_file_targets_exit_2(good_out, tmp_path, argv):
    (tmp_path / "sub").mkdir()
    argv = [str(good_out) if a == "OUT" else a for a in argv]
    code, _, err = invoke(argv, tmp_path)
    one_line(code, err)
    assert sorted(os.listdir(tmp_path)) == ["sub"] and not os.listdir(tmp_path / "sub")


# ------------------------------------------------------------------ sizes, one check
@pytest.mark.parametrize("key,value", [("pin_radius", 1e8), ("pin_radius", 1e-9), ("pin_length", 1e300),
                                       ("pin_length", 1e-7), ("link_radius", 1e-300), ("link_radius", 1e6)])
def test_absurd_sizes_are_refused_by_the_cli_and_batch_alike(tmp_path, key, value):
    from synth.tools.batchjobs import run_job

    job = {"kind": "bennett", "poses": POSES3, "units": {"length": "mm"}, "out": "o", key: value}
    res = run_job((1, json.dumps(job)), out_dir=tmp_path)
    assert (res["ok"], res["exit_code"]) == (False, 2), res
    assert "out of range" in res["error"] or "must be a positive" in res["error"], res
    assert os.listdir(tmp_path) == []
    code, _, err = invoke(["bennett", str(REPO / "fixtures" / "bennett_mm_deg.yaml"), "-o", "o", "-q",
                           f"--{key.replace('_', '-')}", repr(value)], tmp_path)
    one_line(code, err)
    assert ("out of range" in err or "must be a positive" in err) and os.listdir(tmp_path) == []


def test_size_check_worked_numbers():
    from synth.design.sizes import check_extent, check_sizes
    from synth.errors import InputError

    check_sizes({"pin_radius": 1e-6, "link_radius": 10.0, "clearance": 0.0}, 1.0)  # the bounds themselves
    for sizes in ({"pin_radius": 0.99e-6}, {"link_radius": 10.01}, {"clearance": 10.01}, {"pin_length": float("nan")}):
        with pytest.raises(InputError):
            check_sizes(sizes, 1.0)
    check_extent(1e-5)
    with pytest.raises(InputError, match="below"):
        check_extent(0.9e-5)


def test_batch_out_with_a_lone_surrogate_or_a_long_component(tmp_path):
    from synth.tools.batchjobs import run_job

    for out in ("a\ud800b", "x" * 300, "d/" + "y" * 256):
        res = run_job((1, json.dumps({"kind": "bennett", "poses": POSES3, "out": out})), out_dir=tmp_path)
        assert (res["ok"], res["exit_code"]) == (False, 2), res
        assert "\n" not in res["error"]
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ option bounds
@pytest.mark.parametrize("argv", [["trajectory", "OUT", "--speed", "1e-12"], ["trajectory", "OUT", "--speed", "1e-4"],
                                  ["trajectory", "OUT", "--duration", "1e308"],
                                  ["trajectory", "OUT", "--through-poses", "--dwell", "1e300"],
                                  ["render", "OUT", "--png", "x.png", "--azim", "inf"],
                                  ["render", "OUT", "--png", "x.png", "--elev", "nan"],
                                  ["simulate", "OUT", "--timestep", "1e-9"], ["simulate", "OUT", "--tol", "nan"]])
def test_option_bounds_exit_2(good_out, tmp_path, argv):
    argv = [str(good_out) if a == "OUT" else a for a in argv]
    code, _, err = invoke(argv, tmp_path)
    one_line(code, err)
    assert os.listdir(tmp_path) == []


# ------------------------------------------------------------------ readers of an output directory
def _corrupt(out: Path, how: str) -> None:
    import struct

    doc = json.loads((out / "linkage.json").read_text())
    if how == "string angle":
        jn = next(iter(doc["poses"][0]["joint_angles"]))
        doc["poses"][0]["joint_angles"][jn] = "abc"
        (out / "linkage.json").write_text(json.dumps(doc))
    elif how == "deep json":
        (out / "linkage.json").write_text("[" * 1_000_000 + "]" * 1_000_000)
    elif how == "huge json":
        with open(out / "linkage.json", "ab") as fh:
            fh.truncate(2 * 1024 ** 3)  # sparse: 2 GB without the disk
    elif how == "zero axis":
        text = (out / "linkage.urdf").read_text()
        i = text.index('<axis xyz="')
        j = text.index('"', i + 11)
        (out / "linkage.urdf").write_text(text[:i] + '<axis xyz="0 0 0' + text[j:])
    else:
        stl = sorted((out / "meshes").glob("*.stl"))[0]
        data = bytearray(stl.read_bytes())
        if how == "truncated stl":
            data = data[:2000]
        else:
            data[96:100] = struct.pack("<f", float("nan"))
        stl.write_bytes(bytes(data))


@pytest.mark.parametrize("how", ["string angle", "deep json", "huge json", "zero axis", "truncated stl", "nan stl"])
def test_readers_validate_and_bound_what_they_read(good_out, tmp_path, how):
    out = copy_out(good_out, tmp_path / "bad")
    _corrupt(out, how)
    code, _, err = invoke(["collide", "bad"], tmp_path)
    one_line(code, err)
    code, _, err = invoke(["render", "bad", "--png", "x.png"], tmp_path)
    one_line(code, err)
    code, _, err = invoke(["check", "bad"], tmp_path)
    assert code in (1, 2) and "Traceback" not in err and "internal error" not in err, err
    assert not (tmp_path / "x.png").exists()


# ------------------------------------------------------------------ ambiguous input
@pytest.mark.parametrize("text,hint", [
    ("poses:\n  - {position: [0, 0, 0], rpy: [180, 0, 0]}\n", "units: {angle: deg}"),
    ("poses:\n  - {position: [0, 0, 0], axis_angle: {axis: [0, 0, 1], angle: 90}}\n", "units: {angle: deg}"),
    ("poses:\n  - {position: [0, 0, 0], quaternion: [0, 0, 0, 1]}\n", "quaternion_order"),
    ("poses:\n  - {position: [0, 0, 0], rpy: [0, 0, 0]}\n  - {position: [120, 40, 0], rpy: [0, 0, 1]}\n",
     "units: {length: mm}"),
    ("poses:\n  - {position: [0, 0, 0], orientation: {x: 0, y: 0, z: 0}}\n", "give w, x, y, z"),
    ("poses:\n  - {position: [0, 0, 0], quaterion: {w: 1, x: 0, y: 0, z: 0}}\n", "valid keys: name, position"),
])
def test_ambiguous_input_is_an_error_with_a_hint(text, hint):
    from synth.errors import InputError
    from synth.io.poses import load_poses

    with pytest.raises(InputError) as e:
        load_poses("p.yaml", text=text)
    assert hint in str(e.value) and "\n" not in str(e.value)


def test_explicit_units_and_orders_are_read_as_given():
    from synth.io.poses import load_poses

    ps = load_poses("p.yaml", text="units: {angle: deg, length: mm}\nquaternion_order: xyzw\nposes:\n"
                                   "  - {position: [0, 0, 0], rpy: [180, 0, 0]}\n"
                                   "  - {position: [120, 40, 0], quaternion: [0, 0, 0, 1]}\n"
                                   "  - {position: {x: 1, y: 2, z: 3}, orientation: {x: 1, y: 0, z: 0, w: 0}}\n")
    np.testing.assert_allclose(ps.matrices[0][:3, :3], np.diag([1, -1, -1]), atol=1e-15)
    np.testing.assert_allclose(ps.matrices[1][:3, :3], np.eye(3), atol=1e-15)  # x, y, z, w: the identity
    np.testing.assert_allclose(ps.matrices[1][:3, 3], [0.12, 0.04, 0], atol=1e-15)
    np.testing.assert_allclose(ps.matrices[2][:3, :3], np.diag([1, -1, -1]), atol=1e-15)
    np.testing.assert_allclose(ps.matrices[2][:3, 3], [1e-3, 2e-3, 3e-3], atol=1e-15)


# ------------------------------------------------------------------ workers die with their parent
def _descendants(pid: int) -> set[int]:
    kids: dict[int, list[int]] = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                fields = Path(f"/proc/{d}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            kids.setdefault(int(fields[1]), []).append(int(d))
    out, todo = set(), [pid]
    while todo:
        for c in kids.get(todo.pop(), []):
            out.add(c)
            todo.append(c)
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_batch_workers_die_with_a_killed_parent(tmp_path):
    lines = "".join(json.dumps({"id": i, "kind": "bennett", "poses": POSES3, "out": f"o{i}"}) + "\n"
                    for i in range(40))
    (tmp_path / "jobs.jsonl").write_text(lines)
    p = subprocess.Popen([sys.executable, "-m", "cli.main", "batch", "jobs.jsonl", "-j", "2", "-q"], cwd=tmp_path,
                         env=dict(os.environ, PYTHONPATH=str(REPO)), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    t0 = time.monotonic()
    family: set[int] = set()
    while time.monotonic() - t0 < 60 and len([q for q in family if _alive(q)]) < 2:  # the two workers (forked
        family |= _descendants(p.pid)  # from the batch process on Linux; elsewhere a fork server's children too)
        time.sleep(0.05)
    assert len(family) >= 2, "the pool did not start"
    p.send_signal(signal.SIGKILL)
    p.wait()
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and any(_alive(q) for q in family):
        time.sleep(0.1)
    assert not [q for q in family if _alive(q)]
    err = p.stderr.read().decode()
    assert "Traceback" not in err and "BrokenPipeError" not in err, err


# ------------------------------------------------------------------ same result on a loaded machine
def test_same_linkage_json_when_the_clock_runs_slow(tmp_path, monkeypatch):
    """No CPU or wall-clock budget decides a result: every clock running 1000x slow (as on a fully loaded
    machine) gives the same linkage.json byte for byte."""
    code, _, err = invoke(["bennett", str(FIXTURE), "-o", "a", "-q"], tmp_path)
    assert code == 0, err
    base = {name: getattr(time, name) for name in ("process_time", "perf_counter", "monotonic", "time")}
    start = {name: f() for name, f in base.items()}
    for name, f in base.items():
        monkeypatch.setattr(time, name, lambda f=f, s=start[name]: s + 1000.0 * (f() - s))
    code, _, err = invoke(["bennett", str(FIXTURE), "-o", "b", "-q"], tmp_path)
    assert code == 0, err
    assert (tmp_path / "a" / "linkage.json").read_bytes() == (tmp_path / "b" / "linkage.json").read_bytes()


# ------------------------------------------------------------------ the seeded hostile sweep
def hostile_case(rng: random.Random) -> list[str]:
    """One hostile command line from the families of issue #35."""
    n = lambda: rng.choice(["1e8", "1e-9", "1e300", "1e-300", "inf", "nan", "-1", "0", "1e6"])  # noqa: E731
    return rng.choice([
        lambda: ["trajectory", "OUT", rng.choice(["--speed", "--duration", "--rate", "--dwell"]), n()],
        lambda: ["render", "OUT", "--png", rng.choice(["x.png", "", "/dev/null", "sub"]),
                 rng.choice(["--azim", "--elev"]), n()],
        lambda: ["simulate", "OUT", rng.choice(["--timestep", "--tol", "--seconds"]), n()],
        lambda: ["bennett", str(REPO / "fixtures" / "bennett_mm_deg.yaml"), "-o", rng.choice(["o", "", "x" * 256]),
                 rng.choice(["--pin-radius", "--pin-length", "--link-radius", "--clearance"]), n()],
        lambda: ["view", "OUT", "-o", rng.choice(["/dev/null", "sub", "", "v.html", "y" * 300])],
        lambda: ["collide", "OUT", "--range", rng.choice(["task", "full"])],
    ])()


def hostile_sweep(tmp_path: Path, good: Path, seed: int, n: int) -> None:
    rng = random.Random(seed)
    for i in range(n):
        work = tmp_path / f"r{i}"
        (work / "sub").mkdir(parents=True)
        argv = [str(good) if a == "OUT" else a for a in hostile_case(rng)]
        code, _, err = invoke(argv, work)
        what = f"{argv} -> {code}: {err}"
        assert code in (0, 1, 2) and "Traceback" not in err and "internal error" not in err, what
        if code == 2:
            assert len(err.strip().splitlines()) == 1, what
            assert sorted(os.listdir(work)) == ["sub"] and not os.listdir(work / "sub"), what


def test_hostile35_sample(good_out, tmp_path):
    hostile_sweep(tmp_path, good_out, seed=35, n=6)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_hostile35_sweep(good_out, tmp_path, seed):
    hostile_sweep(tmp_path, good_out, seed=3500 + seed, n=40)


def test_collide_checks_the_claimed_range_unless_told(good_out, tmp_path):
    """`collide` defaults to the range linkage.json claims (this design: the full cycle); --range task
    checks the driver's arc through the task poses only."""
    pytest.importorskip("fcl")
    claim = json.loads((good_out / "linkage.json").read_text())["collision"]["range"]
    for argv, span in (([], claim), (["--range", "task"], "task"), (["--range", "full"], "full")):
        code, out, err = invoke(["collide", str(good_out), "--steps", "24", "--json", *argv], tmp_path)
        assert code in (0, 1), err
        assert json.loads(out)["range"] == span
        assert ("of the task range" in err) == (span == "task")
