"""`mpsynth simulate`: drive a written linkage in a real physics engine and compare with the exact motion.

Engines (optional extra ``mpsynth[sim]``): PyBullet (`pybullet_sim`, always run in a child process
because a malformed model can crash it) and MuJoCo (`mujoco_sim`, model built by `mjcf`); `run.simulate`
picks one. This module holds what they share (`load_setup`, `DriveProfile`, `Tracker`) and imports
none of them.

What every engine does (the closed-loop convention of docs/conventions.md):
- load the tree of linkage.urdf with the base fixed, gravity off unless asked for;
- close every loop the engine's way (PyBullet: a JOINT_FIXED user constraint between ``coupler`` and
  ``coupler_k``; MuJoCo: an ``<equality><weld>``), with no contacts between the linkage's links;
- the cut copy ``coupler_k`` carries only a 1e-6 kg placeholder inertial in the URDF, which the
  engines' constraint solvers cannot hold (PyBullet's weld then gives way by decimetres); for the
  simulation the coupler's mass and inertia are therefore shared half and half between ``coupler`` and
  its welded copy (same centre of mass, same inertia tensor), which leaves the dynamics of the welded
  pair unchanged (`sim_inertials`);
- with ``contacts`` (``mpsynth simulate --contacts``): contacts between the meshes of every two rigid
  bodies that share no revolute joint (links merged across fixed joints, e.g. the pins, and loop welds;
  `contact_exclusions`) with the design's capsules as collision geometry (`synth.tools.sim.contact`);
  the result counts the steps with such a contact and the largest contact force;
- start at all-zero angles at rest (a valid configuration: the first pose), release every joint's
  default motor and drive the first joint of the first branch through one full turn in ``seconds``
  with a position motor, paced for an even joint-space speed of the whole linkage (`DriveProfile`); when
  that joint nearly stops somewhere (another joint turns over `STEADY_RATIO` times as fast), the joint
  whose worst speed ratio is smallest drives instead if it stays within `STEADY_RATIO` (`steady_driver`),
  else the stretch where the driver nearly stops (a near-singular passage of the loop) is tracked apart
  (`Unsteady`: there the welds' give is magnified by the speed ratio);
- after every step compare every joint with the exact motion: the configuration's distance from the
  motion's curve in joint space (`nearest_on_motion`: the driver angle phi whose exact angles, via the
  motion parameter t = a + b cot(phi/2) of the angle laws theta(t) = 2 atan2(b, t - a),
  `synth.tools.check.continuation.law_angles`, fit all joints best); and measure the gap of every weld (the
  engine's own world frames of the two welded links against their relative pose at all-zero angles).
"""
from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.algebra.geometry import invert_pose, pose_difference
from synth.errors import InputError, MpsynthError
from synth.frames import wrap_angle
from synth.tools.check.continuation import law_angles
from synth.io.linkagedoc import angle_laws, angle_rates, loop_laws
from synth.io.readback import mesh_path, read_files

ENGINES = ("pybullet", "mujoco")
TWO_PI = 2.0 * math.pi
NEGLIGIBLE_MASS = 1e-3  # a welded copy lighter than this fraction of its partner is a placeholder


class EngineNotInstalled(MpsynthError):
    """The physics engine cannot be imported (exit code 2)."""

    exit_code = 2


class SimulationError(MpsynthError):
    """The engine failed (crashed, model rejected, diverged). Exit code 1."""

    exit_code = 1


def require_engine(engine: str) -> None:
    if engine not in ENGINES:
        raise InputError(f"unknown engine {engine!r}: choose one of {', '.join(ENGINES)}")
    if importlib.util.find_spec(engine) is None:
        raise EngineNotInstalled(f"{engine} is not installed: pip install 'mpsynth[sim]'")


