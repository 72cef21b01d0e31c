"""PyBullet run of a linkage, always in a child process (`run_in_subprocess`): a malformed model can
crash the engine, which must not take the CLI down with it.

The child (``python -m synth.tools.sim.pybullet_sim REQUEST.json``) loads a simulation copy of linkage.urdf
(absolute mesh paths, the coupler's inertial shared with its welded copy, see `synth.tools.sim`) with a fixed
base and ``URDF_USE_INERTIA_FROM_FILE`` (self-collision is off unless ``contacts``: then
``URDF_USE_SELF_COLLISION`` with the pairs of `synth.tools.sim.contact_exclusions` filtered out),
adds one ``JOINT_FIXED`` user constraint per loop between ``coupler`` and ``coupler_k`` (frames relative
to the links' centre-of-mass frames, as PyBullet wants, computed so that the weld holds the all-zero
relative pose), releases the default velocity motors (``VELOCITY_CONTROL`` with force 0) and drives the
first joint with ``POSITION_CONTROL``. Solver: fixed time step (default 1 ms), 3000 iterations, more for
several loops (`solver_iterations`) (the loop
is overconstrained: a weld of 6 equations on a 1-dof loop, which PyBullet's iterative solver only
settles with many iterations; a 6R still gains from 300 to 3000), error reduction 0.8 per step (the
default 0.2 lets the weld drift about four times further). The solver stops early once its residual
falls below a threshold (PyBullet's default 1e-7): for several loops (welds in series) that early stop,
not the step or the iteration count, leaves the ~1e-4 m weld gap that near-singular configurations
magnify to ~3e-3 rad in the joints, so a multi-loop linkage gets `residual_threshold` 1e-12 (measured
on fixtures/curve_ellipse.yaml and motion_elliptic.yaml at the default 4 s per loop: 3.2e-3 / 3.3e-3 rad
at 1e-7, 1.4e-3 / 2.2e-3 at 1e-9, 4.3e-4 / 9.8e-4 at 1e-10, 3.8e-4 / 7.2e-4 at 1e-12; about 19 s / 30 s
CPU). A single loop keeps the default: the tighter threshold costs 5-9x there for no gain. The result
goes to a JSON file named in the request.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from synth.algebra.dq import matrix_to_quat
from synth.algebra.geometry import invert_pose
from synth.frames import rpy_from_matrix
from synth.tools.sim import DriveProfile, SimulationError, Tracker, load_setup

DEFAULT_TIMESTEP = 1e-3
ITERATIONS = 3000  # at least; welds in series want more, `solver_iterations`
ITERATIONS_PER_LOOP = 1200
ERP = 0.8  # error reduction per step; PyBullet's default 0.2 lets the weld drift 4x further
RESIDUAL_THRESHOLD = 1e-7  # PyBullet's default early stop of the solver: enough for one loop
MULTI_LOOP_RESIDUAL_THRESHOLD = 1e-12  # several loops: see the module docstring
MOTOR_FORCE = 1e4  # N m: a bound, not a gain (POSITION_CONTROL is a velocity-level constraint)


def sim_urdf_text(setup, contacts: bool = False) -> str:
    """linkage.urdf for PyBullet: absolute mesh paths, simulation inertials, no <gazebo> tags; with
    ``contacts`` the collision meshes are replaced by the design's capsules when linkage.json has them
    (`synth.tools.sim.contact`)."""
    root = ET.parse(setup.out / "linkage.urdf").getroot()
    for g in root.findall("gazebo"):
        root.remove(g)
    caps = None
    if contacts:
        from synth.tools.sim.contact import contact_capsules

        caps = contact_capsules(setup)
    for link in root.findall("link"):
        name = link.get("name")
        for m in link.iter("mesh"):
            m.set("filename", str(setup.mesh_path(m.get("filename", ""))))
        if caps is not None:
            _capsule_collisions(link, caps.get(name, []))
        if name in setup.inertials:
            mass, T, I = setup.inertials[name]
            for old in link.findall("inertial"):
                link.remove(old)
            el = ET.Element("inertial")
            ET.SubElement(el, "origin", xyz=" ".join(repr(float(v)) for v in T[:3, 3]),
                          rpy=" ".join(repr(float(v)) for v in rpy_from_matrix(T[:3, :3])))
            ET.SubElement(el, "mass", value=repr(float(mass)))
            ET.SubElement(el, "inertia", ixx=repr(float(I[0, 0])), ixy=repr(float(I[0, 1])), ixz=repr(float(I[0, 2])),
                          iyy=repr(float(I[1, 1])), iyz=repr(float(I[1, 2])), izz=repr(float(I[2, 2])))
            link.insert(0, el)
    return ET.tostring(root, encoding="unicode")


def _capsule_collisions(link, caps) -> None:
    """Replace the <collision> elements of URDF ``link`` by PyBullet capsules (z along the segment)."""
    from synth.io.solid import axis_rotation

    for old in link.findall("collision"):
        link.remove(old)
    for p0, p1, r in caps:
        el = ET.SubElement(link, "collision")
        d = p1 - p0
        length = float(np.linalg.norm(d))
        R = axis_rotation(d / length) if length > 1e-9 * r else np.eye(3)
        ET.SubElement(el, "origin", xyz=" ".join(repr(float(v)) for v in (p0 + p1) / 2),
                      rpy=" ".join(repr(float(v)) for v in rpy_from_matrix(R)))
        geom = ET.SubElement(el, "geometry")
        if length > 1e-9 * r:
            ET.SubElement(geom, "capsule", radius=repr(r), length=repr(length))
        else:
            ET.SubElement(geom, "sphere", radius=repr(r))


CPU_SECONDS_PER_STEP = 0.05  # the child's CPU budget per engine step (measured: ~3-5 ms for the 5-loop ladder)
STALL_SECONDS = 120.0  # a child that uses no CPU at all for this long (wall time) is hung


def run_in_subprocess(setup, *, seconds: float, timestep: float | None, gravity: bool, timeout: float = 600.0,
                      contacts: bool = False, tight: bool = False) -> dict:
    """Run `child_main` in a fresh Python; returns its result or raises SimulationError. The child's bound is
    CPU time, not wall time (a loaded machine must give the same answer, only later): at most ``timeout``
    or `CPU_SECONDS_PER_STEP` per step, whichever is larger (RLIMIT_CPU), and it is stopped as hung when
    it uses no CPU for `STALL_SECONDS`."""
    dt = timestep or DEFAULT_TIMESTEP
    cpu_budget = max(timeout, CPU_SECONDS_PER_STEP * seconds / dt)
    with tempfile.TemporaryDirectory(prefix="mpsynth-pybullet-") as tmp:
        tmp = Path(tmp)
        urdf = tmp / "sim.urdf"
        urdf.write_text(sim_urdf_text(setup, contacts), encoding="utf-8")
        request = {"out": str(setup.out), "urdf": str(urdf), "result": str(tmp / "result.json"),
                   "seconds": seconds, "timestep": dt, "gravity": gravity,
                   "contacts": contacts, "tight": tight}
        (tmp / "request.json").write_text(json.dumps(request), encoding="utf-8")
        proc = subprocess.Popen([sys.executable, "-m", "synth.tools.sim.pybullet_sim", str(tmp / "request.json")],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(_repo_root()),
                                preexec_fn=lambda: _limit_cpu(cpu_budget))
        stdout, stderr = _wait_while_working(proc, cpu_budget)
        result_file = tmp / "result.json"
        if proc.returncode == -signal.SIGXCPU:
            raise SimulationError(f"pybullet used its CPU budget ({cpu_budget:.0f} s) on {setup.out}")
        if proc.returncode < 0:
            raise SimulationError(f"pybullet crashed (signal {-proc.returncode}) on {setup.out}")
        if not result_file.exists():
            tail = (stderr or stdout).strip().splitlines()[-1:] or ["no output"]
            raise SimulationError(f"pybullet failed on {setup.out} (exit {proc.returncode}): {tail[0]}")
        res = json.loads(result_file.read_text(encoding="utf-8"))
    if "error" in res:
        raise SimulationError(f"pybullet failed on {setup.out}: {res['error']}")
    return res


def _limit_cpu(seconds: float) -> None:
    """In the child before exec: SIGXCPU once it has used ``seconds`` of CPU time."""
    import resource

    resource.setrlimit(resource.RLIMIT_CPU, (int(seconds) + 1, int(seconds) + 6))


def _cpu_seconds(pid: int) -> float | None:
    """CPU time (user + system) used so far by process ``pid`` (Linux /proc), None when unknown."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def _wait_while_working(proc, cpu_budget: float):
    """(stdout, stderr) of ``proc`` once it ends; kills it and raises SimulationError when it uses no CPU
    for `STALL_SECONDS` (or, where its CPU time cannot be read, after ``cpu_budget`` of wall time)."""
    last = None
    waited = 0.0
    while True:
        try:
            return proc.communicate(timeout=STALL_SECONDS)
        except subprocess.TimeoutExpired:
            waited += STALL_SECONDS
            cpu = _cpu_seconds(proc.pid)
            if (cpu is not None and cpu == last) or (cpu is None and waited >= cpu_budget):
                proc.kill()
                proc.communicate()
                raise SimulationError(f"pybullet stopped working (no progress for {STALL_SECONDS:.0f} s)") from None
            last = cpu


