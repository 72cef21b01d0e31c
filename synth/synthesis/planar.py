"""Planar and spherical pose sets: families of motions through the poses (docs/planar.md).

When every relative displacement between the poses has zero pitch *and* they belong to one subgroup --
rotations about parallel axes with translations perpendicular to them (planar), or rotations about one
common point (spherical) -- the span of ``D_0 = 1, D_1, ...`` lies inside the Study quadric. Then the
conic (three poses) and the cubic (four poses) through the poses are not unique: every polynomial in that
span is a motion polynomial, and the syntheses pick a member of an explicit family:

* three poses: ``C(t) = t (t - 1) - lambda1 (t - 1) D_1 + lambda2 t D_2`` (`synth.synthesis.conic.conic_member`),
  ``C(0) = lambda1 D_1``, ``C(1) = lambda2 D_2``, member ``(lambda1, lambda2)``, both nonzero;
* four poses: the Lagrange cubic with ``C(0) = lambda1 D_1``, ``C(1) = lambda2 D_2``, ``C(t3) = lambda3 D_3``
  (`synth.synthesis.cubic.cubic_member`), member ``(t3, lambda1, lambda2, lambda3)``.

Every factor of such a motion lies in the same subgroup, so the two branches form a planar loop (all axes
parallel to ``normal``) or a spherical one (all axes through ``centre``). Lengths in metres, lines at the
first pose (t = inf), conditioned frame as in docs/conic.md. This module classifies the pose set and
scores members; `synth.synthesis.planar_bennett` and `synth.synthesis.sixbar` build the linkages.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import dq_to_pose, study_form
from synth.errors import SynthesisError
from synth.info import PlanarFamily
from synth.synthesis.conic import Conditioning, condition, relative_displacements
from synth.synthesis.multiloop import constraint_jacobian

ZERO_PITCH_TOL = 1e-12  # every |B(D_i, D_j)| (conditioned) at most this: the span lies in the Study quadric
# (exactly planar or spherical input has |B| at rounding level; between this and the spatial synthesis' 1e-9
# the set is refused as nearly but not exactly planar, `synth.synthesis.conic.check_conic_degeneracy`)
ROTATION_TOL = 1e-9  # |vec p| of a unit D_i at most this: a pure translation
PARALLEL_TOL = 1e-7  # second singular value of the stacked rotation axes at most this: parallel axes
RANK_TOL = 1e-9  # singular value of [D_0 .. D_k] below this times the largest: the poses do not span a k-space


@dataclass
class ZeroPitch:
    """A planar or spherical pose set (conditioned frame data plus the world-frame subgroup)."""

    kind: str  # "planar" | "spherical"
    normal: np.ndarray | None  # (3,) planar: unit direction of every joint axis (normal of the plane of motion)
    centre: np.ndarray | None  # (3,) spherical: the common fixed point (world frame, metres)
    D: np.ndarray  # (k, 8) relative displacements, conditioned frame, D_0 = 1
    cond: Conditioning
    poses: np.ndarray  # (k, 4, 4) world, metres
    names: list

    def describe(self, poses: int, parameters: tuple[str, ...], motion: str) -> PlanarFamily:
        """The family of motions through the poses for the linkage's info: the subgroup (kind plus normal
        (planar) or centre (spherical, metres)), the number of poses, the family's parameters and motions."""
        where = {"normal": tuple(self.normal.tolist())} if self.kind == "planar" else {
            "centre": tuple(self.centre.tolist())}
        return PlanarFamily(kind=self.kind, **where, poses=poses, parameters=parameters, motion=motion)


def study_forms(D) -> np.ndarray:
    """All mixed Study form values B(D_i, D_j), i < j, of displacements D (k, 8), shape (k (k - 1) / 2,)."""
    i, j = np.triu_indices(len(D), 1)
    return study_form(D[i], D[j])


def zero_pitch(T, names, tol: float = ZERO_PITCH_TOL) -> ZeroPitch | None:
    """Classify the poses T (k, 4, 4), metres: None when some Study form value B(D_i, D_j) exceeds ``tol``
    (conditioned frame: a spatial pose set), else the planar or spherical subgroup they lie in.

    Raises SynthesisError for the truly degenerate cases: pure translations only (no rotation axis for a
    revolute joint), or displacements that do not span a (k-1)-space (e.g. rotations about one fixed axis,
    which a single revolute joint performs)."""
    T = np.asarray(T, float)
    Tc, cond = condition(T)
    D = relative_displacements(Tc)
    if np.max(np.abs(study_forms(D))) > tol:
        return None
    k = len(T)
    v = D[1:, 1:4]
    rot = np.linalg.norm(v, axis=1)
    if np.all(rot <= ROTATION_TOL):
        raise SynthesisError(
            f"the {k} poses differ by pure translations only: the motion through them has no rotation axis, so no "
            "linkage of revolute joints built from a motion of this degree carries them; rotate at least one pose")
    sv = np.linalg.svd(D, compute_uv=False)
    if sv[-1] < RANK_TOL * sv[0]:
        raise SynthesisError(
            f"the {k} poses lie on a motion of lower degree (all reached by rotations about one fixed axis, or "
            f"{'on one quadratic motion' if k > 3 else 'one translation direction'}): there is no closed loop "
            "through them of this kind; move one pose off that motion")
    axes = v[rot > ROTATION_TOL] / rot[rot > ROTATION_TOL, None]
    s = np.linalg.svd(axes, compute_uv=False)
    if len(axes) == 1 or s[1] <= PARALLEL_TOL * s[0]:
        n = axes[0] / np.linalg.norm(axes[0])
        n = n if n[np.argmax(np.abs(n))] > 0 else -n
        return ZeroPitch("planar", n, None, D, cond, T, list(names))
    # spherical: the common fixed point c of every D_i (x -> R_i x + d_i): (I - R_i) c = d_i, least squares
    P = dq_to_pose(D[1:])
    A = (np.eye(3) - P[:, :3, :3]).reshape(-1, 3)
    c = np.linalg.lstsq(A, P[:, :3, 3].reshape(-1), rcond=None)[0]
    return ZeroPitch("spherical", None, cond.scale * c + cond.centre, D, cond, T, list(names))


