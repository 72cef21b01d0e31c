"""MJCF (MuJoCo's model format) of a written linkage, built from linkage.urdf by our own code.

We write the MJCF ourselves instead of using MuJoCo's URDF import: the import ignores the ``<gazebo>``
welds, drops mesh directories unless told otherwise, and merges fixed-joint links; our own writer keeps
every link and joint name of the URDF and needs no MuJoCo to run (``--export-mjcf`` works without it).

- one ``<body>`` per URDF link with the URDF link frame (``pos``/``quat`` = the joint origin), a
  ``hinge`` joint with the URDF axis for every continuous/revolute joint, no joint for fixed ones;
  ``base`` is welded to the world;
- ``<inertial>`` from the URDF's (``inertiafromgeom="false"``) as principal moments and axes, the
  coupler's inertial shared with its welded copy (see `synth.tools.sim`);
- mesh geoms ``<mesh file=... scale="0.001 0.001 0.001">`` (the URDF's scale; the STL files are in
  millimetres), visual and collision alike; ``<contact><exclude>`` for every pair of the linkage's
  bodies, so the links never touch each other (they may still touch anything you add);
- one ``<equality><weld>`` per loop between ``coupler`` and ``coupler_k`` with the all-zero relative
  pose (``relpose``), stiff ``solref``/``solimp`` and the ``torquescale`` (weight of its angular rows)
  that holds the angular rows as stiffly as the linear ones (`synth.tools.sim.mujoco_sim.weld_torquescales`;
  1 when not given);
- a ``<position>`` actuator ``drive_<joint>`` on the first joint, ``ctrl`` = the target angle; ``kp``/``kv``
  make a critically damped servo with a time constant of 20 time steps for the smallest inertia the
  driver sees (`servo_gains`);
- ``<option>``: the time step, gravity off (or on), the implicit-fast integrator, Newton solver, 200
  iterations, tolerance 1e-12 — the weld on a one-dof loop is overconstrained and needs a converged
  solve.
"""
from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from synth.algebra.dq import matrix_to_quat
from synth.errors import InputError
from synth.io.atomic import atomic_write

DEFAULT_TIMESTEP = 5e-4
ITERATIONS = 200
SERVO_STEPS = 20  # servo time constant in time steps
WELD_SOLIMP = "0.9999 0.9999 0.001 0.5 2"  # the loop welds' impedance: MuJoCo's stiffest (d <= 0.9999)


def _f(x) -> str:
    return repr(float(x) + 0.0)


def _v(v) -> str:
    return " ".join(_f(x) for x in v)


def _mesh_assets(setup, asset, mesh_base) -> dict:
    """The <mesh> assets, one per (file, scale): {(path, scale): asset name}."""
    mesh_names = {}
    for m in setup.urdf.meshes:
        path = setup.mesh_path(m.filename)
        key = (str(path), tuple(m.scale))
        if key in mesh_names:
            continue
        name = f"mesh_{m.link}" if f"mesh_{m.link}" not in mesh_names.values() else f"mesh_{m.link}_{len(mesh_names)}"
        mesh_names[key] = name
        file = os.path.relpath(path, mesh_base) if mesh_base is not None else str(path)
        ET.SubElement(asset, "mesh", name=name, file=file, scale=_v(m.scale))
    return mesh_names


def _body(setup, parent_el, link, T, joint, mesh_names, caps):
    """The <body> of ``link`` in ``parent_el`` at pose ``T`` (None: the world's), with its inertial, its
    hinge ``joint`` (None: welded), its mesh geoms and, with ``caps``, the design's capsules as the
    colliding geoms."""
    attrs = {"name": link}
    if T is not None:
        attrs.update(pos=_v(T[:3, 3]), quat=_v(matrix_to_quat(T[:3, :3])))
    b = ET.SubElement(parent_el, "body", **attrs)
    if link in setup.inertials:
        mass, Ti, I = setup.inertials[link]
        quat, diag = principal_inertia(Ti[:3, :3] @ I @ Ti[:3, :3].T)
        ET.SubElement(b, "inertial", pos=_v(Ti[:3, 3]), quat=_v(quat), mass=_f(mass), diaginertia=_v(diag))
    else:
        ET.SubElement(b, "inertial", pos="0 0 0", mass="1e-06", diaginertia="1e-09 1e-09 1e-09")
    if joint is not None:
        extra = {}
        if joint.name == setup.driver and tuple(setup.drive_range) != (0.0, 2 * math.pi):
            extra["range"] = _v(setup.drive_range)  # the task range of a task-range design
        ET.SubElement(b, "joint", name=joint.name, type="hinge", pos="0 0 0", axis=_v(joint.axis), **extra)
    seen = set()
    for m in setup.urdf.meshes:
        if m.link != link:
            continue
        key = (str(setup.mesh_path(m.filename)), tuple(m.scale))
        if (key, m.origin.tobytes()) in seen:  # visual and collision share one geom
            continue
        seen.add((key, m.origin.tobytes()))
        ET.SubElement(b, "geom", type="mesh", mesh=mesh_names[key], pos=_v(m.origin[:3, 3]),
                      quat=_v(matrix_to_quat(m.origin[:3, :3])), rgba=_rgba(link),
                      **({"contype": "0", "conaffinity": "0"} if caps is not None else {}))
    for p0, p1, r in (caps or {}).get(link, []):  # --contacts: the design's capsules collide
        if np.linalg.norm(p1 - p0) > 1e-9 * r:
            ET.SubElement(b, "geom", type="capsule", fromto=_v(list(p0) + list(p1)), size=_f(r), group="3",
                          rgba="0 0 0 0", mass="0")
        else:
            ET.SubElement(b, "geom", type="sphere", pos=_v(p0), size=_f(r), group="3", rgba="0 0 0 0", mass="0")
    return b


