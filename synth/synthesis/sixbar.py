"""Spatial 6R linkages through four poses (docs/cubic.md).

``sixbar(poses)`` takes a (4, 4, 4) array of poses in metres and returns the best verified `Linkage`
(branch h = h1 h2 h3, branch k = k1 k2 k3, C = (t-h1)(t-h2)(t-h3) = (t-k1)(t-k2)(t-k3); pose 0 at
t = inf with all angles 0, pose 1 at t = 0, pose 2 at t = 1, pose 3 at t = t3 of the family).

Pipeline (conditioned frame: origin at the centroid of the positions, lengths divided by their RMS
spread L): relative displacements -> quadric (refuse oval / degenerate sets) -> both families of cubics
(`synth.synthesis.cubic`) -> a scan of GRID members per family, all factorized and scored in one batch
(`synth.synthesis.sixbar_loops.evaluate_members`) -> the best candidates built (factors polished where
it matters, `synth.synthesis.assemble.two_branch_linkage`), mapped back to the world frame and
self-checked (`synth.checks.self_check`) until one passes.

Numbering (also in `synth.synthesis.cubic`): family 1 has the larger t3; a member is its lambda1
(C(0) = lambda1 D_1); pairs 1..9 in lexicographic order of the factorization orders (h, k). The
engineering score is described in `synth.synthesis.sixbar_loops` (SCORE_RULE); the scan keeps the local
maxima of each pair's score along each family's pencil and ranks them by score.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import islice

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.geometry import Conditioning, dh_parameters
from synth.checks import DEFAULT_CHECK_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.info import LinkageInfo, Orders, SixbarCandidate
from synth.infoparts import DHRow, ScoreParts
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett import check_distinct
from synth.synthesis.conditioning import transmission_problem
from synth.synthesis.conic import condition, relative_displacements, to_world
from synth.synthesis.cubic import PAIRS, PERMS, CubicFamily, families, quadric
from synth.synthesis.planar import zero_pitch
from synth.synthesis.planar_sixbar import candidates as planar_candidates
from synth.synthesis.sixbar_loops import (COND_WEIGHT, PART_KEYS, SCORE_RULE, MemberEval, evaluate_members,
                                          factor_members, root_pairs, score_warnings)
from synth.task import default_name

__all__ = ["COND_WEIGHT", "PART_KEYS", "SCORE_RULE", "Problem", "prepare", "scan", "sixbar", "sixbar_candidates",
           "build_linkage", "Candidate", "Ranking", "LOOP"]

GRID = 24  # members per family in the scan
REFINE = 0  # scan candidates refined locally by default (library option; the CLI uses the plain scan)
CHECK_TOL = 1e-9  # relative self-check tolerance for accepting a linkage
MAX_ATTEMPTS = 8  # candidates built and checked before giving up
EPS = float(np.finfo(float).eps)
FLOOR_ULPS = 2**17  # rounding floor of world-frame checks, in ulps of the pose coordinates (as for Bennett)
POLISH_TOL = 1e-12  # predicted relative pose error (residual / smallest weight) above this: polish (1000x inside CHECK_TOL)
LOOP = ["h1", "h2", "h3", "k3", "k2", "k1"]


# ============================================================================ set-up
@dataclass
class Problem:
    """Four poses prepared for synthesis (conditioned frame)."""

    poses: np.ndarray  # (4, 4, 4) world, metres
    names: list[str]
    Tc: np.ndarray
    cond: object  # synth.synthesis.conic.Conditioning
    D: np.ndarray  # (4, 8) relative displacements (conditioned)
    quadric: object
    families: list[CubicFamily]
    missing: dict[int, str]  # family number -> why it does not exist

    def family(self, index: int) -> CubicFamily:
        for f in self.families:
            if f.index == index:
                return f
        if index not in (1, 2):
            raise InputError(f"--family must be 1 or 2, got {index}")
        why = self.missing.get(index, "it does not exist for these poses")
        raise SynthesisError(f"family {index} of cubic motions is degenerate: {why}; use the other family")


def prepare(poses, names=None) -> Problem:
    """Validate four poses, condition them and compute the quadric and both families.

    Raises InputError (wrong shape) or SynthesisError (coincident poses, degenerate or oval section)."""
    T, names = _checked(poses, names)
    Tc, cond = condition(T)
    D = relative_displacements(Tc)
    q = quadric(D)
    fams, missing = families(q)
    if not fams:
        raise SynthesisError("both families of cubic motions through the poses are degenerate ("
                             + "; ".join(missing.values()) + "): no 6R linkage of this kind")
    return Problem(poses=T, names=names, Tc=Tc, cond=cond, D=D, quadric=q, families=fams, missing=missing)


def _checked(poses, names):
    """(poses (4, 4, 4), names) after the shape and coincidence checks."""
    T = np.asarray(poses, float)
    if T.shape != (4, 4, 4):
        raise InputError(f"a 6R linkage needs exactly 4 poses (array of shape (4, 4, 4)), got {T.shape}")
    names = list(names) if names is not None else [default_name(i) for i in range(4)]
    try:
        check_distinct(T, names)
    except SynthesisError as e:
        raise SynthesisError(str(e).replace("three distinct poses", "four distinct poses")) from None
    return T, names


def _planar(poses, names, family, member, pair, top, check_samples):
    """The Watt six-bars of a planar or spherical pose set (`synth.synthesis.planar_sixbar`, docs/planar.md),
    or None for spatial poses. ``member``: (t3, lambda1, lambda2, lambda3); ``pair``: the chain 1..6."""
    T, names = _checked(poses, names)
    if not np.all(np.isfinite(T)):
        return None
    zp = zero_pitch(T, names)
    if zp is None:
        if member is not None and np.ndim(member) != 0:
            raise InputError("--member of spatial poses is one number (lambda1); T3,L1,L2,L3 applies to planar or "
                             "spherical poses")
        return None
    if family is not None:
        raise InputError(f"--family does not apply to {zp.kind} poses: their cubic motions form one family with "
                         "the member T3,L1,L2,L3 (--member)")
    if member is not None and np.size(member) != 4:
        raise InputError(f"--member of {zp.kind} poses is T3,L1,L2,L3 (the parameter of pose 3 and the weights at "
                         "poses 1, 2, 3), e.g. --member 2,1,1,1")
    return planar_candidates(zp, member, pair, top=top, check_samples=check_samples)


# ============================================================================ members
def member_lambdas(fam: CubicFamily, C) -> np.ndarray:
    """(lambda1, lambda2, lambda3) of monic members C (..., 4, 8): C(t_i) = lambda_i D_i."""
    vals = (np.asarray(fam.ts[1:], float)[:, None] ** np.arange(4)) @ np.asarray(C, float)[..., :4]
    return (vals * fam.D[1:, :4]).sum(-1)


def grid_angles(n: int = GRID) -> np.ndarray:
    """Pencil angles of the scan: n points uniform in [0, pi), none at 0."""
    return (np.arange(n) + 0.5) * np.pi / n


def grid_members(fams: list[CubicFamily], grid: int = GRID):
    """Members of the scan, all families at once (`CubicFamily.members` and `CubicFamily.lambdas`
    batched): (C (G, 4, 8), lambdas (G, 3), phi (G,), family of each member); G = grid x families,
    one block of ``grid`` rows per family."""
    phi = grid_angles(grid)
    c, s = np.cos(phi), np.sin(phi)
    basis = np.stack([f.basis for f in fams], 1)[:, :, None]  # (2, F, 1, 4, 8): Q_a, Q_b
    lead = np.stack([f.lead for f in fams], 1)[..., None]  # (2, F, 1)
    w = np.stack([f.weights for f in fams], 1)[:, :, None]  # (2, F, 1, 4)
    with np.errstate(all="ignore"):
        ld = c * lead[0] + s * lead[1]  # (F, G)
        C = (c[:, None, None] * basis[0] + s[:, None, None] * basis[1]) / ld[..., None, None]
        C[..., 3, :] = np.eye(8)[0]
        wg = c[:, None] * w[0] + s[:, None] * w[1]  # (F, G, 4)
        lams = wg[..., 1:] / wg[..., :1]
    fl = [f for f in fams for _ in range(grid)]
    return C.reshape(-1, 4, 8), lams.reshape(-1, 3), np.tile(phi, len(fams)), fl


def evaluate_member(fams: list[CubicFamily], member: float) -> MemberEval:
    """The member with label lambda1 = ``member`` (exact) of each family in ``fams``, as one batch, its
    factorizations polished."""
    C = np.stack([f.member(member) for f in fams])
    lam = np.stack([member_lambdas(f, c) for f, c in zip(fams, C)])
    lam[:, 0] = float(member)
    return evaluate_members(C, lam, [f.phi_of_lambda1(member) for f in fams], fams, polish=True)


# ============================================================================ candidates
@dataclass
class Candidate:
    """One 6R design: a member of a family and one of its 9 loop pairs (conditioned-frame data)."""

    family: int
    member: float  # lambda1
    pair: int  # 1..9
    score: float
    parts: dict[str, float]
    t3: float
    phi: float
    lambdas: tuple[float, float, float]
    H: np.ndarray  # (3, 8) branch h factors (conditioned frame)
    K: np.ndarray  # (3, 8)
    C: np.ndarray  # (4, 8) monic cubic (conditioned frame)
    orders: tuple[tuple[int, ...], tuple[int, ...]]
    roots: np.ndarray  # (3,) complex


def _candidate(ev: MemberEval, g: int, k: int) -> Candidate:
    fam = ev.fams[g]
    i, j = PAIRS[k]
    return Candidate(
        family=fam.index, member=float(ev.lam[g, 0]), pair=int(k + 1), score=float(ev.score[g, k]),
        parts={key: float(ev.parts[key][g, k]) for key in PART_KEYS}, t3=fam.t3, phi=float(ev.phi[g]),
        lambdas=tuple(float(x) for x in ev.lam[g]), H=ev.factors.H[g, i].copy(), K=ev.factors.H[g, j].copy(),
        C=ev.factors.C[g].copy(), orders=(tuple(int(x) for x in PERMS[i]), tuple(int(x) for x in PERMS[j])),
        roots=ev.factors.roots[g].copy())


def _local_maxima(score: np.ndarray, nfam: int) -> np.ndarray:
    """Mask (G, 9) of grid members that are local maxima of their pair's score along their family's
    (circular) pencil: the scan reports distinct designs, not neighbouring grid points of one design.
    The rows are ``nfam`` consecutive blocks of equal length, one per family (`grid_members`)."""
    s = score.reshape(nfam, -1, score.shape[-1])
    keep = (s > 0) & (s >= np.roll(s, 1, axis=1)) & (s >= np.roll(s, -1, axis=1))
    return keep.reshape(score.shape)


class Ranking:
    """Ranked candidates of a scan, best first; `Candidate` objects are made on demand (``ranking[i]``).
    Entries are (MemberEval, member row, pair column)."""

    def __init__(self, ev: MemberEval, keep: np.ndarray):
        g, k = np.nonzero(keep)
        order = np.argsort(-ev.score[g, k], kind="stable")
        self.entries = [(ev, gi, ki) for gi, ki in zip(g[order].tolist(), k[order].tolist())]

    def score(self, i: int) -> float:
        ev, g, k = self.entries[i]
        return float(ev.score[g, k])

    def __len__(self):
        return len(self.entries)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        return _candidate(*self.entries[i])

    def __iter__(self):
        return (self[i] for i in range(len(self)))

    def refine(self, n: int, grid: int, steps: int = 3) -> None:
        """Refine the first ``n`` scan candidates: evaluate 2 ``steps`` members around each (within 3/4
        of a grid step on both sides, where the grid neighbours are known to be worse) in one batch and
        keep the best of each candidate's pair. In place; the refined head is re-sorted."""
        n = min(n, len(self.entries))
        if n == 0:
            return
        delta = np.pi / grid
        offs = delta * 0.75 * np.concatenate([-np.arange(steps, 0, -1), np.arange(1, steps + 1)]) / steps
        head = self.entries[:n]
        Cs, lams, phis, fams = [], [], [], []
        with np.errstate(all="ignore"):
            for ev, g, _ in head:
                fam, phi = ev.fams[g], ev.phi[g] + offs
                Cs.append(fam.members(phi)[0])
                lams.append(fam.lambdas(phi))
                phis.append(phi)
                fams += [fam] * len(offs)
        fine = evaluate_members(np.concatenate(Cs), np.concatenate(lams), np.concatenate(phis), fams)
        m = len(offs)
        out = []
        for i, (ev, g, k) in enumerate(head):
            rows = np.arange(i * m, (i + 1) * m)
            best = rows[int(np.argmax(fine.score[rows, k]))]
            out.append((fine, int(best), k) if fine.score[best, k] > ev.score[g, k] else (ev, g, k))
        out.sort(key=lambda e: -float(e[0].score[e[1], e[2]]))
        self.entries[:n] = out