@dataclass
class SimSetup:
    """Everything the engines need, read from OUT (no engine imported here)."""

    out: Path
    urdf: object  # synth.io.urdfmodel.UrdfModel
    name: str
    laws: dict  # joint -> (a, b)
    driver: str
    joints: list  # revolute joints (URDF order), driver included
    closures: list  # [(link, duplicate)]
    closure_names: list
    refs: list  # inv(F_link(0)) @ F_duplicate(0)
    inertials: dict  # link -> (mass, 4x4 inertial frame in the link frame, 3x3 inertia), after the split
    split: list = field(default_factory=list)  # links whose inertial was shared with their welded copy
    size: float = 1.0  # RMS spread of the joint frames (m): the scale for the closure gap
    drive_range: tuple = (0.0, TWO_PI)  # the driver's sweep: its URDF limits when it has them, else a turn
    rates: dict = field(default_factory=dict)  # joint -> rate of its angle law (absent: 1)
    singular_deg: tuple = ()  # driver angles (deg) of singular configurations (linkage.json info.darboux)
    loops: dict = field(default_factory=dict)  # joint -> its planar four-bar loop law (docs/fourbar.md)
    driver_choice: object = None  # a `DriverChoice` when another joint than the first is driven
    unsteady: object = None  # the `Unsteady` stretch of the sweep: where the driver nearly stops

    def start_angles(self) -> dict:
        """Joint angles at the start of the sweep: all zero, or the exact motion at the lower limit."""
        lo = self.drive_range[0]
        if lo == 0.0:
            return {jn: 0.0 for jn in self.joints}
        ex = self.exact(lo)
        return {jn: (lo if jn == self.driver else float(np.asarray(ex[jn]))) for jn in self.joints}

    def exact(self, phi):
        """Exact angles of every joint when the driver is at angle(s) phi (radians, any turn)."""
        return law_angles(self.laws, self.driver, np.mod(np.asarray(phi, float), TWO_PI), self.rates, self.loops)

    def mesh_path(self, filename: str) -> Path:
        """Absolute path of a URDF mesh filename (relative to OUT; package://NAME/x -> OUT/x)."""
        p = mesh_path(filename, self.out)
        return (p if p is not None else self.out / filename).resolve()


def load_setup(out) -> SimSetup:
    """Read OUT (linkage.urdf, linkage.json). InputError when unreadable or not a simulable linkage."""
    o = read_files(out)
    u, doc = o.urdf, o.doc
    if u.problems:
        raise InputError(f"{out}: linkage.urdf is malformed: {u.problems[0]}")
    laws = angle_laws(doc)
    joints = [jn for jn in u.order if u.joints[jn].kind in ("revolute", "continuous")]
    if not joints:
        raise InputError(f"{out}: the URDF has no revolute joint to drive")
    missing = [jn for jn in joints if jn not in laws]
    if missing:
        raise InputError(f"{out}: linkage.json has no angle law for joint(s) {', '.join(missing)} "
                         "(the exact motion to compare with)")
    if not u.closures:
        raise InputError(f"{out}: the URDF has no loop closure (<gazebo><joint type=\"fixed\">)")
    closures = [(a, b) for _, a, b in u.closures]
    names = [n for n, _, _ in u.closures]
    for a, b in closures:
        if a not in u.links or b not in u.links:
            raise InputError(f"{out}: loop closure {a}-{b} names a missing link")
    br = doc.get("branches")
    driver = br[0][0] if (isinstance(br, list) and br and isinstance(br[0], list) and br[0]
                          and br[0][0] in joints) else u.path(closures[0][0])[0]
    F0 = u.fk({})
    refs = [invert_pose(F0[a]) @ F0[b] for a, b in closures]
    inertials, split = sim_inertials(u, closures, refs)
    pts = np.array([F0[u.joints[jn].child][:3, 3] for jn in joints])
    size = float(np.sqrt(np.mean(np.sum((pts - pts.mean(0)) ** 2, 1))))
    drive = (0.0, TWO_PI)
    lim = u.joints[driver].limit if u.joints[driver].kind == "revolute" else None
    if lim is not None and 0 < lim[1] - lim[0] < TWO_PI - 1e-9:  # a task-range design: stay inside
        drive = (float(lim[0]), float(lim[1]))
    rates, loops, singular = angle_rates(doc), loop_laws(doc), _singular_deg(doc, driver)
    choice = steady_driver(laws, rates, loops, joints, driver, drive) if not singular else None
    setup = SimSetup(Path(out).resolve(), u, u.name or "linkage", laws, driver, joints, closures, names, refs,
                     inertials, split, size, drive, rates, singular, loops)
    if choice is not None:
        setup.driver, setup.drive_range, setup.driver_choice = choice.joint, choice.drive_range, choice
    elif not singular:
        setup.unsteady = unsteady_stretch(laws, rates, loops, joints, driver, drive)
    return setup


