"""Self-checks of a linkage: pose reproduction at the reported angles and loop closure over the whole
motion (MATH.md section 12). Errors are translation (metres) and rotation angle (radians)."""
from __future__ import annotations

import numpy as np

from .linkage import Linkage


def rotation_angle(R):
    """Rotation angle (rad) of rotation matrices (..., 3, 3), accurate for small and large angles."""
    R = np.asarray(R, float)
    s = 0.5 * np.linalg.norm(np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                                       R[..., 1, 0] - R[..., 0, 1]], -1), axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1)
    return np.arctan2(s, c)


def pose_difference(A, B):
    """(translation error, rotation angle) between poses (..., 4, 4)."""
    A = np.asarray(A, float)
    B = np.asarray(B, float)
    dt = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    dr = rotation_angle(np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3])
    return dt, dr


def sample_parameters(linkage: Linkage, samples: int = 200) -> np.ndarray:
    """Parameters t covering the real line (t = centre + scale tan(phi)) plus t = infinity."""
    a = np.array([j.a for j in linkage.joints])
    b = np.array([j.b for j in linkage.joints])
    centre, scale = float(np.mean(a)), float(max(np.mean(b), 1e-12))
    phi = np.linspace(-np.pi / 2, np.pi / 2, samples + 1)[1:]
    t = centre + scale * np.tan(phi[:-1])
    return np.concatenate([t, [np.inf]])


def pose_errors(linkage: Linkage) -> tuple[float, float]:
    """Largest (translation, rotation) error of the tool frame at every pose's joint angles."""
    dt_max = dr_max = 0.0
    for rec in linkage.poses:
        T = linkage.tool_pose(rec.joint_angles)
        dt, dr = pose_difference(T, rec.matrix)
        dt_max, dr_max = max(dt_max, float(dt)), max(dr_max, float(dr))
    return dt_max, dr_max


def closure_errors(linkage: Linkage, samples: int = 200) -> tuple[float, float]:
    """Largest (translation, rotation) mismatch of every welded pair over the sampled motion, and of the
    coupler against the motion polynomial."""
    t = sample_parameters(linkage, samples)
    disp = linkage.displacements(linkage.angles_at(t))
    dt_max = dr_max = 0.0
    for a, b in linkage.closures:
        dt, dr = pose_difference(disp[a], disp[b])
        dt_max, dr_max = max(dt_max, float(dt.max())), max(dr_max, float(dr.max()))
    return dt_max, dr_max


def motion_error(linkage: Linkage, samples: int = 200) -> float:
    """Largest deviation (translation + rotation, over the sample) of the tool link's displacement from
    the motion polynomial C(t)."""
    from .motion import pose_at

    t = sample_parameters(linkage, samples)
    disp = linkage.displacements(linkage.angles_at(t))[linkage.tool_link]
    target = pose_at(linkage.motion, t)
    dt, dr = pose_difference(disp, target)
    return float(np.max(dt + dr))


def self_check(linkage: Linkage, samples: int = 200) -> dict[str, float]:
    """All self-check figures (metres / radians) for linkage.json's ``checks``."""
    pt, pr = pose_errors(linkage)
    ct, cr = closure_errors(linkage, samples)
    return {
        "max_pose_error": pt + pr,
        "max_pose_translation_error": pt,
        "max_pose_rotation_error": pr,
        "max_closure_error": ct + cr,
        "max_closure_translation_error": ct,
        "max_closure_rotation_error": cr,
        "max_motion_error": motion_error(linkage, samples),
        "length_scale": linkage.extent(),
        "samples": samples,
    }
