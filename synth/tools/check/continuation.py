"""The exact motion of a written linkage from its angle laws, and an independent continuation of its loops.

``law_angles``: every joint's exact angle when the driver joint is at a given angle (linkage.json's
``joints[].angle_law``, theta_j(t) = 2 atan2(b_j, t - a_j); docs/conventions.md).
``continue_loop``: drive one joint of a `synth.io.urdfmodel.UrdfModel` through a full turn in adaptive
steps (tangent predictor, Gauss-Newton corrector on all loops together), without using the laws except
to stay on their motion at a branch crossing (a singular configuration where another branch of the
configuration curve meets it; docs/exceptional.md, section 6): what `mpsynth check` compares the laws with. Angles in radians, lengths in metres.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from synth.algebra.anglelaw import driven_angle
from synth.algebra.geometry import cross, invert_pose
from synth.frames import TWO_PI, wrap_angle
from synth.io.urdfmodel import UrdfModel


# ----------------------------------------------------------------------------- angle laws
def law_angles(laws: dict, driver: str, phi, rates: dict | None = None, loops: dict | None = None) -> dict[str, np.ndarray]:
    """Exact joint angles when the driver joint is at angle(s) ``phi`` in [0, 2pi]: the driver's law
    theta = 2 atan2(b, t - a) gives t = a + b cot(phi/2); with s = sin(phi/2) >= 0, c = cos(phi/2),
    theta_j = 2 atan2(b_j s, (a_d - a_j) s + b_d c), which is exact at phi = 0 (t = infinity) too
    (`synth.algebra.anglelaw.driven_angle`). ``rates``: joint -> rate of its law (default 1; a driver of
    rate r covers the motion once as phi runs over [0, 2 pi r]). ``loops``: joint -> its planar four-bar loop
    law (`synth.algebra.fourbar_loop.FourBarLaw`), applied to the angle of its own (a, b), the crank's."""
    phi = np.asarray(phi, float)
    rates = rates or {}
    ad, bd = laws[driver]
    rd = rates.get(driver, 1)
    out = {}
    for jn, (a, b) in laws.items():
        out[jn] = phi.copy() if jn == driver else driven_angle(a, b, ad, bd, phi, rates.get(jn, 1), rd)
    for jn, law in (loops or {}).items():  # a four-bar's joint: its loop law of the crank's angle (its (a, b))
        if jn in out and jn != driver:
            out[jn] = law.angle(out[jn])
    return out


# ----------------------------------------------------------------------------- continuation
def loop_residual(u: UrdfModel, closures, refs, cfg, unknowns, length, jacobian=True):
    """Residual of all loops (6 per loop: translation / length, rotation) and its Jacobian with respect
    to the ``unknowns`` joint angles (and, as a last column, nothing else)."""
    F = u.fk(cfg)
    rows, jac = [], []
    axes = {}
    paths = _path_sets(u, closures)
    if jacobian:
        for jn in unknowns:
            j = u.joints[jn]
            Fj = F[j.parent] @ j.origin
            axes[jn] = (Fj[:3, :3] @ j.axis, Fj[:3, 3])
    for (a, b), R in zip(closures, refs):
        G = F[b] @ invert_pose(R)  # where link a should be, according to branch b
        Fa = F[a]
        M = G[:3, :3] @ Fa[:3, :3].T
        e_p = (G[:3, 3] - Fa[:3, 3]) / length
        e_r = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
        rows.append(np.concatenate([e_p, e_r]))
        if jacobian:
            pa, pb = paths[(a, b)]
            J = np.zeros((6, len(unknowns)))
            for k, jn in enumerate(unknowns):
                w, c = axes[jn]
                sb, sa = jn in pb, jn in pa
                if sb == sa:
                    continue
                if sb:
                    J[:3, k] = cross(w, G[:3, 3] - c) / length
                    J[3:, k] = w
                else:
                    J[:3, k] = -cross(w, Fa[:3, 3] - c) / length
                    J[3:, k] = -w
            jac.append(J)
    r = np.concatenate(rows) if rows else np.zeros(0)
    return r, (np.vstack(jac) if jacobian and jac else None)