@dataclass(frozen=True)
class Unsteady:
    """Where the driver nearly stops: over the driver angles ``phi`` (n,) (rad, its sweep) the steps
    ``mask`` (n,) where some joint turns more than `STEADY_RATIO` times as fast as the driver, and no joint
    of the linkage would drive that stretch steadily (`steady_driver` found none); the worst: ``fastest``
    turns ``ratio`` times as fast as the driver at its angle ``at`` (rad)."""

    phi: np.ndarray
    mask: np.ndarray
    ratio: float
    fastest: str
    at: float

    def contains(self, angles) -> np.ndarray:
        """(n,) bool: which driver angles (rad, in the sweep's coordinates) lie in the stretch."""
        k = np.clip(np.searchsorted(self.phi, np.asarray(angles, float)), 0, len(self.phi) - 1)
        return self.mask[k] | self.mask[np.maximum(k - 1, 0)]

    def span_deg(self) -> tuple[float, float]:
        """The first and last driver angle (deg) of the piece of the stretch around the worst point ``at``
        (over the end of a whole-turn sweep: from below 0)."""
        k = int(np.argmin(np.abs(self.phi - self.at)))
        lo = hi = k
        while lo > 0 and self.mask[lo - 1]:
            lo -= 1
        while hi < len(self.mask) - 1 and self.mask[hi + 1]:
            hi += 1
        start, end = float(self.phi[lo]), float(self.phi[hi])
        turn = abs(self.phi[-1] - self.phi[0] - TWO_PI) < 1e-9
        if turn and lo == 0 and self.mask[-2]:  # the piece runs on from the end of the turn
            j = len(self.mask) - 2
            while j > 0 and self.mask[j - 1]:
                j -= 1
            start = float(self.phi[j]) - TWO_PI
        elif turn and hi == len(self.mask) - 1 and self.mask[1]:
            j = 1
            while j < len(self.mask) - 1 and self.mask[j + 1]:
                j += 1
            end = float(self.phi[j]) + TWO_PI
        return math.degrees(start), math.degrees(end)


def unsteady_stretch(laws, rates, loops, joints, driver, drive, grid: int = 4096) -> Unsteady | None:
    """The `Unsteady` stretch of the driver's sweep ``drive`` (rad), or None when every joint stays within
    `STEADY_RATIO` times the driver's speed."""
    if driver not in laws or driver in (loops or {}):
        return None
    phi, _, dq = joint_speeds(laws, rates, loops, joints, driver, drive, grid)
    ratio = dq / np.maximum(dq[joints.index(driver)], 1e-300)  # (J, n)
    worst = ratio.max(axis=0)
    if worst.max() <= STEADY_RATIO:
        return None
    k = int(worst.argmax())
    return Unsteady(phi, worst > STEADY_RATIO, float(worst[k]), joints[int(ratio[:, k].argmax())], float(phi[k]))


STEADY_RATIO = 10.0  # the first joint drives unless another joint turns this many times as fast somewhere


