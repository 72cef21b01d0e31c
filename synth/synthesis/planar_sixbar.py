"""Planar and spherical six-bars through four poses: the cubic family (docs/planar.md).

For a planar or spherical set of four poses (`synth.synthesis.planar.zero_pitch`) every Lagrange cubic
``C`` with ``C(inf) = 1``, ``C(0) = lambda1 D_1``, ``C(1) = lambda2 D_2``, ``C(t3) = lambda3 D_3``
(`synth.synthesis.cubic.cubic_member`) is a motion through the poses: a four-parameter family, member
``(t3, lambda1, lambda2, lambda3)``. A single loop of two factorizations (the spatial 6R) would have three
degrees of freedom here (planar or spherical Grübler count 3 (6 - 1) - 2 * 6 = 3), so the linkage is the
**Watt six-bar** of three factorizations that share factors: for the order ``A = (i, j, k)`` (the
*chain*, 1..6 in the lexicographic order of `synth.synthesis.cubic.PERMS`) take ``B = (i, k, j)`` (same
leftmost factor) and ``G = (j, i, k)`` (same rightmost factor):

    C = (t - h1)(t - h2)(t - h3) = (t - h1)(t - k2)(t - k3) = (t - g1)(t - g2)(t - h3)

six links, seven joints, two anti-parallelogram loops (``h2 h3 k3 k2`` and ``h1 h2 g2 g1``), mobility
3 (6 - 1) - 2 * 7 = 1 (`synth.synthesis.assemble.watt_linkage`). All members x 6 orders are factored in
one batch (`synth.synthesis.sixbar_loops.factor_members`, the one batched Algorithm 1) and scored like
the 6R scan (docs/cubic.md, section 6) with the subgroup's penalty (`synth.synthesis.planar.axis_penalties`)
on every two joints of one link. Conditioned frame as in docs/conic.md; lengths in metres.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import islice

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.checks import DEFAULT_CHECK_SAMPLES, self_check
from synth.errors import InputError, SynthesisError
from synth.info import FamilyMember, LinkageInfo, Member, Orders
from synth.infoparts import ScoreParts
from synth.synthesis.assemble import watt_linkage
from synth.synthesis.conic import Conditioning, to_world
from synth.synthesis.cubic import PERMS, cubic_member, parameter_separation
from synth.synthesis.planar import ZeroPitch, axis_penalties, isogram_margin, isogram_penalty
from synth.synthesis.planar_bennett import COND_WEIGHT, KAPPA_GOOD, RESIDUAL_TOL, accepted_error, select_tracked
from synth.synthesis.sixbar_loops import edge_normals, factor_members, geometry_parts, root_pairs

T3_GRID = np.array([-3.0, -1.0, -1 / 3, 1 / 3, 2 / 3, 4 / 3, 2.0, 4.0])  # t3 of the default scan (all three arcs)
LAMBDA_GRID = np.array([-3.0, -1.0, -1 / 3, 1 / 3, 1.0, 3.0])  # lambda1..3 of the default scan
CHECK_TOL = 1e-9  # relative self-check error accepted (as the 6R, docs/cubic.md)
MAX_ATTEMPTS = 8
NAMES = ("h1", "h2", "h3", "k2", "k3", "g1", "g2")
MOTION = ("C(t) = t (t - 1)(t - t3) + lambda1 l1(t) D1 + lambda2 l2(t) D2 + lambda3 l3(t) D3 (Lagrange basis of the "
          "nodes 0, 1, t3; C(0) = lambda1 D1, C(1) = lambda2 D2, C(t3) = lambda3 D3)")


def _chains() -> np.ndarray:
    """(6, 7, 2): for chain p (order A = PERMS[p]), the (order, position) of h1 h2 h3 k2 k3 g1 g2."""
    index = {tuple(r): n for n, r in enumerate(PERMS.tolist())}
    out = []
    for i, j, k in PERMS.tolist():
        a, b, g = index[(i, j, k)], index[(i, k, j)], index[(j, i, k)]
        out.append([(a, 0), (a, 1), (a, 2), (b, 1), (b, 2), (g, 0), (g, 1)])
    return np.array(out)


CHAINS = _chains()
# joints carried by one link (link_h1: h1 h2 k2; link_h2: h2 h3 g2; base, coupler, link_k2, link_g1: two each)
EDGES = np.array([(0, 5), (0, 1), (0, 3), (1, 3), (1, 2), (1, 6), (2, 6), (2, 4), (3, 4), (5, 6)])
SIDES = np.array([[4, 7], [1, 5]])  # two adjacent sides (EDGES rows) of loop h2 h3 k3 k2 and of loop h1 h2 g2 g1


@dataclass
class Scan:
    members: np.ndarray  # (G, 4): t3, lambda1, lambda2, lambda3
    C: np.ndarray  # (G, 4, 8) conditioned frame
    F: np.ndarray  # (G, 6, 7, 8): h1 h2 h3 k2 k3 g1 g2 of each chain
    roots: np.ndarray  # (G, 3)
    parts: dict  # each (G, 6)
    valid: np.ndarray  # (G, 6)
    score: np.ndarray  # (G, 6)


def grid_members() -> np.ndarray:
    """The default scan's members (t3, lambda1, lambda2, lambda3), shape (G, 4)."""
    g = np.meshgrid(T3_GRID, LAMBDA_GRID, LAMBDA_GRID, LAMBDA_GRID, indexing="ij")
    return np.stack([x.ravel() for x in g], -1)


