"""`solve_bennett` for many pose sets at once: the batch jobs' fast path (README "Batch and shell pipelines").

``solve_bennett_many(T)`` takes N three-pose sets (N, 3, 4, 4) in metres and returns `BennettSummaries`:
for every set it decides (``decided[n]``) it gives what `synth.solve.solve_bennett` with the default
options gives for that set (no physical design, no constraints): the verified linkage's extent (m), its
``checks`` (the self-check at VERIFY_SAMPLES parameters, `synth.bennett.verify`) and its Bennett
parameters, the same numbers to the last bit. It runs the pipeline once for all sets
(`synth.synthesis.bennett_core.solve`) and applies `solve_bennett`'s gates to the arrays: the pipeline's
own acceptance, the transmission ratio (`synth.synthesis.conditioning`), the 200-sample verification and
its acceptance (`synth.bennett.verify`) and the extent limit (`synth.design.constraints.admissible`).
A set that fails a gate, or comes within a factor 2 of a gate's limit (where rounding could decide; not
the transmission ratio, which is `verify`'s own figure bit for bit), or that the pipeline leaves to the
per-set path, is not decided: its caller runs `solve_bennett` on it,
which gives the linkage or the refusal with its message. A set the pipeline judges whose transmission
ratio is above the limit is decided as refused (``refused``), with `solve_bennett`'s message
(`BennettSummaries.refusal`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.checks import VERIFY_SAMPLES, as_checks, check_figures
from synth.design.sizes import EXTENT_FACTOR
from synth.algebra.dq import pose_to_dq
from synth.algebra.geometry import extent, joint_sites, spread
from synth.blas import one_blas_thread
from synth.errors import InputError
from synth.synthesis.bennett_core import ACCEPT_TOL, JOINTS, LOOP, STRUCTURE, acceptance_error, axis_distance, solve
from synth.synthesis.conditioning import TRANSMISSION_LIMIT, transmission_refusal, worst_pairs

BENNETT_PAIRS = ((0, 2), (0, 1), (2, 3), (1, 3))  # joints h1 h2 k1 k2 carried by one link (base, link_h1, link_k1, coupler)
MARGIN = 0.5  # a set is decided here only with every gate's figure below MARGIN times its limit
PARAMETERS = ("a", "alpha", "b", "beta")
CHUNK = 1024  # sets per call of the pipeline


@dataclass
class BennettSummaries:
    """Per-set results of `solve_bennett_many` (arrays over the N sets; rows of undecided sets are NaN).
    ``figures``: the self-check figures at VERIFY_SAMPLES parameters (`synth.checks.check_figures`:
    pose_translation, pose_rotation, closure_translation, closure_rotation, motion; m and rad);
    ``extent`` (N,) m; ``bennett``: a, alpha, b, beta (m, rad) of the loop h1 h2 k2 k1; ``refused`` (N,)
    bool: decided sets that `solve_bennett` refuses at the transmission gate, with ``worst`` = (ratio,
    faster joint, slower joint) (N,) arrays (`synth.synthesis.conditioning.worst_pairs`; joints index
    JOINTS) for its message (`synth.synthesis.conditioning.transmission_refusal`)."""

    decided: np.ndarray  # (N,) bool
    extent: np.ndarray
    figures: dict
    bennett: dict
    refused: np.ndarray  # (N,) bool
    worst: tuple

    def refusal(self, n: int, T, names) -> str:
        """The message of refused set n (poses T (3, 4, 4) named ``names``), as `solve_bennett` gives it
        (without the source's prefix)."""
        rho, fast, slow = (w[n] for w in self.worst)
        return transmission_refusal(T, names, float(rho), JOINTS[int(fast)], JOINTS[int(slow)])

    def checks(self, n: int) -> dict:
        """linkage.json's ``checks`` of decided set n, as `synth.bennett.verify` stores them."""
        return as_checks({k: float(v[n]) for k, v in self.figures.items()}, VERIFY_SAMPLES, float(self.extent[n]))

    def parameters(self, n: int) -> dict:
        """The Bennett parameters a, alpha, b, beta of decided set n (floats)."""
        return {k: float(self.bennett[k][n]) for k in PARAMETERS}

    def columns(self, index) -> tuple[dict, dict]:
        """(`checks`, `parameters`) of the decided sets ``index`` (a list) as columns: dicts of arrays (n,)
        (or the scalars every row has, e.g. ``samples``), in the order of `checks` and `parameters`."""
        checks = as_checks({k: v[index] for k, v in self.figures.items()}, VERIFY_SAMPLES, self.extent[index])
        return checks, {k: self.bennett[k][index] for k in PARAMETERS}

    def rows(self, index) -> tuple[list, list]:
        """(`checks`, `parameters`) of the decided sets ``index`` (a list), at once: lists of dicts."""
        checks, parameters = self.columns(index)
        return _rows(checks, len(index)), _rows(parameters, len(index))


def _rows(columns: dict, n: int) -> list:
    """The n dicts of plain floats (or the scalars given) of a dict of columns (arrays (n,) or scalars)."""
    cols = [v.tolist() if isinstance(v, np.ndarray) else [v] * n for v in columns.values()]
    keys = list(columns)
    return [dict(zip(keys, row)) for row in zip(*cols)]


def solve_bennett_many(poses) -> BennettSummaries:
    """`solve_bennett` (default options) of N three-pose sets (N, 3, 4, 4), metres, where the arrays
    decide (module docstring). Raises InputError only for a wrong overall shape."""
    T = np.asarray(poses, float)
    if T.ndim != 4 or T.shape[1:] != (3, 4, 4):
        raise InputError(f"solve_bennett_many needs poses of shape (N, 3, 4, 4), got {T.shape}")
    with one_blas_thread():  # (`synth.blas`: threads only cost in these batched kernels)
        parts = [_summaries(T[i : i + CHUNK]) for i in range(0, len(T), CHUNK)]
    if len(parts) == 1:
        return parts[0]
    return BennettSummaries(*(np.concatenate([getattr(p, k) for p in parts]) if k in ("decided", "extent", "refused") else
                              tuple(np.concatenate(w) for w in zip(*(p.worst for p in parts))) if k == "worst" else
                              {f: np.concatenate([p.__dict__[k][f] for p in parts]) for f in parts[0].__dict__[k]}
                              for k in ("decided", "extent", "figures", "bennett", "refused", "worst")))


def _summaries(T) -> BennettSummaries:
    out = solve(T, 0, as_single=True)
    with np.errstate(all="ignore"):
        a, b = out.laws[..., 0], out.laws[..., 1]
        U, M = out.lines[..., 0, :], out.lines[..., 1, :]
        Q = pose_to_dq(np.where(out.finite[:, None, None, None], T, np.eye(4)))
        fig = check_figures(STRUCTURE, U, M, a, b, out.pose_angles, Q, Q[:, 0], out.motion, VERIFY_SAMPLES)
        # `synth.linkage.Linkage.extent`: joint sites and tool positions (pose 0 twice: the reference)
        positions = np.concatenate([T[:, :, :3, 3], T[:, :1, :3, 3]], axis=1)
        sites = joint_sites(U, M, BENNETT_PAIRS, np.mean(positions, axis=1))
        E = extent(np.concatenate([sites, positions], axis=1))
        # the gates of `verify` (acceptance of the sampled figures, transmission) and of `admissible` (extent)
        loop = out.lines[:, LOOP]
        far = axis_distance(loop[..., 0, :], loop[..., 1, :], out.centre)
        rel = np.maximum(acceptance_error(T, out.scale, far, fig), out.relative_error)
        limit = EXTENT_FACTOR * spread(T[:, :, :3, 3])[1]
        # the transmission ratio is `verify`'s own figure, bit for bit (the same laws and formula): no margin;
        # a set above it is refused whatever the other gates say (`bennett_candidates` checks it first)
        worst = worst_pairs(a, b)
        transmits = worst[0] <= TRANSMISSION_LIMIT
        refused = out.good & ~transmits
        decided = out.good & (rel <= MARGIN * ACCEPT_TOL) & transmits & (E <= MARGIN * limit)
    nan = ~decided
    figures = {k: np.where(nan, np.nan, v) for k, v in fig.items()}
    params = {k: np.where(nan, np.nan, out.bennett[k]) for k in PARAMETERS}
    return BennettSummaries(decided=decided | refused, extent=np.where(nan, np.nan, E), figures=figures, bennett=params,
                            refused=refused, worst=worst)