def mjcf_text(setup, *, timestep: float | None = None, gravity: bool = False, mesh_base: Path | None = None,
              kp: float | None = None, kv: float | None = None, contacts: bool = False, torquescale=None) -> str:
    """The MJCF document. Mesh files are written relative to ``mesh_base`` (the directory of the MJCF
    file) when given, else as absolute paths. ``torquescale``: one per loop weld (None: 1 each). ``contacts``: exclude only the pairs of
    `synth.tools.sim.contact_exclusions` (else every pair), and collide the design's capsules
    (`synth.tools.sim.contact.contact_capsules`) instead of the meshes when linkage.json has a design."""
    u = setup.urdf
    dt = timestep or DEFAULT_TIMESTEP
    if kp is None or kv is None:
        kp, kv = servo_gains(setup, dt)
    caps = None
    if contacts:  # collide the design's capsules (linkage.json) where there is one, else the meshes
        from synth.tools.sim.contact import contact_capsules

        caps = contact_capsules(setup)
    root = ET.Element("mujoco", model=setup.name)
    root.append(ET.Comment(" written by mpsynth simulate from linkage.urdf; loop welds in <equality>, the "
                           "coupler's mass shared with its welded copy, contacts between linkage links excluded "))
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    ET.SubElement(root, "option", timestep=_f(dt), gravity=_v([0, 0, -9.81 if gravity else 0.0]),
                  integrator="implicitfast", solver="Newton", iterations=str(ITERATIONS), tolerance="1e-12",
                  ls_iterations="50")
    mesh_names = _mesh_assets(setup, ET.SubElement(root, "asset"), mesh_base)
    world = ET.SubElement(root, "worldbody")
    bodies = {}

    def add_body(parent_el, link, T, joint=None):
        bodies[link] = _body(setup, parent_el, link, T, joint, mesh_names, caps)

    add_body(world, "base", None)
    for jn in u.order:
        j = u.joints[jn]
        add_body(bodies[j.parent], j.child, j.origin,
                 j if j.kind in ("revolute", "continuous") else None)

    contact = ET.SubElement(root, "contact")
    names = list(bodies)
    if contacts:
        from synth.tools.sim import contact_exclusions

        excluded = contact_exclusions(setup)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if not contacts or frozenset((a, b)) in excluded:
                ET.SubElement(contact, "exclude", body1=a, body2=b)

    eq = ET.SubElement(root, "equality")
    scales = [1.0] * len(setup.closures) if torquescale is None else list(torquescale)
    for name, (a, b), R, ts in zip(setup.closure_names, setup.closures, setup.refs, scales):
        # relpose: pose of body2 in the frame of body1 (the all-zero relative pose)
        ET.SubElement(eq, "weld", name=name, body1=a, body2=b, relpose=_v(list(R[:3, 3]) + list(matrix_to_quat(R[:3, :3]))),
                      solref=_v([2 * dt, 1.0]), solimp=WELD_SOLIMP, torquescale=_f(ts))

    act = ET.SubElement(root, "actuator")
    ET.SubElement(act, "position", name=f"drive_{setup.driver}", joint=setup.driver, kp=_f(kp), kv=_f(kv))
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n"


def principal_inertia(I) -> tuple[np.ndarray, np.ndarray]:
    """(quat wxyz, principal moments) of a body-frame inertia tensor. The moments are kept positive and
    within the triangle inequality that MuJoCo enforces: a thin pin's moment about its own axis can
    round to zero or below, and is raised to 1e-9 of the largest moment (and to 1e-15 kg m^2, MuJoCo's
    smallest accepted value)."""
    I = 0.5 * (np.asarray(I, float) + np.asarray(I, float).T)
    ev, V = np.linalg.eigh(I)
    if np.linalg.det(V) < 0:
        V[:, 0] = -V[:, 0]
    top = max(float(ev.max()), 1e-15)
    ev = np.maximum(ev, max(1e-9 * top, 1e-15))
    a, b, c = ev  # ascending
    if a + b < c:
        a = b = max(a, c / 2)
    return matrix_to_quat(V), np.array([a, b, c])


