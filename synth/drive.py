"""Drivability of a linkage: which joint the motor turns, over which range, and how well (docs/drive.md).

The **driver** is the first joint on the tree path from ``base`` to the first closure's link (the first
joint of the first branch: what the URDF limits and an independent checker drives); `with_driver`
re-orders the closures so that another joint on the base becomes it. The **task range** is the shortest
arc of the driver's angle through every pose (``../shared/docs/OUTPUT.md``).

Every joint follows the driver through the angle laws (`synth.algebra.anglelaw`): the **speed ratio**
``|d theta_j / d theta_driver|`` over the task range is maximized exactly (`driven_speed_max`). The
**conditioning** of the loops at a configuration is ``sigma_{n-1} / sigma_1`` of the loop-closure
Jacobian (6 rows per closure, one column per joint: the joint's world twist ``(u, p x u / E)``, E the
linkage's extent, signed by the side of the cut it lies on); a mobility-one loop has rank n - 1, and 0
means a singular configuration (a dead or change point: the linkage may stall or switch branches).
Angles in radians, conditioning dimensionless in [0, 1]. Pure functions; batched over samples.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from synth.algebra.geometry import cross
from synth.algebra.anglelaw import angle_law_inverse, driven_angle, driven_speed, driven_speed_max
from synth.errors import InputError
from synth.linkage import Linkage

__all__ = ["DeadPoint", "DriveReport", "driver_joint", "task_range", "with_driver", "base_joints",
           "follower_angles", "speed_ratio", "loop_jacobian", "loop_conditioning", "drive_report"]

TWO_PI = 2.0 * math.pi
SPEED_RATIO_WARN = 10.0  # a joint turning this many times as fast as the driver is called poor
CONDITIONING_WARN = 0.02  # sigma_{n-1} / sigma_1 below this over the task range is called poor
DEAD_CONDITIONING = 1e-4  # a local minimum of the conditioning below this is a singular configuration
NEAR = math.radians(10.0)  # a singular configuration this close (driver angle) to the task range is "near" it
SAMPLES_PER_JOINT = 96  # conditioning samples: evenly spaced in each joint's angle over the cycle
REFINE_STEPS = 32  # golden-section steps refining a local minimum of the conditioning (0.618^32 = 2e-7 of a bracket)
REFINE_BELOW = 0.1  # local minima below this (in or near the task range) are refined


@dataclass(frozen=True)
class DeadPoint:
    """A singular configuration of the loops: the driver's angle there (rad), the conditioning, and
    whether it lies inside the task range (else within `NEAR` of it)."""

    driver_angle: float
    conditioning: float
    inside: bool


@dataclass(frozen=True)
class DriveReport:
    """How the linkage is driven over the task: ``driver`` turns from ``range[0]`` to ``range[1]`` (rad,
    increasing, may exceed 2 pi); ``max_speed_ratio`` = the largest |d theta_j / d driver| of any other
    joint over it (``max_speed_joint``, at driver angle ``max_speed_at``); ``min_conditioning`` (at
    ``min_conditioning_at``) the worst loop conditioning over it; ``dead_points`` the singular
    configurations in or near it; ``warnings`` sentences when the drive is poor."""

    driver: str
    range: tuple[float, float]
    max_speed_ratio: float
    max_speed_joint: str
    max_speed_at: float
    min_conditioning: float
    min_conditioning_at: float
    dead_points: tuple[DeadPoint, ...] = ()
    warnings: tuple[str, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict:
        """linkage.json's ``drive`` section (plain JSON types)."""
        d = dataclasses.asdict(self)
        d["range"] = [float(v) for v in self.range]
        d["dead_points"] = [dataclasses.asdict(p) for p in self.dead_points]
        d["warnings"] = list(self.warnings)
        return d

    def sentence(self) -> str:
        """One line for the summary (angles in degrees)."""
        lo, hi = (math.degrees(v) for v in self.range)
        text = (f"{self.driver} from {lo:.1f} to {hi:.1f} deg ({hi - lo:.1f} deg); largest speed ratio "
                f"{self.max_speed_ratio:.3g} ({self.max_speed_joint} at {self.driver} = "
                f"{math.degrees(self.max_speed_at):.1f} deg); worst loop conditioning {self.min_conditioning:.3g}")
        if self.dead_points:
            text += "; singular configurations at " + ", ".join(
                f"{self.driver} = {math.degrees(p.driver_angle):.1f} deg ({'inside' if p.inside else 'near'})"
                for p in self.dead_points)
        return text