def solver_iterations(loops: int) -> int:
    """Solver iterations per step for ``loops`` welded loops: `ITERATIONS`, and `ITERATIONS_PER_LOOP` per
    loop beyond that. With the multi-loop residual threshold the iteration cap is what stops the solver,
    and the sequential-impulse solver passes a correction on about one weld of a chain per sweep
    (measured on fixtures/motion_darboux.yaml, 5 loops, at the defaults: 1.25e-3 rad with 3000 iterations,
    7.4e-4 with 6000 for 1.3x the CPU; halving the time step instead: 7.3e-4 for 1.8x)."""
    return max(ITERATIONS, ITERATIONS_PER_LOOP * loops)


def residual_threshold(loops: int, tight: bool = False) -> float:
    """The solver's early-stop residual for a linkage of ``loops`` welded loops (module docstring);
    ``tight``: the multi-loop threshold for any linkage (`synth.tools.sim.run.simulate`'s retry)."""
    return MULTI_LOOP_RESIDUAL_THRESHOLD if loops > 1 or tight else RESIDUAL_THRESHOLD


def _repo_root() -> Path:
    return Path(__file__).resolve().parents[2]


def _T(pos, orn, p) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)
    T[:3, 3] = pos
    return T


def _pos_quat_xyzw(T):
    w, x, y, z = matrix_to_quat(T[:3, :3])
    return [float(v) for v in T[:3, 3]], [float(x), float(y), float(z), float(w)]


