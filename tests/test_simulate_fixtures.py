"""Issue #35: `mpsynth simulate OUT` passes at its defaults (no option but --engine) on every shipped
fixture's output, in both engines. The whole table is slow (the ladders of `mpsynth curve` take minutes
in PyBullet); a Bennett fixture runs in the default suite. An engine that is not installed is skipped."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
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
    judged = res.get("max_joint_deviation_steady", res["max_joint_deviation"])  # outside a near-singular stretch
    assert r.exit_code == 0 and res["ok"] and judged <= 1e-3, r.stderr + json.dumps(res)
    return res


def test_fixture_list_covers_every_command():
    assert {f.split("_")[0] for f in FIXTURES} == set(COMMANDS) and len(FIXTURES) >= 20


@pytest.mark.parametrize("engine", ENGINES)
def test_a_bennett_fixture_passes_at_the_defaults(outputs, engine):
    res = simulate_at_defaults(outputs("bennett_quat.yaml"), engine)
    assert res["engine"] == engine and res["loops"] == 1


# sixbar_hermite's design passes a near-singular configuration in its cycle (its linkage.json drive
# warnings: k1 turns 253 times as fast as the driver h1 at 2.8 deg, loop conditioning 3.2e-4; every other
# joint as driver sees a ratio of 36 or more): the welds' give is magnified there (MuJoCo at the defaults:
# 2.9e-3 rad after the retry at 8.1 s, measured); the stretch is reported on its own (synth.tools.sim.Unsteady)
NEAR_SINGULAR = {"sixbar_hermite.yaml"}


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("fixture", FIXTURES)
def test_every_fixture_passes_at_the_defaults(outputs, fixture, engine):
    res = simulate_at_defaults(outputs(fixture), engine)
    assert res["engine"] == engine
    if fixture in NEAR_SINGULAR:  # reported on its own, --tol held elsewhere
        assert res["unsteady"]["speed_ratio"] > 100 and res["max_joint_deviation_steady"] <= 1e-3


def test_a_near_singular_passage_is_found_and_no_joint_drives_it_steadily(outputs):
    from synth.tools.sim import STEADY_RATIO, load_setup, speed_ratios

    setup = load_setup(outputs("sixbar_hermite.yaml"))
    u = setup.unsteady
    assert setup.driver == "h1" and setup.driver_choice is None and u is not None
    # k1 and h3 turn at about the same peak rate there (252 and 248 times h1's): either is the fastest,
    # depending on the design's drive samples
    assert u.fastest in ("k1", "h3") and u.ratio == pytest.approx(250, rel=0.03) and abs(np.degrees(u.at) - 2.8) < 0.2
    lo, hi = u.span_deg()
    assert 0.0 < lo < 2.8 < hi < 10.0 and not u.contains(np.radians([20.0, 60.0])).any()
    worst = speed_ratios(setup.laws, setup.rates, setup.loops, setup.joints, "h1", setup.drive_range)[0]
    assert worst.min() > STEADY_RATIO  # every joint as driver: a ratio of 36 at least (h2, k3)


def test_the_steadiest_joint_drives_when_the_first_one_nearly_stops():
    from synth.tools.sim import steady_driver

    # theta = 2 atan2(b, t - a): at t = 0 k1 turns 2 / 0.02 = 100 per unit t, h1 2: 50 times as fast; h2
    # (b = 0.15) sees at most 7.5 (k1 at t = 0) and 1 / 0.15 = 6.7 (h1 as t -> infinity)
    laws = {"h1": (0.0, 1.0), "k1": (0.0, 0.02), "h2": (0.0, 0.15)}
    c = steady_driver(laws, {}, {}, ["h1", "k1", "h2"], "h1", (0.0, 2 * np.pi))
    assert c.joint == "h2" and c.fastest == "k1" and c.ratio == pytest.approx(50, rel=0.01)
    assert c.joint_ratio == pytest.approx(7.5, rel=0.01) and c.drive_range == (0.0, 2 * np.pi)
    assert steady_driver({"h1": (0.0, 1.0), "k1": (0.0, 0.5)}, {}, {}, ["h1", "k1"], "h1", (0.0, 2 * np.pi)) is None


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


# ------------------------------------------------------------------ the comparison: distance from the motion's curve
@pytest.fixture(scope="module")
def planar_setup(outputs):
    from synth.tools.sim import load_setup

    return load_setup(outputs("bennett_planar.yaml"))


def _speed_ratios(setup, phi):
    import numpy as np

    h = 1e-6
    a, b = setup.exact(phi + h), setup.exact(phi - h)
    return {jn: np.abs((a[jn] - b[jn] + np.pi) % (2 * np.pi) - np.pi) / (2 * h) for jn in setup.joints}


def test_exact_configurations_are_on_the_motion(planar_setup):
    import numpy as np

    from synth.tools.sim import nearest_on_motion

    phi = np.linspace(0.05, 6.2, 97)
    q = {jn: np.asarray(v, float) for jn, v in planar_setup.exact(phi).items()}
    at, res = nearest_on_motion(planar_setup, q)
    assert np.abs(res).max() < 1e-9 and np.abs(at - phi).max() < 1e-7


def test_a_slipped_driver_is_not_multiplied_by_the_speed_ratio(planar_setup):
    """Where a joint turns R times faster than the driver, a driver that slipped by e along the motion is
    e off at its own angle but R e at the others read there; the nearest exact configuration is about the
    slipped one: deviation about e (its own slip), not R e."""
    import numpy as np

    from synth.tools.sim import nearest_on_motion

    phi = np.linspace(0.0, 2 * np.pi, 4001)[:-1]
    ratio = np.max(np.array(list(_speed_ratios(planar_setup, phi).values())), axis=0)
    k = int(np.argmax(ratio))
    assert ratio[k] > 5  # the anti-parallelogram's flat configuration
    e = 2e-4
    q = {jn: np.atleast_1d(np.asarray(v, float)) for jn, v in planar_setup.exact(phi[k] + e).items()}
    q[planar_setup.driver] = np.array([phi[k]])
    at_driver = max(abs(float(q[jn][0] - planar_setup.exact(phi[k])[jn])) for jn in planar_setup.joints)
    _, res = nearest_on_motion(planar_setup, q)
    assert at_driver > 5 * e and np.abs(res).max() < 1.5 * e


def test_a_configuration_off_the_motion_deviates(planar_setup):
    """One joint turned by d away from an exact configuration (where every joint turns at most as fast as
    the driver times 3) is at least d / 4 from the motion: the comparison still fails a wrong linkage."""
    import numpy as np

    from synth.tools.sim import nearest_on_motion

    phi = np.linspace(0.0, 2 * np.pi, 721)[:-1]
    ratios = _speed_ratios(planar_setup, phi)
    calm = np.max(np.array(list(ratios.values())), axis=0) < 3
    phi = phi[calm]
    other = next(jn for jn in planar_setup.joints if jn != planar_setup.driver)
    d = 1e-2
    q = {jn: np.asarray(v, float).copy() for jn, v in planar_setup.exact(phi).items()}
    q[other] = q[other] + d
    _, res = nearest_on_motion(planar_setup, q)
    assert np.abs(res).max(axis=0).min() > d / 4


# ------------------------------------------------------------------ MuJoCo's loop weld: its angular rows held as stiffly as d says
def test_the_torquescale_brings_every_angular_row_of_the_weld_to_mujocos_softening(outputs):
    """MuJoCo softens a weld row by (1 - d) / d times its own estimate D_i of A_ii, which ignores the
    torquescale s, while A_ii of the angular rows grows as s^2: after `weld_torquescales` every angular row
    the loop moves is softened at most as d says (D_i / A_ii <= 1) at every sampled configuration of the
    motion, and before it some was softened more than 100 times that (sixbar_hermite, measured 110). A
    planar loop's out-of-plane rows (no joint moves them) are left out: its torquescale stays near 1."""
    pytest.importorskip("mujoco")
    import mujoco

    from synth.tools.sim import load_setup
    from synth.tools.sim.mujoco_sim import TORQUESCALE, angular_softening, build_model, joint_addresses, weld_torquescales

    def worst_softening(out, scales_on: bool):
        setup = load_setup(out)
        model = build_model(setup)
        scales = weld_torquescales(model, setup)
        if not scales_on:
            model.eq_data[:, TORQUESCALE] = 1.0
        data, qadr = mujoco.MjData(model), joint_addresses(model, setup.joints)
        phi = np.linspace(*setup.drive_range, 37)
        exact = setup.exact(phi)
        worst = 0.0
        for k in range(len(phi)):
            for jn, adr in qadr.items():
                data.qpos[adr] = np.broadcast_to(exact[jn], phi.shape)[k]
            worst = max(worst, float(angular_softening(model, data).max()))
        return scales, worst

    scales, before = worst_softening(outputs("sixbar_hermite.yaml"), False)
    assert scales == pytest.approx([10.3], abs=0.1) and before > 50  # (10.5 with the cranked 7.7 mm bars before
    # issue 33's written slenderness, 11.1 with straight 24.4 mm bars before its stacks for links that share a joint)
    _, after = worst_softening(outputs("sixbar_hermite.yaml"), True)
    assert after <= 1.1  # 37 configurations against the 16 the scale was set from (1.056 measured on one design)
    planar, after = worst_softening(outputs("bennett_planar.yaml"), True)
    assert 1.0 <= planar[0] < 2.0 and after <= 1.05


