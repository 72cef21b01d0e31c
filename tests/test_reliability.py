"""Reliability (issue 20): no lost user files, batch isolation, bounded input, no internal errors on
odd input or environments, no leftovers after signals. One regression test per reported defect, then a
seeded hostile sweep (a small sample by default, the long one marked slow)."""
from __future__ import annotations

import errno
import json
import os
import random
import select
import shutil
import signal
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from synth.design.choose import design_for
from synth.errors import InputError, OutputError
from synth.io import writer as writer_mod
from synth.io.docload import open_lines, read_lines
from synth.io.names import check_package, check_robot_name, safe_robot_name
from synth.tools.batchjobs import run_job, worker_count

from conftest import REPO, random_poses, run_process

FIXTURE = REPO / "fixtures" / "bennett_mm_deg.yaml"
POSES3 = [{"position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
          {"position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}},
          {"position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}}]


def one_line_error(code, err, expected=(2,)):
    assert code in expected, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def job(**kw):
    return json.dumps({"kind": "bennett", "poses": POSES3, **kw})


@pytest.fixture(scope="module")
def bennett():
    from synth.synthesis.bennett import bennett as synth_bennett

    T = random_poses(np.random.default_rng(11), 3)
    return synth_bennett(T, ["a", "b", "c"])


# ---------------------------------------------------------------- data loss

def test_rerun_keeps_user_files_beside_the_output(tmp_path):
    """notes, a CAD folder and simulate's linkage.mjcf.xml survive a second run without --force."""
    code, _, err = run_process(["bennett", FIXTURE, "-o", "out", "-q"], tmp_path)
    assert code == 0, err
    out = tmp_path / "out"
    (out / "notes.txt").write_text("mine")
    (out / "cad").mkdir()
    (out / "cad" / "part.step").write_text("solid")
    (out / "linkage.mjcf.xml").write_text("<mujoco/>")
    code, _, err = run_process(["bennett", FIXTURE, "-o", "out", "-q", "--name", "again"], tmp_path)
    assert code == 0, err
    assert (out / "notes.txt").read_text() == "mine" and (out / "cad" / "part.step").read_text() == "solid"
    assert (out / "linkage.mjcf.xml").read_text() == "<mujoco/>"
    assert 'name="again"' in (out / "linkage.urdf").read_text()
    files = json.loads((out / writer_mod.MARKER).read_text())["files"]
    assert "notes.txt" not in files and "linkage.urdf" in files
    assert sorted(os.listdir(tmp_path)) == ["out"]


def test_thesis_beside_an_output_without_manifest_is_kept(tmp_path, bennett):
    """A directory whose linkage.json merely has an mpsynth format (no manifest) is not mpsynth's (#35):
    refused without --force, its meshes kept; with --force every file of the user's survives."""
    out = tmp_path / "OUT"
    writer_mod.write_output(bennett, out, robot_name="a", result=design_for(bennett))
    (out / writer_mod.MARKER).unlink()
    (out / "thesis.tex").write_text("years of work")
    meshes = sorted(os.listdir(out / "meshes"))
    with pytest.raises(InputError, match="not written by mpsynth"):
        writer_mod.write_output(bennett, out, robot_name="b", result=design_for(bennett))
    assert sorted(os.listdir(out / "meshes")) == meshes
    writer_mod.write_output(bennett, out, robot_name="b", force=True, result=design_for(bennett))
    assert (out / "thesis.tex").read_text() == "years of work"


def test_force_into_the_working_directory_deletes_nothing(tmp_path):
    (tmp_path / "jobs.jsonl").write_text("keep")
    (tmp_path / "linkage.urdf").write_text("the user's own URDF")
    code, _, err = run_process(["bennett", FIXTURE, "-o", ".", "-q"], tmp_path)
    one_line_error(code, err)  # foreign directory: refused without --force
    assert (tmp_path / "linkage.urdf").read_text() == "the user's own URDF"
    code, _, err = run_process(["bennett", FIXTURE, "-o", ".", "-q", "--force"], tmp_path)
    one_line_error(code, err)  # the working directory cannot be replaced as a whole (#35)
    assert "working directory" in err
    assert (tmp_path / "jobs.jsonl").read_text() == "keep"
    assert (tmp_path / "linkage.urdf").read_text() == "the user's own URDF"


def test_a_users_file_where_mpsynth_would_write_is_refused_without_force(tmp_path, bennett):
    out = tmp_path / "OUT"
    writer_mod.write_output(bennett, out, robot_name="a", result=design_for(bennett))
    names = json.loads((out / writer_mod.MARKER).read_text())["files"]
    (out / "meshes" / "mine.stl").write_text("user mesh")  # not listed: kept, never replaced
    writer_mod.write_output(bennett, out, robot_name="b", result=design_for(bennett))
    assert (out / "meshes" / "mine.stl").read_text() == "user mesh"
    assert json.loads((out / writer_mod.MARKER).read_text())["files"] == names


def test_batch_out_dot_with_force_keeps_the_working_directory(tmp_path):
    lines = [job(id="a", out=".", force=True), job(id="b", out="..", force=True), job(id="c", out="x/../.."),
             job(id="d", out="jobs.jsonl", force=True), job(id="e", out="results.jsonl", force=True)]
    (tmp_path / "jobs.jsonl").write_text("\n".join(lines) + "\n")
    with open(tmp_path / "results.jsonl", "wb") as fh:
        code, _, err = run_process(["batch", "jobs.jsonl", "-q"], tmp_path, stdout=fh)
    assert code == 1, err  # the jobs failed, the batch did not lie about it
    results = [json.loads(s) for s in (tmp_path / "results.jsonl").read_text().splitlines()]
    assert [(r["id"], r["ok"], r["exit_code"]) for r in results] == [(k, False, 2) for k in "abcde"]
    assert sorted(os.listdir(tmp_path)) == ["jobs.jsonl", "results.jsonl"]


# ---------------------------------------------------------------- batch isolation

def test_out_of_range_id_is_one_result_and_echoed_as_text(tmp_path):
    text = job(id=1).replace('"id": 1', '"id": 1e400') + "\n" + job(id="next") + "\n"
    code, out, err = run_process(["batch", "-", "-q"], tmp_path, input=text.encode())
    assert code == 0, err
    res = [json.loads(s) for s in out.splitlines()]
    assert [(r["id"], r["line"], r["ok"]) for r in res] == [("1e400", 1, True), ("next", 2, True)]


def test_cr_inside_a_line_does_not_split_it(tmp_path):
    text = '{"id": "a\r", "kind":\r "bennett"}\n' + job(id="b") + "\r\n" + job(id="c") + "\n"
    code, out, err = run_process(["batch", "-", "-q"], tmp_path, input=text.encode())
    res = [json.loads(s) for s in out.splitlines()]
    assert [r["line"] for r in res] == [1, 2, 3] and [r["ok"] for r in res] == [False, True, True], out
    assert res[1]["id"] == "b" and res[2]["id"] == "c" and code == 1


@pytest.mark.parametrize("blank", [" ", "\t", "\r", "\x0b", "\x0c", "\x1c", "\u2028", "\u00a0", "\u3000", ""])
def test_every_line_gets_exactly_one_result(blank):
    lines = [job(id=1), blank, job(id=3)]
    res = [run_job((n, t)) for n, t in enumerate(lines, 1)]
    assert [r["line"] for r in res] == [1, 2, 3]
    assert res[1]["ok"] is (blank.strip(" \t\r") == "") and (res[1].get("skipped") or res[1]["exit_code"] == 2)


def test_out_may_not_escape_the_base_directory(tmp_path):
    base = tmp_path / "base"
    base.mkdir()
    (tmp_path / "outside").mkdir()
    (base / "link").symlink_to(tmp_path / "outside")
    for out in ("../x", str(tmp_path / "abs"), "a/../../x", "link/x", ".", "a/..", "~/x", "x\u0000y"):
        res = run_job((1, job(out=out)), out_dir=base)
        assert res["ok"] is False and res["exit_code"] == 2 and "'out'" in res["error"], (out, res)
    assert sorted(os.listdir(tmp_path)) == ["base", "outside"] and os.listdir(tmp_path / "outside") == []
    assert sorted(os.listdir(base)) == ["link"]
    res = run_job((1, job(out="deep/er/x", poses=POSES3[:2])), out_dir=base)  # a failed job: no parents left
    assert not res["ok"] and sorted(os.listdir(base)) == ["link"]
    res = run_job((1, job(out="deep/er/x")), out_dir=base)
    assert res["ok"] and (base / "deep" / "er" / "x" / "linkage.urdf").is_file()


def test_workers_are_capped_by_jobs_and_cpus(tmp_path):
    assert worker_count(1024, 2) <= 2 and worker_count(64, None) <= (os.cpu_count() or 1)
    assert worker_count(0, 1) == 1 and worker_count(1, 0) == 1
    (tmp_path / "j.jsonl").write_text(job(id=1) + "\n" + job(id=2) + "\n")
    code, out, err = run_process(["batch", "j.jsonl", "-j", "1024"], tmp_path)
    assert code == 0 and len(out.splitlines()) == 2 and err.rstrip().endswith("-j 2)"), err


# ---------------------------------------------------------------- bounded input

class Endless:
    """A binary stream of ``n`` bytes without a newline (like /dev/zero), then b"\\n{}"."""

    def __init__(self, n):
        self.left = n
        self.tail = b"\n{}"

    def read(self, k):
        if self.left <= 0:
            t, self.tail = self.tail, b""
            return t
        k = min(k, self.left)
        self.left -= k
        return b"\0" * k


def test_an_overlong_line_is_read_without_holding_it():
    tracemalloc.start()
    try:
        lines = list(read_lines(Endless(64 << 20), limit=1 << 20))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert lines == [(1, None), (2, "{}")]
    assert peak < 8 << 20, f"peak {peak / 1e6:.1f} MB while skipping a 64 MB line"
    res = run_job(lines[0])
    assert res == {"id": None, "line": 1, "ok": False, "exit_code": 2, "error": "line is longer than 10 MB"}


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/full"])
def test_endless_devices_are_refused_and_dev_null_is_empty(tmp_path, device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    with pytest.raises(InputError, match="is a device"):
        open_lines(device)
    code, _, err = run_process(["batch", device], tmp_path, timeout=30)
    one_line_error(code, err)
    code, out, err = run_process(["batch", os.devnull, "-q"], tmp_path, timeout=30)
    assert code == 0 and out == "" and err == ""


def test_a_pipe_is_read_lazily_and_never_counted(tmp_path):
    r, w = os.pipe()
    os.write(w, job(id=1).encode() + b"\n")
    os.close(w)
    if not os.path.exists(f"/proc/self/fd/{r}"):
        os.close(r)
        pytest.skip("no /proc/self/fd")
    try:
        stream, total = open_lines(f"/proc/self/fd/{r}")
        with stream:
            assert total is None and [n for n, _ in read_lines(stream)] == [1]
    finally:
        os.close(r)


def test_an_11_mb_line_is_a_failed_result_and_the_batch_goes_on(tmp_path):
    (tmp_path / "j.jsonl").write_bytes(b'{"id": "' + b"x" * (11 << 20) + b'"}\n' + job(id="ok").encode() + b"\n")
    code, out, err = run_process(["batch", "j.jsonl", "-q"], tmp_path)
    res = [json.loads(s) for s in out.splitlines()]
    assert code == 1 and [(r["line"], r["ok"]) for r in res] == [(1, False), (2, True)]
    assert "10 MB" in res[0]["error"]


# ---------------------------------------------------------------- internal errors on odd input

@pytest.mark.parametrize("args", [["bennett", "-"], ["batch", "-"], ["factor", "-"]])
def test_closed_stdin(tmp_path, args):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.run([sys.executable, "-c", "import os, sys; os.close(0); from cli.main import main; main()",
                        *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    assert p.returncode in (1, 2) and "Traceback" not in p.stderr and "internal error" not in p.stderr, p.stderr


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("args", [["bennett", FIXTURE, "--json", "-q"], ["batch", "j.jsonl", "-q"]])
def test_stdout_on_a_full_device(tmp_path, args):
    (tmp_path / "j.jsonl").write_text(job(id=1) + "\n")
    with open("/dev/full", "wb") as full:
        code, _, err = run_process(args, tmp_path, stdout=full)
    one_line_error(code, err)
    assert "No space left" in err


@pytest.mark.parametrize("args", [["bennett", FIXTURE, "--json", "-q"], ["batch", "j.jsonl", "-q"]])
@pytest.mark.parametrize("how", ["os.close(1)", "sys.stdout = None"])
def test_closed_stdout(tmp_path, args, how):
    (tmp_path / "j.jsonl").write_text(job(id=1) + "\n")
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.run([sys.executable, "-c", f"import os, sys; {how}; from cli.main import main; main()",
                        *map(str, args)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60)
    one_line_error(p.returncode, p.stderr)


@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="needs /dev/null")
def test_force_never_replaces_a_device(tmp_path):
    code, _, err = run_process(["bennett", FIXTURE, "-q", "-o", "/dev/null", "--force"], tmp_path)
    one_line_error(code, err)
    assert "special file" in err and Path("/dev/null").is_char_device()


def test_disk_full_while_writing_leaves_nothing(tmp_path, bennett, monkeypatch):
    import synth.io.urdf as urdf_mod

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(urdf_mod, "urdf_text", full)
    with pytest.raises(OutputError, match="No space left on device"):
        writer_mod.write_output(bennett, tmp_path / "OUT", robot_name="b", result=design_for(bennett))
    assert os.listdir(tmp_path) == []


def _small_tmpfs(path: Path, size: str) -> bool:
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    path.mkdir()
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)], capture_output=True)
    return p.returncode == 0


def test_disk_full_on_a_real_small_file_system(tmp_path):
    disk = tmp_path / "disk"
    if not _small_tmpfs(disk, "64k"):
        pytest.skip("mounting a tmpfs is not permitted here")
    try:
        (disk / "keep.txt").write_text("mine")
        code, _, err = run_process(["bennett", FIXTURE, "-o", disk / "out", "-q"], tmp_path)
        one_line_error(code, err)
        assert os.listdir(disk) == ["keep.txt"]  # nothing partial, no temporary directory
        (tmp_path / "j.jsonl").write_text(job(id=1, out="a/b") + "\n" + job(id=2) + "\n")
        code, out, err = run_process(["batch", "j.jsonl", "-q", "--out-dir", disk], tmp_path)
        res = [json.loads(s) for s in out.splitlines()]
        assert code == 1 and [(r["ok"], r.get("exit_code")) for r in res] == [(False, 2), (True, None)], out
        assert "No space left" in res[0]["error"] and os.listdir(disk) == ["keep.txt"]
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


@pytest.mark.parametrize("opt,value", [("--name", b"\xff\xfe"), ("--name", b"a\x01b"), ("--name", b"a\x1b[31m"),
                                       ("--name", b""), ("--package", b"a/b"), ("--package", b"../../evil"),
                                       ("--package", b"My_Pkg"), ("--package", b"a\nb")])
def test_bad_name_or_package_is_a_clear_error(tmp_path, opt, value):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.run([sys.executable.encode(), b"-m", b"cli.main", b"bennett", str(FIXTURE).encode(),
                        b"-o", b"out", opt.encode(), value], cwd=tmp_path, env=env, capture_output=True, timeout=120)
    err = p.stderr.decode("utf-8", "replace")
    one_line_error(p.returncode, err)
    assert opt in err and os.listdir(tmp_path) == []


def test_names_module():
    assert check_robot_name("Bennett 4R – π") == "Bennett 4R – π" and check_package("my_pkg2") == "my_pkg2"
    assert check_package(None) is None
    for bad in ("", " a", "a\x00", "\udcff", "x" * 201):
        with pytest.raises(InputError):
            check_robot_name(bad)
    for bad in ("", "1abc", "a-b", "a.b", "A", "é"):
        with pytest.raises(InputError):
            check_package(bad)
    assert safe_robot_name("a\udcffb\x07") == "a_b_" and safe_robot_name("\x00") == "_" and safe_robot_name("") == "linkage"


def test_non_utf8_pose_file_name_gives_a_valid_default_name(tmp_path):
    name = os.fsdecode(b"poses\xff")
    shutil.copy(FIXTURE, tmp_path / (name + ".yaml"))
    code, _, err = run_process(["bennett", name + ".yaml", "-o", "out", "-q"], tmp_path)
    assert code == 0, err
    assert '<robot name="poses' in (tmp_path / "out" / "linkage.urdf").read_text(encoding="utf-8")


def test_batch_name_with_control_characters_is_a_failed_result(tmp_path):
    res = run_job((1, job(id=1, name="a\u0007b")))
    assert res["ok"] is False and res["exit_code"] == 2 and "control character" in res["error"]
    res = run_job((1, job(id="x\u0007", out="o")), out_dir=tmp_path)  # the default name (the id) is cleaned
    assert res["ok"] and '<robot name="x_">' in (tmp_path / "o" / "linkage.urdf").read_text()


# ---------------------------------------------------------------- leftovers, signals

def test_stale_temporaries_of_dead_writers_are_removed(tmp_path, bennett):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead_pid = int(dead.stdout)
    stale = tmp_path / f".OUT.mpsynth-tmp-{dead_pid}-abc"
    stale.mkdir()
    (stale / "linkage.urdf").write_text("half")
    old = tmp_path / ".OUT.mpsynth-tmp-xyz"  # an earlier version's name, without the pid: by age
    old.mkdir()
    os.utime(old, (time.time() - 2 * writer_mod.STALE_AGE,) * 2)
    alive = tmp_path / f".OUT.mpsynth-tmp-{os.getppid()}-live"  # a running writer's: kept
    alive.mkdir()
    other = tmp_path / f".OTHER.mpsynth-tmp-{dead_pid}-abc"  # another OUT's: not ours to judge now
    other.mkdir()
    writer_mod.write_output(bennett, tmp_path / "OUT", robot_name="b", result=design_for(bennett))
    assert sorted(os.listdir(tmp_path)) == sorted(["OUT", alive.name, other.name])


def _launch(args, cwd):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.Popen([sys.executable, "-m", "cli.main", *map(str, args)], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


@pytest.mark.parametrize("sig,code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_to_a_parallel_batch_is_quiet(tmp_path, sig, code):
    sixbar = {"kind": "sixbar", "poses": POSES3 + [{"position": [-1, 0.5, 0], "quaternion": {"w": 0.2, "x": 0.4, "y": 0.4, "z": 0.8}}]}
    (tmp_path / "j.jsonl").write_text("".join(json.dumps({"id": i, **sixbar}) + "\n" for i in range(400)))
    p = _launch(["batch", "j.jsonl", "-j", "2"], tmp_path)
    # signal the batch once its workers deliver results (a fixed sleep raced the start of the worker pool on a
    # loaded machine, e.g. with pytest-xdist: the forkserver then reports a missing semaphore of the dead parent)
    started = select.select([p.stdout], [], [], 300)[0]  # (waits without reading)
    time.sleep(0.5)
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    err = err.decode()
    assert started and p.returncode == code and "Traceback" not in err and "Error" not in err, err
    for line in out.decode().splitlines():
        json.loads(line)  # whole result lines only


def test_interrupt_while_importing_is_one_line():
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.run([sys.executable, "-c", "import cli.main; raise KeyboardInterrupt"], env=env,
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and p.stderr == "mpsynth: interrupted\n"


# ---------------------------------------------------------------- seeded hostile sweep

def hostile_lines(rng: random.Random, n: int) -> list[bytes]:
    """Malformed and odd job lines (never containing \\n): broken JSON, random bytes, odd ids, odd paths."""
    good = job(id=0).encode()
    odd_out = ["../up", "/abs", ".", "", " ", "a/../..", "a\\b", "con", "x" * 300, "ü/ß", "~", "a//b", "-rf"]
    odd_id = ["1e400", "-1e999", "1" * 5000, "true", "null", "[1]", "{}", '"\\ud800"', '"a\\u0000b"', "0.1"]
    out = []
    for i in range(n):
        kind = rng.randrange(8)
        if kind == 0:
            b = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 80))).replace(b"\n", b"")
        elif kind == 1:
            b = good[: rng.randrange(len(good))]
        elif kind == 2:
            b = good.replace(b'"id": 0', b'"id": ' + rng.choice(odd_id).encode())
        elif kind == 3:
            b = job(id=i, out=rng.choice(odd_out), force=rng.random() < 0.5).encode()
        elif kind == 4:
            b = rng.choice([b"", b" ", b"\r", b"\x0b", b"\xc2\x85", b"\xe2\x80\xa8", b"\t\r", b"\x00"])
        elif kind == 5:
            b = job(id=i, name=rng.choice(["a\x01", "\udcff", "ok", " x", "é" * 300])).encode("utf-8", "replace")
        elif kind == 6:
            b = b"[" * rng.randrange(1, 5000)
        else:
            b = good.replace(b"0.6", rng.choice([b"NaN", b"1e400", b"-0", b"0.6\r", b"\xff"]))
        out.append(b)
    return out


def sweep(tmp_path: Path, seed: int, n: int, workers: int = 1):
    rng = random.Random(seed)
    work = tmp_path / f"w{seed}"
    work.mkdir()
    (work / "keep.txt").write_text("keep")
    lines = hostile_lines(rng, n)
    (work / "jobs.jsonl").write_bytes(b"\n".join(lines) + b"\n")
    code, out, err = run_process(["batch", "jobs.jsonl", "-q", "-j", workers], work, timeout=600)
    assert code in (0, 1) and "Traceback" not in err and err == "", err
    res = [json.loads(s) for s in out.splitlines()]
    assert [r["line"] for r in res] == list(range(1, n + 1))
    assert all(r.get("exit_code") != 3 for r in res), [r for r in res if r.get("exit_code") == 3]
    assert (work / "keep.txt").read_text() == "keep" and (work / "jobs.jsonl").is_file()
    assert not [p for p in tmp_path.rglob("*") if "mpsynth-tmp" in p.name or "mpsynth-old" in p.name]
    assert sorted(os.listdir(tmp_path)) == [f"w{seed}"]  # nothing escaped upwards


def test_hostile_sweep_sample(tmp_path):
    sweep(tmp_path, seed=20, n=60)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(5))
def test_hostile_sweep(tmp_path, seed):
    sweep(tmp_path, seed=seed, n=400, workers=2)


def _kill_during_write(cwd: Path, delay: float, sig=signal.SIGKILL) -> int:
    """Start `bennett -o out`, wait until its temporary directory appears (or it ends), then ``delay``
    seconds, then send ``sig``. Returns the exit status."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.Popen([sys.executable, "-m", "cli.main", "bennett", str(FIXTURE), "-o", "out", "-q"], cwd=cwd,
                         env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
    while p.poll() is None and not any("mpsynth-tmp" in n for n in os.listdir(cwd)):
        time.sleep(0.002)
    time.sleep(delay)
    if p.poll() is None:
        p.send_signal(sig)
    _, err = p.communicate(timeout=120)
    assert b"Traceback" not in err, err
    return p.returncode


def _killed_then_rerun(tmp_path: Path, delays) -> None:
    """SIGKILL writers at the given delays into their write phase, beside a user's file in OUT; a clean
    run afterwards leaves a complete OUT, the user's file, and no temporary directory."""
    code, _, err = run_process(["bennett", FIXTURE, "-o", "out", "-q"], tmp_path)
    assert code == 0, err
    (tmp_path / "out" / "notes.txt").write_text("mine")
    for d in delays:
        _kill_during_write(tmp_path, d)
        assert (tmp_path / "out" / "notes.txt").read_text() == "mine"
    code, _, err = run_process(["bennett", FIXTURE, "-o", "out", "-q"], tmp_path)
    assert code == 0, err
    assert os.listdir(tmp_path) == ["out"]  # the killed writers' temporary directories are gone
    out = tmp_path / "out"
    files = json.loads((out / writer_mod.MARKER).read_text())["files"]
    assert all((out / f).is_file() for f in files) and "notes.txt" not in files
    assert (out / "notes.txt").read_text() == "mine"


def test_sigkilled_writer_leftovers_are_cleaned_by_the_next_run(tmp_path):
    _killed_then_rerun(tmp_path, [0.0, 0.05])


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_sigkill_sweep(tmp_path, seed):
    rng = random.Random(seed)
    _killed_then_rerun(tmp_path, [rng.uniform(0.0, 0.4) for _ in range(6)])