@dataclass(frozen=True)
class DriverChoice:
    """Why the simulation drives ``joint`` and not the first joint ``first``: somewhere in its sweep
    ``fastest`` turns ``ratio`` times as fast as ``first`` (at ``first``'s angle ``at``, rad), while no joint
    ever turns more than ``joint_ratio`` times as fast as ``joint``; ``drive_range``: ``joint``'s sweep
    (rad) over the same arc of the motion."""

    first: str
    ratio: float
    fastest: str
    at: float
    joint: str
    joint_ratio: float
    drive_range: tuple

    def sentence(self) -> str:
        return (f"driving {self.joint} (no joint turns more than {self.joint_ratio:.3g} times as fast) instead of "
                f"{self.first}, which nearly stops where {self.fastest} turns {self.ratio:.3g} times as fast "
                f"({self.first} = {math.degrees(self.at) % 360:.1f} deg)")


def joint_speeds(laws, rates, loops, joints, driver, drive, grid: int = 4096):
    """(phi (n,), angles (J, n) unwrapped, speeds (J, n) |d theta_j / d phi|) of ``joints`` over the
    driver's sweep ``drive`` (rad) on a grid of n = ``grid`` + 1 driver angles phi."""
    phi = np.linspace(drive[0], drive[1], grid + 1)
    ex = law_angles(laws, driver, np.mod(phi, TWO_PI), rates, loops)
    q = np.unwrap(np.array([np.broadcast_to(ex[jn], phi.shape) for jn in joints]), axis=1)
    return phi, q, np.abs(np.gradient(q, phi, axis=1))


def speed_ratios(laws, rates, loops, joints, driver, drive, grid: int = 4096):
    """(ratios (J,), fastest joint index (J,), driver-grid index of it (J,), phi grid, angles (J, n)) over
    the driver's sweep ``drive`` (rad): for every joint k of ``joints`` the largest |d theta_i / d theta_k|
    over the sweep and the joints i (the joint whose speed a motor on k would have to multiply most)."""
    phi, q, dq = joint_speeds(laws, rates, loops, joints, driver, drive, grid)
    ratio = dq[None, :, :] / np.maximum(dq[:, None, :], 1e-300)  # [k, i, n]: joint i per unit of joint k
    worst = ratio.max(axis=1)  # (J, n)
    at = worst.argmax(axis=1)
    fastest = ratio[np.arange(len(joints)), :, at].argmax(axis=1)
    return worst.max(axis=1), fastest, at, phi, q


def steady_driver(laws, rates, loops, joints, driver, drive) -> DriverChoice | None:
    """The joint to drive instead of ``driver`` over the same arc of the motion, or None to keep it: when
    some joint turns more than `STEADY_RATIO` times as fast as ``driver`` somewhere in its sweep ``drive``
    (the driver nearly stops at a near-singular configuration: a position motor on it barely constrains the
    rest of the loop, whose welds then give way by the speed ratio), the joint whose worst speed ratio is
    smallest, when that one stays within `STEADY_RATIO` (else no joint drives the passage steadily: the
    first joint is kept); candidates: joints with their own angle law of rate 1 (no four-bar loop law)."""
    ok = [k for k, jn in enumerate(joints) if jn in laws and jn not in (loops or {}) and rates.get(jn, 1) == 1]
    if driver not in [joints[k] for k in ok]:
        return None
    worst, fastest, at, phi, q = speed_ratios(laws, rates, loops, joints, driver, drive)
    d = joints.index(driver)
    if worst[d] <= STEADY_RATIO:
        return None
    best = min(ok, key=lambda k: (worst[k], k))
    if worst[best] > STEADY_RATIO:  # no steady joint: a near-singular passage of the loop (`run.simulate`)
        return None
    lo, hi = float(q[best, 0]), float(q[best, -1])
    if (lo, hi) != (0.0, 0.0) and tuple(drive) == (0.0, TWO_PI):
        lo, hi = 0.0, TWO_PI  # a whole turn of the driver is a whole turn of every joint of rate 1
    lo, hi = min(lo, hi), max(lo, hi)
    return DriverChoice(driver, float(worst[d]), joints[int(fastest[d])], float(phi[at[d]]), joints[best],
                        float(worst[best]), (lo, hi))


