"""Factorization of monic motion polynomials into linear factors (Algorithm 1, docs/algorithm1.md).

``factorize(C)`` returns every factorization ``C = (t - h_1)...(t - h_n)`` obtainable from the
orders of the norm polynomial's monic real quadratic factors: n! for distinct quadratics, fewer
with repeated ones. All orders are processed together as one batch (numpy), so the cost of the
whole enumeration is a few dozen array operations.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from synth.algebra.algorithm1 import (PRISMATIC_TOL, algorithm1, distinct_orders, multiply_back, norm_roots,
                                      polish, root_conditioning)
from synth.algebra.anglelaw import half_angle
from synth.algebra.dq import dq_inv, dq_mul, plucker
from synth.algebra.polynomial import divide_real_quadratic, norm_poly, right_value, study_residual
from synth.errors import InputError, NoFactorizationError, NotGenericError

REAL_ROOT_TOL = 1e-7  # |Im z| <= tol * max(1, |z|): the root is taken as real
MERGE_TOL = 1e-6  # roots closer than tol * max(1, |z|) are one repeated root
CLEAR_ROOTS = 1e-5  # root_conditioning above this: simple, non-real norm roots (no clustering needed)
REFINE_TRIGGER = 5e-13  # multiply-back error above which the norm quadratics are refined on C (target 1e-12)


@dataclass
class Factor:
    """One linear factor t - h, classified."""

    h: np.ndarray  # (8,)
    kind: str  # "revolute" or "translation"

    @property
    def a(self) -> float:
        return float(self.h[0])

    @property
    def b(self) -> float:
        return float(np.linalg.norm(self.h[1:4]))

    @property
    def quadratic(self) -> tuple[float, float]:
        """N(t - h) = t^2 + c1 t + c0 as (c0, c1)."""
        return float(self.a**2 + self.b**2), float(-2 * self.a)

    @property
    def line(self):
        """(direction, moment) of the revolute axis (world frame of the polynomial)."""
        return plucker(self.h)

    @property
    def translation_direction(self) -> np.ndarray:
        """For a translation factor t - a - eps w: the point moves by 2 w / (t - a)."""
        return 2 * self.h[5:8]

    def angle(self, t):
        """theta(t) = 2 atan2(b, t - a) in (-2 pi, 2 pi), not reduced, 0 at t = inf (revolute factors;
        `synth.algebra.anglelaw.half_angle`)."""
        return 2.0 * half_angle(self.a, self.b, t)


@dataclass
class Factorization:
    factors: np.ndarray  # (n, 8): C = (t - factors[0]) ... (t - factors[n-1])
    order: tuple[int, ...]  # index into FactorResult.quadratics of N(t - h_i), left to right
    residual: float  # multiply-back relative error

    def classified(self) -> list[Factor]:
        return [classify(h) for h in self.factors]


@dataclass
class FactorResult:
    C: np.ndarray
    norm: np.ndarray  # real norm polynomial, ascending
    quadratics: np.ndarray  # (m, 2) distinct monic quadratics [c0, c1]
    multiplicity: list[int]
    factorizations: list[Factorization]
    generic: bool  # primal part without real polynomial factor
    real_factor_roots: list[complex] = field(default_factory=list)  # roots of mrpf(P), Im >= 0
    failed_orders: list[tuple[int, ...]] = field(default_factory=list)


def classify(h) -> Factor:
    h = np.asarray(h, float)
    v = np.linalg.norm(h[1:4])
    kind = "translation" if v <= PRISMATIC_TOL * (1 + abs(h[0])) else "revolute"
    return Factor(h=h, kind=kind)


# ----------------------------------------------------------------------------- norm factors
def _polish_roots(coeffs, z, iterations=3):
    """Newton steps on the real polynomial (ascending coeffs) at complex roots z."""
    c = np.asarray(coeffs, float)
    d = c[1:] * np.arange(1, len(c))
    for _ in range(iterations):
        f = np.polyval(c[::-1], z)
        df = np.polyval(d[::-1], z)
        ok = np.abs(df) > 0
        step = np.where(ok, f / np.where(ok, df, 1), 0)
        z = z - step
    return z


def _merge_radius(m: int) -> float:
    """Relative radius within which m computed roots are taken as one m-fold root: the root finder
    splits an m-fold root by ~eps^(1/m), so MERGE_TOL for a double root, MERGE_TOL^(2/m) beyond
    (capped at 1e-2: multiplicities above ~6 are not resolved reliably in double precision)."""
    return min(MERGE_TOL ** (2.0 / m), 1e-2)


def _cluster_roots(z):
    """Group roots that are one repeated root split by the root finder. Divisive single linkage: a
    group whose radius (largest distance from its mean) exceeds _merge_radius(size) * max(1, |mean|)
    is cut at the longest edge of its minimum spanning tree, recursively. Returns index lists."""
    z = np.asarray(z, complex)
    if len(z) == 0:
        return []
    # fast path: a root farther than any merge radius from every other root is a simple root
    dist = np.abs(z[:, None] - z[None, :])
    reach = 2.05 * _merge_radius(2 * len(z)) * np.maximum(1.0, np.maximum.outer(np.abs(z), np.abs(z)))
    np.fill_diagonal(dist, np.inf)
    isolated = np.all(dist > reach, axis=1)
    out = [[int(i)] for i in np.flatnonzero(isolated)]
    rest = np.flatnonzero(~isolated)
    stack = [rest] if len(rest) else []
    while stack:
        idx = stack.pop()
        m = len(idx)
        c = np.mean(z[idx])
        if m == 1 or np.max(np.abs(z[idx] - c)) <= _merge_radius(m) * max(1.0, abs(c)):
            out.append([int(i) for i in idx])
            continue
        # Prim's minimum spanning tree on the group; cut its longest edge
        w = z[idx]
        dist = np.abs(w[:, None] - w[None, :])
        in_tree = np.zeros(m, bool)
        in_tree[0] = True
        best = dist[0].copy()
        parent = np.zeros(m, int)
        edges = []
        for _ in range(m - 1):
            cand = np.where(in_tree, np.inf, best)
            v = int(np.argmin(cand))
            edges.append((cand[v], int(parent[v]), v))
            in_tree[v] = True
            closer = dist[v] < best
            best = np.where(closer, dist[v], best)
            parent = np.where(closer, v, parent)
        cut = max(range(len(edges)), key=lambda e: edges[e][0])
        # components after removing the cut edge
        adj = [[] for _ in range(m)]
        for e, (_, a, b) in enumerate(edges):
            if e != cut:
                adj[a].append(b)
                adj[b].append(a)
        seen = np.zeros(m, bool)
        todo = [edges[cut][1]]
        seen[todo[0]] = True
        while todo:
            a = todo.pop()
            for b in adj[a]:
                if not seen[b]:
                    seen[b] = True
                    todo.append(b)
        stack.append(idx[seen])
        stack.append(idx[~seen])
    return out


def norm_quadratics(N):
    """Monic real quadratic factors of a monic real polynomial N of even degree 2n, as
    (quadratics (m, 2) = [c0, c1], multiplicities, roots (Im >= 0) per quadratic).

    Complex conjugate pairs give t^2 - 2 Re z t + |z|^2; roots with |Im z| <= REAL_ROOT_TOL max(1,|z|)
    count as real and are paired in sorted order. A repeated root is split by the root finder
    (~eps^(1/m) for multiplicity m): such clusters are merged (see `_cluster_roots`), and the mean of the
    cluster is polished by Newton steps on the (m-1)-th derivative of N, where it is a simple root
    (Newton on N itself would spoil it)."""
    N = np.asarray(N, float)
    z = np.roots(N[::-1])
    scale = np.maximum(1.0, np.abs(z))
    real = np.abs(z.imag) <= REAL_ROOT_TOL * scale
    upper = z[(~real) & (z.imag > 0)]
    reals = np.sort(z[real].real)
    groups = _cluster_roots(upper)
    # sort by (Re z, Im z); Re rounded so that equal real parts (e.g. 0 and 1e-17) tie and Im decides,
    # which keeps the order of the quadratics (and of the factorizations) the same as in exact mode
    groups.sort(key=lambda g: (round(float(np.mean(upper[g]).real), 9), float(np.mean(upper[g]).imag)))
    centers = np.array([np.mean(upper[g]) for g in groups], complex)
    simple = np.array([len(g) == 1 for g in groups], bool)
    centers[simple] = _polish_roots(N, centers[simple])
    quads, mult, roots = [], [], []
    for g, c in zip(groups, centers):
        m = len(g)
        if m > 1:
            coeffs = N
            for _ in range(m - 1):
                coeffs = coeffs[1:] * np.arange(1, len(coeffs))
            c = _polish_roots(coeffs, np.array([c]))[0]
        c = complex(c)
        quads.append([abs(c) ** 2, -2 * c.real])
        mult.append(m)
        roots.append(c)
    if len(reals) % 2:
        raise NoFactorizationError("the norm polynomial has an odd number of real roots (not a motion polynomial)")
    # pair sorted real roots; identical pairs merge into one quadratic with multiplicity
    for x, y in zip(reals[::2], reals[1::2]):
        q = [x * y, -(x + y)]
        for i, (qq, r) in enumerate(zip(quads, roots)):
            if abs(qq[0] - q[0]) + abs(qq[1] - q[1]) <= MERGE_TOL * (1 + abs(q[0]) + abs(q[1])) and isinstance(r, tuple):
                mult[i] += 1
                break
        else:
            quads.append(q)
            mult.append(1)
            roots.append((float(x), float(y)))
    return np.array(quads, float).reshape(-1, 2), mult, roots


def real_factor_roots(C, roots, tol=1e-6):
    """The roots (Im >= 0) of the maximal real polynomial factor of the primal part P: the roots z
    of N(C) with P(z) = 0 (all four component polynomials vanish there)."""
    P = np.asarray(C, float)[:, :4]
    cand = np.array([w for r in roots for w in ((r,) if not isinstance(r, tuple) else r)], complex)
    if len(cand) == 0:
        return []
    val = np.zeros((len(cand), 4), complex)
    for k in range(P.shape[0] - 1, -1, -1):
        val = val * cand[:, None] + P[k]
    ref = np.abs(P).max() * np.sum(np.abs(cand)[:, None] ** np.arange(P.shape[0]), axis=1)
    out = []
    for z in cand[np.linalg.norm(val, axis=1) <= tol * ref].tolist():
        if all(abs(z - w) > 1e-9 for w in out):
            out.append(z)
    return out


# ----------------------------------------------------------------------------- Algorithm 1
def _refine_quadratics(C, quads, mult, roots, iterations=4):
    """Gauss-Newton on every simple, non-real norm quadratic at once so that the zero h(M) of
    C mod M right-divides C exactly. The roots of N(C) are worse conditioned than this condition
    (N has twice the degree, and the conjugate roots), so this gains ~2 digits when roots are close.
    Used only when the multiply-back check is not at machine precision. Returns new quadratics."""
    quads = np.array(quads, float)
    sel = np.array([m == 1 and not isinstance(r, tuple) for m, r in zip(mult, roots)], bool)
    if not np.any(sel):
        return quads
    M = quads[sel]
    Cb = np.broadcast_to(C, (len(M),) + C.shape)

    def resid(Mv):
        _, r1, r0 = divide_real_quadratic(Cb, Mv, quotient=False)
        return right_value(Cb, -dq_mul(dq_inv(r1), r0))

    r = resid(M)
    for _ in range(iterations):
        dM = 1e-7 * np.maximum(1.0, np.abs(M))
        J = np.stack([(resid(M + dM * e) - r) / dM[:, j:j + 1] for j, e in enumerate(np.eye(2))], -1)
        JT = np.swapaxes(J, -1, -2)
        A = JT @ J
        g = (JT @ r[..., None])[..., 0]
        det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
        det = np.where(det != 0, det, 1.0)
        step = -np.stack([A[:, 1, 1] * g[:, 0] - A[:, 0, 1] * g[:, 1],
                          A[:, 0, 0] * g[:, 1] - A[:, 1, 0] * g[:, 0]], -1) / det[:, None]
        Mn = M + np.where(np.isfinite(step), step, 0.0)
        rn = resid(Mn)
        better = np.linalg.norm(rn, axis=-1) < np.linalg.norm(r, axis=-1)
        if not np.any(better):
            break
        M = np.where(better[:, None], Mn, M)
        r = np.where(better[:, None], rn, r)
    quads[sel] = M
    return quads


def check_motion_polynomial(C, tol=1e-9):
    """Validate a monic motion polynomial; raise InputError otherwise."""
    C = np.asarray(C, float)
    if C.ndim != 2 or C.shape[1] != 8:
        raise InputError(f"a motion polynomial needs rows of 8 numbers, got shape {C.shape}")
    if C.shape[0] < 2:
        raise InputError("a motion polynomial needs degree >= 1")
    if not np.all(np.isfinite(C)):
        raise InputError("the coefficients contain NaN or infinity")
    if np.max(np.abs(C[-1] - np.eye(8)[0])) > tol:
        raise InputError("the polynomial is not monic (leading coefficient must be 1)")
    with np.errstate(all="ignore"):
        res = float(study_residual(C))
        overflow = not (np.isfinite(res) and np.all(np.isfinite(norm_poly(C))))
    if overflow:
        raise InputError("the coefficients are too large for double precision (the norm polynomial C C~ "
                         f"overflows; largest |coefficient| {np.max(np.abs(C)):.3g}): rescale t, e.g. t = 10^k s")
    if res > tol:
        raise InputError(f"not a motion polynomial: its norm is not real (Study condition violated by {res:.2g})")


def factorize(C, *, validate=True) -> FactorResult:
    """All factorizations of a monic motion polynomial C (shape (n+1, 8)) from Algorithm 1
    (`synth.algebra.algorithm1.algorithm1`, all orders as one batch; docs/algorithm1.md).

    The norm quadratics are numbered by (Re z rounded to 9 decimals, Im z) of their roots (Im z > 0),
    real-root pairs last; ``order`` gives the quadratic of each factor, left to right. Repeated roots are
    merged (fewer distinct orders), multiply-back errors above REFINE_TRIGGER trigger a refinement of the
    quadratics on C and a Newton polish of the factors. Orders whose remainder has a non-invertible
    leading coefficient are skipped (recorded in ``failed_orders``); when none succeeds, raises
    NotGenericError (primal part with a real factor) or NoFactorizationError."""
    C = np.asarray(C, float)
    if validate:
        check_motion_polynomial(C)
    N = norm_poly(C)
    quads = None
    if C.shape[0] >= 2 and np.all(np.isfinite(N)):
        z = norm_roots(N)  # the simple, clearly non-real case: no clustering, no real pairs
        im, _ = root_conditioning(z)
        if im > CLEAR_ROOTS and _isolated(z):
            key = sorted(range(len(z)), key=lambda i: (round(float(z[i].real), 9), float(z[i].imag)))
            z = z[key]
            quads = np.stack([np.abs(z) ** 2, -2 * z.real], -1)
            mult, roots = [1] * len(z), [complex(w) for w in z]
    if quads is None:
        quads, mult, roots = norm_quadratics(N)
    rf = real_factor_roots(C, roots)
    orders = distinct_orders(mult)
    H, ok, res = _run(C, quads, orders)
    if np.any(ok) and np.max(res[ok]) > REFINE_TRIGGER:  # close roots: sharpen the quadratics on C and redo
        quads2 = _refine_quadratics(C, quads, mult, roots)
        H2, ok2, res2 = _run(C, quads2, orders)
        if np.sum(ok2) >= np.sum(ok) and np.max(res2[ok2], initial=0.0) < np.max(res[ok]):
            quads, H, ok, res = quads2, H2, ok2, res2
    facts, failed = [], []
    for idx, order in enumerate(orders):
        if ok[idx]:
            facts.append(Factorization(factors=H[idx], order=tuple(order), residual=float(res[idx])))
        else:
            failed.append(tuple(order))
    result = FactorResult(C=C, norm=N, quadratics=quads, multiplicity=mult, factorizations=facts,
                          generic=not rf, real_factor_roots=rf, failed_orders=failed)
    if not facts:
        if rf:
            g = " * ".join(_real_factor_text(z) for z in rf)
            raise NotGenericError(
                f"not generic: the primal part has the real factor {g}; Algorithm 1 finds no "
                "factorization into linear factors (try --cofactor)")
        raise NoFactorizationError("no factorization into linear factors was found")
    return result


_SMALL_PAIRS = {n: np.triu_indices(n, 1) for n in (2, 3)}


def _isolated(z) -> bool:
    """No two roots z (n,) within the clustering's reach (`_cluster_roots`): all are simple roots."""
    if len(z) < 2:
        return True
    i, j = np.triu_indices(len(z), 1) if len(z) > 3 else _SMALL_PAIRS[len(z)]
    reach = 2.05 * _merge_radius(2 * len(z)) * np.maximum(1.0, np.maximum(np.abs(z[i]), np.abs(z[j])))
    return bool(np.all(np.abs(z[i] - z[j]) > reach))


