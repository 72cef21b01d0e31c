"""The one 6R member/loop builder: every factorization of a batch of monic cubics, the 9 loops of each
member, their geometry and engineering score (docs/cubic.md).

All functions work on a batch of G members: C (G, 4, 8) monic cubics (conditioned frame: origin at the
pose centroid, unit = pose spread). The default scan is a batch of 2 x GRID members, a single member
(``--member``, `synth.synthesis.sixbar_member.one_member_loops`) a batch of one; both go through
`evaluate_members`, which calls the one batched Algorithm 1 (`synth.algebra.algorithm1`) once for all
members x 6 orders.

Conventions (see `synth.synthesis.cubic`): the norm quadratics of a member are sorted by the real part
of their root; a factorization is named by its order (PERMS row, quadratic of h1, h2, h3); the 9 loop
pairs (PAIRS rows, numbered 1..9) join two orders with different leftmost and different rightmost
quadratics, branch h = order PAIRS[K, 0], branch k = order PAIRS[K, 1]. A loop is the ring of joints
h1 h2 h3 k3 k2 k1.

Engineering score (higher is better), from penalties measured in decades:

    score = 10 ** -(3 P_cond + P_size + P_parallel + P_intersect)
    P_cond      = max(0, log10(0.05 / conditioning))
                  conditioning = min(root_imag, root_separation, t3_separation)
    P_size      = log10(extent)        extent = max distance of the 12 common-normal feet of consecutive
                                       axes from the pose centroid, / L (pose spread)
    P_parallel  = max(0, log10(sin 10deg / sin min_twist))   min_twist: smallest angle between
                                                             consecutive axes
    P_intersect = max(0, log10(0.05 / min_offset))           min_offset: smallest distance between
                                                             consecutive axes, / L

root_imag and root_separation are `synth.algebra.algorithm1.root_conditioning` of the norm roots (a
nearly real root is a nearly real factor, a joint whose angle jumps; nearly equal roots a nearly
repeated norm factor); t3_separation is `synth.synthesis.cubic.parameter_separation`. A loop with a
failed factorization, a translation factor or a multiply-back (or Study condition) error above
RESIDUAL_TOL is invalid (score 0).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.algebra import algorithm1 as a1
from synth.algebra.dq import dot, factor_lines
from synth.algebra.geometry import CommonNormals, common_normal
from synth.algebra.polynomial import norm_poly
from synth.synthesis.cubic import PAIRS, PERMS, CubicFamily, parameter_separation

KAPPA_GOOD = 0.05  # conditioning above this is not penalized
TWIST_GOOD = np.radians(10.0)  # consecutive axes at least this far from parallel are not penalized
OFFSET_GOOD = 0.05  # consecutive axes at least this far apart (x L) are not penalized
COND_WEIGHT = 3.0
RESIDUAL_TOL = 1e-10  # factorization multiply-back error above this: the loop is invalid

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


# ============================================================================ factorizations
@dataclass
class MemberFactors:
    """All 6 factorizations of a batch of monic cubics, by order (PERMS)."""

    C: np.ndarray  # (G, 4, 8)
    roots: np.ndarray  # (G, 3) norm roots, Im >= 0, sorted by real part (quadratic k has root roots[:, k])
    H: np.ndarray  # (G, 6, 3, 8) factors h1, h2, h3 of each order (NaN where Algorithm 1 failed)
    ok: np.ndarray  # (G, 6) Algorithm 1 succeeded and no factor is a translation
    residual: np.ndarray  # (G, 6) max(multiply-back error, Study violation), relative; inf where failed
    translation: np.ndarray  # (G, 6) some factor is a translation (then not ok)


def factor_members(C, *, polish: bool = False) -> MemberFactors:
    """All 6 factorizations of every monic cubic in C (G, 4, 8): one call of the batched Algorithm 1
    over G x 6 (member, order). With ``polish`` the norm roots get two Newton steps (else one) and the
    successful factorizations Newton's method on the product equations (`synth.algebra.algorithm1.polish`),
    which brings the residual to rounding level even for nearly real or nearly equal norm roots; the
    scan runs without it. ``residual``: the multiply-back error (from the division remainders,
    `synth.algebra.algorithm1.remainder_error`, or from the polish) and the Study violation."""
    C = np.asarray(C, float)
    with np.errstate(all="ignore"):
        z = a1.norm_roots(norm_poly(C), newton=2 if polish else 1)
        H, ok, R = a1.algorithm1(C[:, None], a1.quadratics(z)[:, PERMS], remainders=True)
        res = a1.remainder_error(C[:, None], H, R)
        if polish and ok.any():
            g, p = np.nonzero(ok)
            H[g, p], rm = a1.polish(C[g], H[g, p])
            res[g, p] = rm / np.maximum(1.0, np.abs(C[g]).max((-2, -1)))
        res = np.maximum(res, a1.study_violation(H))
        trans = a1.is_translation(H).any(-1) & ok
    res = np.where(ok & np.isfinite(res), res, np.inf)
    H = np.where(ok[..., None, None], H, np.nan)
    return MemberFactors(C=C, roots=z, H=H, ok=ok & ~trans, residual=res, translation=trans)


# ============================================================================ loop geometry
def _edge_tables():
    """Distinct joints and consecutive-joint edges of the 9 loops of a member.

    A member has 12 distinct joints: the 3 leftmost factors (one per quadratic), the 3 rightmost ones
    and the 6 middle factors (one per order). JOINTS (12, 2) = (order, position) picks each from
    MemberFactors.H; EDGES (18, 2) are the joint pairs that are consecutive in some loop; LOOP_EDGES
    (9, 6) lists, per pair, its edges around h1 h2 h3 k3 k2 k1."""
    left = {int(PERMS[p, 0]): p for p in range(6)}
    right = {int(PERMS[p, 2]): p for p in range(6)}
    joints = [(left[i], 0) for i in range(3)] + [(right[k], 2) for k in range(3)] + [(p, 1) for p in range(6)]
    jid = {("l", i): i for i in range(3)} | {("r", k): 3 + k for k in range(3)} | {("m", p): 6 + p for p in range(6)}
    edges: list[tuple[int, int]] = []

    def edge(a, b):
        key = (min(a, b), max(a, b))
        if key not in edges:
            edges.append(key)
        return edges.index(key)

    loops = []
    for ph, pk in PAIRS:
        sh, sk = PERMS[ph], PERMS[pk]
        ring = [jid["l", int(sh[0])], jid["m", int(ph)], jid["r", int(sh[2])],
                jid["r", int(sk[2])], jid["m", int(pk)], jid["l", int(sk[0])]]
        loops.append([edge(ring[i], ring[(i + 1) % 6]) for i in range(6)])
    return np.array(joints), np.array(edges), np.array(loops)


JOINTS, EDGES, LOOP_EDGES = _edge_tables()


def edge_normals(F, edges) -> CommonNormals:
    """Common normals (`synth.algebra.geometry.common_normal`) of the joint pairs ``edges`` (E, 2) (indices
    into the joints) of the revolute factors F (..., J, 8): arrays (..., E)."""
    L = factor_lines(F)[0]  # (..., J, 2, 3)
    A, B = L.take(edges[:, 0], axis=-3), L.take(edges[:, 1], axis=-3)
    return common_normal(A[..., 0, :], A[..., 1, :], B[..., 0, :], B[..., 1, :])


def geometry_parts(normals: CommonNormals, loop_edges) -> dict[str, np.ndarray]:
    """The geometric parts of the engineering score of loops made of edges (`edge_normals`, (..., E)), the
    rows of ``loop_edges`` (P, K): ``min_offset`` (smallest distance of consecutive axes), ``min_twist``
    (smallest angle between consecutive axes, in [0, pi/2]) and ``extent`` (largest distance of a
    common-normal foot of consecutive axes from the origin), each (..., P); lengths in the factors' units."""
    foot = dot(normals.feet, normals.feet).max(axis=-1)  # (..., E)
    return {"min_offset": normals.distance[..., loop_edges].min(-1),
            "min_twist": normals.line_angle[..., loop_edges].min(-1),
            "extent": np.sqrt(foot[..., loop_edges].max(-1))}