def test_sixbar_hermite_passes_in_mujoco_at_the_defaults_and_failed_with_a_soft_angular_weld(outputs, monkeypatch):
    """The MuJoCo failure of issue 35: with torquescale 1 the weld's angular rows give way ~100 times more
    than d says, and the loop (conditioning ~1e-3 over its whole turn) magnifies that in the joints far
    from the near-singular stretch. Measured on the design with issue 33's written slenderness (straight
    24.4 mm bars) at a 16 s turn: 1.0e-3 rad held, 1.8e-2 soft. At the defaults the 2 s turn misses
    (3.6e-3 rad) and the 14.4 s retry (the advised factor) passes (before issue 33's stacks for links that
    share a joint the 2 s turn threw the loop onto another branch and a second retry, 32.2 s, was needed; on
    the design of issue 36's bounded search, 34.6 mm bars, the one retry is 16.0 s)."""
    pytest.importorskip("mujoco")
    from synth.tools.sim import load_setup
    from synth.tools.sim import mujoco_sim

    out = outputs("sixbar_hermite.yaml")
    res = simulate_at_defaults(out, "mujoco")
    assert res["weld_torquescale"] == pytest.approx([10.3], abs=0.1)
    assert res["retried"]["seconds"] == 2 and res["retries"] == 1 and 2 < res["seconds"] < 32.2  # one retry
    setup = load_setup(out)
    held = mujoco_sim.run(setup, seconds=16.0)
    monkeypatch.setattr(mujoco_sim, "weld_torquescales", lambda model, setup: np.ones(1))
    soft = mujoco_sim.run(setup, seconds=16.0)
    assert held["max_joint_deviation_steady"] < 1.5e-3 and soft["max_joint_deviation_steady"] > 10 * held[
        "max_joint_deviation_steady"]