def _singular_deg(doc: dict, driver: str) -> tuple:
    """The driver's angles (deg) at the singular configurations recorded in linkage.json (the 7R Darboux
    loop's ``info.darboux.singular_driver_deg``, driver = the first joint of the first branch), else ()."""
    d = doc.get("info", {}).get("darboux", {}) if isinstance(doc.get("info"), dict) else {}
    br = doc.get("branches")
    first = br[0][0] if isinstance(br, list) and br and isinstance(br[0], list) and br[0] else None
    vals = d.get("singular_driver_deg") if isinstance(d, dict) else None
    if first != driver or not isinstance(vals, list):
        return ()
    return tuple(float(v) for v in vals if isinstance(v, (int, float)))


def contact_exclusions(setup) -> set:
    """Pairs of URDF links (frozensets) that never get contacts: links of one rigid body (fixed joints,
    loop welds) and links of two bodies joined by a revolute joint (they touch at the pin by design)."""
    u = setup.urdf
    body = {lk: lk for lk in u.links}

    def find(x):
        while body[x] != x:
            x = body[x]
        return x

    for jn in u.order:
        j = u.joints[jn]
        if j.kind not in ("revolute", "continuous"):
            body[find(j.child)] = find(j.parent)
    for a, b in setup.closures:
        body[find(b)] = find(a)
    adjacent = {frozenset((find(u.joints[jn].parent), find(u.joints[jn].child))) for jn in u.order
                if u.joints[jn].kind in ("revolute", "continuous")}
    links = list(u.links)
    return {frozenset((a, b)) for i, a in enumerate(links) for b in links[i + 1:]
            if find(a) == find(b) or frozenset((find(a), find(b))) in adjacent}


def sim_inertials(u, closures, refs):
    """Inertials for the simulation: a welded copy with a negligible (placeholder) mass shares its
    partner's mass and inertia equally (same centre of mass and axes, expressed in each link's frame).
    Returns ({link: (mass, 4x4 frame, 3x3 inertia)}, [links split])."""
    out = {k: (m, T.copy(), I.copy()) for k, (m, T, I) in u.inertials.items()}
    copies: dict[str, list] = {}
    for (a, b), R in zip(closures, refs):
        ma = u.inertials.get(a, (0.0, None, None))[0]
        mb = u.inertials.get(b, (0.0, None, None))[0]
        if ma > 0 and mb <= NEGLIGIBLE_MASS * ma:
            copies.setdefault(a, []).append((b, R))
    split = []
    for a, dups in copies.items():
        m, T, I = u.inertials[a]
        k = len(dups) + 1
        out[a] = (m / k, T.copy(), I / k)
        for b, R in dups:  # R = pose of b in a's frame; the inertial frame in b's frame is R^-1 T
            out[b] = (m / k, invert_pose(R) @ T, I / k)
        split.append(a)
    return out, split


def ease(s):
    """Smooth 0 -> 1 over s in [0, 1] with zero speed at both ends: s - sin(2 pi s) / (2 pi)."""
    s = np.asarray(s, float)
    return s - np.sin(TWO_PI * s) / TWO_PI


