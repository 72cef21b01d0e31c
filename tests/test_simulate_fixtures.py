"""Issue #35: `mpsynth simulate OUT` passes at its defaults (no option but --engine) on every shipped
fixture's output, in both engines. The whole table is slow (the ladders of `mpsynth curve` take minutes
in PyBullet); a Bennett fixture runs in the default suite. An engine that is not installed is skipped."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from conftest import REPO, run

COMMANDS = {"bennett": "bennett", "sixbar": "sixbar", "fourbar": "fourbar", "curve": "curve", "motion": "curve"}
FIXTURES = sorted(p.name for p in (REPO / "fixtures").iterdir() if p.name.split("_")[0] in COMMANDS)
ENGINES = ("mujoco", "pybullet")


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """fixture name -> its output directory, made once per module on first use."""
    root, made = tmp_path_factory.mktemp("fixtures"), {}

    def get(fixture: str) -> Path:
        if fixture not in made:
            out = root / Path(fixture).stem
            r = run(COMMANDS[fixture.split("_")[0]], REPO / "fixtures" / fixture, "-o", out, "-q")
            assert r.exit_code == 0, r.output
            made[fixture] = out
        return made[fixture]

    return get


def simulate_at_defaults(out: Path, engine: str) -> dict:
    if importlib.util.find_spec(engine) is None:
        pytest.skip(f"{engine} is not installed")
    r = run("simulate", out, "--engine", engine, "--json", "-q")
    res = json.loads(r.stdout)
    assert r.exit_code == 0 and res["ok"] and res["max_joint_deviation"] <= 1e-3, r.stderr + json.dumps(res)
    return res


def test_fixture_list_covers_every_command():
    assert {f.split("_")[0] for f in FIXTURES} == set(COMMANDS) and len(FIXTURES) >= 20


@pytest.mark.parametrize("engine", ENGINES)
def test_a_bennett_fixture_passes_at_the_defaults(outputs, engine):
    res = simulate_at_defaults(outputs("bennett_quat.yaml"), engine)
    assert res["engine"] == engine and res["loops"] == 1


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("fixture", FIXTURES)
def test_every_fixture_passes_at_the_defaults(outputs, fixture, engine):
    res = simulate_at_defaults(outputs(fixture), engine)
    assert res["engine"] == engine


# ------------------------------------------------------------------ the PyBullet child's bound: CPU time, not wall time
def test_a_child_that_uses_no_cpu_is_stopped_as_hung(monkeypatch):
    import subprocess
    import sys

    from synth.tools.sim import SimulationError, pybullet_sim

    monkeypatch.setattr(pybullet_sim, "STALL_SECONDS", 0.3)
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with pytest.raises(SimulationError, match="no progress"):
        pybullet_sim._wait_while_working(proc, 600.0)
    assert proc.returncode is not None


def test_a_working_child_is_waited_for_however_long_it_takes(monkeypatch):
    """A child that keeps using CPU is never stopped by the stall check (a loaded machine only makes the
    same run take longer)."""
    import subprocess
    import sys

    from synth.tools.sim import pybullet_sim

    monkeypatch.setattr(pybullet_sim, "STALL_SECONDS", 5.0)  # CPU ticks come every 10 ms: under load, seconds apart
    code = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.5: pass\nprint('done')"
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out, _ = pybullet_sim._wait_while_working(proc, 600.0)
    assert out.strip() == "done" and proc.returncode == 0


def test_the_cpu_budget_ends_a_runaway_child():
    import signal
    import subprocess
    import sys

    from synth.tools.sim import pybullet_sim

    proc = subprocess.run([sys.executable, "-c", "while True: pass"], preexec_fn=lambda: pybullet_sim._limit_cpu(0.5),
                          capture_output=True, timeout=600)
    assert proc.returncode == -signal.SIGXCPU
