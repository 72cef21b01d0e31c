"""`simulate(OUT, engine)`: read OUT, check the engine is installed, run it (see `synth.tools.sim`)."""
from __future__ import annotations

import math

from synth.errors import InputError
from synth.tools.sim import load_setup, require_engine
from synth.tools.sim.mjcf import write_mjcf
from synth.tools.sim.mujoco_sim import run as run_mujoco
from synth.tools.sim.pybullet_sim import run_in_subprocess


def simulate(out, engine: str, *, seconds: float = 2.0, timestep: float | None = None, gravity: bool = False,
             export_mjcf=None, timeout: float = 600.0, contacts: bool = False) -> dict:
    """Run ``engine`` on OUT; returns the result dict (see `Tracker.result`). Raises EngineNotInstalled
    (exit 2), InputError (exit 2) or SimulationError (exit 1)."""
    if not (seconds > 0 and math.isfinite(seconds) and seconds <= 3600):
        raise InputError(f"--seconds must be in (0, 3600], got {seconds}")
    if timestep is not None and not (0 < timestep <= seconds / 10):
        raise InputError(f"--timestep must be positive and at most a tenth of --seconds, got {timestep}")
    setup = load_setup(out)  # input errors before engine errors
    if export_mjcf and engine != "mujoco":  # the MuJoCo run writes (and loads) it itself
        write_mjcf(setup, export_mjcf, timestep=timestep, gravity=gravity, contacts=contacts)
    require_engine(engine)
    if engine == "pybullet":
        return run_in_subprocess(setup, seconds=seconds, timestep=timestep, gravity=gravity, timeout=timeout,
                                 contacts=contacts)
    return run_mujoco(setup, seconds=seconds, timestep=timestep, gravity=gravity, export_mjcf=export_mjcf,
                      contacts=contacts)