def _weld_loops(p, cid, robot, setup, link_index) -> list:
    """The loop closures as fixed constraints between the welded links (frames relative to each link's
    centre-of-mass frame, as PyBullet places them); returns the constraint ids."""
    F0 = setup.urdf.fk({})
    constraints = []
    for a, b in setup.closures:
        ia, ib = link_index[a], link_index[b]
        Ia = _T(*p.getDynamicsInfo(robot, ia, physicsClientId=cid)[3:5], p)
        Ib = _T(*p.getDynamicsInfo(robot, ib, physicsClientId=cid)[3:5], p)
        X = F0[a]  # the weld frame: link a's frame at all-zero angles
        pa, qa = _pos_quat_xyzw(invert_pose(F0[a] @ Ia) @ X)
        pb, qb = _pos_quat_xyzw(invert_pose(F0[b] @ Ib) @ X)
        c = p.createConstraint(robot, ia, robot, ib, p.JOINT_FIXED, [0, 0, 0], pa, pb, qa, qb, physicsClientId=cid)
        p.changeConstraint(c, maxForce=1e9, physicsClientId=cid)
        constraints.append(c)
    return constraints


def simulate_in_process(setup, urdf_path, *, seconds: float, timestep: float, gravity: bool,
                        contacts: bool = False, tight: bool = False) -> dict:
    """The PyBullet run itself (call it in a child process only); ``tight``: see `residual_threshold`."""
    import pybullet as p

    t_wall = time.perf_counter()
    cid = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81 if gravity else 0.0, physicsClientId=cid)
        flags = p.URDF_USE_INERTIA_FROM_FILE | (p.URDF_USE_SELF_COLLISION if contacts else 0)
        robot = p.loadURDF(str(urdf_path), useFixedBase=True, flags=flags, physicsClientId=cid)
        index, link_index = {}, {"base": -1}
        for i in range(p.getNumJoints(robot, physicsClientId=cid)):
            info = p.getJointInfo(robot, i, physicsClientId=cid)
            index[info[1].decode()] = i
            link_index[info[12].decode()] = i
        missing = [jn for jn in setup.joints if jn not in index]
        if missing:
            raise RuntimeError(f"PyBullet did not load joint(s) {', '.join(missing)}")
        if contacts:  # self-collision on, except between links of one body or of two bodies on a joint
            from synth.tools.sim import contact_exclusions

            for pair in contact_exclusions(setup):
                a, b = tuple(pair)
                if a in link_index and b in link_index:
                    p.setCollisionFilterPair(robot, robot, link_index[a], link_index[b], 0, physicsClientId=cid)
        _weld_loops(p, cid, robot, setup, link_index)
        residual = residual_threshold(len(setup.closures), tight)
        iterations = solver_iterations(len(setup.closures))
        p.setPhysicsEngineParameter(fixedTimeStep=timestep, numSolverIterations=iterations, numSubSteps=0, erp=ERP,
                                    solverResidualThreshold=residual, physicsClientId=cid)
        start = setup.start_angles()
        for jn in setup.joints:
            p.resetJointState(robot, index[jn], start[jn], 0.0, physicsClientId=cid)
            p.setJointMotorControl2(robot, index[jn], p.VELOCITY_CONTROL, force=0, physicsClientId=cid)
        n = max(int(round(seconds / timestep)), 10)
        tracker = Tracker(setup)
        ids = [index[jn] for jn in setup.joints]
        welded = sorted({lk for pair in setup.closures for lk in pair})
        driver = index[setup.driver]
        targets = DriveProfile(setup, seconds).angle(np.arange(1, n + 1) / n)
        qs = np.empty((n, len(ids)))
        frames = {lk: np.zeros((n, 4, 4)) for lk in welded}
        contact_steps, max_force = 0, 0.0
        for k in range(n):
            p.setJointMotorControl2(robot, driver, p.POSITION_CONTROL, targetPosition=float(targets[k]),
                                    force=MOTOR_FORCE, positionGain=1.0, velocityGain=1.0, physicsClientId=cid)
            p.stepSimulation(physicsClientId=cid)
            if contacts:
                # PyBullet also reports pairs closer than its contact-breaking threshold (2 cm by
                # default) with a positive distance (c[8]); only a distance <= 0 is a contact
                touching = [c for c in p.getContactPoints(robot, robot, physicsClientId=cid) if c[8] <= 0.0]
                if touching:
                    contact_steps += 1
                    max_force = max(max_force, max(float(c[9]) for c in touching))
            qs[k] = [st[0] for st in p.getJointStates(robot, ids, physicsClientId=cid)]
            if not np.all(np.isfinite(qs[k])):
                raise RuntimeError(f"the simulation diverged at step {k + 1}")
            for lk in welded:
                st = p.getLinkState(robot, link_index[lk], computeForwardKinematics=True, physicsClientId=cid)
                frames[lk][k] = _T(st[4], st[5], p)
        tracker.joints({jn: qs[:, i] for i, jn in enumerate(setup.joints)}, targets)
        tracker.frames(frames)
        return tracker.result("pybullet", n, seconds=seconds, timestep=timestep, gravity=gravity,
                              iterations=iterations, residual_threshold=residual, shared_inertial=setup.split, contacts=contacts,
                              contact_steps=contact_steps, max_contact_force=max_force,
                              wall_time=time.perf_counter() - t_wall)
    finally:
        p.disconnect(physicsClientId=cid)


def child_main(argv=None) -> int:
    """Entry point of the child process: REQUEST.json in, RESULT.json out."""
    argv = sys.argv[1:] if argv is None else argv
    req = json.loads(Path(argv[0]).read_text(encoding="utf-8"))
    result_path = Path(req["result"])
    try:
        setup = load_setup(req["out"])
        with contextlib.redirect_stdout(io.StringIO()):  # PyBullet prints its build time on stdout
            res = simulate_in_process(setup, req["urdf"], seconds=req["seconds"], timestep=req["timestep"],
                                      gravity=req["gravity"], contacts=req.get("contacts", False),
                                      tight=req.get("tight", False))
    except Exception as e:  # noqa: BLE001 - reported to the parent as one line
        res = {"error": f"{type(e).__name__}: {e}"}
    result_path.write_text(json.dumps(res), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(child_main())
