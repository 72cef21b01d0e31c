"""Link frames, the roll-pitch-yaw conversion and small rigid-transform helpers shared by the exporters
and the readers of an output directory.

The frame of link X (docs/conventions.md, synth/linkage.py) sits at the site (``Linkage.joint_sites``: where the pins
are) on the axis of the joint whose child is X, with axes parallel to the world axes at the reference configuration; ``base`` has the
world frame. So every frame differs from the world frame by a translation only, and a URDF joint's
origin is the plain difference of the two origins with rpy "0 0 0".
"""
from __future__ import annotations

import math

import numpy as np


def link_origins(linkage) -> dict[str, np.ndarray]:
    """World position (3,) of every tree link's frame origin at the reference configuration."""
    out: dict[str, np.ndarray] = {"base": np.zeros(3)}
    sites = linkage.joint_sites()
    for j in linkage.joints:
        if j.parent not in out:
            raise ValueError(f"joint {j.name}: parent link {j.parent!r} comes before it is defined")
        if j.child in out:
            raise ValueError(f"joint {j.name}: link {j.child!r} already has a parent")
        out[j.child] = np.asarray(sites[j.name], float)
    return out


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def rpy_from_sincos(sr, cr, sp, cp, sy, cy) -> np.ndarray:
    """URDF roll-pitch-yaw (fixed axes, R = Rz(yaw) @ Ry(pitch) @ Rx(roll)) from the sines and cosines
    of the three angles (so a caller can pass exact values, e.g. for multiples of 90 degrees): floats or
    arrays of one shape (...), giving (..., 3, 3), the product written out entry by entry (the same bits
    for one rotation and for a batch)."""
    sr, cr, sp, cp, sy, cy = np.broadcast_arrays(*(np.asarray(v, float) for v in (sr, cr, sp, cp, sy, cy)))
    R = np.empty(sr.shape + (3, 3))
    cysp, sysp = cy * sp, sy * sp
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cysp * sr - sy * cr
    R[..., 0, 2] = cysp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sysp * sr + cy * cr
    R[..., 1, 2] = sysp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF convention: fixed axes, R = Rz(yaw) @ Ry(pitch) @ Rx(roll); angles in radians."""
    return rpy_from_sincos(math.sin(roll), math.cos(roll), math.sin(pitch), math.cos(pitch), math.sin(yaw),
                           math.cos(yaw))


def rpy_from_matrix(R) -> tuple[float, float, float]:
    """(roll, pitch, yaw) with ``rpy_matrix(roll, pitch, yaw) == R`` to a few ulps, for every rotation.

    Yaw comes from the first column; the yaw rotation is then taken out (R' = Rz(-yaw) R =
    Ry(pitch) Rx(roll)) and pitch and roll are read from entries of R' that have unit magnitude,
    so nothing divides by cos(pitch): at or near gimbal lock (pitch = +-pi/2) the yaw is arbitrary
    but the roll computed after it compensates exactly."""
    R = np.asarray(R, float)
    yaw = math.atan2(R[1, 0], R[0, 0])
    if R[1, 0] == 0.0 and R[0, 0] == 0.0:  # exact gimbal lock: choose yaw = 0
        yaw = 0.0
    Rp = _rz(-yaw) @ R
    pitch = math.atan2(-Rp[2, 0], Rp[0, 0])
    roll = math.atan2(-Rp[1, 2], Rp[1, 1])
    return roll, pitch, yaw


def tool_mount_origin(linkage) -> np.ndarray:
    """4x4 transform of the tool frame in the frame of ``linkage.tool_link``: F_tool_link^-1 @ tool_ref."""
    origins = link_origins(linkage)
    if linkage.tool_link not in origins:
        raise ValueError(f"tool link {linkage.tool_link!r} is not a link of the tree")
    T = np.array(linkage.tool_ref, float).copy()
    T[:3, 3] = T[:3, 3] - origins[linkage.tool_link]
    return T


# ---------------------------------------------------------------- angles (rigid-body maths: synth.algebra.geometry)
TWO_PI = 2.0 * math.pi


def wrap_angle(x) -> np.ndarray:
    """Angles (radians) to [-pi, pi)."""
    return np.mod(np.asarray(x, float) + math.pi, TWO_PI) - math.pi
