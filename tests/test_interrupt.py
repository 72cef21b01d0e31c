"""Interrupted runs (SIGINT / SIGTERM) of the real `mpsynth bennett` process never leave a partial OUT.

No hook in the product makes anything slow: each run is signalled at a random moment, either measured
from the start of the process or from the moment its temporary sibling directory appears (the write
phase, which the test sees by polling the parent directory). After every run exactly one of these
holds: OUT is complete (every file present, linkage.json parses, the URDF names its meshes, the STL
files are whole) or there is no OUT; in both cases no ``.out.mpsynth-tmp-*`` / ``-old-*`` directory
is left. When an existing good OUT is being replaced, it is afterwards either the old complete OUT or
the new complete one. A long sweep is marked slow."""
from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from conftest import REPO

EXE = REPO / ".venv" / "bin" / "mpsynth"
CMD = [str(EXE)] if EXE.exists() else [sys.executable, "-c", "from cli.main import main; main()"]
POSES = REPO / "fixtures" / "bennett_quat.yaml"
OK_CODES = {0, 130, 143, -signal.SIGINT, -signal.SIGTERM}


def leftovers(parent: Path) -> list[str]:
    return sorted(n for n in os.listdir(parent) if "mpsynth-tmp" in n or "mpsynth-old" in n)


def complete_out(out: Path) -> str:
    """Assert that ``out`` is a complete mpsynth output directory; return the URDF's robot name."""
    doc = json.loads((out / "linkage.json").read_text())
    assert doc["format"] == "mpsynth.linkage/1" and len(doc["poses"]) == 3
    robot = ET.parse(out / "linkage.urdf").getroot()
    meshes = {m.get("filename") for m in robot.iter("mesh")}
    assert meshes and all(m.startswith("meshes/") for m in meshes)
    stl = {f"meshes/{p.name}" for p in (out / "meshes").iterdir()}
    assert stl == meshes, (stl, meshes)
    for rel in stl:
        data = (out / rel).read_bytes()
        n = int.from_bytes(data[80:84], "little")
        assert len(data) == 84 + 50 * n and n > 0, rel  # a whole binary STL
    assert (out / ".mpsynth-output").is_file()
    optional = {"linkage.step"}  # with the cad extra (synth.io.step)
    assert set(os.listdir(out)) - optional == {"linkage.json", "linkage.urdf", "meshes", ".mpsynth-output"}
    return robot.get("name")


