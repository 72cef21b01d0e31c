"""`simulate(OUT, engine)`: read OUT, check the engine is installed, run it (see `synth.tools.sim`)."""
from __future__ import annotations

import math

from synth.errors import InputError
from synth.tools.sim import load_setup, require_engine
from synth.tools.sim.mjcf import write_mjcf
from synth.tools.sim.mujoco_sim import export_torquescales, run as run_mujoco
from synth.tools.sim.pybullet_sim import run_in_subprocess


SINGLE_LOOP_SECONDS = 2.0  # default time of the turn for one loop
SECONDS_PER_LOOP = 4.0  # ... and per loop of a multi-loop linkage


def default_seconds(loops: int) -> float:
    """The default time of the driver's turn: 2 s for one loop, 4 s per loop for several.

    The engines hold a loop closed with a stiff but soft weld whose give grows with the speed of the
    links (and, in MuJoCo, with the time step); welds in series (the ladders of `mpsynth curve`) add
    up: at 2 s the curve fixtures deviate by 3e-3 to 8e-3 rad, at 4 s per loop MuJoCo stays within
    about 5e-4 rad (measured on fixtures/curve_ellipse.yaml and motion_elliptic.yaml)."""
    return SINGLE_LOOP_SECONDS if loops <= 1 else SECONDS_PER_LOOP * loops


def advice(result: dict, engine: str, tol: float, seconds: float, loops: int) -> str:
    """What to change when the deviation exceeds ``tol``: a slower turn (the weld's give is about
    proportional to the speed), a finer MuJoCo step, or MuJoCo instead of PyBullet for several loops
    (PyBullet's weld gap, ~1e-4 m on the curve fixtures whatever the speed at its default solver
    residual, is magnified in the joints by the near-singular configurations of the ladder: worst
    conditioning ~1e-3; `synth.tools.sim.pybullet_sim.residual_threshold` tightens the solver for
    several loops, which brings both curve fixtures within 1e-3 rad, but with little margin). A worst
    deviation next to a recorded singular configuration (`near_singular`: the 7R Darboux loop's branch
    crossings, docs/exceptional.md section 6) is said to be one, with the slower turn to try."""
    near = near_singular(result)
    if near is not None:
        return (f"the worst deviation ({result['worst_joint']} at {result['driver']} = "
                f"{math.degrees(result['worst_driver_angle']) % 360:.0f} deg) is next to a singular configuration "
                f"({result['driver']} = {near:.0f} deg, linkage.json info.darboux.singular_driver_deg), where another "
                "assembly branch of the loop meets the motion and the welds' give is magnified; try a slower turn "
                f"(--seconds {min(3600.0, seconds * max(2.0, 2.0 * judged_deviation(result) / tol)):.3g})"
                + (f" or a smaller --timestep (e.g. {result['timestep'] / 4:.2g})" if engine == "mujoco" else ""))
    if engine == "pybullet" and loops > 1:  # measured: a 6x slower turn barely helps PyBullet here
        return (f"PyBullet's solver holds the {loops} welds only to ~{result['max_closure_gap']:.0e} m, "
                "and near-singular configurations of the loops magnify that in the joints; "
                "use --engine mujoco (or a larger --tol)")
    factor = max(2.0, 2.0 * judged_deviation(result) / tol)
    tips = [f"a slower turn (--seconds {min(3600.0, seconds * factor):.3g})"]
    if engine == "mujoco":
        tips.append(f"a smaller --timestep (e.g. {result['timestep'] / 4:.2g})")
    return f"the loops' welds give way with the speed of the links ({loops} loop(s)); try " + " or ".join(tips)


NEAR_SINGULAR_DEG = 10.0  # a worst deviation this close (driver angle) to a singular configuration is blamed on it


def near_singular(result: dict) -> float | None:
    """The driver angle (deg) of the singular configuration (``result["singular_driver_deg"]``) within
    `NEAR_SINGULAR_DEG` of where the worst joint deviation was seen (``worst_driver_angle``, rad), else None."""
    at = math.degrees(result.get("worst_driver_angle", 0.0)) % 360
    best = None
    for s in result.get("singular_driver_deg", ()):
        d = abs((at - s + 180) % 360 - 180)
        if d <= NEAR_SINGULAR_DEG and (best is None or d < best[0]):
            best = (d, s)
    return None if best is None else best[1]


def judged_deviation(result: dict) -> float:
    """The deviation (rad) held against the tolerance: the worst joint deviation from the exact motion,
    outside the stretch where the driver nearly stops (``result["unsteady"]``: some joint turns more
    than `synth.tools.sim.STEADY_RATIO` times as fast as the driver and no joint would drive the passage
    steadily) when there is one. Inside it a near-singular loop magnifies the welds' give by the speed
    ratio: that deviation is reported (``unsteady.max_joint_deviation``), not failed."""
    return result.get("max_joint_deviation_steady", result["max_joint_deviation"])