_PATHS: dict = {}


def _path_sets(u, closures):
    key = (id(u), tuple(closures))
    if key not in _PATHS or _PATHS[key][0] is not u:
        _PATHS.clear()
        _PATHS[key] = (u, {(a, b): (set(u.path(a)), set(u.path(b))) for a, b in closures})
    return _PATHS[key][1]


def _gauss_newton(fun, x0, tol, max_iter=25, target=1e-3):
    """Gauss-Newton with step halving (least squares through the SVD, so redundant loop equations and
    rank deficiency are fine) until |r| <= target * tol, or until a step no longer lowers it; below
    1e-3 tol only full steps that halve |r| count (no halving: the rounding floor is near).
    Returns (x, |r|)."""
    x = x0.copy()
    r, J = fun(x)
    nr = float(np.linalg.norm(r))
    for _ in range(max_iter):
        if nr <= target * tol:
            break
        polishing = nr <= 1e-3 * tol
        dx = np.linalg.lstsq(J, -r, rcond=1e-12)[0]
        lam, improved = 1.0, False
        for _ in range(1 if polishing else 8):
            xn = x + lam * dx
            rn, Jn = fun(xn)
            nrn = float(np.linalg.norm(rn))
            if nrn < (0.5 * nr if polishing else nr):
                x, r, J, nr, improved = xn, rn, Jn, nrn, True
                break
            lam /= 2
        if not improved or float(np.abs(lam * dx).max()) < 1e-16:
            break
    return x, nr


def continue_loop(u: UrdfModel, closures, driver: str, others: list[str], *, steps: int = 360,
                  length: float = 1.0, tol: float = 1e-8, min_step: float = 1e-9, ratio: float = 1.0,
                  guide=None, guide_tol: float = 1e-6, singular: float = 1e-3) -> dict:
    """Drive ``driver`` from 0 through a full turn, solving ``others`` so every loop stays closed.

    Adaptive continuation: tangent predictor (from the loop Jacobian), Gauss-Newton corrector, the step
    (at most 2 pi / steps) halves when the corrector fails or moves a joint by more than a quarter of
    the step bound, and grows by 1.5 after a success; below ``min_step`` * 2 pi the linkage is stuck
    (1e-9: a joint turning up to ~1e7 times faster than the driver somewhere in the cycle is followed;
    syntheses refuse ratios above 1e4, `synth.synthesis.conditioning`). ``ratio``: the linkage's
    transmission ratio rho; where a joint turns rho times faster than the driver its angle is far more
    uncertain than the loop residual (rho ~ 5e4 left the path 1.5e-4 rad off the laws with the residual
    at 1e-3 tol), so the corrector goes on to 1e-3 tol / max(1, rho / 100).
    ``guide``: optional phi -> the others' angles the linkage's angle laws expect (`law_angles`), used
    only at branch crossings (docs/exceptional.md, section 6): where an accepted point is more than
    ``guide_tol`` rad off the guide, or the continuation is stuck, and the loop Jacobian at the guide's
    configurations since the last point on it loses rank (conditioning at most ``singular``,
    `law_conditioning`), the continuation re-seeds at the guide's configuration polished by the
    corrector, provided that closes the loops and stays within ``guide_tol`` of the guide; each such
    crossing is reported. Anywhere else (or when a re-seed fails) the guide is dropped, so a linkage
    that does not move as its laws say still leaves them.
    Returns ``followed`` (fraction of the turn), ``path`` (rows: driver angle, others' angles),
    ``accepted``/``rejected`` step counts, ``max_residual`` (of accepted points), ``crossings`` (dicts:
    ``angle`` of the rank drop, its ``conditioning``, the ``deviation`` re-seeded away, rad) and, when
    stuck, the ``angle`` and ``stuck_residual``."""
    return _Continuation(u, closures, driver, others, length=length, tol=tol, ratio=ratio, guide=guide,
                         guide_tol=guide_tol, singular=singular).run(steps, min_step)