def axis_penalties(zp: ZeroPitch, min_twist, min_offset) -> dict:
    """The geometric penalties (decades) that apply to the subgroup: a planar loop has parallel axes by
    nature and is penalized for short links (consecutive axes closer than 0.05 pose spreads), a spherical
    loop has intersecting axes by nature and is penalized for small angles between consecutive axes (below
    10 degrees), as in the 6R score (docs/cubic.md, section 6)."""
    with np.errstate(all="ignore"):
        zero = np.zeros(np.shape(min_twist))
        if zp.kind == "planar":
            return {"penalty_parallel": zero, "penalty_intersect": np.maximum(0.0, np.log10(0.05 / min_offset))}
        return {"penalty_parallel": np.maximum(0.0, np.log10(np.sin(np.radians(10.0)) / np.sin(min_twist))),
                "penalty_intersect": zero}


def tracks_motion(linkage, driver: str = "h1", steps: int = 180, tol: float = 1e-6) -> bool:
    """Whether driving ``driver`` through a full turn in ``steps`` equal steps, solving the loops by
    Gauss-Newton from a secant prediction (as an independent verifier does), stays on the motion (every
    joint within ``tol`` rad of its angle law). Planar and spherical loops are change-point mechanisms
    (an anti-parallelogram passes flat configurations where a second branch crosses, docs/planar.md,
    section 5); where two branches cross at a shallow angle the continuation can switch, and such a
    design is avoided."""
    names = [j.name for j in linkage.joints]
    d = names.index(driver)
    others = [i for i in range(len(names)) if i != d]
    jd = linkage.joints[d]
    theta = np.linspace(0.0, 2 * np.pi, steps + 1)[1:-1]
    t = jd.parameter(theta)  # the driver's angle law inverted
    laws = np.array([j.angle(t) for j in linkage.joints]).T  # (steps - 1, joints)
    q_prev = q = np.zeros(len(names))
    for k, th in enumerate(theta):
        guess = q + (q - q_prev) if k else q.copy()
        guess[d] = th
        x = guess
        for _ in range(8):
            angles = dict(zip(names, x))
            disp = linkage.displacements(angles)  # one evaluation for the error and the Jacobian
            e = _closure_error(linkage, disp)
            if np.max(np.abs(e)) < 1e-13:
                break
            J = constraint_jacobian(linkage, angles, disp)
            x = x.copy()
            x[others] -= np.linalg.lstsq(J[:, others], e, rcond=None)[0]
        diff = np.angle(np.exp(1j * (x - laws[k])))
        if not np.max(np.abs(diff)) <= tol:
            return False
        q_prev, q = q, x
    return True


def _closure_error(linkage, disp) -> np.ndarray:
    """Stacked twists (omega, v) of disp(Y) disp(Y')^-1 over the welds (Y, Y'), small-displacement form;
    ``disp``: the links' displacements (`Linkage.displacements`)."""
    out = []
    for y, y2 in linkage.closures:
        E = disp[y] @ np.linalg.inv(disp[y2])
        R = E[:3, :3]
        out += [0.5 * (R[2, 1] - R[1, 2]), 0.5 * (R[0, 2] - R[2, 0]), 0.5 * (R[1, 0] - R[0, 1]), *E[:3, 3]]
    return np.array(out)


ISOGRAM_GOOD = 0.2  # relative difference of a loop's two side lengths (or angles) above which it is not penalized


def isogram_margin(kind: str, dist, twist) -> np.ndarray:
    """How far a loop with opposite sides equal is from the equilateral case, from two adjacent sides
    (distances ``dist`` (..., 2) for a planar loop, signed twists ``twist`` (..., 2) for a spherical one):
    ``|a - b| / max(a, b)``, or ``min(|alpha - beta|, |pi - alpha - beta|) / (pi / 2)`` for side angles
    alpha, beta in [0, pi]. An equilateral loop (a rhombus) has extra modes and its branches cross at
    shallow angles (docs/planar.md, section 5)."""
    with np.errstate(all="ignore"):
        if kind == "planar":
            d = np.asarray(dist, float)
            return np.abs(d[..., 0] - d[..., 1]) / np.maximum(d[..., 0], d[..., 1])
        a = np.abs(np.asarray(twist, float))
        return np.minimum(np.abs(a[..., 0] - a[..., 1]), np.abs(np.pi - a[..., 0] - a[..., 1])) / (np.pi / 2)


def isogram_penalty(margin) -> np.ndarray:
    """Decades of penalty for a loop closer than ISOGRAM_GOOD to equilateral (`isogram_margin`)."""
    with np.errstate(all="ignore"):
        return np.maximum(0.0, np.log10(ISOGRAM_GOOD / np.asarray(margin, float)))