MAX_STEPS = 1_000_000  # engine steps of one run (--timestep 1e-9 asked for 14.9 GiB of samples)
RETRIES = 2  # the default turn's automatic retries, at most
RETRY_SLOWDOWN = 8.0  # each at most this much slower than the run before
RETRY_MAX_SLOWDOWN = 32.0  # ... and together at most this much slower than the default turn


def simulate(out, engine: str, *, seconds: float | None = None, timestep: float | None = None,
             gravity: bool = False, export_mjcf=None, timeout: float = 600.0, contacts: bool = False,
             tol: float | None = None) -> dict:
    """Run ``engine`` on OUT; returns the result dict (see `Tracker.result`, plus ``seconds``). ``seconds``
    None: `default_seconds` for the linkage's loops, and while the run then deviates by more than ``tol``
    (rad) from the exact motion, up to `RETRIES` retries, each with a slower turn (the advised factor of
    the last run, each at most RETRY_SLOWDOWN, together at most RETRY_MAX_SLOWDOWN; PyBullet also with the tight solver
    threshold): linkages that pass a flat (change-point) configuration, where some joints turn several
    times faster than the driver, need it, and a first turn that throws the loop onto another branch
    says little about the speed that holds it (sixbar_hermite: 3.1 rad at 2 s, 1.007e-3 at 16 s,
    within 1e-3 at 32 s); ``retried`` in the result then records the first attempt, ``retries`` their count. Raises EngineNotInstalled (exit 2),
    InputError (exit 2) or SimulationError (exit 1)."""
    setup = load_setup(out)  # input errors before engine errors
    auto = seconds is None
    if seconds is None:
        seconds = default_seconds(len(setup.closures))
    if not (seconds > 0 and math.isfinite(seconds) and seconds <= 3600):
        raise InputError(f"--seconds must be in (0, 3600], got {seconds}")
    if timestep is not None and not (0 < timestep <= seconds / 10):
        raise InputError(f"--timestep must be positive and at most a tenth of --seconds, got {timestep}")
    if timestep is not None and seconds / timestep > MAX_STEPS:
        raise InputError(f"--timestep {timestep:g} s makes {seconds / timestep:.3g} steps of a {seconds:g} s run, "
                         f"more than {MAX_STEPS}; give a larger --timestep or fewer --seconds")
    if tol is not None and not (math.isfinite(tol) and tol > 0):
        raise InputError(f"--tol must be a positive number of radians, got {tol}")
    res = _run(setup, engine, seconds=seconds, timestep=timestep, gravity=gravity, export_mjcf=export_mjcf,
               timeout=timeout, contacts=contacts)
    first, retries, limit = None, 0, seconds * RETRY_MAX_SLOWDOWN
    while auto and tol is not None and judged_deviation(res) > tol and retries < RETRIES and seconds < limit:
        first = first or {"seconds": seconds, "max_joint_deviation": judged_deviation(res)}
        seconds = min(limit, seconds * min(RETRY_SLOWDOWN, max(2.0, 2.0 * judged_deviation(res) / tol)))
        res = _run(setup, engine, seconds=seconds, timestep=timestep, gravity=gravity, export_mjcf=export_mjcf,
                   timeout=timeout, contacts=contacts, tight=True)
        retries += 1
    if first is not None:
        res["retried"], res["retries"] = first, retries
    res["seconds"] = seconds
    res["loops"] = len(setup.closures)
    if tol is not None:
        res["ok"] = judged_deviation(res) <= tol
    if setup.singular_deg:
        res["singular_driver_deg"] = list(setup.singular_deg)
    return res


def _run(setup, engine, *, seconds, timestep, gravity, export_mjcf, timeout, contacts, tight=False) -> dict:
    if export_mjcf and engine != "mujoco":  # the MuJoCo run writes (and loads) it itself
        write_mjcf(setup, export_mjcf, timestep=timestep, gravity=gravity, contacts=contacts,
                   torquescale=export_torquescales(setup, timestep=timestep, gravity=gravity, contacts=contacts))
    require_engine(engine)
    if engine == "pybullet":
        return run_in_subprocess(setup, seconds=seconds, timestep=timestep, gravity=gravity, timeout=timeout,
                                 contacts=contacts, tight=tight)
    return run_mujoco(setup, seconds=seconds, timestep=timestep, gravity=gravity, export_mjcf=export_mjcf,
                      contacts=contacts)