def run_and_signal(cwd: Path, sig, *, delay: float, after_tmp: bool, name: str = "new"):
    """Start `mpsynth bennett POSES -o out`; send ``sig`` ``delay`` s after the start, or after the temp
    directory appears when ``after_tmp``. Returns (returncode, stderr, whether the signal was sent while
    the temp directory existed)."""
    proc = subprocess.Popen(CMD + ["bennett", str(POSES), "-o", "out", "-q", "--name", name], cwd=cwd,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
    try:
        t0 = time.monotonic()
        if after_tmp:
            while proc.poll() is None and not leftovers(cwd):
                time.sleep(0.002)
            t0 = time.monotonic()
        while proc.poll() is None and time.monotonic() - t0 < delay:
            time.sleep(0.002)
        during_write = bool(leftovers(cwd))
        if proc.poll() is None:
            proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err, during_write


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """One uninterrupted run: its OUT (robot "old") and its timings (start -> temp dir -> end)."""
    d = tmp_path_factory.mktemp("reference")
    t0 = time.monotonic()
    proc = subprocess.Popen(CMD + ["bennett", str(POSES), "-o", "out", "-q", "--name", "old"], cwd=d,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
    t_tmp = None
    while proc.poll() is None:
        if t_tmp is None and leftovers(d):
            t_tmp = time.monotonic() - t0
        time.sleep(0.002)
    total = time.monotonic() - t0
    assert proc.returncode == 0, proc.stderr.read()
    assert complete_out(d / "out") == "old" and leftovers(d) == []
    return {"out": d / "out", "t_tmp": t_tmp or 0.5 * total, "total": total}


def schedule(reference, n: int, seed: int):
    """n (signal, delay, after_tmp) triples: half anywhere in the run, half inside the write phase."""
    rng = random.Random(seed)
    write = max(reference["total"] - reference["t_tmp"], 0.05)
    out = []
    for i in range(n):
        sig = (signal.SIGINT, signal.SIGTERM)[i % 2]
        if i % 4 < 2:
            out.append((sig, rng.uniform(0.0, 1.1 * write), True))
        else:
            out.append((sig, rng.uniform(0.0, 1.1 * reference["total"]), False))
    return out


def _interpreter_startup(code, err) -> bool:
    """A SIGINT that lands while CPython itself is still starting (importing ``site``, before any of our
    code runs) makes the interpreter abort with exit 1 and "Fatal Python error: init_import_site"; no
    program can handle it. Nothing can have been written then (checked by the caller)."""
    return code == 1 and err.startswith("Fatal Python error: init_") and "KeyboardInterrupt" in err


def check_run(tmp: Path, code, err, during_write, *, old_name=None):
    if not during_write and _interpreter_startup(code, err):
        assert os.listdir(tmp) == (["out"] if old_name else []), os.listdir(tmp)
        if old_name:
            assert complete_out(tmp / "out") == old_name
        return old_name
    assert code in OK_CODES, (code, err)
    assert leftovers(tmp) == [], (code, err)
    out = tmp / "out"
    if out.exists():
        name = complete_out(out)
        assert name in ({"new", old_name} if old_name else {"new"})
        if code == 0:
            assert name == "new"
        return name
    assert old_name is None, "the previous good OUT was destroyed"
    assert code != 0
    assert os.listdir(tmp) == [], os.listdir(tmp)
    if during_write:  # the signal surely arrived inside the command: a clean one-line report or none
        assert "Traceback" not in err, err
        assert err in ("", "mpsynth: interrupted\n"), err
    return None


def _fresh(tmp_path: Path, i: int) -> Path:
    d = tmp_path / f"run{i}"
    d.mkdir()
    return d


def test_interrupted_runs_leave_complete_out_or_none(reference, tmp_path):
    for i, (sig, delay, after_tmp) in enumerate(schedule(reference, 4, seed=8)):
        d = _fresh(tmp_path, i)
        code, err, during = run_and_signal(d, sig, delay=delay, after_tmp=after_tmp)
        check_run(d, code, err, during)


def test_interrupted_replacement_keeps_old_or_new_out(reference, tmp_path):
    for i, (sig, delay, after_tmp) in enumerate(schedule(reference, 3, seed=88)):
        d = _fresh(tmp_path, i)
        shutil.copytree(reference["out"], d / "out")
        code, err, during = run_and_signal(d, sig, delay=delay, after_tmp=after_tmp)
        check_run(d, code, err, during, old_name="old")
        assert sorted(os.listdir(d)) == ["out"]


@pytest.mark.parametrize("sig,replace", [(signal.SIGINT, False), (signal.SIGTERM, True)], ids=["INT", "TERM-replace"])
def test_signal_right_after_temp_dir_appears(reference, tmp_path, sig, replace):
    """The moment most likely to leak the temp dir: as soon as it exists. The run must stop (exit 130 or
    143 from the writer's handler) and leave no OUT, or the old OUT untouched."""
    if replace:
        shutil.copytree(reference["out"], tmp_path / "out")
    code, err, during = run_and_signal(tmp_path, sig, delay=0.0, after_tmp=True)
    assert code == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], (code, err)
    assert check_run(tmp_path, code, err, during, old_name="old" if replace else None) == ("old" if replace else None)


@pytest.mark.slow
@pytest.mark.parametrize("replace", [False, True])
def test_interrupt_sweep(reference, tmp_path, replace):
    for i, (sig, delay, after_tmp) in enumerate(schedule(reference, 30, seed=1000 + replace)):
        d = _fresh(tmp_path, i)
        if replace:
            shutil.copytree(reference["out"], d / "out")
        code, err, during = run_and_signal(d, sig, delay=delay, after_tmp=after_tmp)
        check_run(d, code, err, during, old_name="old" if replace else None)
