"""Joint trajectories of a written linkage: what a motor controller needs (`mpsynth trajectory`).

One joint drives (``driver``, default the first joint of linkage.json); every other joint follows it
exactly through the angle laws theta_j(t) = 2 atan2(b_j, t - a_j) (docs/conventions.md): with the
driver at angle phi, s = sin(phi/2), c = cos(phi/2),

    theta_j = 2 atan2(b_j s, (a_d - a_j) s + b_d c),
    dtheta_j/dphi = b_j b_d / ((b_d c + (a_d - a_j) s)^2 + b_j^2 s^2),

and theta_j is continued over whole turns (`follower_angles`) so that every column is continuous and
every joint is 0 at the reference configuration (the first pose), as in the URDF. The driver's angle
follows a time law:

* ``constant``: phi(t) = phi0 + omega t over a driver range (the collision-free range recorded in
  linkage.json by default);
* ``through-poses``: the shortest arc of the driver through every task pose, visited in order along it;
  between consecutive poses phi follows the quintic rest-to-rest profile s(x) = 10x^3 - 15x^4 + 6x^5
  (zero velocity and acceleration at both ends), and it rests ``dwell`` seconds at every pose. The
  moves share the time left after the rests in proportion to their driver angle; every move and rest
  lasts a whole number of samples, so each pose is held exactly (phi equal to its recorded angle) at
  the samples of its rest.

A range that leaves the collision-free range of linkage.json's ``collision`` claim (``driver_range``
of its ``driver``, mapped to the chosen driver through the laws) is refused unless
``allow_collisions``. Times in seconds, angles in radians, velocities in rad/s, lengths in metres;
the tool pose is the ``tool`` frame (position and Hamilton quaternion w, x, y, z) in the world frame.
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.algebra.anglelaw import driven_angle, driven_speed
from synth.algebra.dq import matrix_to_quat
from synth.design.search import task_range
from synth.errors import InputError
from synth.io.readback import Readback
from synth.io.atomic import atomic_write
from synth.linkage import Linkage

TWO_PI = 2.0 * math.pi
ARC_TOL = 1e-9  # rad: how far a requested range may pass the end of the collision-free range (rounding)
FORMAT = "mpsynth.trajectory/1"


@dataclass
class Trajectory:
    """Samples of one motion. ``angles``/``velocities``: (n, J) in the order of ``joints``; ``tool``:
    (n, 4, 4); ``pose_index``: (n,) index into ``poses`` of the pose held at each sample, -1 for none;
    ``poses``: [{name, time, until, driver_angle}] in the order they are visited."""

    driver: str
    law: str
    rate: float
    joints: list[str]
    time: np.ndarray
    angles: np.ndarray
    velocities: np.ndarray
    tool: np.ndarray
    pose_index: np.ndarray
    poses: list[dict] = field(default_factory=list)
    driver_range: tuple[float, float] = (0.0, TWO_PI)
    collision: str = ""  # a sentence on the collision claim this range relies on

    @property
    def duration(self) -> float:
        return float(self.time[-1]) if len(self.time) else 0.0

    def columns(self) -> list[str]:
        cols = ["time_s"]
        cols += [f"{j}_angle_rad" for j in self.joints] + [f"{j}_velocity_rad_s" for j in self.joints]
        cols += ["tool_x_m", "tool_y_m", "tool_z_m", "tool_qw", "tool_qx", "tool_qy", "tool_qz", "pose"]
        return cols

    def tool_position_quaternion(self) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) positions and (n, 4) unit quaternions (w >= 0) of the tool frame."""
        q = matrix_to_quat(self.tool[:, :3, :3])
        q = q * np.where(q[:, :1] < 0, -1.0, 1.0)
        return self.tool[:, :3, 3].copy(), q

    def to_dict(self) -> dict:
        pos, quat = self.tool_position_quaternion()
        return {
            "format": FORMAT, "units": {"time": "s", "angle": "rad", "velocity": "rad/s", "length": "m"},
            "driver": self.driver, "law": self.law, "rate": self.rate, "duration": self.duration,
            "driver_range": [float(self.driver_range[0]), float(self.driver_range[1])],
            "collision": self.collision, "joints": list(self.joints), "poses": self.poses,
            "time": self.time.tolist(),
            "angles": {j: self.angles[:, k].tolist() for k, j in enumerate(self.joints)},
            "velocities": {j: self.velocities[:, k].tolist() for k, j in enumerate(self.joints)},
            "tool": {"position": pos.tolist(), "quaternion_wxyz": quat.tolist()},
            "pose": [self.poses[i]["name"] if i >= 0 else None for i in self.pose_index],
        }

    def csv_text(self) -> str:
        pos, quat = self.tool_position_quaternion()
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns())
        for i in range(len(self.time)):
            nums = [self.time[i], *self.angles[i], *self.velocities[i], *pos[i], *quat[i]]
            name = self.poses[self.pose_index[i]]["name"] if self.pose_index[i] >= 0 else ""
            w.writerow([repr(float(x)) for x in nums] + [name])
        return buf.getvalue()