class DriveProfile:
    """The driver's target angle over time: one full turn in ``seconds``, paced so that the linkage moves
    at an even speed in joint space (all joints together), easing in and out at rest.

    Driving the first joint at an even pace would whip the other joints where their angle laws are
    steep (a joint can turn 10-100 times faster than the driver for a moment), and the engines' errors
    grow with those accelerations. So with ``w(phi) = |d q / d phi|`` along the exact motion and the
    arc length ``L(phi) = integral of w``, the driver's angle at normalized time s is
    ``phi = L^-1(L(2 pi) ease(s))``."""

    def __init__(self, setup, seconds: float, grid: int = 8192):
        self.seconds = seconds
        phi = np.linspace(*setup.drive_range, grid + 1)
        ex = setup.exact(phi)
        dq = np.array([np.gradient(np.unwrap(ex[j]), phi) for j in setup.joints])
        w = np.sqrt(np.sum(dq * dq, axis=0))
        L = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(phi))])
        self.phi, self.L, self.w, self.dw = phi, L, w, np.gradient(w, phi)
        self.peak_ratio = float(np.abs(dq).max())  # fastest joint speed per unit driver speed

    def angle(self, s):
        """Driver angle(s) at normalized time(s) s in [0, 1]."""
        return np.interp(ease(s) * self.L[-1], self.L, self.phi)

    def track(self, n: int):
        """(angle, speed, acceleration) arrays at the times k / n * seconds, k = 0..n-1. With l = L(phi):
        phi' = l' / w(phi) and phi'' = (l'' - w'(phi) phi'^2) / w(phi)."""
        s = np.arange(n) / n
        T, Ltot = self.seconds, self.L[-1]
        phi = self.angle(s)
        w, dw = np.interp(phi, self.phi, self.w), np.interp(phi, self.phi, self.dw)
        l1 = Ltot * (1.0 - np.cos(TWO_PI * s)) / T
        l2 = Ltot * TWO_PI * np.sin(TWO_PI * s) / T ** 2
        speed = l1 / w
        return phi, speed, (l2 - dw * speed * speed) / w


NEAREST_ITERATIONS = 6  # Gauss-Newton steps of `nearest_on_motion` (it starts within ~1e-3 rad: 2-3 suffice)


def nearest_on_motion(setup: SimSetup, q: dict):
    """The exact configurations nearest to simulated ones: per step, the driver angle phi* minimizing
    sum_j wrap(q_j - theta_j(phi))^2 over every joint j (Gauss-Newton from the driver's own angle, a step
    kept only where it lowers the sum). q: joint -> (n,) angles (rad). Returns (phi* (n,), residuals
    (joints, n) in rad, joints in ``setup.joints`` order).

    The deviation of a simulated linkage from its motion is its distance from the motion's curve in joint
    space. Reading the curve at the driver's angle alone instead multiplies the driver's own error by the
    speed ratio |d theta_j / d phi|, which reaches 250 where a driver barely turns while the rest of the
    linkage swings (fixtures/sixbar_hermite.yaml: 0.09 rad from a 3.5e-4 rad slip of the driver)."""
    Q = np.array([q[jn] for jn in setup.joints])

    def residual(phi):
        ex = setup.exact(phi)
        return wrap_angle(Q - np.array([np.broadcast_to(ex[jn], phi.shape) for jn in setup.joints]))

    phi = np.array(q[setup.driver], float)
    r = residual(phi)
    cost = np.sum(r * r, axis=0)
    h = 1e-7
    for _ in range(NEAREST_ITERATIONS):
        d = (residual(phi + h) - residual(phi - h)) / (2 * h)  # d r / d phi
        step = -np.sum(d * r, axis=0) / np.maximum(np.sum(d * d, axis=0), 1e-300)
        cand = phi + step
        rc = residual(cand)
        cc = np.sum(rc * rc, axis=0)
        better = cc < cost
        phi, r, cost = np.where(better, cand, phi), np.where(better, rc, r), np.where(better, cc, cost)
    return phi, r


