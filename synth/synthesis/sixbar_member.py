"""One member of a 6R family and all its loops (`one_member_loops`): the 6 factorizations and the 9 loop
pairs in the world frame, with their engineering scores, by the scan's code (`synth.synthesis.sixbar`) on a
batch of one member (docs/cubic.md)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import factor_lines
from synth.synthesis.conic import to_world
from synth.synthesis.cubic import PAIRS, PERMS
from synth.synthesis.sixbar import Problem, evaluate_member, prepare
from synth.synthesis.sixbar_loops import factor_members

__all__ = ["MemberLoops", "one_member_loops"]


@dataclass
class MemberLoops:
    """The 9 loops of one member (world frame, metres): factors by order, the loop pairs, scores.
    Each factor t - h is a revolute joint: line `synth.algebra.dq.factor_lines` (h), angle law
    theta(t) = 2 atan2(|vec p|, t - h0)."""

    family: int
    member: float
    t3: float
    C: np.ndarray  # (4, 8) world frame, metres
    factorizations: np.ndarray  # (6, 3, 8) world frame, by order (synth.synthesis.cubic.PERMS)
    orders: np.ndarray  # (6, 3) quadratic indices of h1, h2, h3 (quadratics sorted by Re of their root)
    ok: np.ndarray  # (6,)
    residual: np.ndarray  # (6,) multiply-back relative error
    pairs: np.ndarray  # (9, 2) indices into factorizations: branch h, branch k (pair K = row K - 1)
    H: np.ndarray  # (9, 3, 8) branch h of each pair
    K: np.ndarray  # (9, 3, 8) branch k of each pair
    valid: np.ndarray  # (9,)
    score: np.ndarray | None = None  # (9,) engineering score (None when not scored)
    parts: dict | None = None  # score parts, each (9,)

    def lines(self):
        """Plücker lines (u, m) of both branches of every pair, each (9, 2, 3, 3): [pair, branch, joint]."""
        L = factor_lines(np.stack([self.H, self.K], axis=1))[0]
        return L[..., 0, :], L[..., 1, :]


def one_member_loops(poses, family: int, member: float, names=None, problem: Problem | None = None,
                     score: bool = True) -> MemberLoops:
    """All 6 factorizations and the 9 loop pairs of one member (family 1|2, label lambda1 with
    C(0) = lambda1 D_1), in the world frame, built by the scan's code on a batch of one member
    (factors polished); with ``score`` also the engineering score of each loop (else ``valid`` only
    says that both factorizations succeeded). ``problem`` (from `prepare`) skips the set-up for
    repeated calls on the same poses."""
    problem = problem or prepare(poses, names)
    fam = problem.family(int(family))
    if score:
        ev = evaluate_member([fam], float(member))
        mf, valid, sc, parts = ev.factors, ev.valid[0], ev.score[0], {k: v[0] for k, v in ev.parts.items()}
    else:  # the same factorizations, without the loop geometry and scores
        mf = factor_members(fam.member(float(member))[None], polish=True)
        valid, sc, parts = mf.ok[0, PAIRS[:, 0]] & mf.ok[0, PAIRS[:, 1]], None, None
    W = to_world(np.concatenate([mf.H[0].reshape(18, 8), mf.C[0]]), problem.cond)  # one call for all
    F = W[:18].reshape(6, 3, 8)
    return MemberLoops(
        family=fam.index, member=float(member), t3=fam.t3, C=W[18:], factorizations=F,
        orders=PERMS.copy(), ok=mf.ok[0], residual=mf.residual[0], pairs=PAIRS.copy(),
        H=F[PAIRS[:, 0]], K=F[PAIRS[:, 1]], valid=valid, score=sc, parts=parts)