class _Continuation:
    """The loops, tolerances and guide of one `continue_loop` (its docstring has the meaning of each)."""

    def __init__(self, u: UrdfModel, closures, driver: str, others, *, length, tol, ratio, guide, guide_tol,
                 singular):
        F0 = u.fk({})
        self.u, self.closures, self.driver, self.others = u, closures, driver, list(others)
        self.refs = [invert_pose(F0[a]) @ F0[b] for a, b in closures]
        self.length, self.tol, self.guide, self.guide_tol, self.singular = length, tol, guide, guide_tol, singular
        self.target = 1e-3 / max(1.0, ratio / 100.0)

    def fun_at(self, phi):
        """x -> (loop residual, Jacobian) with the driver at ``phi``."""
        def f(x):
            cfg = {self.driver: phi, **dict(zip(self.others, x))}
            return loop_residual(self.u, self.closures, self.refs, cfg, self.others, self.length)
        return f

    def tangent(self, phi, x):
        """d(others)/d(driver) at (phi, x), from the loop Jacobian."""
        cfg = {self.driver: phi, **dict(zip(self.others, x))}
        _, J = loop_residual(self.u, self.closures, self.refs, cfg, [self.driver] + self.others, self.length)
        if J is None or not self.others:
            return np.zeros(len(self.others))
        return np.linalg.lstsq(J[:, 1:], -J[:, 0], rcond=1e-10)[0]

    def polished_guide(self, phi_a, phi_b, x_near):
        """The guide's configuration at phi_b polished, when a rank drop of the laws lies in [phi_a, phi_b]
        and it closes the loops next to the guide: (x, crossing record), else None."""
        g = np.asarray(self.guide(phi_b), float)
        cond, at = law_conditioning(self.u, self.closures, self.refs, self.driver, self.others, self.guide,
                                    phi_a, phi_b, self.length)
        if cond > self.singular:
            return None
        xg, res = _gauss_newton(self.fun_at(phi_b), g, self.tol, target=self.target)
        if not (res <= self.tol and np.all(np.isfinite(xg))
                and _wrapped(xg - g).max(initial=0.0) <= self.guide_tol):
            return None
        xg = xg - TWO_PI * np.round((xg - x_near) / TWO_PI)  # keep the path continuous
        return xg, {"angle": at, "conditioning": cond,
                    "deviation": float(_wrapped(x_near - g).max(initial=0.0))}

    def run(self, steps: int, min_step: float) -> dict:
        """The continuation through a full turn (`continue_loop`'s result)."""
        h_max, h_min = TWO_PI / steps, TWO_PI * min_step
        phi, h = 0.0, h_max
        x = np.zeros(len(self.others))
        path = [np.concatenate([[0.0], x])]
        accepted = rejected = 0
        worst = float(np.linalg.norm(self.fun_at(0.0)(x)[0]))
        crossings = []
        last_on = 0.0  # the last driver angle where the path agreed with the guide
        while phi < TWO_PI - 1e-13:
            step = min(h, TWO_PI - phi)
            guess = x + step * self.tangent(phi, x)
            xn, res = _gauss_newton(self.fun_at(phi + step), guess, self.tol, target=self.target)
            jump = float(np.abs(xn - guess).max()) if len(xn) else 0.0
            if res <= self.tol and jump <= 0.25 * h_max + 1e-12 and np.all(np.isfinite(xn)):
                phi += step
                x = xn
                if self.guide is not None and len(x):
                    if _wrapped(x - np.asarray(self.guide(phi), float)).max() > self.guide_tol:
                        got = self.polished_guide(last_on, phi, x)
                        if got is None:
                            self.guide = None  # off the laws away from a rank drop: no more guiding
                        else:
                            x, rec = got
                            crossings.append(rec)
                    if self.guide is not None:
                        last_on = phi
                worst = max(worst, res)
                path.append(np.concatenate([[phi], x]))
                accepted += 1
                h = min(h_max, 1.5 * step)
                continue
            rejected += 1
            if step > h_min:
                h = step / 2
                continue
            got = None
            if self.guide is not None and len(x):  # stuck at a crossing: re-seed past it
                phi_b = min(phi + h_max, TWO_PI)
                got = self.polished_guide(last_on, phi_b, x)
            if got is None:
                return {"followed": phi / TWO_PI, "path": path, "accepted": accepted, "rejected": rejected,
                        "max_residual": worst, "crossings": crossings, "angle": phi, "stuck_residual": res}
            x, rec = got
            crossings.append(rec)
            phi = last_on = phi_b
            path.append(np.concatenate([[phi], x]))
            accepted += 1
            h = h_max
        return {"followed": 1.0, "path": path, "accepted": accepted, "rejected": rejected, "max_residual": worst,
                "crossings": crossings, "angle": TWO_PI, "stuck_residual": 0.0}