class Tracker:
    """Running worst deviations: joints against the exact motion, welds against their rest pose."""

    def __init__(self, setup: SimSetup):
        self.setup = setup
        self.max_dev = 0.0
        self.worst_joint = None
        self.worst_angle = 0.0  # the driver's angle (rad) where the worst joint deviation was seen
        self.max_gap = 0.0
        self.max_gap_angle = 0.0
        self.max_driver_error = 0.0
        self.max_at_driver = 0.0
        self.max_dev_steady = 0.0  # outside the setup's `Unsteady` stretch (all of the sweep without one)
        self.max_dev_unsteady = 0.0  # inside it
        self.samples = 0

    def joints(self, q: dict, target=None) -> None:
        """q: joint -> angle, or arrays of angles over many steps; target: the driver's target(s). The
        deviation of a step is that of its configuration from the nearest exact one (`nearest_on_motion`),
        every joint the driver included; ``max_deviation_at_driver_angle`` keeps the plain comparison at the
        driver's own angle, which a joint turning R times faster than the driver inflates R-fold."""
        s = self.setup
        q = {jn: np.atleast_1d(np.asarray(v, float)) for jn, v in q.items()}
        exact = s.exact(q[s.driver])
        for jn in s.joints:
            if jn != s.driver:
                self.max_at_driver = max(self.max_at_driver, float(np.abs(wrap_angle(q[jn] - exact[jn])).max()))
        _, res = nearest_on_motion(s, q)
        dev = np.abs(res)  # (joints, steps)
        inside = s.unsteady.contains(q[s.driver]) if s.unsteady is not None else np.zeros(dev.shape[1], bool)
        step = dev.max(axis=0)
        if (~inside).any():
            self.max_dev_steady = max(self.max_dev_steady, float(step[~inside].max()))
        if inside.any():
            self.max_dev_unsteady = max(self.max_dev_unsteady, float(step[inside].max()))
        j, i = np.unravel_index(int(np.argmax(dev)), dev.shape)
        if dev[j, i] > self.max_dev or self.worst_joint is None:
            self.max_dev, self.worst_joint = float(dev[j, i]), s.joints[j]
            self.worst_angle = float(q[s.driver][i])
        if target is not None:
            err = float(np.abs(q[s.driver] - np.asarray(target, float)).max())
            self.max_driver_error = max(self.max_driver_error, err)
        self.samples += len(q[s.driver])

    def frames(self, frames: dict) -> None:
        """frames: link -> world frame(s) (4x4 or (n, 4, 4)) as the engine reports them."""
        for (a, b), R in zip(self.setup.closures, self.setup.refs):
            dt, dr = pose_difference(np.asarray(frames[a]) @ R, np.asarray(frames[b]))
            self.max_gap = max(self.max_gap, float(np.max(dt)))
            self.max_gap_angle = max(self.max_gap_angle, float(np.max(dr)))

    def result(self, engine: str, steps: int, **extra) -> dict:
        return {"engine": engine, "max_joint_deviation": self.max_dev, "max_closure_gap": self.max_gap,
                "steps": steps, "max_closure_angle": self.max_gap_angle, "linkage_size": self.setup.size,
                "worst_joint": self.worst_joint, "worst_driver_angle": self.worst_angle,
                "driver": self.setup.driver, "max_driver_error": self.max_driver_error,
                "drive_range": [float(v) for v in self.setup.drive_range],
                "max_deviation_at_driver_angle": self.max_at_driver,
                **({"driver_choice": self.setup.driver_choice.sentence(),
                    "first_joint_speed_ratio": self.setup.driver_choice.ratio} if self.setup.driver_choice else {}),
                **(self._unsteady() if self.setup.unsteady is not None else {}), **extra}

    def _unsteady(self) -> dict:
        u = self.setup.unsteady
        return {"max_joint_deviation_steady": self.max_dev_steady,
                "unsteady": {"driver_deg": list(u.span_deg()), "speed_ratio": u.ratio, "fastest": u.fastest,
                             "at_deg": math.degrees(u.at), "max_joint_deviation": self.max_dev_unsteady}}
