"""Theorem 2 of the survey: a real co-factor R with C R = (t - h_1)...(t - h_m) for a bounded monic
motion polynomial C whose primal part has a real factor (docs/exceptional.md).

Pipeline (``factorize_with_cofactor``):

1. g = mrpf(P) (``realfactor``); deg g = 0: Algorithm 1, R = 1; a real zero of g: unbounded, refused.
   A real factor of C itself (M | P and M | Q) is split off first: it does not change the motion and
   is written back as a coaxial pair (t - ~x)(t - x).
2. Template split (linear): P0 = P / g = (t - p_1)...(t - p_d) over H (Algorithm 1); g = prod B_i,
   B_i = M_i^k_i. Items: the rotations t - p_j - eps d_j (d_j ⊥ vec p_j, 2 unknowns) and the primary
   translations B_i + eps E_i (E_i vectorial, deg E_i < 2 k_i) inserted between them. The dual part of
   the product is linear in (E_i, d_j); least squares against Q, accepted below 1e-8. "All
   translations first" is tried first; other orders/positions when a rotation shares its norm with g.
3. Kernel search: in the affine solution family, Levenberg-Marquardt on the circularity equations
   (|F_i|^2 mod M_i = 0, two real quadratics per k = 1 block) saves a factor M_i of R each (E4).
4. Each primary translation T_i = B_i + eps E_i is factored after multiplying by R_i:
   k = 1 circular -> 2 rotations (R_i = 1, the min-norm member of the family of eq. (5));
   k = 1 otherwise -> T_i M_i = (M_i + eps F1)(M_i + eps F2) with circular F1 + F2 = F (R_i = M_i);
   k >= 2 planar -> patterns x+^k x-^k, x-^k x+^k (R_i = 1) or x+^k x-^2k x+^k (R_i = M_i^k);
   k >= 2 non-planar -> the nested chain [a.., ~a.., b.., ~b..] by LM over the directions (R_i = M_i^k),
   last resort two planar halves (deg R > deg g, ``bound_met = False``).
5. Assemble, denormalize, multiply back: ``residual`` = |prod(t - h) - C R| / max(1, |C R|).

Everything runs in floating point after an affine normalization of t and a scaling of lengths;
rational answers are certified by ``exact_check`` on rationalized factors (`synth.algebra.certify`).
The modules: `synth.algebra.realfactor` (step 1), `synth.algebra.dualsystem` (the linear system of
step 2), `synth.algebra.translation` (steps 3-4), this module (the pipeline, normalization, step 5).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from synth.algebra.certify import exact_check, exact_product, exact_result, rationalize, rationalize_factors
from synth.algebra.dualsystem import qp_mul, rot_item, rotation_from, solve_items, split_unknowns, trans_item
from synth.algebra.factorize import check_motion_polynomial, factorize, norm_quadratics
from synth.algebra.polynomial import norm_poly, product_of_linear, relative_error
from synth.algebra.realfactor import RealFactor, mrpf, require_bounded
from synth.algebra.realpoly import compose_affine, divide_real, mod_real, quad, quadratic_roots, real_mul, real_pow
from synth.algebra.text import poly_text
from synth.algebra.translation import (CIRCULAR_TOL, TEMPLATE_TOL, FactorizationError, circular_kernel_search,
                                       circular_residual, factor_block, factor_circular, factor_real)

FINAL_TOL = 1e-8  # relative multiply-back residual accepted
MAX_TEMPLATES = 200

__all__ = ["CofactorResult", "FactorizationError", "factorize_with_cofactor", "circular_residual",
           "factor_circular", "exact_check", "exact_product", "exact_result", "rationalize",
           "rationalize_factors", "qp_mul", "FINAL_TOL", "MAX_TEMPLATES", "TEMPLATE_TOL", "CIRCULAR_TOL"]


@dataclass
class CofactorResult:
    """C R = (t - factors[0]) ... (t - factors[m-1]), R real monic (ascending coefficients)."""

    C: np.ndarray  # (n+1, 8) input (float)
    R: np.ndarray  # ascending real coefficients, monic
    factors: np.ndarray  # (m, 8)
    residual: float
    g: np.ndarray  # mrpf(P), ascending monic
    bound_met: bool  # deg R <= deg g
    generic: bool
    report: list = field(default_factory=list)  # one dict per component
    template: list = field(default_factory=list)  # item labels, left to right
    real_content: list = field(default_factory=list)  # real quadratics [c0, c1] split off C
    family: dict | None = None  # the circular-translation family when C is one

    @property
    def deg_R(self) -> int:
        return len(self.R) - 1

    def product(self) -> np.ndarray:

        return product_of_linear(self.factors)

    def as_dict(self) -> dict:
        return {
            "cofactor": [float(x) for x in self.R],
            "cofactor_text": poly_text(self.R),
            "deg_R": self.deg_R,
            "mrpf": [float(x) for x in self.g],
            "mrpf_text": poly_text(self.g),
            "bound_met": self.bound_met,
            "generic": self.generic,
            "residual": self.residual,
            "factors": [[float(x) for x in h] for h in self.factors],
            "template": list(self.template),
            "report": self.report,
            "real_content": [[float(x) for x in q] for q in self.real_content],
            "family": self.family,
        }


# ====================================================================== normalization
def _normalization(C):
    """(tau, sigma, lam): t = sigma s + tau, dual parts divided by lam."""

    N = norm_poly(C)
    z = np.roots(N[::-1])
    tau = float(np.mean(z.real)) if len(z) else 0.0
    sigma = float(np.sqrt(np.mean(np.abs(z - tau) ** 2))) if len(z) else 1.0
    if not np.isfinite(sigma) or sigma <= 0:
        sigma = 1.0
    Cs = compose_affine(C, sigma, tau)
    lam = float(np.max(np.abs(Cs[:, 4:])))
    if lam <= 0 or not np.isfinite(lam):
        lam = 1.0
    return tau, sigma, lam


def _denormalize_factor(h, tau, sigma, lam):
    h = np.array(h, float)
    h[4:] *= lam
    h = h * sigma
    h[0] += tau
    return h


def _denormalize_real(R, tau, sigma):
    """R(s) -> sigma^deg R((t - tau)/sigma) (monic in t)."""
    R = np.asarray(R, float)
    d = len(R) - 1
    if d == 0:
        return np.ones(1)
    out = compose_affine(R[:, None], 1 / sigma, -tau / sigma)[:, 0]
    return out / out[-1]


# ====================================================================== main
def _templates(n_rot, n_blocks, orders, limit=MAX_TEMPLATES):
    """Yield (order index, positions tuple): translations first, then last, then the rest."""
    seen = set()
    firsts = [(0, (0,) * n_blocks), (0, (n_rot,) * n_blocks)]
    count = 0
    for oi in range(len(orders)):
        for pos in itertools.chain(firsts if oi == 0 else [], itertools.product(range(n_rot + 1), repeat=n_blocks)):
            key = (oi, tuple(pos))
            if key in seen:
                continue
            seen.add(key)
            yield key
            count += 1
            if count >= limit:
                return


def build_items(rot_primals, blocks, positions):
    items = []
    d = len(rot_primals)
    for p in range(d + 1):
        for b, pos in enumerate(positions):
            if pos == p:
                M, k = blocks[b]
                items.append(trans_item(real_pow(quad(M), k), b, label=f"T{b + 1}"))
        if p < d:
            items.append(rot_item(rot_primals[p], label=f"r{p + 1}"))
    return items


def _real_content(C, rf):
    """Split real quadratic factors of C itself (M | P and M | Q). Returns (C', list of quadratics)."""
    Cw = np.array(C, float)
    out = []
    for M, k in zip(rf.quadratics, rf.multiplicity):
        Mq = quad(M)
        for _ in range(k):
            Q = Cw[:, 4:]
            qs = max(float(np.max(np.abs(Q))), 1e-300)
            if np.max(np.abs(Q)) == 0 or np.max(np.abs(mod_real(Q, Mq))) <= 1e-10 * qs:
                Cw = divide_real(Cw, Mq)
                Cw[-1] = np.eye(8)[0]
                out.append(np.asarray(M, float))
            else:
                break
    return Cw, out


def _generic(C):

    res = factorize(C, validate=False)
    f = min(res.factorizations, key=lambda f: f.residual)
    return f.factors


def factorize_with_cofactor(C, *, seed: int = 0, max_templates: int = MAX_TEMPLATES) -> CofactorResult:
    """C R = (t - h_1)...(t - h_m) for a bounded monic motion polynomial C (rows of 8 floats, or of
    ints/Fractions for exact mrpf detection). Raises UnboundedMotionError (a real zero of mrpf(P)),
    InputError (not a monic motion polynomial) or FactorizationError."""
    rows = C
    Cf = np.array([[float(x) for x in r] for r in np.asarray(C, dtype=object)], float) \
        if not isinstance(C, np.ndarray) else np.asarray(C, float)
    check_motion_polynomial(Cf)
    rf = mrpf(rows)
    require_bounded(rf)
    rng = np.random.default_rng(seed)
    n = Cf.shape[0] - 1

    if rf.generic:
        hs = _generic(Cf)
        res = float(relative_error(product_of_linear(hs), Cf))
        return CofactorResult(C=Cf, R=np.ones(1), factors=np.asarray(hs), residual=res, g=np.ones(1),
                              bound_met=True, generic=True, template=[f"r{i + 1}" for i in range(n)],
                              report=[])
    nc = _normalized(Cf, rf)
    n2 = nc.Cs2.shape[0] - 1
    if not nc.blocks:  # only real content: C' is generic
        hs = list(_generic(nc.Cs2)) if n2 > 0 else []
        return _finish(Cf, rf, nc, hs, np.ones(1), [f"r{i + 1}" for i in range(n2)],
                       [{"kind": "real", "quadratic": q.tolist(), "deg_R": 0} for q in nc.real_quads])
    best = _best_template(Cf, rf, nc, rng, max_templates)
    if best is None:
        raise FactorizationError(
            "no factorization of C R was found (no template of the co-factor algorithm solved; "
            f"mrpf = {rf.text()})")
    return best


@dataclass
class _Normalized:
    """C in the normalized parameter s (t = sigma s + tau, dual part / lam) without its real content: Cs2,
    the real quadratics and their factors, the blocks (quadratic, multiplicity) left for the co-factor and
    g_s, their product."""

    tau: float
    sigma: float
    lam: float
    Cs2: np.ndarray
    real_quads: list
    real_hs: list
    blocks: list
    g_s: np.ndarray


def _normalized(Cf, rf) -> _Normalized:
    tau, sigma, lam = _normalization(Cf)
    Cs = compose_affine(Cf, sigma, tau)
    Cs[:, 4:] /= lam
    Cs[-1] = np.eye(8)[0]
    rfs = mrpf(Cs, exact=False) if rf.exact is None else None
    if rfs is None:  # transport the exact g to s
        g_s = compose_affine(rf.g[:, None], sigma, tau)[:, 0]

        quads, mult, _ = norm_quadratics(g_s)
        rfs = RealFactor(g=g_s, exact=None, bounded=True, quadratics=quads, multiplicity=list(mult))
    Cs2, real_quads = _real_content(Cs, rfs)
    real_hs = []
    for M in real_quads:
        real_hs += factor_real(M)
    g_s = np.ones(1)
    blocks_q, blocks_k = [], []
    rq = [tuple(np.round(np.asarray(q) / 1e-9)) for q in real_quads]
    for M, k in zip(rfs.quadratics, rfs.multiplicity):
        k_left = k - sum(1 for q in rq if q == tuple(np.round(np.asarray(M) / 1e-9)))
        if k_left > 0:
            blocks_q.append(np.asarray(M, float))
            blocks_k.append(k_left)
            g_s = real_mul(g_s, real_pow(quad(M), k_left))
    return _Normalized(tau=tau, sigma=sigma, lam=lam, Cs2=Cs2, real_quads=real_quads, real_hs=real_hs,
                       blocks=list(zip(blocks_q, blocks_k)), g_s=g_s)


def _finish(Cf, rf, nc: _Normalized, hs_s, R_s, template, report, family=None) -> CofactorResult:
    """The result in the original parameter t from factors ``hs_s`` and co-factor ``R_s`` in s."""
    n = Cf.shape[0] - 1
    hs_s = list(hs_s) + nc.real_hs
    R_t = _denormalize_real(R_s, nc.tau, nc.sigma)
    hs = np.array([_denormalize_factor(h, nc.tau, nc.sigma, nc.lam) for h in hs_s])
    CR = np.zeros((n + len(R_t), 8))
    for k, r in enumerate(R_t):
        CR[k:k + n + 1] += r * Cf
    res = float(relative_error(product_of_linear(hs), CR))
    return CofactorResult(C=Cf, R=R_t, factors=hs, residual=res, g=rf.g.copy(),
                          bound_met=len(R_t) - 1 <= len(rf.g) - 1, generic=False, template=template,
                          report=report, real_content=[np.asarray(q) for q in nc.real_quads], family=family)


def _primal_orders(nc: _Normalized):
    """(degree d of the primal part without the blocks, the factor orders of that part (lists of (d, 4)))."""
    P0 = divide_real(nc.Cs2[:, :4], nc.g_s)
    P0[-1] = [1.0, 0, 0, 0]
    d = P0.shape[0] - 1
    if d == 0:
        return d, [np.zeros((0, 4))]
    P0dq = np.concatenate([P0, np.zeros_like(P0)], axis=1)
    return d, [f.factors[:, :4] for f in factorize(P0dq, validate=False).factorizations]


def _best_template(Cf, rf, nc: _Normalized, rng, max_templates: int):
    """The best `CofactorResult` over the templates (lowest co-factor degree, then residual), or None."""
    blocks = nc.blocks
    n2 = nc.Cs2.shape[0] - 1
    Q = nc.Cs2[:n2, 4:]
    d, orders = _primal_orders(nc)
    best = None
    for oi, positions in _templates(d, len(blocks), orders, max_templates):
        items = build_items(orders[oi], blocks, positions)
        z0, K, res = solve_items(items, Q, n2)
        if res > TEMPLATE_TOL:
            continue
        z = _circular(items, z0, K, blocks, rng)
        try:
            hs_s, R_s, report, family = _assemble(items, z, blocks, rng)
        except FactorizationError:
            continue
        result = _finish(Cf, rf, nc, hs_s, R_s, [it.label for it in items], report, family)
        if result.residual > FINAL_TOL:
            continue
        better = best is None or result.deg_R < best.deg_R or (
            result.deg_R == best.deg_R and result.residual < best.residual * 1e-3)
        if better:
            best = result
        if best.deg_R == 0 or K.shape[1] == 0 and _coprime(blocks, orders[oi]):
            break
    return best


def _circular(items, z0, K, blocks, rng):
    """The template's solution z0, moved along its kernel K so that the translations of the simple blocks
    are circular when they are not (largest subsets first; z0 when none is found)."""
    k1 = [b for b, (M, k) in enumerate(blocks) if k == 1]
    E0 = {it.block: s.reshape(-1, 3) for it, s in zip(items, split_unknowns(items, z0)) if it.kind == "trans"}
    noncirc = [b for b in k1 if np.max(np.abs(E0[b])) > 0
               and np.max(np.abs(circular_residual(blocks[b][0], E0[b]))) > CIRCULAR_TOL]
    if not noncirc or K.shape[1] == 0:
        return z0
    others = [b for b in k1 if b not in noncirc]  # already circular: keep them so
    for size in range(len(noncirc), 0, -1):
        for subset in itertools.combinations(noncirc, size):
            found = circular_kernel_search(items, z0, K, blocks, list(subset) + others, rng)
            if found is not None:
                return found
    return z0


def _coprime(blocks, rot_primals):
    for x in rot_primals:
        a, b = float(x[0]), float(np.linalg.norm(x[1:4]))
        for M, _ in blocks:
            al, be = quadratic_roots(M)
            if abs(a - al) + abs(b - be) <= 1e-6 * (1 + abs(al) + be):
                return False
    return True


def _assemble(items, z, blocks, rng):
    hs, R = [], np.ones(1)
    report = []
    family = None
    for it, zs in zip(items, split_unknowns(items, z)):
        if it.kind == "rot":
            hs.append(rotation_from(it, zs))
            continue
        M, k = blocks[it.block]
        E = zs.reshape(-1, 3)
        Ri, hsi, rep = factor_block(M, k, E, rng)
        R = real_mul(R, Ri)
        hs += hsi
        rep = dict(rep, block=it.label, quadratic=[float(M[0]), float(M[1])], multiplicity=k,
                   rotations=len(hsi))
        if "family" in rep and len(items) == 1:
            family = rep["family"]
        report.append(rep)
    return hs, R, report, family