def scan(problem: Problem, *, family=None, member=None, pair=None, grid: int = GRID, refine: int = 0) -> Ranking:
    """All candidate designs, best first. With ``member`` the given member of the family (or of both
    families) is evaluated; otherwise ``grid`` members per family, keeping the local maxima of each
    pair's score along the pencil, and the best ``refine`` of them are refined locally (`Ranking.refine`).
    ``pair`` (1..9) restricts to one loop pair."""
    if pair is not None and not 1 <= int(pair) <= 9:
        raise InputError(f"--pair must be between 1 and 9, got {pair}")
    fams = [problem.family(int(family))] if family is not None else problem.families
    if member is not None:
        if not np.isfinite(member):
            raise InputError(f"--member must be a finite number, got {member}")
        ev = evaluate_member(fams, float(member))
        keep = ev.valid.copy()
    else:
        ev = evaluate_members(*grid_members(fams, grid))
        keep = _local_maxima(ev.score, len(fams))
    if pair is not None:
        keep[:, np.arange(9) != int(pair) - 1] = False
    ranking = Ranking(ev, keep)
    if member is None and refine:
        ranking.refine(refine, grid)
    return ranking


def _explicit_failure(problem: Problem, family, member, pair) -> SynthesisError:
    what = []
    if family is not None:
        what.append(f"family {family}")
    if member is not None:
        what.append(f"member lambda1 = {member:g}")
    if pair is not None:
        what.append(f"pair {pair}")
    sel = ", ".join(what) or "the scan"
    hint = ""
    if member is not None:
        bad = []
        for fam in (problem.families if family is None else [problem.family(int(family))]):
            b = fam.bad_members()
            bad.append(f"lambda1 = 0, {b['lambda2']:.6g} and {b['lambda3']:.6g} in family {fam.index}")
        hint = (" (this member's norm polynomial has a real or repeated root, or a factor is a translation; "
                "stay away from " + "; ".join(bad) + ", or omit --member to scan)")
    return SynthesisError(f"{sel} gives no valid 6R linkage{hint}")


