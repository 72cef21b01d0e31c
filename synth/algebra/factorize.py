"""Factorization of monic motion polynomials into linear factors (MATH.md section 4, Algorithm 1).

``factorize(C)`` returns every factorization ``C = (t - h_1)...(t - h_n)`` obtainable from the
orders of the norm polynomial's monic real quadratic factors: n! for distinct quadratics, fewer
with repeated ones. All orders are processed together as one batch (numpy), so the cost of the
whole enumeration is a few dozen array operations.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from itertools import chain

import numpy as np

from synth.algebra.dq import dq_inv, dq_mul, plucker
from synth.errors import InputError, NoFactorizationError, NotGenericError
from synth.algebra.polynomial import (
    divide_linear_right,
    divide_real_quadratic,
    norm_poly,
    product_of_linear,
    relative_error,
    right_value,
    study_residual,
)
from synth.algebra.scalar import factorize_generic

REAL_ROOT_TOL = 1e-7  # |Im z| <= tol * max(1, |z|): the root is taken as real
MERGE_TOL = 1e-6  # roots closer than tol * max(1, |z|) are one repeated root
GENERIC_TOL = 1e-9  # |primal(r1)| <= tol * max |primal(D)|: remainder not invertible
PRISMATIC_TOL = 1e-7  # |vec(primal h)| <= tol * (1 + |h0|): a translation factor
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
        """theta(t) = 2 atan2(b, t - a), 0 at t = inf (revolute factors)."""
        t = np.asarray(t, float)
        return np.where(np.isinf(t), 0.0, 2 * np.arctan2(self.b, t - self.a))


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
    out = []
    pows_scale = np.abs(P).max()
    for r in roots:
        cand = [complex(r)] if not isinstance(r, tuple) else [complex(r[0]), complex(r[1])]
        for z in cand:
            val = np.zeros(4, complex)
            for k in range(P.shape[0] - 1, -1, -1):
                val = val * z + P[k]
            ref = pows_scale * sum(abs(z) ** k for k in range(P.shape[0]))
            if np.linalg.norm(val) <= tol * ref and all(abs(z - w) > 1e-9 for w in out):
                out.append(z)
    return out


# ----------------------------------------------------------------------------- Algorithm 1
def _refine_quadratic(D, M):
    """Gauss-Newton on M = [c0, c1] so that the zero h(M) of D mod M right-divides D exactly
    (MATH.md section 4, numerical note ii). Returns the refined M."""

    def resid(Mv):
        _, r1, r0 = divide_real_quadratic(D, Mv)
        h = -dq_mul(dq_inv(r1), r0)
        return right_value(D, h)

    M = np.array(M, float)
    r = resid(M)
    for _ in range(8):
        J = np.empty((8, 2))
        for j in range(2):
            dM = np.zeros(2)
            dM[j] = 1e-7 * max(1.0, abs(M[j]))
            J[:, j] = (resid(M + dM) - r) / dM[j]
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        Mn = M + step
        rn = resid(Mn)
        if np.linalg.norm(rn) >= np.linalg.norm(r):
            break
        M, r = Mn, rn
    return M


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
        _, r1, r0 = divide_real_quadratic(Cb, Mv)
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


def _distinct_orders(mult):
    labels = [i for i, m in enumerate(mult) for _ in range(m)]
    return sorted(set(itertools.permutations(labels)))


def _factor_orders(C, quads, orders):
    """Algorithm 1 for every order at once. Returns (H (P, n, 8) with NaN rows for failed orders,
    ok mask (P,))."""
    orders = np.array(orders, int)
    P, n = orders.shape
    D = np.broadcast_to(C, (P,) + C.shape).copy()
    H = np.full((P, n, 8), np.nan)
    ok = np.ones(P, bool)
    for s in range(n):
        pos = n - 1 - s
        M = quads[orders[:, pos]]
        _, r1, r0 = divide_real_quadratic(D, M)
        prim_scale = np.max(np.linalg.norm(D[..., :4], axis=-1), axis=-1)
        bad = np.linalg.norm(r1[:, :4], axis=-1) <= GENERIC_TOL * prim_scale
        ok &= ~bad
        r1 = np.where(bad[:, None], np.eye(8)[0], r1)
        h = -dq_mul(dq_inv(r1), r0)
        Dn, rem = divide_linear_right(D, h)
        dscale = np.maximum(1.0, np.max(np.abs(D), axis=(-2, -1)))
        loose = ok & (np.max(np.abs(rem), axis=-1) > 1e-11 * dscale)
        for p in np.flatnonzero(loose):  # rare: nearly real / nearly equal roots
            Mr = _refine_quadratic(D[p], M[p])
            _, a1, a0 = divide_real_quadratic(D[p], Mr)
            hp = -dq_mul(dq_inv(a1), a0)
            Dp, remp = divide_linear_right(D[p], hp)
            if np.max(np.abs(remp)) < np.max(np.abs(rem[p])):
                h[p], Dn[p] = hp, Dp
        H[:, pos] = h
        D = Dn
    return H, ok


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
    res = float(study_residual(C))
    if res > tol:
        raise InputError(f"not a motion polynomial: its norm is not real (Study condition violated by {res:.2g})")


def _real_parts_apart(z) -> bool:
    """Consecutive roots (sorted by real part) differ in real part by more than 1e-8 relative: then
    rounding the real parts to 9 decimals (the numbering of `norm_quadratics`) keeps their order."""
    return all(b.real - a.real > 1e-8 * max(1.0, abs(a.real), abs(b.real)) for a, b in zip(z, z[1:]))


def _renumber(z, quads, orders, factors, residuals):
    """Number the quadratics like norm_quadratics: by (Re z rounded, Im z), so that equal real parts tie
    exactly and the numbering of the factorizations matches the general code and exact mode (z comes
    sorted by (Re z, Im z)). Returns (quads, orders, factors, residuals), reordered if need be."""
    if _real_parts_apart(z):
        return quads, orders, factors, residuals
    keys = [(round(w.real, 9), w.imag) for w in z]
    if keys == sorted(keys):
        return quads, orders, factors, residuals
    perm = sorted(range(len(z)), key=keys.__getitem__)
    new_of_old = {old: new for new, old in enumerate(perm)}
    entries = sorted(((tuple(new_of_old[q] for q in o), H, r) for o, H, r in zip(orders, factors, residuals)),
                     key=lambda e: e[0])
    return ([quads[i] for i in perm], *(list(x) for x in zip(*entries)))


def _factorize_fast(C, validate) -> FactorResult | None:
    """`factorize` for generic input in plain floats (`synth.algebra.scalar.factorize_generic`: the same
    steps, no numpy call per step); None when C is not clearly generic (then the code below decides)."""
    if C.ndim != 2 or C.shape[0] > 4:  # degree <= 3: plain floats beat numpy's batching over orders
        return None
    out = factorize_generic(C, validate)
    if out is None:
        return None
    N, z, quads, orders, factors, residuals = out
    quads, orders, factors, residuals = _renumber(z, quads, orders, factors, residuals)
    n = C.shape[0] - 1
    # (n!, n, 8); each factorization gets a view, as in the general code
    H = np.fromiter(chain.from_iterable(chain.from_iterable(factors)), float, 8 * n * len(factors))
    facts = list(map(Factorization, H.reshape(len(factors), n, 8), orders, residuals))  # factors, order, residual
    return FactorResult(C=C, norm=np.array(N), quadratics=np.array(quads), multiplicity=[1] * len(quads),
                        factorizations=facts, generic=True, real_factor_roots=[], failed_orders=[])


def factorize(C, *, validate=True) -> FactorResult:
    """All factorizations of a monic motion polynomial C (shape (n+1, 8)) from Algorithm 1.

    Orders whose remainder has a non-invertible leading coefficient are skipped (recorded in
    ``failed_orders``); when none succeeds, raises NotGenericError (primal part with a real factor)
    or NoFactorizationError."""
    C = np.asarray(C, float)
    fast = _factorize_fast(C, validate)
    if fast is not None:
        return fast
    if validate:
        check_motion_polynomial(C)
    N = norm_poly(C)
    quads, mult, roots = norm_quadratics(N)
    rf = real_factor_roots(C, roots)
    orders = _distinct_orders(mult)
    H, ok = _factor_orders(C, quads, orders)
    res = np.full(len(orders), np.inf)
    if np.any(ok):
        res[ok] = relative_error(product_of_linear(H[ok]), C)
        if np.max(res[ok]) > REFINE_TRIGGER:  # close roots: sharpen the quadratics on C and redo
            quads2 = _refine_quadratics(C, quads, mult, roots)
            H2, ok2 = _factor_orders(C, quads2, orders)
            res2 = np.full(len(orders), np.inf)
            if np.any(ok2):
                res2[ok2] = relative_error(product_of_linear(H2[ok2]), C)
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


def _real_factor_text(z: complex) -> str:
    def num(x):
        return f"{x:.6g}"

    if abs(z.imag) <= REAL_ROOT_TOL * max(1, abs(z)):
        x = z.real
        return "t" if abs(x) <= 1e-12 else f"(t {'-' if x > 0 else '+'} {num(abs(x))})"
    c1, c0 = -2 * z.real, abs(z) ** 2
    mid = "" if abs(c1) <= 1e-12 * max(1.0, c0) else f" {'+' if c1 > 0 else '-'} {num(abs(c1))} t"
    return f"(t^2{mid} + {num(c0)})"