# ----------------------------------------------------------------------------------------- angles
def follower_angles(linkage: Linkage, driver: str, phi) -> tuple[np.ndarray, np.ndarray]:
    """(angles, d angle / d phi), each (..., J) in the order of ``linkage.joints``, when ``driver`` is
    at angle(s) ``phi`` (any real: whole turns of the driver give whole turns of every joint); every
    joint is continued from 0 at phi = 0 (see the module docstring)."""
    phi = np.asarray(phi, float)
    d = linkage.joint(driver)
    a = np.array([j.a for j in linkage.joints])
    b = np.array([j.b for j in linkage.joints])
    r = np.array([j.rate for j in linkage.joints])
    ang = driven_angle(a, b, d.a, d.b, phi[..., None], r, d.rate, continued=True)
    k = [j.name for j in linkage.joints].index(driver)
    ang[..., k] = phi
    dang = driven_speed(a, b, d.a, d.b, phi[..., None], r, d.rate)
    dang[..., k] = 1.0
    return ang, dang


def quintic(x):
    """Rest-to-rest profile s(x) = 10x^3 - 15x^4 + 6x^5 on [0, 1] and its derivative ds/dx."""
    x = np.clip(np.asarray(x, float), 0.0, 1.0)
    return x ** 3 * (10 - 15 * x + 6 * x ** 2), 30 * x ** 2 * (1 - x) ** 2


# ----------------------------------------------------------------------------------------- ranges
def _arc_of(linkage: Linkage, driver: str, ref: str, lo: float, hi: float) -> tuple[float, float]:
    """The arc [start, end] (end > start) of ``driver``'s angle that covers the configurations where
    joint ``ref`` runs from lo to hi (increasing)."""
    if hi - lo >= TWO_PI - ARC_TOL:
        return 0.0, TWO_PI
    if driver == ref:
        return lo, hi
    ang, _ = follower_angles(linkage, ref, np.array([lo, hi]))
    k = [j.name for j in linkage.joints].index(driver)
    x0, x1 = float(ang[0, k]), float(ang[1, k])
    if np.sign(linkage.joint(driver).b) != np.sign(linkage.joint(ref).b):
        x0, x1 = x1, x0  # the driver turns the other way
    return x0, x0 + (x1 - x0) % TWO_PI


def _normalize(lo: float, hi: float) -> tuple[float, float]:
    """Shift [lo, hi] by whole turns so that it holds 0 (the reference configuration) when it can,
    else so that lo is in [0, 2 pi)."""
    k = math.floor((hi + ARC_TOL) / TWO_PI)
    if lo - TWO_PI * k <= ARC_TOL:
        return lo - TWO_PI * k, hi - TWO_PI * k
    k = math.floor(lo / TWO_PI)
    return lo - TWO_PI * k, hi - TWO_PI * k


def _inside(arc, allowed) -> bool:
    if allowed[1] - allowed[0] >= TWO_PI - ARC_TOL:
        return True
    off = (arc[0] - allowed[0]) % TWO_PI
    if off > TWO_PI - ARC_TOL:
        off -= TWO_PI
    return off >= -ARC_TOL and off + (arc[1] - arc[0]) <= allowed[1] - allowed[0] + ARC_TOL


def _deg(x: float) -> str:
    return f"{math.degrees(x):.1f}"