# ============================================================================ linkages
def polish_candidate(cand: Candidate) -> Candidate:
    """The candidate with both branches polished by Newton's method on the product equations
    (`synth.algebra.algorithm1.polish`) when it matters: the scan's factors multiply back to ~1e-15
    relative (~1e-12 for nearly real or equal norm roots), and the pose errors are about that divided
    by the smallest weight |lambda_i| of the poses (C(t_i) = lambda_i D_i)."""
    scale = max(1.0, float(np.max(np.abs(cand.C))))
    weight = min(1.0, min(abs(x) for x in cand.lambdas))
    if not cand.parts["residual"] * scale > POLISH_TOL * weight:
        return cand
    HK, _ = a1.polish(cand.C, np.stack([cand.H, cand.K]))
    res = np.maximum(a1.multiply_back(cand.C, HK), a1.study_violation(HK))
    if not np.all(res <= cand.parts["residual"]):
        return cand
    return replace(cand, H=HK[0], K=HK[1], parts=dict(cand.parts, residual=float(np.max(res))))


def build_linkage(problem: Problem, cand: Candidate, *, check_samples: int = DEFAULT_CHECK_SAMPLES,
                  check: bool = True):
    """World-frame Linkage of a candidate (its factors polished first where it matters,
    `polish_candidate`) with its info and, unless ``check`` is false, ``checks`` (`self_check` at
    ``check_samples`` parameters)."""
    cand = polish_candidate(cand)
    cond = problem.cond
    W = to_world(np.concatenate([cand.H, cand.K, cand.C]), cond)  # (3 + 3 + 4, 8)
    H, K, C = W[:3], W[3:6], W[6:]
    record = SixbarCandidate(
        family=cand.family, member=cand.member, pair=cand.pair, t3=cand.t3, lambdas=tuple(cand.lambdas),
        score=cand.score, score_parts=ScoreParts.of(cand.parts), orders=Orders(h=tuple(cand.orders[0]),
                                                                              k=tuple(cand.orders[1])),
        norm_roots=root_pairs(cand.roots), factorization_residual=cand.parts["residual"],
        gram_signature=tuple(problem.quadric.signature), family_t3={str(f.index): f.t3 for f in problem.families},
        conditioning=Conditioning(cond.centre, float(cond.scale)))
    info = LinkageInfo(synthesis=record)
    linkage = two_branch_linkage("6r", H, K, C, problem.poses, problem.names, (np.inf, 0.0, 1.0, cand.t3), info)
    linkage.info = info.replace(dh=loop_dh(linkage, LOOP), warnings=score_warnings(cand.parts))
    if check:
        linkage.checks = self_check(linkage, check_samples)
    return linkage