def _run(C, quads, orders):
    """Algorithm 1 for every order (P, n) at once, factors polished where the multiply-back error
    exceeds REFINE_TRIGGER. Returns (H (P, n, 8), ok (P,), residuals (P,), inf where not ok)."""
    H, ok = algorithm1(C, np.asarray(quads)[np.asarray(orders, int)])
    res = np.where(ok, multiply_back(C, H), np.inf)
    loose = ok & (res > REFINE_TRIGGER)
    if np.any(loose):
        Hp, _ = polish(C, H[loose], iterations=3)
        rp = multiply_back(C, Hp)
        better = rp < res[loose]
        H[np.flatnonzero(loose)[better]] = Hp[better]
        res[np.flatnonzero(loose)[better]] = rp[better]
    return H, ok, res


def _real_factor_text(z: complex) -> str:
    def num(x):
        return f"{x:.6g}"

    if abs(z.imag) <= REAL_ROOT_TOL * max(1, abs(z)):
        x = z.real
        return "t" if abs(x) <= 1e-12 else f"(t {'-' if x > 0 else '+'} {num(abs(x))})"
    c1, c0 = -2 * z.real, abs(z) ** 2
    mid = "" if abs(c1) <= 1e-12 * max(1.0, c0) else f" {'+' if c1 > 0 else '-'} {num(abs(c1))} t"
    return f"(t^2{mid} + {num(c0)})"
