"""Least-squares fits of motion polynomials of any degree n to a task (docs/fit.md).

The motion is ``P(phi) = C(phi) Q`` with ``C(phi) = sum_k c_k cos^k(phi) sin^(n-k)(phi)`` the monic motion
polynomial C(t) = t^n + c_{n-1} t^{n-1} + ... + c_0 evaluated in homogeneous form at t = cot(phi)
(phi = 0 is t = inf, where C = 1 and the tool is at its reference pose Q), dual quaternions (8,) in the
layout of `synth.algebra.dq` (pose r - (eps/2) d r), everything in the task's conditioned frame
(`synth.synthesis.conic.condition`: lengths in pose spreads). The unknowns of one seed (`Layout`):
the coefficients c_0 .. c_{n-1} (8 n), a correction of the reference pose (rotation vector-ish w/2 and
translation, 6) and the item parameters phi_i (N; three of them fixed to remove the reparametrizations
t -> (a t + b) / (c t + d)). Equality constraints: the Study condition (2 n dual parts of C C~), the
exact components of items and the direction of prescribed velocities; the other components are
weighted residuals (error / tolerance). `levenberg_marquardt` solves this for a batch of seeds at once
(KKT steps; Jacobians chained from the rows' derivatives in the tool poses, `MotionModel.jacobians`), and
is generic: any model given as a batched residual function with the same row/column structure can use it.
The rows themselves: `synth.synthesis.fit_rows`.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from synth.algebra.dq import dq_left_matrix, dq_right_matrix
from synth.synthesis.arrow import ArrowJacobian
from synth.synthesis.fit_rows import (ERRORS, POSE_STEPS, ROWS, STEP, TaskArrays, basis, homogeneous, item_errors,
                                      item_rows, monic, pose_rows, reference_pose, reference_steps, study_jacobian,
                                      study_rows, task_arrays, twist_rows)

__all__ = ["sample_combinations", "nth_combination", "Layout", "LMResult", "MotionModel", "levenberg_marquardt",
           "cost_classes", "rank_seeds",
           # the rows (`synth.synthesis.fit_rows`), here for the fits that import them with the solver
           "TaskArrays", "task_arrays", "item_errors", "study_rows", "homogeneous", "monic", "basis", "reference_pose",
           "ERRORS", "ROWS"]

FEASIBLE_FLOOR = 1e-14  # constraint violation (conditioned units) counted as met
NEARLY_FEASIBLE = 1e-6  # during the damped steps: cost-lowering steps may leave this much (`polish_feasible` ends)
CORRECTIONS = 2  # second-order corrections per trial step, while the violation is above CORRECT_ABOVE
CORRECT_ABOVE = 1e-9
POLISH_STEPS = 4
FLAT = 1e-10  # a relative decrease of the cost below this ends a seed's refinement
COST_TIE = 1e-12  # relative: seeds whose costs differ by less are tied (rounding), ranked by seed index
COST_FLOOR = 1e-20  # and costs this close (squared misses over tolerance: 1e-10 of a tolerance) likewise


@dataclass(frozen=True)
class Layout:
    """Unknowns of one seed of a degree-n fit of N items: x = [c_0..c_{n-1} (8 n), w, dp (6), phi (N)].
    ``gauge`` (S, 3): per seed, the items whose phi is held fixed (the reparametrizations)."""

    n: int
    items: int
    gauge: np.ndarray

    @property
    def size(self) -> int:
        return 8 * self.n + 6 + self.items

    @property
    def fixed(self) -> np.ndarray:
        """(S, P) bool: the columns held fixed."""
        g = np.asarray(self.gauge, int)
        f = np.zeros((len(g), self.size), bool)
        f[np.arange(len(g))[:, None], 8 * self.n + 6 + g] = True
        return f

    def split(self, x):
        n = self.n
        return x[..., :8 * n].reshape(x.shape[:-1] + (n, 8)), x[..., 8 * n:8 * n + 6], x[..., 8 * n + 6:]

    def join(self, coef, x_ref, phi):
        return np.concatenate([coef.reshape(coef.shape[:-2] + (8 * self.n,)), x_ref, phi], -1)


@dataclass
class LMResult:
    """Per seed: ``x`` (S, P), ``cost`` (S,) (sum of squared weighted residuals), ``violation`` (S,)
    (max |constraint|), ``iterations`` (int, the same for all: counted work)."""

    x: np.ndarray
    cost: np.ndarray
    violation: np.ndarray
    iterations: int


def _chained(b, db, dEC, dEdC):
    """Derivatives (S, N, R, 8 n) of item rows in the coefficients c_0 .. c_{n-1}, from their derivatives
    dEC (S, N, R, 8) in C and dEdC in C' (None: the rows do not depend on C') at the items, and the basis
    b, db (S, N, n + 1) there (`basis`: C = b @ [c; 1], C' = db @ [c; 1])."""
    S, N, R, _ = dEC.shape
    n = b.shape[-1] - 1
    dcoef = b[:, :, None, :n, None] * dEC[:, :, :, None, :]
    if dEdC is not None:
        dcoef += db[:, :, None, :n, None] * dEdC[:, :, :, None, :]
    return dcoef.reshape(S, N, R, 8 * n)


class MotionModel:
    """The rows of a motion fit (`item_errors`, `study_rows`) as (residuals, constraints) of x."""

    def __init__(self, layout: Layout, task: TaskArrays, ref0):
        self.layout, self.task, self.ref0 = layout, task, np.asarray(ref0, float)
        width = ROWS if task.has_velocity else ERRORS  # (`item_rows`)
        self.free = (task.weight[:, :width] != 0).ravel()
        self.eq = task.exact[:, :width].ravel()

    def rows(self, x):
        """(residuals (..., M), constraints (..., E)) at x (..., P); leading axes broadcast with ref0's."""
        coef, x_ref, phi = self.layout.split(x)
        ref = reference_pose(self.ref0.reshape(self.ref0.shape[:1] + (1,) * (x.ndim - 2) + (8,)), x_ref)
        e = item_rows(coef, ref, phi, self.task)
        flat = e.reshape(e.shape[:-2] + (-1,))
        r = (e * self.task.weight[:, :e.shape[-1]]).reshape(flat.shape)[..., self.free]
        c = np.concatenate([flat[..., self.eq], study_rows(coef)], -1)
        return r, c

    def jacobians(self, x):
        """The rows and Jacobians at x (S, P) as a `synth.synthesis.arrow.ArrowJacobian` (item rows uncompressed:
        the rows that do not count are 0). The rows are a function of the tool poses P = C Q at the items
        (and of P' = C' Q, with velocities) alone: their derivatives in P (`pose_rows`; the twist rows by
        complex steps in P and P'), chained by matrix products to C (P = C Q: Q's right-multiplication
        matrix) and the coefficients (`basis`), to the reference correction (C's left-multiplication matrix
        times dQ / dx_ref, `reference_steps`) and to phi (dP / dphi = P'); the Study rows' by `study_jacobian`."""
        lay, task = self.layout, self.task
        n, g, S = lay.n, 8 * lay.n + 6, x.shape[0]
        coef, x_ref, phi = lay.split(x)
        vel = task.has_velocity
        if vel:  # the second derivative too: real parts the basis and its derivative, imaginary / STEP d / dphi
            bc, dbc = basis(phi + 1j * STEP, n)
            b, db = bc.real, dbc.real
            W = np.stack([b, db, dbc.imag / STEP], -2)  # (S, N, 3, n+1)
        else:
            b, db = basis(phi, n)
            W = np.stack([b, db], -2)
        N, k = phi.shape[1], W.shape[2]
        CC = W.reshape(S, N * k, n + 1) @ monic(coef)  # C, C' (and C'') at the items: (S, N k, 8)
        ref = reference_pose(self.ref0, x_ref)  # (S, 8)
        right = dq_right_matrix(ref)  # (S, 8, 8): P = C @ right
        PP = (CC @ right).reshape(S, N, k, 8)  # P, P' (and P'')
        CC = CC.reshape(S, N, k, 8)
        P, dP = PP[:, :, 0], PP[:, :, 1]
        E0, JP = pose_rows(P, task, jacobian=True)  # (S, N, ERRORS), (S, N, ERRORS, 8)
        JdP = None
        if vel:  # the twist rows: complex steps in P and P' (8 + 8 directions)
            step = POSE_STEPS
            Pz = np.concatenate([P[:, None] + step, np.broadcast_to(P[:, None], (S, 8) + P.shape[1:])], 1)
            dPz = np.concatenate([np.broadcast_to(dP[:, None], (S, 8) + P.shape[1:]), dP[:, None] + step], 1)
            T = twist_rows(Pz, dPz, task)  # (S, 16, N, 5)
            dT = np.moveaxis(T.imag, 1, -1) / STEP  # (S, N, 5, 16)
            E0 = np.concatenate([E0, T[:, 0].real], -1)
            JdP = np.concatenate([np.zeros(JP.shape), dT[..., 8:]], -2)
            JP = np.concatenate([JP, dT[..., :8]], -2)
        RT = np.swapaxes(right, 1, 2)[:, None]  # (S, 1, 8, 8): dP / dC
        dref_T = np.swapaxes(reference_steps(self.ref0, x_ref), 1, 2)[:, None]  # (S, 1, 8, 6)
        dcoef = _chained(b, db, JP @ RT, None if JdP is None else JdP @ RT)
        dx_ref = JP @ (np.swapaxes(dq_left_matrix(CC[:, :, 0]), -1, -2) @ dref_T)  # (S, N, rows, 6)
        dphi = (JP @ dP[..., None])[..., 0]  # (S, N, rows)
        if vel:
            dx_ref += JdP @ (np.swapaxes(dq_left_matrix(CC[:, :, 1]), -1, -2) @ dref_T)
            dphi += (JdP @ PP[:, :, 2, :, None])[..., 0]
        Jg = np.concatenate([dcoef, dx_ref], -1)  # (S, N, rows, g): rows = ROWS (ERRORS without velocities)
        c, Jc = self._study(coef, x.shape[-1])
        if self.eq.any():  # the exact rows of the items that have them
            items = np.nonzero(task.exact.any(1))[0]
            eq = task.exact[items, :Jg.shape[2]].ravel()
            owner = np.repeat(items, Jg.shape[2])[eq]
            Je = np.zeros((S, len(owner), lay.size))
            Je[..., :g] = Jg[:, items].reshape(S, -1, g)[:, eq]
            Je[:, np.arange(len(owner)), g + owner] = dphi[:, items].reshape(S, -1)[:, eq]
            c, Jc = np.concatenate([E0[:, items].reshape(S, -1)[:, eq], c], -1), np.concatenate([Je, Jc], 1)
        w = task.weight[:, :ERRORS]  # (the twist rows are never residuals)
        counts = w != 0  # (rows that do not count: 0, whatever their values)
        return ArrowJacobian.of_items(np.where(counts, E0[..., :ERRORS] * w, 0.0),
                                      np.where(counts[..., None], Jg[:, :, :ERRORS] * w[..., None], 0.0),
                                      np.where(counts, dphi[..., :ERRORS] * w, 0.0), c, Jc)

    def _study(self, coef, columns: int):
        """The Study rows (S, 2n) of the coefficients (S, n, 8) and their Jacobian (S, 2n, columns)
        (`study_jacobian`)."""
        n = self.layout.n
        J = np.zeros((coef.shape[0], 2 * n, columns))
        J[..., :8 * n] = study_jacobian(coef)
        return study_rows(coef), J

    def constraints(self, x):
        """(c (S, E), its Jacobian (S, E, P)) at x (S, P): `jacobians` for the constraints only, of the items
        with exact rows alone."""
        items = np.nonzero(self.task.exact.any(1))[0]
        if not len(items):
            return self._study(self.layout.split(x)[0], x.shape[-1])
        t, g = self.task, 8 * self.layout.n + 6
        sub = MotionModel(Layout(self.layout.n, len(items), np.zeros((0, 3), int)),
                          TaskArrays(t.Q[items], t.X[items], t.weight[items], t.exact[items], t.perp[items]), self.ref0)
        jac = sub.jacobians(np.concatenate([x[:, :g], x[:, g + items]], 1))
        Jc = np.zeros(jac.Jc.shape[:2] + (x.shape[-1],))
        Jc[..., :g], Jc[..., g + items] = jac.Jc[..., :g], jac.Jc[..., g:]
        return jac.c, Jc


def levenberg_marquardt(model, x0, fixed, iterations: int = 60) -> LMResult:
    """Minimize |r(x)|^2 subject to c(x) = 0 for a batch of seeds x0 (S, P) by damped Gauss-Newton steps on
    the KKT system [[J^T J + lam D, A^T], [A, 0]] [dx; mu] = [-J^T r; -c] (D = diag(J^T J) + 1e-12), each
    followed by a second-order correction back onto c = 0 (min-norm along A's rows). A step is accepted
    (lam / 3, else lam * 4) when it lowers |r|^2 and keeps max |c| below max(NEARLY_FEASIBLE, its value), or
    halves max |c| while that is above NEARLY_FEASIBLE (a filter: exact rows never trade against the cost);
    `polish_feasible` then meets c = 0 to rounding. ``fixed`` (S, P) bool: columns held, per seed. ``model``:
    ``rows(x) -> (r, c)``, ``jacobians(x) -> ArrowJacobian`` and ``constraints(x) -> (c, A)`` (its KKT system is solved with the items'
    columns eliminated, `synth.synthesis.arrow.KKTSystem`: linear in the number of items). Stops after ``iterations`` Jacobians
    or when every seed's step is below 1e-13 (relative) or its cost stops moving (FLAT, relative): counted
    work only."""
    x = np.array(x0, float)
    fixed = np.broadcast_to(np.asarray(fixed, bool), x.shape)
    S = x.shape[0]
    lam = np.full(S, 1e-3)
    done = np.zeros(S, bool)
    it = 0
    jac = model.jacobians(x)
    cost, viol = jac.cost, np.abs(jac.c).max(-1, initial=0.0)
    for it in range(1, iterations + 1):
        system = jac.system(fixed)
        A, ne = system.A, system.A.shape[1]
        pending = ~done
        for _ in range(8):  # damping tries per Jacobian
            xn = x + system.step(lam, _solve)
            rn, cn = model.rows(xn)
            for _ in range(CORRECTIONS if ne else 0):  # second-order corrections: back onto c = 0 along A's rows
                if np.abs(cn[pending]).max(initial=0.0) <= CORRECT_ABOVE:
                    break
                xn = xn - _min_norm(A, cn)
                rn, cn = model.rows(xn)
            cost_n, viol_n = (rn * rn).sum(-1), np.abs(cn).max(-1, initial=0.0)
            restores = viol_n <= 0.5 * viol  # feasibility progress, any cost (far from c = 0)
            improves = (cost_n < cost) & (viol_n <= np.maximum(viol, NEARLY_FEASIBLE))
            ok = pending & np.isfinite(cost_n) & (improves | (restores & (viol > NEARLY_FEASIBLE)))
            step = np.max(np.abs(xn - x), axis=1)
            flat = ok & (cost - cost_n <= FLAT * cost + 1e-28)  # the cost no longer moves
            x[ok] = xn[ok]
            cost, viol = np.where(ok, cost_n, cost), np.where(ok, viol_n, viol)
            lam = np.where(ok, np.maximum(lam / 3, 1e-12), np.where(pending, lam * 4, lam))
            small = step <= 1e-13 * (1 + np.max(np.abs(x), axis=1))
            done |= pending & (small | flat) & (viol <= NEARLY_FEASIBLE)
            pending &= ~ok & ~done
            if not pending.any():
                break
        if done.all():
            break
        jac = model.jacobians(x)
    x = polish_feasible(model, x, fixed)
    r, c = model.rows(x)
    return LMResult(x=x, cost=(r * r).sum(-1), violation=np.abs(c).max(-1, initial=0.0), iterations=it)


def _min_norm(A, c):
    """The least-norm dx (S, P) with A dx = c (A (S, E, P))."""
    if not A.shape[1]:
        return np.zeros((A.shape[0], A.shape[2]))
    return (np.swapaxes(A, 1, 2) @ _solve(A @ np.swapaxes(A, 1, 2), c)[..., None])[..., 0]


def polish_feasible(model, x, fixed, steps: int = POLISH_STEPS):
    """Newton steps onto c(x) = 0 (min-norm along the constraint Jacobian's rows, held columns fixed), for
    the exact rows' last digits after the damped steps (which keep them only below NEARLY_FEASIBLE).
    Counted steps."""
    for _ in range(steps):
        c = model.rows(x)[1]  # (cheaper than the Jacobians, which only a violated constraint needs)
        if not c.shape[-1] or np.abs(c).max() <= FEASIBLE_FLOOR:
            break
        c, Jc = model.constraints(x)
        xn = x - _min_norm(np.where(fixed[:, None, :], 0.0, Jc), c)
        cn = model.rows(xn)[1]
        better = np.abs(cn).max(-1) < np.abs(c).max(-1)
        x[better] = xn[better]
    return x


def _solve(K, rhs):
    """Batched solve; a singular system (a degenerate seed) gives a zero step."""
    try:
        return np.linalg.solve(K, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        out = np.zeros_like(rhs)
        for s in range(len(K)):
            try:
                out[s] = np.linalg.solve(K[s], rhs[s])
            except np.linalg.LinAlgError:
                pass
        return out


def nth_combination(n: int, k: int, index: int) -> tuple:
    """The ``index``-th k-subset of range(n) in the lexicographic order of itertools.combinations."""
    out, start = [], 0
    for left in range(k, 0, -1):
        for a in range(start, n):
            count = math.comb(n - a - 1, left - 1)  # subsets that start with a
            if index < count:
                out.append(a)
                start = a + 1
                break
            index -= count
    return tuple(out)


def sample_combinations(items, k: int, size: int, first=()) -> list:
    """Up to ``size`` k-subsets of ``items`` (tuples, in the lexicographic order of
    itertools.combinations): all when there are at most ``size``; else ``first`` (some of them, kept
    in front) and a seeded sample (generator seed 0) of the rest, picked by rank, never listing all
    (a task of 10,000 poses has 1.7e11 triples). The same subsets as sampling from the full list."""
    items = list(items)
    total = math.comb(len(items), k)
    if total <= size:
        return list(itertools.combinations(items, k))
    first = list(first)
    pick = np.random.default_rng(0).choice(total, size=size - len(first), replace=False)
    return first + [tuple(items[i] for i in nth_combination(len(items), k, int(r))) for r in sorted(pick)]


def cost_classes(cost, rel: float = COST_TIE) -> np.ndarray:
    """(S,) int: the rank of each of the costs ``cost`` (S,) (NaN as inf) with rounding-level ties merged:
    walking the costs upwards, a cost within ``rel`` (relative, plus `COST_FLOOR`) of the first cost of
    its class joins that class. Two seeds that converge to one minimum get costs that differ in their last
    bits, in an order that rounding decides; ranking by (class, seed index) makes it the seeds' order."""
    cost = np.nan_to_num(np.asarray(cost, float), nan=np.inf)
    out = np.empty(len(cost), int)
    k, base = -1, np.nan
    for i in np.argsort(cost, kind="stable"):
        if not cost[i] - base <= rel * abs(base) + COST_FLOOR:  # (NaN for the first and for inf - inf: a new class)
            k, base = k + 1, cost[i]
        out[i] = k
    return out


def rank_seeds(cost, *before) -> np.ndarray:
    """The seed indices (S,) ordered by the keys ``before`` (each (S,), most significant first, e.g. "not
    feasible"), then by cost (`cost_classes`: ties within `COST_TIE`), then by seed index."""
    return np.lexsort((np.arange(len(cost)), cost_classes(cost), *reversed(before)))