def loop_dh(linkage, loop: list[str]) -> tuple[DHRow, ...]:
    """Denavit-Hartenberg parameters around the closed loop of joints ``loop`` at the reference
    configuration (`synth.algebra.geometry.dh_parameters`)."""
    J = {j.name: j for j in linkage.joints}
    U = np.array([J[n].direction for n in loop], float)
    M = np.array([J[n].moment for n in loop], float)
    return DHRow.table(dh_parameters(U, M).table(loop))


def checks_pass(linkage, scale: float, tol: float = CHECK_TOL) -> bool:
    """Self-check errors within ``tol`` relative: translations to the pose spread (closure: to the larger
    of the spread and the linkage's size) plus the rounding floor of coordinates far from the origin
    (as `synth.synthesis.bennett`), rotations in radians."""
    c = linkage.checks
    size = max(scale, c.get("length_scale", scale))
    floor = FLOOR_ULPS * EPS * max(abs(x) for p in linkage.poses for x in p.matrix[:3, 3].tolist())
    vals = [c["max_pose_translation_error"] / (scale + floor / tol), c["max_pose_rotation_error"],
            c["max_closure_translation_error"] / (size + floor / tol), c["max_closure_rotation_error"]]
    return all(np.isfinite(v) and v <= tol for v in vals)