# ----------------------------------------------------------------------------------------- the driver
def _paths(linkage: Linkage) -> dict[str, list[str]]:
    """{link: joint names from base to it}."""
    parents = {j.child: j for j in linkage.joints}
    out = {}
    for link in linkage.links:
        path, cur = [], link
        while cur in parents:
            path.append(parents[cur].name)
            cur = parents[cur].parent
        out[link] = path[::-1]
    return out


def driver_joint(linkage: Linkage) -> str:
    """The driving joint: the first joint on the tree path from ``base`` to the first closure's link
    (the first joint of the first branch; what the exporters limit and the verifier drives)."""
    if not linkage.closures:
        return linkage.joints[0].name
    path = _paths(linkage).get(linkage.closures[0][0], [])
    return path[0] if path else linkage.joints[0].name


def base_joints(linkage: Linkage) -> list[str]:
    """The joints that can drive: those on the base that start the path to a closure's link."""
    paths = _paths(linkage)
    firsts = [paths.get(x, [None])[0] for c in linkage.closures for x in c]
    return [j.name for j in linkage.joints if j.parent == "base" and j.name in firsts]


def with_driver(linkage: Linkage, joint: str | None) -> Linkage:
    """A copy of ``linkage`` driven by ``joint`` (None: unchanged): the closure whose cut ends a path
    starting with ``joint`` is put first, that path's end first. InputError naming the joints that can
    drive otherwise."""
    if joint is None or joint == driver_joint(linkage):
        return linkage
    paths = _paths(linkage)
    for i, (a, b) in enumerate(linkage.closures):
        for x, y in ((a, b), (b, a)):
            if paths.get(x, [None])[0] == joint:
                closures = [(x, y)] + [c for k, c in enumerate(linkage.closures) if k != i]
                return dataclasses.replace(linkage, closures=closures)
    raise InputError(f"--driver {joint}: not a joint on the base that drives the loop "
                     f"(joints that can drive: {', '.join(base_joints(linkage))})")


def task_range(linkage: Linkage, driver: str | None = None) -> tuple[str, float, float]:
    """(driver, start, end) radians: the shortest arc of the driver's angle (``driver``, default
    `driver_joint`) that visits every pose (start in [0, 2 pi), end = start + span); for a task whose
    poses must be passed in the listed order (``info.fit.order == "listed"``) the arc from the
    first pose through the others in that order, one way, when there is one."""
    driver = driver or driver_joint(linkage)
    listed = listed_arc(linkage, driver)
    if listed is not None:
        return driver, *listed
    angles = sorted(float(p.joint_angles[driver]) % TWO_PI for p in linkage.poses)
    if len(angles) < 2:
        return driver, 0.0, TWO_PI
    gaps = [((angles[(i + 1) % len(angles)] - angles[i]) % TWO_PI) or TWO_PI for i in range(len(angles))]
    g = int(np.argmax(gaps))
    start = angles[(g + 1) % len(angles)]
    return driver, start, start + TWO_PI - gaps[g]


def listed_arc(linkage: Linkage, driver: str) -> tuple[float, float] | None:
    """[start, end] of the driver's arc through the poses in the listed order (turning one way through
    less than a turn, as ``../shared/docs/OUTPUT.md`` defines it), or None when the order is not
    prescribed or no such arc exists."""
    fit = linkage.info.fit
    if fit is None or fit.order != "listed" or len(linkage.poses) < 2:
        return None
    theta = np.array([float(p.joint_angles[driver]) for p in linkage.poses])
    for direction in (1.0, -1.0):
        steps = np.mod(direction * np.diff(theta), TWO_PI)
        if np.all(steps > 0) and steps.sum() < TWO_PI:
            span = float(steps.sum())
            first = float(np.mod(theta[0], TWO_PI))
            lo = first if direction > 0 else first - span
            shift = TWO_PI if lo < 0 else 0.0  # start in [0, 2 pi)
            return lo + shift, lo + shift + span
    return None


