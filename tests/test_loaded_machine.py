"""Issue #35: "the same command gives the same linkage.json on an idle and on a fully loaded machine".

Each fixture runs once as it is and once while busy-loop processes hog every CPU (a real load: the
scheduler, not a patched clock, slows the command), and once in-process with every clock running 1000x
slow; the linkage.json bytes (under the real load every file written, the STL meshes too) must be equal.
Searches stop on counted work, never on CPU or wall time (docs/architecture.md), so any difference is a
bug."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from contextlib import contextmanager

import pytest

from conftest import REPO, invoke, run_process

COMMANDS = {"bennett": "bennett", "sixbar": "sixbar", "fourbar": "fourbar", "curve": "curve", "motion": "curve"}


def command_for(fixture: str) -> str:
    return COMMANDS[fixture.split("_")[0]]


@contextmanager
def hogged_cpus():
    """Busy-loop processes, one per CPU this process may use and at least 2, for the time of the block."""
    try:
        n = max(2, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        n = max(2, os.cpu_count() or 2)
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
    try:
        time.sleep(0.2)  # let them take the CPUs
        assert all(h.poll() is None for h in hogs)
        yield n
    finally:
        for h in hogs:
            h.kill()
        for h in hogs:
            h.wait()


def output_files(fixture: str, out) -> dict:
    """relative path -> bytes of every file the command writes to OUT (linkage.json, URDF, STL meshes, ...)."""
    code, _, err = run_process([command_for(fixture), REPO / "fixtures" / fixture, "-o", out, "-q"], timeout=1800)
    assert code == 0, err
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def check_same_when_loaded(tmp_path, fixture: str) -> None:
    idle = output_files(fixture, tmp_path / "idle")
    with hogged_cpus():
        loaded = output_files(fixture, tmp_path / "loaded")
    assert "linkage.json" in idle and any(name.endswith(".stl") for name in idle)
    assert idle.keys() == loaded.keys(), f"{fixture}: other files on a loaded machine"
    differ = [name for name in idle if idle[name] != loaded[name]]
    assert not differ, f"{fixture}: {', '.join(differ)} differ between an idle and a loaded machine"


def test_same_linkage_json_on_a_loaded_machine(tmp_path):
    check_same_when_loaded(tmp_path, "bennett_mm_deg.yaml")


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["sixbar_example.yaml", "sixbar_points.yaml", "bennett_points.yaml",
                                     "fourbar_5.yaml", "curve_circle.yaml", "bennett_fit.yaml"])
def test_same_linkage_json_on_a_loaded_machine_slow(tmp_path, fixture):
    check_same_when_loaded(tmp_path, fixture)


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["sixbar_example.yaml", "sixbar_points.yaml", "fourbar_5.yaml"])
def test_same_linkage_json_when_every_clock_runs_slow(tmp_path, monkeypatch, fixture):
    """As tests/test_hostile35.py's Bennett case, on the commands with searches (sixbar, point tasks,
    four-bar)."""
    argv = [command_for(fixture), str(REPO / "fixtures" / fixture), "-q", "-o"]
    code, _, err = invoke(argv + ["a"], tmp_path)
    assert code == 0, err
    base = {name: getattr(time, name) for name in ("process_time", "perf_counter", "monotonic", "time")}
    start = {name: f() for name, f in base.items()}
    for name, f in base.items():
        monkeypatch.setattr(time, name, lambda f=f, s=start[name]: s + 1000.0 * (f() - s))
    code, _, err = invoke(argv + ["b"], tmp_path)
    assert code == 0, err
    assert (tmp_path / "a" / "linkage.json").read_bytes() == (tmp_path / "b" / "linkage.json").read_bytes()