def _ranked(poses, names, family, member, pair, grid, refine):
    """(Problem, candidates best first) of a pose set; SynthesisError when the choice leaves none."""
    problem = prepare(poses, names)
    cands = scan(problem, family=family, member=member, pair=pair, grid=grid, refine=refine)
    if not len(cands):
        raise _explicit_failure(problem, family, member, pair)
    return problem, cands


def _built(problem: Problem, cands, check_samples: int):
    """Yield (checked Linkage, None if it passes `checks_pass` and the transmission gate
    (`synth.synthesis.conditioning.transmission_problem`), else "check" or the gate's sentence) for the
    candidates in order, lazily."""
    for cand in cands:
        linkage = build_linkage(problem, cand, check_samples=check_samples)
        why = transmission_problem(linkage)
        yield linkage, (why if why else None if checks_pass(linkage, problem.cond.scale) else "check")


def _ill_conditioned(why: str, explicit: bool) -> SynthesisError:
    """The refusal when the candidates that close are refused by the transmission gate (its sentence,
    about "the linkage", said of the selected design or of the best candidate)."""
    what = "the selected 6R design" if explicit else "the best 6R candidate"
    return SynthesisError(why.replace("the linkage", what, 1))


def sixbar_candidates(poses, names=None, *, family=None, member=None, pair=None, top=None,
                      grid: int = GRID, refine: int = REFINE, build: bool = False,
                      check_samples: int = DEFAULT_CHECK_SAMPLES):
    """Ranked candidate designs (best first; at most ``top``). With ``build`` each is returned as a
    checked Linkage (`build_linkage`; candidates failing the self-check are skipped), else as
    `Candidate`. ``grid`` and ``refine``: see `scan`. Planar or spherical poses give Watt six-bars
    (`synth.synthesis.planar_sixbar`), always built."""
    planar = _planar(poses, names, family, member, pair, top or MAX_ATTEMPTS, check_samples)
    if planar is not None:
        return planar
    problem, cands = _ranked(poses, names, family, member, pair, grid, refine)
    if not build:
        return cands[:top] if top else list(cands)
    out, gate = [], None
    for linkage, why in _built(problem, cands, check_samples):  # lazily, until ``top`` pass
        if why is None:
            out.append(linkage)
            if top and len(out) >= top:
                break
        elif why != "check":
            gate = gate or why
    if not out and gate:
        raise _ill_conditioned(gate, family is not None or member is not None or pair is not None)
    if not out:
        raise SynthesisError("no candidate 6R linkage passed the self-check (poses, closure) at "
                             f"{CHECK_TOL:g} relative: the pose set is numerically degenerate")
    return out