def scan(zp: ZeroPitch, members, *, polish: bool = False) -> Scan:
    """Factor and score the members (G, 4) of the cubic family of a four-pose set ``zp``, all 6 chains."""
    members = np.asarray(members, float).reshape(-1, 4)
    with np.errstate(all="ignore"):
        C = cubic_member(zp.D[None], members[:, 0], members[:, 1:])
        finite = np.isfinite(C).all((-2, -1))
        C[~finite] = cubic_member(zp.D, 2.0, [1.0, 1.0, 1.0])  # placeholder, scored invalid
        mf = factor_members(C, polish=polish)
        F = mf.H[:, CHAINS[..., 0], CHAINS[..., 1]]  # (G, 6, 7, 8)
        orders = CHAINS[:, [0, 3, 5], 0]  # (6, 3): the orders A, B, G of each chain
        ok = mf.ok[:, orders].all(-1)
        residual = mf.residual[:, orders].max(-1)
        im, sep = a1.root_conditioning(mf.roots)
        kappa = np.minimum(np.minimum(im, sep), parameter_separation(members[:, 0]))[:, None] + np.zeros((1, 6))
        normals = edge_normals(F, EDGES)  # (G, 6, E)
        dist, ang = normals.distance, normals.line_angle
        geo = geometry_parts(normals, np.arange(len(EDGES))[None])  # every edge: (G, 6, 1)
        extent, min_twist, min_offset = (geo[k][..., 0] for k in ("extent", "min_twist", "min_offset"))
        iso = isogram_margin(zp.kind, dist[..., SIDES], ang[..., SIDES]).min(-1)
        parts = {"isogram": iso, "penalty_isogram": isogram_penalty(iso), "conditioning": kappa, "extent": extent,
                 "min_twist": min_twist, "min_offset": min_offset,
                 "residual": residual, "penalty_conditioning": np.maximum(0.0, np.log10(KAPPA_GOOD / kappa)),
                 "penalty_size": np.log10(extent), **axis_penalties(zp, min_twist, min_offset)}
        cost = (COND_WEIGHT * parts["penalty_conditioning"] + parts["penalty_size"] + parts["penalty_parallel"]
                + parts["penalty_intersect"] + parts["penalty_isogram"])
        valid = (ok & (residual <= RESIDUAL_TOL) & np.isfinite(cost) & (kappa > 0) & finite[:, None]
                 & np.all(members[:, 1:] != 0, -1)[:, None] & (members[:, :1] != 0) & (members[:, :1] != 1))
        score = np.where(valid, 10.0 ** -cost, 0.0)
    return Scan(members=members, C=C, F=F, roots=mf.roots, parts=parts, valid=valid,
                score=np.where(np.isfinite(score), score, 0.0))