# ----------------------------------------------------------------------------------------- plan
def plan(rb: Readback, *, driver: str | None = None, rate: float = 100.0, duration: float | None = None,
         speed: float | None = None, through_poses: bool = False, dwell: float = 0.5, span: str = "auto",
         allow_collisions: bool = False) -> Trajectory:
    """The trajectory of the linkage read back in ``rb`` (see the module docstring).

    ``rate``: samples per second; ``duration`` (s) or ``speed`` (driver rad/s, constant law only);
    ``span``: "auto" (the recorded collision-free range; the full turn when none is recorded),
    "full" (one turn from the first pose) or "task" (the shortest arc through every task pose)."""
    lk = rb.linkage
    names = [j.name for j in lk.joints]
    driver = driver or names[0]
    if driver not in names:
        raise InputError(f"--driver {driver}: no such joint (joints: {', '.join(names)})")
    if not abs(lk.joint(driver).b) > 0:
        raise InputError(f"--driver {driver}: this joint does not turn with the motion")
    if not (math.isfinite(rate) and 0 < rate <= 1e5):
        raise InputError(f"--rate {rate}: must be in (0, 100000] Hz")
    if through_poses and speed is not None:
        raise InputError("--speed: only for the constant-speed law (--through-poses takes --duration)")
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration {duration}: must be a positive number of seconds")
    if speed is not None and not (math.isfinite(speed) and speed != 0):
        raise InputError(f"--speed {speed}: must be a non-zero number (rad/s)")
    if not (math.isfinite(dwell) and dwell >= 0):
        raise InputError(f"--dwell {dwell}: must be >= 0 seconds")
    if span not in ("auto", "full", "task"):
        raise InputError(f"--range {span}: expected auto, full or task")

    claim = rb.document.get("collision") if isinstance(rb.document.get("collision"), dict) else None
    allowed, sentence = _allowed(lk, driver, claim)
    if through_poses or span == "task":
        if len(lk.poses) < 2:
            raise InputError(f"{rb.root}: the linkage records {len(lk.poses)} task pose(s); "
                             "--through-poses and --range task need at least two")
        arc = _normalize(*task_range(lk, driver)[1:])
    elif span == "full" or allowed is None:
        arc = (0.0, TWO_PI)
    else:
        arc = allowed
    if allowed is None or not _inside(arc, allowed):
        if not allow_collisions:
            where = f"{driver} from {_deg(arc[0])} to {_deg(arc[1])} deg"
            if allowed is None:
                raise InputError(f"{rb.root}: {sentence}; --allow-collisions drives it anyway ({where})")
            raise InputError(f"{rb.root}: {sentence}; the trajectory ({where}) leaves it "
                             "(--range auto stays inside; --allow-collisions drives it anyway)")
        sentence += " (ignored: --allow-collisions)"
    if through_poses:
        traj = _through_poses(lk, driver, arc, rate, duration if duration is not None else 10.0, dwell)
    else:
        traj = _constant(lk, driver, arc, rate, duration, speed)
    traj.collision = sentence
    return traj


def _allowed(lk: Linkage, driver: str, claim: dict | None) -> tuple[tuple[float, float] | None, str]:
    """(collision-free arc of ``driver`` or None, a sentence saying what linkage.json claims)."""
    if claim is None:
        return (0.0, TWO_PI), "linkage.json records no collision claim"
    try:
        free, rng = bool(claim["free"]), str(claim.get("range", "full"))
        ref = str(claim.get("driver") or lk.joints[0].name)
        lo, hi = (float(v) for v in claim.get("driver_range", (0.0, TWO_PI)))
        lk.joint(ref)
    except (KeyError, TypeError, ValueError):
        raise InputError("linkage.json: malformed 'collision' section") from None
    if not free:
        return None, "linkage.json's design is not collision-free over any range"
    if rng == "full" or hi - lo >= TWO_PI - ARC_TOL:
        return (0.0, TWO_PI), "collision-free over the full cycle"
    arc = _normalize(*_arc_of(lk, driver, ref, lo, hi))
    return arc, f"collision-free only over the task range ({driver} from {_deg(arc[0])} to {_deg(arc[1])} deg)"


MAX_SAMPLES = 1_000_000  # samples of one trajectory (~100 MB of arrays for a 6R linkage)


def _grid(rate: float, seconds: float) -> int:
    """Whole samples (at least 1) closest to ``seconds``; InputError beyond MAX_SAMPLES (``--speed 1e-12``
    asked for 1e13 samples)."""
    n = seconds * rate
    if not n <= MAX_SAMPLES:
        raise InputError(f"{seconds:.6g} s at {rate:.6g} Hz is {n:.3g} samples, more than {MAX_SAMPLES}: "
                         "lower --rate or --duration (--dwell), or raise --speed")
    return max(1, int(round(n)))


def _split(total: int, weights) -> list[int]:
    """``total`` samples shared in proportion to ``weights`` (largest remainders), each at least 1."""
    w = np.asarray(weights, float)
    share = total * w / w.sum() if w.sum() > 0 else np.full(len(w), total / max(len(w), 1))
    steps = np.maximum(np.floor(share).astype(int), 1)
    for i in np.argsort(-(share - np.floor(share)))[:max(0, total - int(steps.sum()))]:
        steps[i] += 1
    return [int(x) for x in steps]


def _assemble(lk, driver, law, rate, arc, t, phi, dphi, pose_index, poses) -> Trajectory:
    ang, dang = follower_angles(lk, driver, phi)
    vel = dang * dphi[:, None]
    tool = lk.tool_pose({j.name: ang[:, k] for k, j in enumerate(lk.joints)})
    return Trajectory(driver=driver, law=law, rate=rate, joints=[j.name for j in lk.joints], time=t,
                      angles=ang, velocities=vel, tool=np.asarray(tool), pose_index=pose_index,
                      poses=poses, driver_range=arc)


