"""MuJoCo run of a linkage: the MJCF of `synth.tools.sim.mjcf`, compiled in memory, stepped in this process.

At the start the joints are at all-zero (the MJCF reference configuration ``qpos0``, where every weld
holds exactly) and at rest. The driver's position actuator gets the target angle plus feed-forward
terms, ``ctrl = target + (kv * target speed + tau) / kp`` with ``tau`` the torque that moves the
linkage along the target (`mjcf.DriveModel`), so the servo does not lag; the other joints are free.
"""
from __future__ import annotations

import importlib.util
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


def joint_addresses(model, joints) -> dict:
    """joint name -> its index in MuJoCo's qpos."""
    import mujoco

    return {jn: int(model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, jn)]) for jn in joints}


WELD_SAMPLES = 16  # configurations of the exact motion where the welds' angular rows are weighed
TORQUESCALE = 10  # index of a weld's torquescale in MuJoCo's eq_data
LOCKED = 1e-9  # an angular row whose A_ii is below this fraction of MuJoCo's estimate: no joint moves it
MAX_TORQUESCALE = 100.0  # bound on s (s^2 scales the angular rows of A; sixbar_hermite also ran stably at 1000)


def weld_torquescales(model, setup, samples: int = WELD_SAMPLES) -> np.ndarray:
    """(welds,) the ``torquescale`` (weight of the three angular rows) of every loop weld, set in
    ``model``: the one that softens those rows no more than MuJoCo's impedance d says.

    MuJoCo softens constraint row i by R_i = (1 - d) / d D_i, with D_i its estimate of the row's
    A_ii = J_i M^-1 J_i^T from the welded bodies' isotropic inverse weights at qpos0 (torquescale not
    included). For a link of a revolute loop the angular estimate is far too large (it turns easily about
    one axis, hardly about the others): on fixtures/sixbar_hermite.yaml D_i / A_ii reaches 110 on the angular
    rows (0.4-0.9 on the linear ones at qpos0), so the weld's angular part gave way 100 times as much as d
    says, and the loop's poor conditioning (1e-3 over the whole turn) turned that into 2.5e-3 rad at h2. A
    torquescale s multiplies the angular A_ii by s^2 and leaves D_i: s = sqrt(max D_i / A_ii)
    (`angular_softening`), from 1 to `MAX_TORQUESCALE`, over ``samples`` configurations of the exact motion
    over the driver's sweep."""
    import mujoco

    welds = np.flatnonzero(model.eq_type == mujoco.mjtEq.mjEQ_WELD)
    model.eq_data[welds, TORQUESCALE] = 1.0
    data, qadr = mujoco.MjData(model), joint_addresses(model, setup.joints)
    phi = np.linspace(*setup.drive_range, samples, endpoint=False)
    exact = setup.exact(phi)
    worst = np.ones(model.neq)
    for k in range(samples):
        for jn, adr in qadr.items():
            data.qpos[adr] = np.broadcast_to(exact[jn], phi.shape)[k]
        worst = np.maximum(worst, angular_softening(model, data))
    scales = np.minimum(np.sqrt(worst[welds]), MAX_TORQUESCALE)
    model.eq_data[welds, TORQUESCALE] = scales
    return scales


def export_torquescales(setup, *, timestep=None, gravity=False, contacts=False):
    """The welds' torquescales (`weld_torquescales`) for an MJCF exported beside another engine's run, or
    None (1 each) when MuJoCo is not installed."""
    if importlib.util.find_spec("mujoco") is None:
        return None
    return weld_torquescales(build_model(setup, timestep=timestep, gravity=gravity, contacts=contacts), setup)


def angular_softening(model, data) -> np.ndarray:
    """(neq,) per weld at the configuration ``data.qpos``: the largest D_i / A_ii over its angular rows (the
    factor by which MuJoCo softens them beyond what its impedance says; see `weld_torquescales`), 0 for
    other equalities and for welds whose angular rows no joint moves (A_ii < `LOCKED` D_i: a planar loop's
    out-of-plane turns need no force)."""
    import mujoco

    jacobian, model.opt.jacobian = model.opt.jacobian, mujoco.mjtJacobian.mjJAC_DENSE
    try:
        mujoco.mj_forward(model, data)
        n = data.nefc
        J = data.efc_J[:n * model.nv].reshape(n, model.nv).copy()
    finally:
        model.opt.jacobian = jacobian
    X = np.empty_like(J)
    mujoco.mj_solveM(model, data, X, J)
    A = np.einsum("ij,ij->i", J, X)
    imp = data.efc_KBIP[:n, 2]
    D = data.efc_R[:n] * imp / (1.0 - imp)
    rows = np.flatnonzero(data.efc_type[:n] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
    out = np.zeros(model.neq)
    for e in np.flatnonzero(model.eq_type == mujoco.mjtEq.mjEQ_WELD):
        ang = rows[data.efc_id[rows] == e][3:6]
        ang = ang[A[ang] > LOCKED * D[ang]]
        if len(ang):
            out[e] = float(np.max(D[ang] / A[ang]))
    return out


def run(setup, *, seconds: float, timestep=None, gravity: bool = False, export_mjcf=None, contacts=False) -> dict:
    import mujoco

    t_wall = time.perf_counter()
    model = build_model(setup, timestep=timestep, gravity=gravity, contacts=contacts)
    scales = weld_torquescales(model, setup)
    if export_mjcf:
        path = write_mjcf(setup, export_mjcf, timestep=timestep, gravity=gravity, contacts=contacts,
                          torquescale=scales)
        try:
            mujoco.MjModel.from_xml_path(str(path))
        except Exception as e:  # noqa: BLE001
            raise InputError(f"MuJoCo cannot load the exported {path}: {one_line(e)}") from None
    data = mujoco.MjData(model)
    dt = float(model.opt.timestep)
    qadr = joint_addresses(model, setup.joints)
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
                          weld_torquescale=[float(v) for v in scales], wall_time=time.perf_counter() - t_wall)