def _wrapped(d):
    """|angle differences| (rad), wrapped to [0, pi]."""
    return np.abs(wrap_angle(d))


def jacobian_conditioning(u: UrdfModel, closures, refs, driver: str, others, phi: float, x, length: float = 1.0) -> float:
    """Smallest kept / largest singular value of the loop Jacobian with respect to all loop joints at the
    configuration (driver at ``phi``, ``others`` at ``x``), rank n - 1 kept for n joints (mobility 1): near 0
    at a singular configuration, where other branches of the configuration curve can cross."""
    _, J = loop_residual(u, closures, refs, {driver: phi, **dict(zip(others, x))}, [driver] + list(others), length)
    sv = np.linalg.svd(J, compute_uv=False)
    k = min(len(sv), J.shape[1] - 1) - 1
    return float(sv[k] / sv[0]) if k >= 0 and sv[0] > 0 else 1.0


def law_conditioning(u: UrdfModel, closures, refs, driver: str, others, guide, lo: float, hi: float,
                     length: float = 1.0, samples: int = 16) -> tuple[float, float]:
    """(minimum, driver angle of it) of `jacobian_conditioning` at the configurations ``guide(phi)`` for
    phi in [lo, hi] (``samples`` + 1 values, the least refined by a bounded scalar minimization)."""
    def cond(p):
        return jacobian_conditioning(u, closures, refs, driver, others, p, guide(p), length)

    phis = np.linspace(lo, hi, samples + 1)
    c = np.array([cond(p) for p in phis])
    i = int(np.argmin(c))
    a, b = phis[max(i - 1, 0)], phis[min(i + 1, samples)]
    if b > a:
        r = minimize_scalar(cond, bounds=(a, b), method="bounded", options={"xatol": 1e-10 * max(1.0, hi)})
        if r.fun < c[i]:
            return float(r.fun), float(r.x)
    return float(c[i]), float(phis[i])


def crossing(u: UrdfModel, closures, driver: str, others: list[str], phi: float, x, exact, *, length: float = 1.0,
             iters: int = 60) -> dict:
    """Is the continued configuration ``x`` (others' angles, driver at ``phi``) that deviates from the
    exact one ``exact`` (same order) on another branch of the configuration curve crossing it? Polishes
    ``x`` by full Gauss-Newton steps to the rounding floor and measures the loop Jacobian (all joints) at
    ``exact``. Returns ``deviation`` (polished x vs exact, rad), ``residual`` (polished) and
    ``conditioning`` (smallest kept / largest singular value of the Jacobian, rank 1 + others - 1 kept):
    a closed x off ``exact`` at a near-singular ``exact`` is a branch crossing, not an error."""
    F0 = u.fk({})
    refs = [invert_pose(F0[a]) @ F0[b] for a, b in closures]
    x = np.array(x, float)
    for _ in range(iters):
        r, J = loop_residual(u, closures, refs, {driver: phi, **dict(zip(others, x))}, others, length)
        dx = np.linalg.lstsq(J, -r, rcond=1e-14)[0]
        if float(np.abs(dx).max()) < 1e-16:
            break
        x = x + dx
    r, _ = loop_residual(u, closures, refs, {driver: phi, **dict(zip(others, x))}, others, length, jacobian=False)
    return {"deviation": float(_wrapped(x - np.asarray(exact, float)).max()), "residual": float(np.linalg.norm(r)),
            "conditioning": jacobian_conditioning(u, closures, refs, driver, others, phi, exact, length)}