def _constant(lk, driver, arc, rate, duration, speed) -> Trajectory:
    span = arc[1] - arc[0]
    if duration is None:
        duration = span / abs(speed) if speed is not None else 10.0
    n = _grid(rate, duration)
    t = np.arange(n + 1) / rate
    omega = span / (n / rate)
    start = arc[0]
    if speed is not None and speed < 0:  # backwards along the same arc
        start, omega = arc[1], -omega
    phi = start + omega * t
    phi[-1] = arc[1] if omega > 0 else arc[0]
    poses, index = _poses_on(lk, driver, phi)
    return _assemble(lk, driver, "constant", rate, arc, t, phi, np.full(n + 1, omega), index, poses)


def _poses_on(lk, driver, phi) -> tuple[list[dict], np.ndarray]:
    """Task poses met exactly at a sample of a constant-speed run (rarely any but the first)."""
    index = np.full(len(phi), -1)
    poses = []
    for p in lk.poses:
        hit = np.flatnonzero(np.abs((phi - p.joint_angles.get(driver, np.nan) + math.pi) % TWO_PI - math.pi)
                             <= 1e-12)
        if len(hit):
            index[hit] = len(poses)
            poses.append({"name": p.name, "time": None, "until": None, "driver_angle": float(phi[hit[0]])})
    return poses, index


def _through_poses(lk, driver, arc, rate, duration, dwell) -> Trajectory:
    # the poses in the order of the arc, each at its driver angle inside it
    at = []
    for p in lk.poses:
        x = arc[0] + (float(p.joint_angles[driver]) - arc[0]) % TWO_PI
        if x > arc[1] + ARC_TOL:
            x -= TWO_PI
        at.append((max(arc[0], min(arc[1], x)), p.name))
    at.sort()
    n_rest = _grid(rate, dwell) if dwell > 0 else 0
    moves = np.diff([x for x, _ in at])
    left = duration - len(at) * n_rest / rate
    if left <= len(moves) / rate:
        raise InputError(f"--duration {duration:g} s: too short for {len(at)} rests of {dwell:g} s "
                         "and the moves between them")
    steps = _split(_grid(rate, left), moves)
    t_parts, phi_parts, dphi_parts, idx_parts, poses = [], [], [], [], []
    k = 0
    for i, (x, name) in enumerate(at):
        rest = np.arange(k, k + n_rest + 1)
        poses.append({"name": name, "time": k / rate, "until": (k + n_rest) / rate, "driver_angle": x})
        t_parts.append(rest)
        phi_parts.append(np.full(len(rest), x))
        dphi_parts.append(np.zeros(len(rest)))
        idx_parts.append(np.full(len(rest), i))
        k += n_rest
        if i < len(moves):
            m = steps[i]
            xs = np.arange(1, m) / m
            s, ds = quintic(xs)
            t_parts.append(k + np.arange(1, m))
            phi_parts.append(x + moves[i] * s)
            dphi_parts.append(moves[i] * ds * rate / m)
            idx_parts.append(np.full(m - 1, -1))
            k += m
    t = np.concatenate(t_parts) / rate
    return _assemble(lk, driver, "through-poses", rate, arc, t, np.concatenate(phi_parts),
                     np.concatenate(dphi_parts), np.concatenate(idx_parts), poses)


# ----------------------------------------------------------------------------------------- output
def write(traj: Trajectory, path) -> Path:
    """Write ``traj`` as CSV or JSON by the suffix of ``path`` (.csv / .json)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".json"):
        raise InputError(f"{path}: unknown format {suffix or '(no suffix)'!r}; use .csv or .json")
    text = traj.csv_text() if suffix == ".csv" else json.dumps(traj.to_dict()) + "\n"
    atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    return path


def summary(traj: Trajectory) -> list[str]:
    """Human-readable lines (degrees) for stderr."""
    lines = [f"trajectory: driver {traj.driver}, law {traj.law}, {len(traj.time)} samples at {traj.rate:g} Hz "
             f"over {traj.duration:g} s; {traj.driver} from {_deg(traj.driver_range[0])} to "
             f"{_deg(traj.driver_range[1])} deg; {traj.collision}"]
    top = np.abs(traj.velocities).max(axis=0)
    k = int(np.argmax(top))
    lines.append(f"  fastest joint {traj.joints[k]}: {math.degrees(top[k]):.1f} deg/s")
    for p in traj.poses:
        if p["time"] is not None:
            lines.append(f"  pose {p['name']}: t = {p['time']:g} .. {p['until']:g} s, {traj.driver} = "
                         f"{_deg(p['driver_angle'])} deg")
    return lines
