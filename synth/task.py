"""The task: what the tool must do, as plain data (metres, radians), read by `synth.io.poses`.

A task is a list of items (poses, or points where only the tool origin is prescribed), each with an
optional tolerance and velocity, an order, and constraints on where the mechanism goes
(``../shared/docs/OUTPUT.md``, "Additions (turn 3)"). Conventions:

* ``tolerance[i] = [position, angle]`` in metres and radians; ``0`` means exact (met to machine
  precision), ``inf`` a component that is unconstrained (e.g. the angle of a point). ``tolerance is
  None`` is the classic task: every item exact.
* ``velocity[i] = [w, v]``: the tool's twist in the world frame, angular velocity ``w`` (rad/s) and the
  velocity ``v`` of the tool origin (m/s); only its direction is prescribed. A row of NaN: none.
* ``Order.LISTED``: the first driving joint, turning one way through less than one turn, carries the
  tool through the items in the listed order. ``Order.ANY``: any order (the linkage reports its own).
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from synth.algebra.dq import pose_to_dq

__all__ = ["Order", "Box", "Constraints", "PoseSet", "CurveSpec", "MotionSpec", "MAX_DEGREE", "default_name"]

MAX_DEGREE = 16  # of a curve component or a motion polynomial (`mpsynth curve`)
NEEDED = {2: 5, 3: 7}  # points that fix a point task's motion of degree 2, 3 up to its free parameters (docs/points.md)
MINIMUM = {2: 3, 3: 4}  # fewest points a point task of degree 2, 3 accepts (the rest is chosen: `synth.synthesis.points`)


def default_name(i: int) -> str:
    """The name of item ``i`` of a task that names none: ``p<i>``."""
    return f"p{i}"


class Order(str, enum.Enum):
    """In which order the tool must pass the task's items."""

    ANY = "any"
    LISTED = "listed"


@dataclass(frozen=True)
class Box:
    """Axis-aligned box ``[lo, hi]`` (each (3,), metres) in the world frame."""

    lo: np.ndarray
    hi: np.ndarray


@dataclass(frozen=True)
class Constraints:
    """Where the mechanism may go: ``base`` (every joint on the root link has its axis through the box),
    ``envelope`` (every written solid stays inside over the task range), ``max_speed_ratio``
    (|d joint / d driver| of every joint over the task range). ``None``: no such constraint."""

    base: Box | None = None
    envelope: Box | None = None
    max_speed_ratio: float | None = None


@dataclass
class PoseSet:
    """Validated poses. ``matrices`` (N, 4, 4) are in metres whatever the file's unit;
    ``length_scale`` is metres per input length unit; ``source`` is the display name."""

    names: list[str]
    matrices: np.ndarray
    length_unit: str = "m"
    angle_unit: str = "rad"
    length_scale: float = 1.0
    source: str = "<poses>"
    named: list[bool] = field(default_factory=list)  # which names were given in the file
    kinds: list[str] = field(default_factory=list)  # "pose" or "point" (position only, docs/points.md); [] = poses
    tolerance: np.ndarray | None = None  # (N, 2) [metres, radians] per item; None = every item exact
    velocity: np.ndarray | None = None  # (N, 6) world twist [angular rad/s, linear m/s of the tool origin]; NaN rows: none
    order: Order = field(default_factory=lambda: Order.ANY)
    constraints: Constraints | None = None

    @property
    def has_points(self) -> bool:
        """Whether some item prescribes a position only (a point task)."""
        return "point" in self.kinds

    @property
    def is_point(self) -> np.ndarray:
        """(N,) bool: which items are points (their matrices carry the identity rotation)."""
        return np.array([k == "point" for k in self.kinds] or [False] * len(self.names), bool)

    def __len__(self) -> int:
        return len(self.names)

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) positions in metres."""
        return self.matrices[:, :3, 3]

    @property
    def rotations(self) -> np.ndarray:
        """(N, 3, 3) rotation matrices."""
        return self.matrices[:, :3, :3]

    def dual_quaternions(self) -> np.ndarray:
        """(N, 8) unit dual quaternions (docs/conventions.md), lengths in metres."""
        return pose_to_dq(self.matrices)


@dataclass
class CurveSpec:
    """A curve task (`mpsynth curve`): a point of the tool draws the rational curve [x, y, z] / w."""

    polys: list  # [x, y, z, w]: ascending coefficient lists (Fractions)
    texts: list  # the source texts


@dataclass
class MotionSpec:
    """A motion task (`mpsynth curve`): the tool follows the rational motion of the polynomial C."""

    C: list  # rows of 8 Fractions (ascending)
    text: str | None = None
