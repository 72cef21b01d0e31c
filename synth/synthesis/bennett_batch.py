"""Bennett synthesis for many pose sets at once: `synth.synthesis.bennett_core.solve` on a batch.

``bennett_batch(poses)`` takes poses of shape (N, 3, 4, 4) (metres) and returns a `BennettBatch` of arrays
over N, with the conventions of `synth.synthesis.bennett_core` (joints ``h1, h2, k1, k2``; lines
(direction, moment) at the first pose; angle laws (a, b) with theta(t) = 2 atan2(b, t - a); pose 0 at
t = inf, pose 1 at t = 0, pose 2 at t = 1; errors in metres and radians). The numeric core has no Python
loop over the sets. Sets it cannot judge go one by one through the per-set path of
`synth.synthesis.bennett` (`per_set_candidates`; solve has already run on them here), which either
synthesizes them or refuses them; its message becomes the set's ``status``. One bad set never raises.
For random poses this is well under 1% of the sets.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from synth.checks import BOUND_CHECK_SAMPLES
from synth.errors import InputError, MpsynthError, SynthesisError
from synth.synthesis.bennett import linkage_from_solution, per_set_candidates, perturbed_poses
from synth.synthesis.bennett_core import ACCEPT_TOL, JOINTS, TS, Solved, factor_sets, solve

__all__ = ["BennettBatch", "bennett_batch", "JOINTS", "TS", "ACCEPT_TOL"]


@dataclass
class BennettBatch:
    """Per-set results of `bennett_batch`. Arrays have the sets on axis 0; rows of sets that failed
    (``ok[n]`` False) are NaN and ``status[n]`` says why (the message `synth.synthesis.bennett` raises)."""

    poses: np.ndarray  # (N, 3, 4, 4) input, metres
    ok: np.ndarray  # (N,) bool: a linkage was synthesized
    status: list  # N strings: "" when ok, else the reason (SynthesisError / InputError message)
    lines: np.ndarray  # (N, 4, 2, 3): joints h1, h2, k1, k2; (direction, moment) at the first pose
    laws: np.ndarray  # (N, 4, 2): angle laws (a, b), theta(t) = 2 atan2(b, t - a)
    pose_angles: np.ndarray  # (N, 3, 4): joint angles (rad, [0, 2pi)) at the poses (t = inf, 0, 1)
    factors: np.ndarray  # (N, 4, 8): t - h of joints h1, h2, k1, k2 (world frame, metres)
    motion: np.ndarray  # (N, 3, 8): the monic motion polynomial C (world frame), constant term first
    study_form: np.ndarray  # (N, 3): B01, B02, B12 in metres
    centre: np.ndarray  # (N, 3): conditioning centre (centroid of the positions)
    scale: np.ndarray  # (N,): conditioning scale (RMS spread of the positions)
    residual: np.ndarray  # (N,): largest multiply-back error of the two factorizations (conditioned)
    bennett: dict  # a, alpha, b, beta, opposite_length_mismatch, opposite_twist_mismatch: each (N,)
    errors: dict  # pose_translation, pose_rotation, closure_translation, closure_rotation, motion: (N,)
    relative_error: np.ndarray = None  # (N,): the figure synth.synthesis.bennett's acceptance gate compares to 1e-8
    check_samples: int = BOUND_CHECK_SAMPLES
    names: list = field(default_factory=lambda: ["p0", "p1", "p2"])
    general: np.ndarray = None  # (N,) bool: the set went through the per-set path of synth.synthesis.bennett
    _solution: Solved = field(default=None, repr=False)  # the arrays of `solve` (for `linkage`)

    def __len__(self) -> int:
        return len(self.ok)

    @property
    def max_pose_error(self) -> np.ndarray:
        return self.errors["pose_translation"] + self.errors["pose_rotation"]

    @property
    def max_closure_error(self) -> np.ndarray:
        return self.errors["closure_translation"] + self.errors["closure_rotation"]

    def linkage(self, i: int, names=None):
        """The full `Linkage` of set i (joints, branches, poses, info, checks), equal to
        ``synth.bennett(poses[i], names, check_samples=self.check_samples)`` up to rounding. Raises the
        set's SynthesisError / InputError when it failed."""
        i = int(i)
        if not self.ok[i]:
            msg = self.status[i]
            raise (InputError if msg.startswith("the poses contain") else SynthesisError)(msg)
        names = list(names) if names is not None else list(self.names)
        if self.general[i]:  # synthesized by the per-set path of synth.synthesis.bennett
            return per_set_candidates(self.poses[i], names, check_samples=self.check_samples)[0]
        return linkage_from_solution(self._solution, i, self.poses[i], names, self.check_samples)


