"""Dyads of a planar task by Burmester theory (docs/fourbar.md, section 2).

A dyad is a fixed pivot G (centre point) and a moving pivot with plane coordinates w at pose 0 (circle
point) whose positions ``Z_i = q_i + Rot(theta_i) w`` (`synth.synthesis.fourbar_plane`) stay on a circle
about G. Relative to pose 0 each further pose gives one equation, bilinear in G and w:

    f_i = |Z_i - G|^2 - |Z_0 - G|^2 = c_i(G) + m_i(G) . w = e_i(w) + n_i(w) . G = 0,
    m_i = 2 (R_i^T q_i - q_0) - 2 (R_i - I)^T G,   c_i = |q_i|^2 - |q_0|^2 - 2 G . (q_i - q_0),
    n_i = -2 (q_i - q_0) - 2 (R_i - I) w,          e_i = |q_i|^2 - |q_0|^2 + 2 (R_i^T q_i - q_0) . w.

A velocity at pose i (`synth.synthesis.fourbar_plane.with_velocities`: the field X' = a + r J X) is a
Hermite condition, pose i and one infinitesimally near it: the moving pivot's velocity is across the crank,
(Z_i - G) . (a + r J Z_i) = 0, again bilinear: ``m = R_i^T (a + r J G)``, ``c = q_i . (a + r J G) - G . a``;
``n = -(a + r J Z_i)``, ``e = Z_i . a``; its rows follow the poses' and vanish at the instant centre
P = -J a / r (its "pole"). The count of conditions (poses plus velocities) picks the method below.

* 3 poses: two equations, linear in G for a chosen w: the circumcentre of Z_0, Z_1, Z_2 (oo^2 dyads; the
  circle points are taken on a grid).
* 4 poses: three equations, linear in (w, 1) with the 3 x 3 matrix [m_i(G), c_i(G)]: its determinant, a
  cubic in G, is the centre-point curve. It passes through the pole P_0j of every relative displacement
  (row j vanishes there), so a line through P_0j meets it in two more points, the roots of a quadratic:
  the curve is sampled by the lines' directions, and w is the matrix's null vector.
* 5 poses: the Burmester points are the common points of the centre-point curves of poses 0123 and
  0124 other than their common poles P_01, P_02, P_12 and the circular points at infinity. The cubics'
  resultant in v is the determinant of their 6 x 6 Sylvester matrix S(u) = S_0 + u S_1 + u^2 S_2 + u^3 S_3,
  a polynomial eigenvalue problem solved by its companion pencil; every real u with the real common v
  is polished by Newton's method on the four equations in (G, w), and the poles, which do not solve them,
  drop out.
* More poses: least squares. Every circle point of a grid gets its algebraic circle fit, the best local
  minima are refined by Levenberg-Marquardt on the geometric residuals |Z_i - G| - R (a fixed number of
  iterations).

Everything in conditioned plane coordinates, vectorized over candidates.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.synthesis.fourbar_plane import PlanarTask

CIRCLE_GRID = np.linspace(-2.5, 2.5, 13)  # 3 poses: circle points w (conditioned) on this grid squared
POLE_RINGS = np.array([0.04, 0.08, 0.16, 0.32])  # and on rings of these radii about the poles (3 poses, fits),
POLE_RING_POINTS = 12  # with this many points each
CURVE_DIRECTIONS = 180  # 4 poses: lines through the pole sampling the centre-point curve
FIT_GRID = np.linspace(-3.0, 3.0, 25)  # > 5 poses: circle points seeding the least-squares dyads
FIT_SEEDS = 24  # local minima refined
FIT_ITERATIONS = 30  # Levenberg-Marquardt iterations (counted work)
NEWTON_STEPS = 8  # Burmester points: Newton steps on the four equations
EXACT_TOL = 1e-9  # a Burmester point's equations (conditioned) at most this after polishing
SAME_TOL = 1e-6  # two dyads closer than this (conditioned) are one


@dataclass
class Dyads:
    """N dyads (conditioned plane coordinates): ``centre`` G (N, 2), ``circle`` w (N, 2), ``radius`` (N,),
    ``error`` (N,): RMS of |Z_i - G| - radius over the poses; ``method``: how they were found."""

    centre: np.ndarray
    circle: np.ndarray
    radius: np.ndarray
    error: np.ndarray
    method: str

    def __len__(self) -> int:
        return len(self.centre)


def moving_points(task: PlanarTask, w) -> np.ndarray:
    """Positions Z (..., k, 2) at every pose of circle points w (..., 2)."""
    return task.qc + np.einsum("kab,...b->...ka", task.rotations, np.asarray(w, float))


def circle_figures(task: PlanarTask, G, w) -> tuple[np.ndarray, np.ndarray]:
    """(radius, RMS circle error) (...,) of dyads with centres G and circle points w (..., 2)."""
    d = np.linalg.norm(moving_points(task, w) - np.asarray(G, float)[..., None, :], axis=-1)
    r = d.mean(axis=-1)
    return r, np.sqrt(np.mean((d - r[..., None]) ** 2, axis=-1))


def _dyads(task, G, w, method) -> Dyads:
    r, err = circle_figures(task, G, w)
    ok = np.all(np.isfinite(G), axis=-1) & np.all(np.isfinite(w), axis=-1) & np.isfinite(err)
    return Dyads(G[ok], w[ok], r[ok], err[ok], method)


def rows_in_w(task: PlanarTask, G) -> np.ndarray:
    """[m_i(G), c_i(G)] (..., k - 1, 3): f_i = m_i . w + c_i for centres G (..., 2)."""
    q, R = task.qc, task.rotations
    G = np.asarray(G, float)[..., None, :]
    m = 2 * (np.einsum("kba,kb->ka", R, q)[1:] - q[0]) - 2 * np.einsum("kba,...kb->...ka", R[1:] - np.eye(2), G)
    c = np.sum(q[1:] ** 2, -1) - np.sum(q[0] ** 2) - 2 * np.sum(G * (q[1:] - q[0]), -1)
    out = np.concatenate([m, c[..., None]], -1)
    if not len(task.velocity_items):
        return out
    a, rate, i = task.velocity[:, :2], task.velocity[:, 2], task.velocity_items  # Hermite rows (module docstring)
    s = a + rate[:, None] * quarter_turn(G)  # (..., m, 2)
    mv = np.einsum("kba,...kb->...ka", R[i], s)
    cv = np.sum(q[i] * s, -1) - np.sum(G * a, -1)
    return np.concatenate([out, np.concatenate([mv, cv[..., None]], -1)], -2)


def quarter_turn(x) -> np.ndarray:
    """J x (..., 2): x turned by +90 degrees."""
    return np.stack([-x[..., 1], x[..., 0]], -1)


def rows_in_g(task: PlanarTask, w) -> np.ndarray:
    """[n_i(w), e_i(w)] (..., k - 1, 3): f_i = n_i . G + e_i for circle points w (..., 2)."""
    q, R = task.qc, task.rotations
    w = np.asarray(w, float)[..., None, :]
    n = -2 * (q[1:] - q[0]) - 2 * np.einsum("kab,...kb->...ka", R[1:] - np.eye(2), w)
    e = np.sum(q[1:] ** 2, -1) - np.sum(q[0] ** 2) + 2 * np.sum((np.einsum("kba,kb->ka", R, q)[1:] - q[0]) * w, -1)
    out = np.concatenate([n, e[..., None]], -1)
    if not len(task.velocity_items):
        return out
    a, rate, i = task.velocity[:, :2], task.velocity[:, 2], task.velocity_items
    Z = q[i] + np.einsum("kab,...kb->...ka", R[i], w)  # (..., m, 2)
    nv = -(a + rate[:, None] * quarter_turn(Z))
    return np.concatenate([out, np.concatenate([nv, np.sum(Z * a, -1)[..., None]], -1)], -2)


def circle_point_grid(task, grid) -> np.ndarray:
    """Circle points (n^2, 2) on ``grid`` x ``grid`` about the centroid of the tool origins."""
    u, v = np.meshgrid(grid, grid, indexing="ij")
    return np.stack([u.ravel(), v.ravel()], -1) + task.qc.mean(axis=0)


def three_pose_dyads(task: PlanarTask, grid=CIRCLE_GRID) -> Dyads:
    """Dyads of three poses: circle points on ``grid`` x ``grid`` and on rings about the three poles (where the
    circles are small: the short cranks of crank-rockers), centres the circumcentres."""
    k = len(task.theta)
    poles = [pole(task, j, i) for i, j in ((0, 1), (0, 2), (1, 2)) if j < k] + [
        task.rotations[i].T @ (pole(task, k + n) - task.qc[i]) for n, i in enumerate(task.velocity_items)]
    w = np.concatenate([circle_point_grid(task, grid)] + [p + pole_rings() for p in poles if np.all(np.isfinite(p))])
    rows = rows_in_g(task, w)  # (N, 2, 3)
    with np.errstate(all="ignore"):
        det = np.linalg.det(rows[..., :2])
        good = np.abs(det) > 1e-12
        G = np.linalg.solve(np.where(good[:, None, None], rows[..., :2], np.eye(2)), -rows[..., 2:])[..., 0]
    return _dyads(task, G[good], w[good], "3 poses: circle points on a grid, centres the circumcentres")


def null_circle_points(M) -> tuple[np.ndarray, np.ndarray]:
    """Circle points w (..., 2) from the null vectors (w, 1) of matrices M (..., r, 3), and the smallest
    singular value relative to the largest (...,)."""
    _, s, Vt = np.linalg.svd(M)
    v = Vt[..., -1, :]
    with np.errstate(all="ignore"):
        return v[..., :2] / v[..., 2:], s[..., -1] / s[..., 0]


def pole(task: PlanarTask, j: int, i: int = 0) -> np.ndarray:
    """The circle point w (2,) at the pole P_ij: Z_i = Z_j, (R_i - R_j) w = q_j - q_i (conditioned; for i = 0
    also the pole's position, Z_0 = w); NaN when poses i and j differ by a translation."""
    R = task.rotations
    k = len(task.theta)
    if j >= k:  # the Hermite row j - k: its instant centre P (a + rate J P = 0), as a centre; NaN for a translation
        a, rate = task.velocity[j - k, :2], task.velocity[j - k, 2]
        return -quarter_turn(a) / rate if abs(rate) > 1e-12 else np.full(2, np.nan)
    A = R[i] - R[j]
    if abs(np.linalg.det(A)) < 1e-24:
        return np.full(2, np.nan)
    return np.linalg.solve(A, task.qc[j] - task.qc[i])


def centre_point_curve(task: PlanarTask, directions: int = CURVE_DIRECTIONS) -> Dyads:
    """Dyads of four poses along the centre-point curve, sampled by ``directions`` lines through the pole
    P_0j of the largest rotation (module docstring)."""
    j = 1 + int(np.argmax(np.abs(np.sin(task.theta[1:4] / 2))))  # (a pose: Hermite rows follow the poses')
    P = pole(task, j)
    tau = np.pi * np.arange(directions) / directions
    d = np.stack([np.cos(tau), np.sin(tau)], -1)
    s = np.array([-1.0, 1.0, 2.0])
    D = np.linalg.det(rows_in_w(task, P + s[:, None, None] * d)[..., :3, :])  # (3, T): s (c1 + c2 s + c3 s^2)
    c = np.linalg.solve(np.vander(s, 3, increasing=True), (D / s[:, None]))  # (3, T)
    with np.errstate(all="ignore"):
        disc = c[1] ** 2 - 4 * c[2] * c[0]
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        q1 = -0.5 * (c[1] + np.copysign(root, c[1]))  # the two roots without cancellation
        S = np.stack([q1 / c[2], c[0] / q1], -1)  # (T, 2)
    G = (P + S[..., None] * d[:, None, :]).reshape(-1, 2)
    G = G[np.all(np.isfinite(G), axis=1)]
    w, _ = null_circle_points(rows_in_w(task, G)[..., :3, :])
    return _dyads(task, G, w, f"4 poses: the centre-point curve through the pole P0{j}, {directions} directions")


def burmester_points(task: PlanarTask) -> Dyads:
    """The (up to four) Burmester dyads of five poses (module docstring)."""
    u0 = np.array([-1.0, -1 / 3, 1 / 3, 1.0])
    U, V = np.meshgrid(u0, u0, indexing="ij")
    rows = rows_in_w(task, np.stack([U, V], -1))  # (4, 4, 4, 3)
    Vm = np.linalg.inv(np.vander(u0, 4, increasing=True))
    cubics = [Vm @ np.linalg.det(rows[..., list(r), :]) @ Vm.T for r in ((0, 1, 2), (0, 1, 3))]  # c[p, q] u^p v^q
    S = np.zeros((4, 6, 6))  # Sylvester matrix in v, coefficients of u^p
    for block, c in enumerate(cubics):
        for shift in range(3):
            S[:, 3 * block + shift, shift:shift + 4] = c
    n = 6
    A = np.zeros((3 * n, 3 * n))
    B = np.eye(3 * n)
    A[:2 * n, n:] = np.eye(2 * n)
    A[2 * n:] = -np.concatenate(S[:3], axis=1)
    B[2 * n:, 2 * n:] = S[3]
    import scipy.linalg  # the generalized eigenproblem (numpy has none); imported on first use

    alpha, beta = scipy.linalg.eig(A, B, right=False, homogeneous_eigvals=True)
    with np.errstate(all="ignore"):
        u = alpha / beta
    u = u[np.isfinite(u) & (np.abs(u.imag) <= 1e-6 * np.maximum(1.0, np.abs(u)))].real
    G = []
    for uk in u:
        f = np.polyval(cubics[0][::-1], uk)[::-1]  # coefficients of v^3 .. v^0 at u = uk
        g = np.polyval(cubics[1][::-1], uk)
        for v in np.roots(np.trim_zeros(f, "f")) if np.any(f) else ():
            if abs(v.imag) <= 1e-6 * max(1.0, abs(v)) and abs(np.polyval(g[::-1], v.real)) <= 1e-6 * np.abs(g).sum():
                G.append((uk, v.real))
    return _polished(task, np.array(G, float).reshape(-1, 2), "5 poses: Burmester points (resultant of two "
                                                              "centre-point curves, Newton-polished)")


def _polished(task, G, method) -> Dyads:
    """Newton's method on the four equations f_i(G, w) = 0 from centres G (N, 2), keeping the distinct
    solutions with finite circle points."""
    w, _ = null_circle_points(rows_in_w(task, G))
    x = np.concatenate([G, w], -1)
    for _ in range(NEWTON_STEPS):
        F, J = dyad_equations(task, x)
        x = x - solve_or_zero(J, F)
    F, _ = dyad_equations(task, x)
    good = np.all(np.isfinite(x), axis=1) & (np.max(np.abs(F), axis=1, initial=0.0) <= EXACT_TOL)
    return _distinct(_dyads(task, x[good, :2], x[good, 2:], method))


def solve_or_zero(A, b) -> np.ndarray:
    """Solutions x (N, n) of A x = b for a batch A (N, n, n), b (N, n); 0 where A is singular or not finite."""
    with np.errstate(all="ignore"):
        ok = np.all(np.isfinite(A), axis=(1, 2)) & np.all(np.isfinite(b), axis=1)
        ok &= np.abs(np.linalg.det(np.where(ok[:, None, None], A, np.eye(A.shape[-1])))) > 1e-300
        x = np.linalg.solve(np.where(ok[:, None, None], A, np.eye(A.shape[-1])), np.where(ok[:, None], b, 0.0)[..., None])
    return np.where(ok[:, None], x[..., 0], 0.0)


def dyad_equations(task, x) -> tuple[np.ndarray, np.ndarray]:
    """f_i (N, 4) of unknowns x = (G, w) (N, 4) and the Jacobian (N, 4, 4)."""
    G, w = x[:, :2], x[:, 2:]
    M = rows_in_w(task, G)[:, :4]  # (N, 4, 3)
    F = np.einsum("nka,na->nk", M[..., :2], w) + M[..., 2]
    J = np.concatenate([rows_in_g(task, w)[:, :4, :2], M[..., :2]], -1)
    return F, J


def _distinct(d: Dyads) -> Dyads:
    keep = []
    x = np.concatenate([d.centre, d.circle], -1)
    for i in np.argsort(d.error, kind="stable"):
        if all(np.max(np.abs(x[i] - x[k])) > SAME_TOL * max(1.0, np.abs(x[i]).max()) for k in keep):
            keep.append(i)
    keep = np.array(sorted(keep), int)
    return Dyads(d.centre[keep], d.circle[keep], d.radius[keep], d.error[keep], d.method)


def least_squares_dyads(task: PlanarTask, weights=None, grid=FIT_GRID, seeds: int = FIT_SEEDS) -> Dyads:
    """Least-squares dyads of any number of poses (module docstring); ``weights`` (k,): each pose's weight
    in the circle fit (default 1). Seeds: the ``seeds`` best local minima of the algebraic circle fit's error
    on the grid of circle points, and the best point of the rings about each pole of consecutive poses."""
    k = len(task.theta)
    wts = np.ones(k) if weights is None else np.asarray(weights, float)
    n = len(grid)
    rings = [pole(task, i + 1, i) + pole_rings() for i in range(k - 1)]
    rings = [r for r in rings if np.all(np.isfinite(r))]
    w = np.concatenate([circle_point_grid(task, grid)] + rings)
    G, err = algebraic_circles(task, w, wts)
    e = err[:n * n].reshape(n, n)
    pad = np.pad(e, 1, constant_values=np.inf)
    local = (e <= pad[:-2, 1:-1]) & (e <= pad[2:, 1:-1]) & (e <= pad[1:-1, :-2]) & (e <= pad[1:-1, 2:])
    idx = np.flatnonzero(local.ravel())
    idx = idx[np.argsort(err[idx], kind="stable")][:seeds]
    m = len(pole_rings())
    idx = np.concatenate([idx, n * n + m * np.arange(len(rings)) + np.argmin(err[n * n:].reshape(-1, m), axis=1)])
    G, w = _levenberg_marquardt(task, G[idx], w[idx], wts)
    return _distinct(_dyads(task, G, w, f"{k} poses: least-squares dyads ({len(idx)} seeds from a {n} x {n} grid of "
                                        "circle points and rings about the poles, Levenberg-Marquardt)"))


def pole_rings() -> np.ndarray:
    """Offsets (m, 2) of the circle points on rings about a pole (POLE_RINGS, POLE_RING_POINTS)."""
    z = POLE_RINGS[:, None] * np.exp(2j * np.pi * np.arange(POLE_RING_POINTS) / POLE_RING_POINTS)
    return np.stack([z.real, z.imag], -1).reshape(-1, 2)


def algebraic_circles(task: PlanarTask, w, wts) -> tuple[np.ndarray, np.ndarray]:
    """Centres G (N, 2) of the weighted algebraic (Kasa) circle fits of the positions of circle points w (N, 2),
    and the circles' RMS geometric error (N,)."""
    Z = moving_points(task, w)  # (N, k, 2)
    A = np.concatenate([2 * Z, np.ones(Z.shape[:-1] + (1,))], -1) * np.sqrt(wts)[:, None]
    G = batched_lstsq(A, np.sum(Z ** 2, -1) * np.sqrt(wts))[:, :2]
    return G, circle_figures(task, G, w)[1]


def batched_lstsq(A, b) -> np.ndarray:
    """Batched least squares A x = b, A (N, k, 3), b (N, k), by QR."""
    Q, R = np.linalg.qr(A)
    return np.linalg.solve(R, np.einsum("nka,nk->na", Q, b)[..., None])[..., 0]


def _levenberg_marquardt(task, G, w, wts, iterations: int = FIT_ITERATIONS):
    """Refine dyads (G, w) (N, 2) by minimizing sum_i wts_i (|Z_i - G| - R)^2 over G, w and R."""
    R = task.rotations
    r, _ = circle_figures(task, G, w)
    x = np.concatenate([G, w, r[:, None]], -1)
    lam = np.full(len(x), 1e-3)
    sq = np.sqrt(wts)

    def residual(x):
        d = moving_points(task, x[:, 2:4]) - x[:, None, :2]
        dist = np.linalg.norm(d, axis=-1)
        return (dist - x[:, 4:5]) * sq, d / np.maximum(dist, 1e-300)[..., None]

    res, unit = residual(x)
    for _ in range(iterations):
        J = np.concatenate([-unit, np.einsum("kab,nka->nkb", R, unit), -np.ones(res.shape + (1,))], -1) * sq[:, None]
        H = np.einsum("nka,nkb->nab", J, J)
        g = np.einsum("nka,nk->na", J, res)
        step = solve_or_zero(H + lam[:, None, None] * np.eye(5) * (1 + np.diagonal(H, axis1=1, axis2=2))[:, None], -g)
        trial = x + step
        res2, unit2 = residual(trial)
        better = np.sum(res2 ** 2, -1) < np.sum(res ** 2, -1)
        x = np.where(better[:, None], trial, x)
        res = np.where(better[:, None], res2, res)
        unit = np.where(better[:, None, None], unit2, unit)
        lam = np.where(better, lam / 3, lam * 4)
    return x[:, :2], x[:, 2:4]


def task_dyads(task: PlanarTask, weights=None) -> Dyads:
    """The dyads of a planar task by its count of conditions (poses, and velocities: each a pose
    infinitesimally near its own): 3 (grid), 4 (centre-point curve), 5 (Burmester points), more (least
    squares, ``weights`` per pose; velocities refused by the caller)."""
    k = len(task.theta) + len(task.velocity_items)  # a pose with a velocity counts twice (Hermite)
    if k == 3:
        return three_pose_dyads(task)
    if k == 4:
        return centre_point_curve(task)
    if k == 5:
        return burmester_points(task)
    return least_squares_dyads(task, weights)