def member_geometry(mf: MemberFactors) -> dict[str, np.ndarray]:
    """`geometry_parts` of the 9 loops of every member, computed once per distinct edge (18 per member):
    each (G, 9)."""
    return geometry_parts(edge_normals(mf.H[:, JOINTS[:, 0], JOINTS[:, 1]], EDGES), LOOP_EDGES)


# ============================================================================ scores
@dataclass
class MemberEval:
    """Scores of a batch of members (of one or both families) and their 9 loops."""

    fams: list[CubicFamily]  # family of each member
    phi: np.ndarray  # (G,) pencil angle
    lam: np.ndarray  # (G, 3) lambda1..3
    factors: MemberFactors
    parts: dict[str, np.ndarray]  # PART_KEYS, each (G, 9)
    valid: np.ndarray  # (G, 9)
    score: np.ndarray  # (G, 9), 0 where invalid


def penalties(parts) -> dict[str, np.ndarray]:
    """The four penalties (decades) of the engineering score from the measured parts."""
    with np.errstate(all="ignore"):
        return {
            "penalty_conditioning": np.maximum(0.0, np.log10(KAPPA_GOOD / parts["conditioning"])),
            "penalty_size": np.log10(parts["extent"]),
            "penalty_parallel": np.maximum(0.0, np.log10(np.sin(TWIST_GOOD) / np.sin(parts["min_twist"]))),
            "penalty_intersect": np.maximum(0.0, np.log10(OFFSET_GOOD / parts["min_offset"])),
        }