def sixbar(poses, names=None, *, family=None, member=None, pair=None, grid: int = GRID, refine: int = REFINE,
           check_samples: int = DEFAULT_CHECK_SAMPLES):
    """Synthesize the best 6R linkage (by the engineering score) whose coupler visits the four poses
    (shape (4, 4, 4), metres): the first of the ranked candidates (`scan`, at most MAX_ATTEMPTS) whose
    self-check (`synth.checks.self_check` at ``check_samples`` parameters, in ``linkage.checks``)
    passes `checks_pass` and the transmission gate (`synth.synthesis.conditioning`). ``family`` (1|2),
    ``member`` (lambda1) and ``pair`` (1..9) restrict the choice; ``grid`` members per family are scanned
    and the best ``refine`` candidates refined locally.
    Planar or spherical poses (docs/planar.md) give a planar or spherical Watt six-bar of a member
    (t3, lambda1, lambda2, lambda3) of their cubic family (`synth.synthesis.planar_sixbar`; ``pair``: the
    chain 1..6). Raises SynthesisError (oval section, degenerate poses, no valid candidate) with a
    plain-language reason, InputError for bad arguments."""
    planar = _planar(poses, names, family, member, pair, 1, check_samples)
    if planar is not None:
        return planar[0]
    problem, cands = _ranked(poses, names, family, member, pair, grid, refine)
    first, gate = None, None
    for linkage, why in _built(problem, islice(cands, MAX_ATTEMPTS), check_samples):  # lazily
        first = first or linkage
        if why is None:
            return linkage
        if why != "check":
            gate = gate or why
    c = first.checks
    explicit = family is not None or member is not None or pair is not None
    if gate:
        raise _ill_conditioned(gate, explicit)
    hint = ("the selected design is numerically ill-conditioned; choose another member or pair, or omit "
            "--member/--pair to scan" if explicit else
            "the pose set is numerically degenerate (nearly real or repeated norm roots in every member); "
            "perturb a pose")
    raise SynthesisError(
        f"the best 6R candidates do not pass the self-check (pose error {c['max_pose_error']:.2g}, closure "
        f"error {c['max_closure_error']:.2g}): {hint}")