def ranked(zp: ZeroPitch, member=None, chain=None) -> list[tuple[np.ndarray, int, float]]:
    """(member, chain index 0..5, score) best first: the given ``member`` (t3, lambda1, lambda2, lambda3)
    or the default grid (each member's best chain, or the given ``chain`` 1..6)."""
    if chain is not None and not 1 <= int(chain) <= 6:
        raise InputError(f"--pair (the chain of a planar or spherical six-bar) must be between 1 and 6, got {chain}")
    if member is not None:
        member = np.asarray(member, float).reshape(1, 4)
        t3 = member[0, 0]
        if not np.all(np.isfinite(member)) or t3 in (0.0, 1.0) or np.any(member[0, 1:] == 0):
            raise InputError("--member T3,L1,L2,L3: finite numbers, t3 not 0 or 1, lambdas nonzero; got "
                             f"{member[0].tolist()}")
    sc = scan(zp, grid_members() if member is None else member)
    score = sc.score.copy()
    if chain is not None:
        score[:, np.arange(6) != int(chain) - 1] = 0.0
    best = np.argmax(score, axis=1)
    s = score[np.arange(len(best)), best]
    rows = np.flatnonzero(s > 0)
    rows = rows[np.argsort(-s[rows], kind="stable")]
    return [(sc.members[g], int(best[g]), float(s[g])) for g in rows.tolist()]


def build(zp: ZeroPitch, member, chain: int, *, check_samples: int = DEFAULT_CHECK_SAMPLES, choice: str = ""):
    """The world-frame Watt six-bar of one member and chain (0..5), its factors polished, with info and
    checks."""
    sc = scan(zp, member, polish=True)
    W = to_world(np.concatenate([sc.F[0, chain], sc.C[0]]), zp.cond)
    t3, l1, l2, l3 = (float(x) for x in sc.members[0])
    A, B, G = (PERMS[CHAINS[chain, n, 0]].tolist() for n in (0, 3, 5))
    parts = ScoreParts.of({k: v[0, chain] for k, v in sc.parts.items()})
    record = FamilyMember(
        family=zp.describe(4, ("t3", "lambda1", "lambda2", "lambda3"), MOTION),
        member=Member(t3=t3, lambda1=l1, lambda2=l2, lambda3=l3), member_choice=choice or "given (--member)",
        chain=chain + 1, orders=Orders(h=tuple(A), k=tuple(B), g=tuple(G)), t3=t3, score=float(sc.score[0, chain]),
        score_parts=parts, norm_roots=root_pairs(sc.roots[0]), factorization_residual=float(sc.parts["residual"][0, chain]),
        mobility="Watt six-bar: 6 links, 7 revolute joints, 2 loops; mobility 3 (6 - 1) - 2 * 7 = 1",
        conditioning=Conditioning(zp.cond.centre, float(zp.cond.scale)))
    linkage = watt_linkage(f"{zp.kind}_sixbar", W[:7], W[7:], zp.poses, zp.names, (np.inf, 0.0, 1.0, t3),
                           LinkageInfo(synthesis=record))
    linkage.checks = self_check(linkage, check_samples)
    c = parts.conditioning
    linkage.info = linkage.info.replace(
        relative_error=accepted_error(linkage, zp.poses, zp.cond),
        warnings=(f"poorly conditioned member (conditioning {c:.2g}): valid but sensitive to small changes of the "
                  "poses",) if c < 1e-3 else ())
    return linkage


def candidates(zp: ZeroPitch, member=None, chain=None, *, top: int = 1,
               check_samples: int = DEFAULT_CHECK_SAMPLES) -> list:
    """Up to ``top`` self-checked six-bars (distinct members, best score first). Raises SynthesisError when
    none passes."""
    choice = "" if member is not None else (
        f"the best-scored of {len(grid_members())} members x 6 chains (t3 in {T3_GRID.round(3).tolist()}, "
        f"lambdas in {LAMBDA_GRID.round(3).tolist()}); score as the 6R scan")
    built = (build(zp, mem, c, check_samples=check_samples, choice=choice)
             for mem, c, _ in islice(ranked(zp, member, chain), MAX_ATTEMPTS + top))
    out = select_tracked(built, member is not None, top, CHECK_TOL)
    if not out:
        what = "this member" if member is not None else "no member of the scan"
        raise SynthesisError(f"{what} of the {zp.kind} family of cubic motions through the poses gives an accurate "
                             "six-bar (real or repeated norm roots, or an inaccurate factorization); "
                             + ("choose another member or omit --member" if member is not None else "perturb a pose"))
    return out