# ============================================================================ the pipeline
def bennett_batch(poses, *, check_samples: int = BOUND_CHECK_SAMPLES, names=None) -> BennettBatch:
    """Bennett linkages for N pose sets, array of shape (N, 3, 4, 4) in metres (see the module
    docstring for conventions). ``check_samples``: parameters (covering R, as `synth.checks`) at which
    closure and motion are also sampled for each set (they are bounded over the whole motion in any
    case, `synth.checks.loop_bound`). Raises InputError only for a wrong overall shape."""
    T = np.asarray(poses, float)
    if T.ndim != 4 or T.shape[1:] != (3, 4, 4):
        raise InputError(f"bennett_batch needs poses of shape (N, 3, 4, 4), got {T.shape}")
    names = list(names) if names is not None else ["p0", "p1", "p2"]
    out = solve(T, check_samples)
    good, finite = out.good, out.finite
    bad = ~good
    errors = {k: v for k, v in out.errors.items()}
    bp = {k: out.bennett[k] for k in ("a", "alpha", "b", "beta", "opposite_length_mismatch",
                                           "opposite_twist_mismatch")}
    fields = [out.lines, out.laws, out.pose_angles, out.factors, out.motion, out.residual,
              out.relative_error, *bp.values(), *errors.values()]
    for arr in fields:
        arr[bad] = np.nan
    status = ["" if g else "?" for g in good.tolist()]
    for i in np.flatnonzero(~finite).tolist():
        status[i] = "the poses contain NaN or infinity"
    res = BennettBatch(poses=T, ok=good.copy(), status=status, lines=out.lines, laws=out.laws,
                       pose_angles=out.pose_angles, factors=out.factors, motion=out.motion,
                       study_form=out.study_form, centre=out.centre, scale=out.scale,
                       residual=out.residual, bennett=bp, errors=errors, relative_error=out.relative_error,
                       check_samples=check_samples, names=names, general=finite & bad, _solution=out)
    _fallback(res, np.flatnonzero(res.general), names)
    return res


def _fallback(res: BennettBatch, idx, names):
    """Sets not handled by the vectorized core: synth.synthesis.bennett decides (result or message). The
    perturbed sets of their condition estimates (`synth.synthesis.bennett.sensitivity`) are factored
    in one batch."""
    if not idx.size:
        return
    Tp = np.stack([perturbed_poses(res.poses[i]) for i in idx.tolist()])  # (M, trials, 3, 4, 4)
    fac = factor_sets(Tp.reshape(-1, 3, 4, 4))
    trials = Tp.shape[1]
    for n, i in enumerate(idx.tolist()):
        perturbed = {k: v[n * trials : (n + 1) * trials] for k, v in fac.items()}
        try:
            L = per_set_candidates(res.poses[i], names, check_samples=res.check_samples, perturbed=perturbed)[0]
        except MpsynthError as e:
            res.status[i] = str(e)
            continue
        except Exception as e:  # never let one set break the batch
            res.status[i] = f"internal error: {type(e).__name__}: {e}"
            continue
        _fill(res, i, L)


def _fill(res: BennettBatch, i, L):
    J = {j.name: j for j in L.joints}
    for n, name in enumerate(JOINTS):
        j = J[name]
        res.lines[i, n] = (j.direction, j.moment)
        res.laws[i, n] = (j.a, j.b)
        res.factors[i, n] = np.concatenate([[j.a], -j.direction * j.b, [0.0], j.moment * j.b])
        for k, rec in enumerate(L.poses):
            res.pose_angles[i, k, n] = rec.joint_angles[name]
    res.motion[i] = L.motion
    res.study_form[i] = L.info.synthesis.study_form.values
    res.residual[i] = L.info.synthesis.factorization_residual
    for k, v in L.info.bennett.to_dict().items():
        if k in res.bennett:  # (the record also has derived figures the batch's columns leave out)
            res.bennett[k][i] = np.nan if v is None else v
    c = L.checks
    res.errors["pose_translation"][i] = c["max_pose_translation_error"]
    res.errors["pose_rotation"][i] = c["max_pose_rotation_error"]
    res.errors["closure_translation"][i] = c["max_closure_translation_error"]
    res.errors["closure_rotation"][i] = c["max_closure_rotation_error"]
    res.errors["motion"][i] = c["max_motion_error"]
    res.relative_error[i] = np.nan if L.info.relative_error is None else L.info.relative_error
    res.ok[i] = True
    res.status[i] = ""