# ----------------------------------------------------------------------------------------- speeds
def _laws(linkage: Linkage) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return (np.array([j.a for j in linkage.joints]), np.array([j.b for j in linkage.joints]),
            np.array([j.rate for j in linkage.joints]))


LOOP_LAW_SAMPLES = 4001  # driver angles sampling a four-bar's speed ratios (smooth: relative error ~1e-6)


def follower_angles(linkage: Linkage, driver: str, phi) -> tuple[np.ndarray, np.ndarray]:
    """(angles, d angle / d phi), each (..., J) in the order of ``linkage.joints``, when ``driver`` is
    at angle(s) ``phi`` (any real: whole turns of the driver give whole turns of every joint); every
    joint is continued from 0 at phi = 0 (`synth.algebra.anglelaw.driven_angle`)."""
    phi = np.asarray(phi, float)
    d = linkage.joint(driver)
    a, b, r = _laws(linkage)
    ang = driven_angle(a, b, d.a, d.b, phi[..., None], r, d.rate, continued=True)
    k = [j.name for j in linkage.joints].index(driver)
    ang[..., k] = phi
    dang = driven_speed(a, b, d.a, d.b, phi[..., None], r, d.rate)
    dang[..., k] = 1.0
    for i, j in enumerate(linkage.joints):  # a planar four-bar: the loop law of the crank's angle (docs/fourbar.md)
        if j.law is not None:
            if d.law is not None:
                raise InputError(f"a planar four-bar is driven by its crank, not by {driver}")
            ang[..., i], dang[..., i] = j.law.continued(ang[..., i]), j.law.speed(ang[..., i]) * dang[..., i]
    return ang, dang