def _rgba(link: str) -> str:
    return {"base": "0.35 0.35 0.38 1", "coupler": "0.95 0.55 0.1 1"}.get(link, "0.45 0.6 0.8 1")


def servo_gains(setup, dt: float) -> tuple[float, float]:
    """(kp, kv) of the driver's position servo: critically damped, time constant SERVO_STEPS * dt, for
    the smallest inertia the driver can see: the inertia reflected along the exact motion, or, on time
    scales shorter than the soft weld's, its own subtree's inertia about its axis (a stiffer servo
    oscillates against the weld and diverges)."""
    ff = DriveModel(setup)
    I = min(float(ff.inertia.min()), ff.subtree_min)
    w = 1.0 / (SERVO_STEPS * dt)
    return I * w * w, 2.0 * I * w


class DriveModel:
    """The one-degree-of-freedom dynamics of the linkage along its exact motion, as a function of the
    driver angle phi: reflected inertia I(phi) (kinetic energy = I phi'^2 / 2), its slope I'(phi) and the
    gravity torque G(phi), sampled on a periodic grid from the URDF inertials and the angle laws. The
    torque that moves the linkage along phi(t) is I phi'' + I' phi'^2 / 2 + G (Lagrange); the MuJoCo run
    feeds it forward to the position servo, which then only corrects small errors."""

    def __init__(self, setup, samples: int = 720, gravity: bool = False):
        u = setup.urdf
        self.phi = np.linspace(0.0, 2 * math.pi, samples, endpoint=False)
        h = 1e-6
        Fp = u.fk(setup.exact(self.phi + h), n=samples)
        Fm = u.fk(setup.exact(self.phi - h), n=samples)
        F0 = u.fk(setup.exact(self.phi), n=samples)
        g = np.array([0.0, 0.0, -9.81 if gravity else 0.0])
        inertia = np.zeros(samples)
        torque_g = np.zeros(samples)
        below = set(_subtree(u, setup.driver))
        sub = np.zeros(samples)
        dj = u.joints[setup.driver]
        Fd = F0[dj.parent] @ dj.origin
        axis = Fd[:, :3, :3] @ dj.axis
        pivot = Fd[:, :3, 3]
        for link, (mass, Ti, I) in setup.inertials.items():
            if link not in F0:
                continue
            Cp, Cm, C0 = Fp[link] @ Ti, Fm[link] @ Ti, F0[link] @ Ti
            v = (Cp[:, :3, 3] - Cm[:, :3, 3]) / (2 * h)
            dR = (Cp[:, :3, :3] - Cm[:, :3, :3]) / (2 * h)
            R = C0[:, :3, :3]
            W = dR @ np.swapaxes(R, 1, 2)  # skew matrix of the angular velocity per unit driver speed
            w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], 1)
            Iw = np.einsum("nij,jk,nlk,nl->ni", R, I, R, w)  # R I R^T w
            inertia += mass * np.sum(v * v, 1) + np.sum(w * Iw, 1)
            torque_g -= mass * (v @ g)
            if link in below:  # inertia of the driver's subtree about its axis, weld ignored
                r = np.cross(axis, C0[:, :3, 3] - pivot)
                Ia = np.einsum("ni,nij,jk,nlk,nl->n", axis, R, I, R, axis)
                sub += mass * np.sum(r * r, 1) + Ia
        self.inertia = np.maximum(inertia, 1e-15)
        self.slope = (np.roll(inertia, -1) - np.roll(inertia, 1)) / (2 * (self.phi[1] - self.phi[0]))
        self.gravity = torque_g
        self.subtree_min = float(max(sub.min(), 1e-15))

    def _at(self, arr, phi):
        return np.interp(np.mod(phi, 2 * math.pi), np.append(self.phi, 2 * math.pi), np.append(arr, arr[0]))

    def torques(self, phi, speed, accel):
        """Torques (array) at driver angles, speeds and accelerations (arrays)."""
        return (self._at(self.inertia, phi) * accel + 0.5 * self._at(self.slope, phi) * speed * speed
                + self._at(self.gravity, phi))


def _subtree(u, joint: str) -> list[str]:
    """Links moved by ``joint`` in the URDF tree (its child and everything below)."""
    out = [u.joints[joint].child]
    for jn in u.order:
        if u.joints[jn].parent in out:
            out.append(u.joints[jn].child)
    return out


def write_mjcf(setup, path, *, timestep: float | None = None, gravity: bool = False, contacts: bool = False,
               torquescale=None) -> Path:
    """Write the MJCF to ``path`` (mesh paths relative to its directory)."""
    path = Path(path)
    if not path.parent.exists():
        raise InputError(f"{path.parent}: directory does not exist (for --export-mjcf)")
    text = mjcf_text(setup, timestep=timestep, gravity=gravity, mesh_base=path.parent.resolve(), contacts=contacts,
                     torquescale=torquescale)
    atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return path
