"""MuJoCo run of a linkage: the MJCF of `synth.tools.sim.mjcf`, compiled in memory, stepped in this process.

At the start the joints are at all-zero (the MJCF reference configuration ``qpos0``, where every weld
holds exactly) and at rest. The driver's position actuator gets the target angle plus feed-forward
terms, ``ctrl = target + (kv * target speed + tau) / kp`` with ``tau`` the torque that moves the
linkage along the target (`mjcf.DriveModel`), so the servo does not lag; the other joints are free.
"""
from __future__ import annotations

import time

import numpy as np

from synth.errors import InputError
from synth.tools.sim import DriveProfile, SimulationError, Tracker
from synth.tools.sim.mjcf import DriveModel, mjcf_text, write_mjcf


def one_line(e: Exception, limit: int = 300) -> str:
    """MuJoCo's (multi-line) compiler message on one bounded line."""
    text = " ".join(str(e).split())
    return text if len(text) <= limit else text[:limit] + "..."


def build_model(setup, *, timestep=None, gravity=False, contacts=False):
    import mujoco

    text = mjcf_text(setup, timestep=timestep, gravity=gravity, contacts=contacts)
    try:
        return mujoco.MjModel.from_xml_string(text)
    except Exception as e:  # noqa: BLE001 - MuJoCo raises ValueError with its compiler message
        raise InputError(f"MuJoCo rejected the model of {setup.out}: {one_line(e)}") from None


def run(setup, *, seconds: float, timestep=None, gravity: bool = False, export_mjcf=None, contacts=False) -> dict:
    import mujoco

    t_wall = time.perf_counter()
    if export_mjcf:
        path = write_mjcf(setup, export_mjcf, timestep=timestep, gravity=gravity, contacts=contacts)
        try:
            mujoco.MjModel.from_xml_path(str(path))
        except Exception as e:  # noqa: BLE001
            raise InputError(f"MuJoCo cannot load the exported {path}: {one_line(e)}") from None
    model = build_model(setup, timestep=timestep, gravity=gravity, contacts=contacts)
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    qadr = {jn: int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, jn)]) for jn in setup.joints}
    bid = {lk: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, lk) for pair in setup.closures for lk in pair}
    act = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"drive_{setup.driver}")
    kp, kv = float(model.actuator_gainprm[act, 0]), -float(model.actuator_biasprm[act, 2])
    mujoco.mj_resetData(model, data)
    for jn, q in setup.start_angles().items():
        data.qpos[qadr[jn]] = q
    mujoco.mj_forward(model, data)
    n = max(int(round(seconds / dt)), 10)
    tracker = Tracker(setup)
    ff = DriveModel(setup, gravity=gravity)
    profile = DriveProfile(setup, seconds)
    angle, speed, accel = profile.track(n)  # the servo acts with the state at the start of each step
    ctrl = angle + (kv * speed + ff.torques(angle, speed, accel)) / kp
    targets = profile.angle(np.arange(1, n + 1) / n)
    adr = [qadr[jn] for jn in setup.joints]
    qs = np.empty((n, len(adr)))
    pos = {lk: np.empty((n, 3)) for lk in bid}
    rot = {lk: np.empty((n, 3, 3)) for lk in bid}
    contact_steps, max_force, force = 0, 0.0, np.zeros(6)
    for k in range(n):
        data.ctrl[act] = ctrl[k]
        mujoco.mj_step(model, data)
        if data.ncon:  # only the pairs left in by --contacts can touch
            contact_steps += 1
            for c in range(data.ncon):
                mujoco.mj_contactForce(model, data, c, force)
                max_force = max(max_force, float(np.linalg.norm(force[:3])))
        qs[k] = data.qpos[adr]
        for lk, b in bid.items():
            pos[lk][k] = data.xpos[b]
            rot[lk][k] = data.xmat[b].reshape(3, 3)
        if not np.all(np.isfinite(qs[k])):
            raise SimulationError(f"MuJoCo diverged at step {k + 1} of {n}")
    tracker.joints({jn: qs[:, i] for i, jn in enumerate(setup.joints)}, targets)
    frames = {}
    for lk in bid:
        T = np.zeros((n, 4, 4))
        T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = rot[lk], pos[lk], 1.0
        frames[lk] = T
    tracker.frames(frames)
    return tracker.result("mujoco", n, seconds=seconds, timestep=dt, gravity=gravity,
                          iterations=int(model.opt.iterations), shared_inertial=setup.split, contacts=contacts,
                          contact_steps=contact_steps, max_contact_force=max_force,
                          wall_time=time.perf_counter() - t_wall)