def speed_ratio(linkage: Linkage, driver: str, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """(J,) the largest |d theta_j / d theta_driver| over driver angles [lo, hi] and (J,) the driver angle
    where it is reached, exactly (`driven_speed_max`); the driver's own entry is 1 at lo. A planar four-bar's
    loop-law joints (docs/fourbar.md): the largest of LOOP_LAW_SAMPLES equally spaced driver angles."""
    d = linkage.joint(driver)
    a, b, r = _laws(linkage)
    ratio, at = driven_speed_max(a, b, d.a, d.b, lo, hi, r, d.rate)
    if any(j.law is not None for j in linkage.joints):
        phi = np.linspace(lo, hi, LOOP_LAW_SAMPLES)
        speed = np.abs(follower_angles(linkage, driver, phi)[1])  # (samples, J)
        ratio, at = speed.max(axis=0), phi[np.argmax(speed, axis=0)]
    k = [j.name for j in linkage.joints].index(driver)
    ratio[k], at[k] = 1.0, lo
    return ratio, at


# ----------------------------------------------------------------------------------------- conditioning
def loop_jacobian(linkage: Linkage, t, extent: float | None = None) -> np.ndarray:
    """(..., 6 L, J) loop-closure Jacobians at parameters t (...): per closure (a, b), the world twists
    (u, p x u / E) of the joints on the path base -> a minus those on base -> b, moments about the centre
    of the task's positions (so that moving the whole task does not change them; E: ``extent``, default
    `Linkage.extent`)."""
    t = np.asarray(t, float)
    E = linkage.extent() if extent is None else extent
    disp = linkage.displacements(linkage.angles_at(t))
    D = np.stack([np.broadcast_to(disp[j.parent], t.shape + (4, 4)) for j in linkage.joints], axis=-3)
    U = np.array([j.direction for j in linkage.joints])
    P = np.array([j.point for j in linkage.joints])
    u = np.einsum("...jkl,jl->...jk", D[..., :3, :3], U)
    centre = np.mean([r.matrix[:3, 3] for r in linkage.poses] + [linkage.tool_ref[:3, 3]], axis=0)
    p = np.einsum("...jkl,jl->...jk", D[..., :3, :3], P) + D[..., :3, 3] - centre
    twists = np.concatenate([u, cross(p, u) / E], axis=-1)  # (..., J, 6)
    J = np.einsum("lj,...jk->...lkj", _closure_signs(linkage), twists)  # (..., L, 6, J)
    return J.reshape(t.shape + (6 * len(linkage.closures), len(linkage.joints)))


def _closure_signs(linkage: Linkage) -> np.ndarray:
    """(L, J): +1 for the joints on the path base -> a of closure (a, b), -1 on base -> b (shared: 0)."""
    paths = _paths(linkage)
    index = {j.name: i for i, j in enumerate(linkage.joints)}
    signs = np.zeros((len(linkage.closures), len(linkage.joints)))
    for c, (a, b) in enumerate(linkage.closures):
        for name in paths.get(a, []):
            signs[c, index[name]] += 1.0
        for name in paths.get(b, []):
            signs[c, index[name]] -= 1.0
    return signs


def loop_conditioning(linkage: Linkage, t, extent: float | None = None) -> np.ndarray:
    """(...) sigma_{n-1} / sigma_1 of `loop_jacobian` at parameters t (1 for a linkage without loops)."""
    n = len(linkage.joints)
    if not linkage.closures or n < 2 or 6 * len(linkage.closures) < n - 1:
        return np.ones(np.shape(t))
    s = np.linalg.svd(loop_jacobian(linkage, t, extent), compute_uv=False)
    return s[..., n - 2] / np.maximum(s[..., 0], 1e-300)


def _cycle_samples(linkage: Linkage, driver: str) -> tuple[np.ndarray, np.ndarray]:
    """(t, driver angle in [0, 2 pi)) of samples evenly spaced in every joint's angle over the cycle,
    sorted by the driver's angle."""
    grid = (np.arange(SAMPLES_PER_JOINT) + 0.5) * (TWO_PI / SAMPLES_PER_JOINT)
    ts = [np.atleast_1d(angle_law_inverse(j.a, j.b, grid * j.rate, j.rate)) for j in linkage.joints if j.b != 0]
    t = np.concatenate(ts + [np.array([np.inf])])
    phi = np.mod(linkage.joint(driver).angle(t), TWO_PI)
    order = np.argsort(phi, kind="stable")
    return t[order], phi[order]


def _refine_minima(linkage: Linkage, driver: str, lo: np.ndarray, hi: np.ndarray,
                   E: float) -> tuple[np.ndarray, np.ndarray]:
    """Golden-section minimization of the conditioning over driver angles [lo, hi] (each (K,)), batched;
    (driver angle, conditioning) of the minima."""
    d = linkage.joint(driver)
    g = (math.sqrt(5) - 1) / 2
    f = lambda x: loop_conditioning(linkage, d.parameter(np.mod(x, TWO_PI)), E)  # noqa: E731
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(REFINE_STEPS):
        left = f1 <= f2
        hi, lo = np.where(left, x2, hi), np.where(left, lo, x1)
        x2n, x1n = np.where(left, x1, lo + g * (hi - lo)), np.where(left, hi - g * (hi - lo), x2)
        fn = f(np.where(left, x1n, x2n))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = x1n, x2n
    x = np.where(f1 <= f2, x1, x2)
    return x, np.minimum(f1, f2)


def _in_arc(phi, lo: float, hi: float, margin: float = 0.0) -> np.ndarray:
    """Whether driver angles phi lie in the arc [lo - margin, hi + margin] (mod 2 pi)."""
    if hi - lo + 2 * margin >= TWO_PI:
        return np.ones(np.shape(phi), bool)
    return np.mod(np.asarray(phi) - (lo - margin), TWO_PI) <= hi - lo + 2 * margin


def drive_report(linkage: Linkage) -> DriveReport:
    """The `DriveReport` of ``linkage`` driven by its `driver_joint` over its `task_range`."""
    driver, lo, hi = task_range(linkage)
    names = [j.name for j in linkage.joints]
    ratio, at = speed_ratio(linkage, driver, lo, hi)
    others = [k for k, n in enumerate(names) if n != driver and linkage.closures]
    k = max(others, key=lambda i: ratio[i]) if others else names.index(driver)
    t, phi = _cycle_samples(linkage, driver)
    E = linkage.extent()
    cond = loop_conditioning(linkage, t, E)
    # local minima of the sampled conditioning (cyclic) that may be singular or the worst of the task
    # range, refined between their neighbours
    prev, nxt = np.roll(cond, 1), np.roll(cond, -1)
    mins = np.flatnonzero((cond <= prev) & (cond <= nxt))
    inside = _in_arc(phi[mins], lo, hi, NEAR)
    worst = mins[inside][np.argmin(cond[mins][inside])] if inside.any() else mins[:0]
    mins = np.union1d(mins[inside & (cond[mins] < REFINE_BELOW)], worst).astype(int)
    span_lo = phi[mins - 1] - np.where(mins == 0, TWO_PI, 0.0)
    span_hi = phi[(mins + 1) % len(phi)] + np.where(mins == len(phi) - 1, TWO_PI, 0.0)
    xm, cm = _refine_minima(linkage, driver, span_lo, span_hi, E)
    xm = np.mod(xm, TWO_PI)
    # the worst conditioning over the task range: samples, refined minima and the ends
    ends = linkage.joint(driver).parameter(np.mod([lo, hi], TWO_PI))
    cand_phi = np.concatenate([phi, xm, np.mod([lo, hi], TWO_PI)])
    cand = np.concatenate([cond, cm, loop_conditioning(linkage, ends, E)])
    inside = _in_arc(cand_phi, lo, hi)
    w = int(np.argmin(np.where(inside, cand, np.inf)))
    dead = [DeadPoint(float(lo + np.mod(x - lo, TWO_PI)), float(c), bool(_in_arc(x, lo, hi)))
            for x, c in sorted(zip(xm, cm)) if c < DEAD_CONDITIONING and _in_arc(x, lo, hi, NEAR)]
    report = DriveReport(driver=driver, range=(float(lo), float(hi)), max_speed_ratio=float(ratio[k]),
                         max_speed_joint=names[k], max_speed_at=float(at[k]), min_conditioning=float(cand[w]),
                         min_conditioning_at=float(lo + np.mod(cand_phi[w] - lo, TWO_PI)), dead_points=tuple(dead))
    return dataclasses.replace(report, warnings=tuple(drive_warnings(report)))


def drive_warnings(report: DriveReport) -> list[str]:
    """Sentences saying what is poor about a drive (empty when nothing is)."""
    out = []
    lo, hi = (math.degrees(v) for v in report.range)
    if report.max_speed_ratio > SPEED_RATIO_WARN:
        out.append(f"poor drive: {report.max_speed_joint} turns {report.max_speed_ratio:.3g} times as fast as the "
                   f"driver {report.driver} (at {math.degrees(report.max_speed_at):.1f} deg): there it whips round "
                   f"and a motor on {report.driver} needs {report.max_speed_ratio:.3g} times the torque of a load on "
                   "it; try --driver with another joint on the base or another solution")
    if any(p.inside for p in report.dead_points):
        out.append(f"dead point: the linkage passes a singular configuration inside the task range "
                   f"({report.driver} from {lo:.1f} to {hi:.1f} deg), where it may stall or switch branches")
    elif report.dead_points:
        out.append("a singular configuration lies within "
                   f"{math.degrees(NEAR):.0f} deg of the task range: keep the drive away from it")
    elif report.min_conditioning < CONDITIONING_WARN:
        out.append(f"poorly conditioned loop: conditioning {report.min_conditioning:.3g} at {report.driver} = "
                   f"{math.degrees(report.min_conditioning_at):.1f} deg (near a singular configuration)")
    return out
