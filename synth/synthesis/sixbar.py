"""Spatial 6R linkages through four poses (MATH.md section 8).

``sixbar(poses)`` takes a (4, 4, 4) array of poses in metres and returns the best verified `Linkage`
(branch h = h1 h2 h3, branch k = k1 k2 k3, C = (t-h1)(t-h2)(t-h3) = (t-k1)(t-k2)(t-k3); pose 0 at
t = inf with all angles 0, pose 1 at t = 0, pose 2 at t = 1, pose 3 at t = t3 of the family).

Pipeline (conditioned frame: origin at the centroid of the positions, lengths divided by their RMS
spread L): relative displacements -> quadric (refuse oval / degenerate sets) -> both families of cubics
(synth.synthesis.cubic) -> a scan of GRID members per family, all factorized at once -> the 9 loops of every
member scored -> the best candidates built, mapped back to the world frame and self-checked.

Numbering (also in synth.synthesis.cubic): family 1 has the larger t3; a member is its lambda1 (C(0) = lambda1
D_1); pairs 1..9 in lexicographic order of the factorization orders (h, k).

Engineering score (higher is better), from penalties measured in decades:

    score = 10 ** -(3 P_cond + P_size + P_parallel + P_intersect)
    P_cond      = max(0, log10(0.05 / conditioning))
                  conditioning = min(root_imag, root_separation, t3_separation)
    P_size      = log10(extent)        extent = max distance of the 12 common-normal feet of consecutive
                                       axes (around h1 h2 h3 k3 k2 k1) from the pose centroid, / L
    P_parallel  = max(0, log10(sin 10deg / sin min_twist))   min_twist: smallest angle between
                                                             consecutive axes
    P_intersect = max(0, log10(0.05 / min_offset))           min_offset: smallest distance between
                                                             consecutive axes, / L

root_imag = min Im z / (1 + |z|^2) and root_separation = min |z - z'| / (1 + max(|z|,|z'|)^2) over the
roots z (Im z >= 0) of N(C) (MATH.md section 8: a nearly real root is a nearly real factor, a joint
whose angle jumps; nearly equal roots a nearly repeated norm factor); t3_separation = chordal distance
of t3 from inf, 0, 1 (two poses nearly on one ruling line). Conditioning is weighted 3x and saturates
at 0.05 (beyond it the self-check errors stay at ~1e-13): it decides first, and among well-conditioned
designs the compact one wins; a well-conditioned design without nearly parallel (< 10 deg) or nearly
intersecting (< 0.05 L) consecutive axes scores 1 / extent. Every candidate with a factor that is a
translation, a failed factorization or a multiply-back error > 1e-10 is dropped.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett import check_distinct
from synth.checks import self_check
from synth.synthesis.cubic import (PAIRS, PERMS, CubicFamily, MemberFactors, factor_members, families,
                    loop_geometry, multiply_back, norm_roots, parameter_separation, polish, quadric,
                    root_conditioning)
from synth.errors import InputError, SynthesisError
from synth.synthesis.conic import condition, relative_displacements, to_world

GRID = 24  # members per family in the scan
REFINE = 0  # scan candidates refined locally by default (library option; the CLI uses the plain scan)
KAPPA_GOOD = 0.05  # conditioning above this is not penalized
TWIST_GOOD = np.radians(10.0)  # consecutive axes at least this far from parallel are not penalized
OFFSET_GOOD = 0.05  # consecutive axes at least this far apart (x L) are not penalized
COND_WEIGHT = 3.0
RESIDUAL_TOL = 1e-10  # factorization multiply-back error above this: candidate dropped
CHECK_TOL = 1e-9  # relative self-check tolerance for accepting a linkage
MAX_ATTEMPTS = 8  # candidates built and checked before giving up

SCORE_RULE = (
    "score = 10**-(3*P_cond + P_size + P_parallel + P_intersect), higher is better; "
    "P_cond = max(0, log10(0.05/conditioning)), conditioning = min(root_imag, root_separation, t3_separation); "
    "P_size = log10(extent), extent = max distance of the common-normal feet of consecutive axes from the pose "
    "centroid / pose spread; P_parallel = max(0, log10(sin(10 deg)/sin(min_twist))), min_twist = smallest "
    "angle between consecutive axes; P_intersect = max(0, log10(0.05/min_offset)), min_offset = smallest "
    "distance between consecutive axes / pose spread")

PART_KEYS = ("conditioning", "root_imag", "root_separation", "t3_separation", "extent", "min_twist",
             "min_offset", "residual", "penalty_conditioning", "penalty_size", "penalty_parallel",
             "penalty_intersect")


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
    T = np.asarray(poses, float)
    if T.shape != (4, 4, 4):
        raise InputError(f"a 6R linkage needs exactly 4 poses (array of shape (4, 4, 4)), got {T.shape}")
    names = list(names) if names is not None else [f"p{i}" for i in range(4)]
    try:
        check_distinct(T, names)
    except SynthesisError as e:
        raise SynthesisError(str(e).replace("three distinct poses", "four distinct poses")) from None
    Tc, cond = condition(T)
    D = relative_displacements(Tc)
    q = quadric(D)
    fams, missing = families(q)
    if not fams:
        raise SynthesisError("both families of cubic motions through the poses are degenerate ("
                             + "; ".join(missing.values()) + "): no 6R linkage of this kind")
    return Problem(poses=T, names=names, Tc=Tc, cond=cond, D=D, quadric=q, families=fams, missing=missing)


# ============================================================================ evaluation of members
@dataclass
class MemberEval:
    """Scores of a batch of members (of one or both families) and their 9 loops."""

    fams: list[CubicFamily]  # family of each member
    phi: np.ndarray  # (G,)
    lam: np.ndarray  # (G, 3) lambda1..3
    factors: MemberFactors
    parts: dict[str, np.ndarray]  # each (G, 9)
    valid: np.ndarray  # (G, 9)
    score: np.ndarray  # (G, 9), 0 where invalid


def member_lambdas(fam: CubicFamily, C) -> np.ndarray:
    """(lambda1, lambda2, lambda3) of a monic member: C(t_i) = lambda_i D_i."""
    vals = _powers(fam.ts[1:]) @ np.asarray(C, float)[..., :4]  # primal parts of C(0), C(1), C(t3)
    return (vals * fam.D[1:, :4]).sum(-1)


def _powers(t):
    """(len(t), 4): 1, t, t^2, t^3."""
    return np.asarray(t, float)[:, None] ** np.arange(4)


def grid_angles(n: int = GRID) -> np.ndarray:
    """Pencil angles of the scan: n points uniform in [0, pi), none at 0."""
    return (np.arange(n) + 0.5) * np.pi / n


def grid_members(fams: list[CubicFamily], grid: int = GRID):
    """Members of the scan: (C (G, 4, 8), lambdas (G, 3), phi (G,), family of each member); all families
    at once, with the arithmetic of `CubicFamily.members` and `CubicFamily.lambdas`."""
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


def evaluate_members(C, lam, phi, fams, *, refine: bool = False) -> MemberEval:
    """Factor the monic members C (G, 4, 8) and score all their loops (vectorized over members)."""
    C = np.array(C, float)
    G = C.shape[0]
    with np.errstate(all="ignore"):
        finite = np.isfinite(C).all((-2, -1)) & (np.abs(C).max((-2, -1)) < 1e12)
        if not finite.all():
            C[~finite] = np.eye(8)[0]
        z = norm_roots(C, newton=2 if refine else 1)
        im, sep = root_conditioning(z)
        mf = factor_members(C, z, refine=refine, exact_residual=refine)
        geo = loop_geometry(mf)  # conditioned frame: origin at the pose centroid, unit = pose spread
        sep3 = {}
        for f in fams:
            if id(f) not in sep3:
                sep3[id(f)] = parameter_separation(f.t3)
        t3s = np.array([sep3[id(f)] for f in fams])
        zero = np.zeros((1, 9))

        def wide(x):
            return x[:, None] + zero  # (G,) -> (G, 9)

        kappa = np.minimum(np.minimum(im, sep), t3s)
        residual = np.maximum(mf.residual[:, PAIRS[:, 0]], mf.residual[:, PAIRS[:, 1]])
        parts = {
            "conditioning": wide(kappa),
            "root_imag": wide(im),
            "root_separation": wide(sep),
            "t3_separation": wide(t3s),
            "extent": geo["extent"],
            "min_twist": geo["min_twist"],
            "min_offset": geo["min_offset"],
            "residual": residual,
        }
        parts.update(penalties(parts))
        cost = (COND_WEIGHT * parts["penalty_conditioning"] + parts["penalty_size"] + parts["penalty_parallel"]
                + parts["penalty_intersect"])
        valid = (mf.ok[:, PAIRS[:, 0]] & mf.ok[:, PAIRS[:, 1]] & (residual <= RESIDUAL_TOL) & np.isfinite(cost)
                 & (finite & (kappa > 0))[:, None])
        score = np.where(valid, 10.0 ** -cost, 0.0)
    return MemberEval(fams=list(fams), phi=np.asarray(phi, float).reshape(G), lam=np.asarray(lam).reshape(G, 3),
                      factors=mf, parts=parts, valid=valid,
                      score=score if np.isfinite(score).all() else np.nan_to_num(score))


def evaluate_member(fam: CubicFamily, member: float) -> MemberEval:
    """The one member with label lambda1 = ``member`` (exact), its factorizations polished."""
    C = fam.member(member)
    lam = member_lambdas(fam, C)
    lam[0] = float(member)
    return evaluate_members(C[None], lam[None], [fam.phi_of_lambda1(member)], [fam], refine=True)


def penalties(parts) -> dict[str, np.ndarray]:
    """The four penalties (decades) of the engineering score from the measured parts."""
    with np.errstate(all="ignore"):
        return {
            "penalty_conditioning": np.maximum(0.0, np.log10(KAPPA_GOOD / parts["conditioning"])),
            "penalty_size": np.log10(parts["extent"]),
            "penalty_parallel": np.maximum(0.0, np.log10(np.sin(TWIST_GOOD) / np.sin(parts["min_twist"]))),
            "penalty_intersect": np.maximum(0.0, np.log10(OFFSET_GOOD / parts["min_offset"])),
        }


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
    parts = {key: float(ev.parts[key][g, k]) for key in PART_KEYS}
    # the two branches multiplied back (the scan only estimated it from the division remainders)
    parts["residual"] = float(np.max(multiply_back(ev.factors.C[g:g + 1], ev.factors.H[g:g + 1, [i, j]])))
    return Candidate(
        family=fam.index, member=float(ev.lam[g, 0]), pair=int(k + 1), score=float(ev.score[g, k]),
        parts=parts, t3=fam.t3, phi=float(ev.phi[g]),
        lambdas=tuple(float(x) for x in ev.lam[g]), H=ev.factors.H[g, i].copy(), K=ev.factors.H[g, j].copy(),
        C=ev.factors.C[g].copy(), orders=(tuple(int(x) for x in PERMS[i]), tuple(int(x) for x in PERMS[j])),
        roots=ev.factors.roots[g].copy())


def _local_maxima(score: np.ndarray, fams) -> np.ndarray:
    """Mask (G, 9) of grid members that are local maxima of their pair's score along their family's
    (circular) pencil: the scan reports distinct designs, not neighbouring grid points of one design.
    The rows are consecutive blocks of equal length, one per family (`grid_members`)."""
    nf = len({id(f) for f in fams})
    s = score.reshape(nf, -1, score.shape[-1])
    prev = np.concatenate([s[:, -1:], s[:, :-1]], 1)  # np.roll(s, 1, axis=1)
    nxt = np.concatenate([s[:, 1:], s[:, :1]], 1)  # np.roll(s, -1, axis=1)
    keep = (s > 0) & (s >= prev) & (s >= nxt)
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
                C, _ = fam.members(phi)
                Cs.append(C)
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
        evs = [evaluate_member(fam, float(member)) for fam in fams]
        ev = evs[0] if len(evs) == 1 else _concat(evs)
        keep = ev.valid.copy()
    else:
        ev = evaluate_members(*grid_members(fams, grid))
        keep = _local_maxima(ev.score, ev.fams)
    if pair is not None:
        keep[:, np.arange(9) != int(pair) - 1] = False
    ranking = Ranking(ev, keep)
    if member is None and refine:
        ranking.refine(refine, grid)
    return ranking


def _concat(evs: list[MemberEval]) -> MemberEval:
    f = evs[0].factors
    mf = MemberFactors(**{k: np.concatenate([getattr(e.factors, k) for e in evs])
                          for k in f.__dataclass_fields__})
    return MemberEval(fams=sum((e.fams for e in evs), []), phi=np.concatenate([e.phi for e in evs]),
                      lam=np.concatenate([e.lam for e in evs]), factors=mf,
                      parts={k: np.concatenate([e.parts[k] for e in evs]) for k in evs[0].parts},
                      valid=np.concatenate([e.valid for e in evs]), score=np.concatenate([e.score for e in evs]))


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
def build_linkage(problem: Problem, cand: Candidate, *, check_samples: int = 200, check: bool = True):
    """World-frame Linkage of a candidate (its factors polished first, `_polish`), with info and
    (unless ``check`` is false) self-checks."""
    linkage = _assemble(problem, _polish(cand))
    if check:
        linkage.checks = self_check(linkage, check_samples)
    return linkage


def _assemble(problem: Problem, cand: Candidate):
    """World-frame Linkage of a (polished) candidate with its info, without self-checks."""
    cond = problem.cond
    W = to_world(np.concatenate([cand.H, cand.K, cand.C]), cond)  # one call for all: (3 + 3 + 4, 8)
    H, K, C = W[:3], W[3:6], W[6:]
    ts = np.array([np.inf, 0.0, 1.0, cand.t3])
    info = {
        "family": cand.family, "member": cand.member, "pair": cand.pair, "t3": cand.t3,
        "lambdas": list(cand.lambdas), "score": cand.score, "score_parts": dict(cand.parts),
        "orders": {"h": list(cand.orders[0]), "k": list(cand.orders[1])},
        "norm_roots": [[float(z.real), float(z.imag)] for z in cand.roots],
        "factorization_residual": cand.parts["residual"],
        "gram_signature": list(problem.quadric.signature),
        "family_t3": {str(f.index): f.t3 for f in problem.families},
        "conditioning": {"centre": cond.centre.tolist(), "scale": float(cond.scale)},
    }
    linkage = two_branch_linkage("6r", H, K, C, problem.poses, problem.names, ts, info)
    linkage.info["dh"] = loop_dh(linkage, LOOP)
    linkage.info["warnings"] = _warnings(cand)
    return linkage


LOOP = ["h1", "h2", "h3", "k3", "k2", "k1"]


POLISH_TOL = 1e-13  # predicted relative pose error (residual / smallest weight) above this: polish


def _polish(cand: Candidate) -> Candidate:
    """The candidate with both branches polished by Newton's method on the product equations
    (`synth.synthesis.cubic.polish`) when it matters: the scan's factors multiply back to ~1e-15 relative (~1e-12
    for nearly real or equal norm roots), and the pose errors are about that divided by the smallest
    weight |lambda_i| of the poses (C(t_i) = lambda_i D_i)."""
    scale = max(1.0, float(np.max(np.abs(cand.C))))
    weight = min(1.0, min(abs(x) for x in cand.lambdas))
    if not cand.parts["residual"] * scale > POLISH_TOL * weight:
        return cand
    HK = polish(cand.C, np.stack([cand.H, cand.K]))
    res = multiply_back(cand.C[None], HK[None])[0]
    if not np.all(res <= cand.parts["residual"]):
        return cand
    return replace(cand, H=HK[0], K=HK[1], parts=dict(cand.parts, residual=float(np.max(res))))


def loop_dh(linkage, loop: list[str]) -> list[dict]:
    """Denavit-Hartenberg parameters around the closed loop at the reference configuration, with the
    definitions of `synth.synthesis.bennett.dh_table` (for joint i: ``a``/``alpha`` to the next joint, the twist
    signed about the common normal from i to i+1; ``d`` the offset along axis i between the incoming
    and outgoing common normals' feet; ``theta`` the angle between those normals about axis i).
    Plain floats, the operations of `synth.synthesis.cubic._pair_geometry` in the same order (bitwise the
    former vectorized figures; parallel consecutive axes: feet as there)."""
    J = {j.name: j for j in linkage.joints}
    lines = [(J[n].direction.tolist(), J[n].moment.tolist()) for n in loop]
    m = len(lines)
    feet, dist, normal, twist = [], [], [], []
    for i in range(m):
        (u, mo), (u2, m2) = lines[i], lines[(i + 1) % m]
        p1, p2, c = _xp(u, mo), _xp(u2, m2), _xp(u, u2)
        s2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
        d = (p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2])
        if s2 < 1e-24:  # parallel
            a1, a2 = 0.0, _dp((-d[0], -d[1], -d[2]), u2)
        else:
            a1, a2 = _dp(_xp(d, u2), c) / s2, _dp(_xp(d, u), c) / s2
        f1 = (p1[0] + a1 * u[0], p1[1] + a1 * u[1], p1[2] + a1 * u[2])
        f2 = (p2[0] + a2 * u2[0], p2[1] + a2 * u2[1], p2[2] + a2 * u2[2])
        e = (f2[0] - f1[0], f2[1] - f1[1], f2[2] - f1[2])
        r = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        cn = math.sqrt(s2)
        if r > 1e-12:
            n = (e[0] / r, e[1] / r, e[2] / r)
        elif cn > 1e-12:
            n = (c[0] / cn, c[1] / cn, c[2] / cn)
        else:
            n = (0.0, 0.0, 0.0)
        feet.append((f1, f2))
        dist.append(r)
        normal.append(n)
        twist.append(math.atan2(_dp(c, n), _dp(u, u2)))
    out = []
    for i in range(m):
        u = lines[i][0]
        f_out, f_in, n, n_in = feet[i][0], feet[i - 1][1], normal[i], normal[i - 1]
        d = _dp((f_out[0] - f_in[0], f_out[1] - f_in[1], f_out[2] - f_in[2]), u)
        theta = math.atan2(_dp(_xp(n_in, n), u), _dp(n_in, n))
        out.append({"joint": loop[i], "next": loop[(i + 1) % m], "a": dist[i], "alpha": twist[i], "d": d,
                    "theta": theta})
    return out


def _xp(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dp(a, b):
    """Dot product summed as numpy's reduction does (from +0.0: a sum of zeros is +0.0)."""
    return 0.0 + a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _warnings(cand: Candidate) -> list[str]:
    p = cand.parts
    out = []
    if p["conditioning"] < 1e-3:
        out.append(f"poorly conditioned member (conditioning {p['conditioning']:.2g}): the linkage is valid "
                   "but sensitive to small changes of the poses")
    if p["extent"] > 100:
        out.append(f"joint axes reach {p['extent']:.3g} pose spreads from the poses: valid but impractically large")
    return out


def checks_pass(linkage, scale: float, tol: float = CHECK_TOL) -> bool:
    """Self-check errors within ``tol`` relative: translations to the pose spread (closure: to the larger
    of the spread and the linkage's size) plus the rounding floor of coordinates far from the origin,
    rotations in radians."""
    from synth.synthesis.bennett import EPS, FLOOR_ULPS

    c = linkage.checks
    size = max(scale, c.get("length_scale", scale))
    # world coordinates far from the origin carry an absolute rounding floor (as in synth.synthesis.bennett._accept)
    floor = FLOOR_ULPS * EPS * max(abs(x) for p in linkage.poses for x in p.matrix[:3, 3].tolist())
    vals = [c["max_pose_translation_error"] / (scale + floor / tol), c["max_pose_rotation_error"],
            c["max_closure_translation_error"] / (size + floor / tol), c["max_closure_rotation_error"]]
    return all(np.isfinite(v) and v <= tol for v in vals)


ESTIMATE_TOL = 1e-10  # error_estimate at or below this: the self-check cannot fail (see `error_estimate`)


def error_estimate(problem: Problem, cand: Candidate) -> float:
    """A cheap, conservative bound on `checks_pass`'s relative self-check error for the built (polished)
    candidate, without forward kinematics (as `synth.synthesis.bennett.error_estimate` for Bennett linkages).

    First-order rounding analysis in the conditioned frame (pose spread 1), cmax = max(1, max |C|), over
    the norm roots z = x + iy (the joints' angle laws: a = x, b = y):
    - factorization: both branches multiply back to C within ``residual`` cmax per coefficient; the
      checks compare normalized motions, so that is amplified by (1 + |t|)^2 / |C(t)| with
      |C(t)| = prod |t - z_k|, over all real t at most kappa = min_k prod_{j != k} r_j / y_k where
      r = sup_t (1 + |t|) / |t - z| = |1 + |x| + iy| / y;
    - interpolation: C(t_i) = lambda_i D_i holds to the measured relative error of the pencil (its
      basis comes from a null space), which the pose checks see directly;
    - world coordinates: rounding of eps times the coordinates' size (centroid, spread, axis distance),
      relative to the spread plus `checks_pass`'s floor, amplified by 1 + max r as a perturbation of
      one factor (t - h_k) is relative to |t - h_k| >= y_k.
    The constants are calibrated on random sweeps (tests/test_sixbar_lazy.py): the self-check error
    stayed below 0.25 of this estimate, so an estimate <= ESTIMATE_TOL means a relative error of at most
    ~2.5e-11, 40x inside CHECK_TOL."""
    from synth.synthesis.bennett import EPS, FLOOR_ULPS

    r, y = [], []
    for w in cand.roots.tolist():
        if not w.imag > 0:
            return math.inf
        r.append(math.hypot(1.0 + abs(w.real), w.imag) / w.imag)
        y.append(w.imag)
    kappa = min(r[1] * r[2] / y[0], r[0] * r[2] / y[1], r[0] * r[1] / y[2])
    C = cand.C.tolist()
    cmax = max(1.0, max(abs(x) for row in C for x in row))
    interp = 0.0
    for t, lam, Di in zip((0.0, 1.0, cand.t3), cand.lambdas, problem.D[1:].tolist()):
        if not abs(lam) > 0:
            return math.inf
        for k in range(8):  # |C(t_i) - lambda_i D_i| / |lambda_i|, C(t) by Horner
            e = abs(((C[3][k] * t + C[2][k]) * t + C[1][k]) * t + C[0][k] - lam * Di[k]) / abs(lam)
            if not e <= interp:  # (NaN too)
                interp = e
    size2 = 0.0  # largest squared distance of an axis from the centroid (conditioned: the origin)
    for h in (*cand.H.tolist(), *cand.K.tolist()):
        vv = h[1] * h[1] + h[2] * h[2] + h[3] * h[3]
        if not vv > 0:
            return math.inf
        d2 = (h[5] * h[5] + h[6] * h[6] + h[7] * h[7]) / vv
        if not d2 <= size2:
            size2 = d2
    L = float(problem.cond.scale)
    cinf = max(abs(x) for x in problem.cond.centre.tolist())
    fact = (cand.parts["residual"] + EPS) * cmax * kappa
    world = (EPS * (cinf / L + SQRT3 + math.sqrt(size2)) / (1.0 + FLOOR_ULPS * EPS * cinf / (CHECK_TOL * L))
             * (1.0 + max(r)))
    est = 4.0 * fact + 16.0 * interp + 1000.0 * world
    return est if est == est else math.inf


SQRT3 = math.sqrt(3.0)


def sixbar_candidates(poses, names=None, *, family=None, member=None, pair=None, top=None,
                      grid: int = GRID, refine: int = REFINE, build: bool = False, check_samples: int = 200):
    """Ranked candidate designs (best first; at most ``top``). With ``build`` each is returned as a
    checked Linkage (candidates failing the self-check are skipped), else as `Candidate`. ``grid`` and
    ``refine``: see `scan`."""
    problem = prepare(poses, names)
    cands = scan(problem, family=family, member=member, pair=pair, grid=grid, refine=refine)
    if not len(cands):
        raise _explicit_failure(problem, family, member, pair)
    if not build:
        return cands[:top] if top else list(cands)
    out = []
    for cand in cands:  # lazily, until ``top`` pass
        linkage = build_linkage(problem, cand, check_samples=check_samples)
        if checks_pass(linkage, problem.cond.scale):
            out.append(linkage)
            if top and len(out) >= top:
                break
    if not out:
        raise SynthesisError("no candidate 6R linkage passed the self-check (poses, closure) at "
                             f"{CHECK_TOL:g} relative: the pose set is numerically degenerate")
    return out


def sixbar(poses, names=None, *, family=None, member=None, pair=None, grid: int = GRID, refine: int = REFINE,
           check_samples: int = 200):
    """Synthesize the best 6R linkage (by the engineering score) whose coupler visits the four poses
    (shape (4, 4, 4), metres). ``family`` (1|2), ``member`` (lambda1) and ``pair`` (1..9) restrict the
    choice; ``grid`` members per family are scanned and the best ``refine`` candidates refined locally
    (`scan`). The self-check (``linkage.checks``) runs on first access when `error_estimate` shows
    that it cannot fail, else at once, to decide. Raises SynthesisError (oval section, degenerate poses,
    no valid candidate) with a plain-language reason, InputError for bad arguments."""
    problem = prepare(poses, names)
    cands = scan(problem, family=family, member=member, pair=pair, grid=grid, refine=refine)
    if not len(cands):
        raise _explicit_failure(problem, family, member, pair)
    first = None
    for i in range(min(len(cands), MAX_ATTEMPTS)):  # candidates are made lazily, one at a time
        cand = _polish(cands[i])
        linkage = _assemble(problem, cand)
        if error_estimate(problem, cand) <= ESTIMATE_TOL:  # the self-check cannot fail: run it on access
            linkage.defer(checks=partial(_deferred_checks, check_samples))
            return linkage
        linkage.checks = self_check(linkage, check_samples)
        first = first or linkage
        if checks_pass(linkage, problem.cond.scale):
            return linkage
    c = first.checks
    explicit = family is not None or member is not None or pair is not None
    hint = ("the selected design is numerically ill-conditioned; choose another member or pair, or omit "
            "--member/--pair to scan" if explicit else
            "the pose set is numerically degenerate (nearly real or repeated norm roots in every member); "
            "perturb a pose")
    raise SynthesisError(
        f"the best 6R candidates do not pass the self-check (pose error {c['max_pose_error']:.2g}, closure "
        f"error {c['max_closure_error']:.2g}): {hint}")


def _deferred_checks(samples, linkage):
    return self_check(linkage, samples)


# ============================================================================ one member, all loops
@dataclass
class MemberLoops:
    """The 9 loops of one member (world frame, metres): factors by order, the loop pairs, scores.
    Each factor t - h is a revolute joint: line `lines(h)`, angle law theta(t) = 2 atan2(|vec p|, t - h0)."""

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
        from synth.synthesis.cubic import lines

        return lines(np.stack([self.H, self.K], axis=1))


def one_member_loops(poses, family: int, member: float, names=None, problem: Problem | None = None,
                     score: bool = True) -> MemberLoops:
    """All 6 factorizations and the 9 loop pairs of one member (family 1|2, label lambda1 with
    C(0) = lambda1 D_1), in the world frame; with ``score`` also the engineering score of each loop.
    ``problem`` (from `prepare`) skips the set-up for repeated calls on the same poses."""
    problem = problem or prepare(poses, names)
    fam = problem.family(int(family))
    fast = _member_loops_fast(fam, float(member), score)
    if fast is not None:
        C, F, ok, residual, valid, sc, parts = fast
    else:
        if score:
            ev = evaluate_member(fam, float(member))
            mf, valid, sc, parts = ev.factors, ev.valid[0], ev.score[0], {k: v[0] for k, v in ev.parts.items()}
        else:
            mf = factor_members(fam.member(float(member))[None], refine=True)
            valid = mf.ok[0, PAIRS[:, 0]] & mf.ok[0, PAIRS[:, 1]]
            sc = parts = None
        C, F, ok, residual = mf.C[0], mf.H[0], mf.ok[0], mf.residual[0]
    W = to_world(np.concatenate([F.reshape(18, 8), C]), problem.cond)  # one call for all
    F = W[:18].reshape(6, 3, 8)
    return MemberLoops(
        family=fam.index, member=float(member), t3=fam.t3, C=W[18:], factorizations=F,
        orders=PERMS.copy(), ok=ok, residual=residual, pairs=PAIRS.copy(),
        H=F[PAIRS[:, 0]], K=F[PAIRS[:, 1]], valid=valid, score=sc, parts=parts)


def _member_loops_fast(fam: CubicFamily, member: float, score: bool):
    """(C, factorizations, ok, residual, valid, score, parts) of one member in the conditioned frame by
    the plain-float path (`synth.synthesis.sixbar_member`), or None when the member is not clearly generic (the
    general path then decides)."""
    from synth.synthesis.sixbar_member import factor_member, score_loops

    C = fam.member(member)
    got = factor_member([tuple(r) for r in C.tolist()])
    if got is None:
        return None
    z, H, res = got
    if score:
        scored = score_loops(z, fam.t3, H, res)
        if scored is None:
            return None
        p, sc = scored
        parts = {k: np.array(p[k]) for k in PART_KEYS}
        sc = np.array(sc)
    else:
        parts = sc = None
    return C, np.array(H), np.ones(6, bool), np.array(res), np.ones(9, bool), sc, parts