def score_loops(im, sep, separation: tuple, geo: dict, residual, ok, finite, pairs):
    """THE engineering score of loops (SCORE_RULE) over a batch of G motions: ``im``, ``sep`` (G,) norm-root
    conditioning (`root_conditioning`), ``separation`` = (name, (G,) values) of the task parameters' own
    separation, ``geo`` the loop geometry (extent, min_twist, min_offset; (G, P)), ``residual`` and ``ok``
    (G, orders) per factorization order, ``finite`` (G,) usable motions, ``pairs`` (P, 2) the orders each
    loop joins. Returns (parts dict of (G, P) arrays, valid (G, P), score (G, P): 10^-cost, 0 when invalid)."""
    name, values = separation
    kappa = np.minimum(np.minimum(im, sep), values)
    residual = np.maximum(residual[:, pairs[:, 0]], residual[:, pairs[:, 1]])
    wide = np.zeros(residual.shape)
    parts = {"conditioning": kappa[:, None] + wide, "root_imag": im[:, None] + wide,
             "root_separation": sep[:, None] + wide, name: values[:, None] + wide,
             "extent": geo["extent"], "min_twist": geo["min_twist"], "min_offset": geo["min_offset"],
             "residual": residual}
    parts.update(penalties(parts))
    cost = (COND_WEIGHT * parts["penalty_conditioning"] + parts["penalty_size"] + parts["penalty_parallel"]
            + parts["penalty_intersect"])
    valid = (ok[:, pairs[:, 0]] & ok[:, pairs[:, 1]] & (residual <= RESIDUAL_TOL) & np.isfinite(cost)
             & (finite & (kappa > 0))[:, None])
    score = 10.0 ** -cost
    return parts, valid, np.where(valid & np.isfinite(score), score, 0.0)


def evaluate_members(C, lam, phi, fams, *, polish: bool = False) -> MemberEval:
    """Factor the monic members C (G, 4, 8) (`factor_members`) and score all their loops. ``lam``
    (G, 3), ``phi`` (G,) and ``fams`` (G CubicFamily) label the members."""
    C = np.array(C, float)
    G = C.shape[0]
    with np.errstate(all="ignore"):
        finite = np.isfinite(C).all((-2, -1)) & (np.abs(C).max((-2, -1)) < 1e12)
        C[~finite] = np.eye(8)[0]  # placeholder for members at infinity (scored invalid)
        mf = factor_members(C, polish=polish)
        im, sep = a1.root_conditioning(mf.roots)
        geo = member_geometry(mf)
        sep3: dict[int, float] = {}
        for f in fams:
            if id(f) not in sep3:
                sep3[id(f)] = parameter_separation(f.t3)
        t3s = np.array([sep3[id(f)] for f in fams], float).reshape(G)
        parts, valid, score = score_loops(im, sep, ("t3_separation", t3s), geo, mf.residual, mf.ok, finite, PAIRS)
    return MemberEval(fams=list(fams), phi=np.asarray(phi, float).reshape(G), lam=np.asarray(lam, float).reshape(G, 3),
                      factors=mf, parts=parts, valid=valid, score=score)


def score_warnings(parts: dict, what: str = "member", task: str = "poses") -> tuple[str, ...]:
    """Plain-language warnings from a candidate's score parts (conditioning, extent in task spreads);
    ``what`` names the candidate (member, motion), ``task`` the input (poses, points)."""
    out = []
    if parts["conditioning"] < 1e-3:
        out.append(f"poorly conditioned {what} (conditioning {parts['conditioning']:.2g}): the linkage is valid "
                   f"but sensitive to small changes of the {task}")
    if parts["extent"] > 100:
        spread = "pose" if task == "poses" else "point"
        out.append(f"joint axes reach {parts['extent']:.3g} {spread} spreads from the {task}: valid but "
                   "impractically large")
    return tuple(out)


def root_pairs(roots) -> tuple[tuple[float, float], ...]:
    """Complex norm roots as (re, im) pairs (the info's ``norm_roots``)."""
    return tuple((float(z.real), float(z.imag)) for z in roots)
