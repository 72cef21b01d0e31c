"""The angle law of a revolute joint and its inverse (docs/conventions.md, "Angle laws").

A factor ``t - h`` of a motion polynomial, ``N(t - h) = (t - a)^2 + b^2`` with b > 0, turns its joint by
``theta(t) = 2 atan2(b, t - a)``: 0 at t = +-infinity, one full turn as t runs over R. A joint of
integer ``rate`` r (a factor ``(t - h)^r``: the same axis r times in a row) turns by ``r theta(t)``.
Everything here broadcasts over numpy arrays (a single value is a batch of one); angles in radians.
"""
from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def half_angle(a, b, t, rate=1) -> np.ndarray:
    """``rate * atan2(b, t - a)``, half the joint angle, not reduced (in [0, rate pi] for b > 0), 0 at
    t = +-inf: what a unit dual quaternion ``cos + sin (u - eps m)`` of the joint needs."""
    t = np.asarray(t, float)
    h = np.where(t == -np.inf, 0.0, np.arctan2(b, t - a))  # atan2(b, +inf) = 0 for finite b
    return h if isinstance(rate, int) and rate == 1 else np.multiply(rate, h)


def angle_law(a, b, t, rate=1) -> np.ndarray:
    """Joint angle ``rate * 2 atan2(b, t - a)`` in [0, 2 pi), 0 at t = +-inf; a, b, t, rate broadcast."""
    return np.mod(2.0 * half_angle(a, b, t, rate), TWO_PI)


def angle_law_inverse(a, b, theta, rate=1, branch=0) -> np.ndarray:
    """The parameter t where the joint is at angle ``theta``: t = a + b cot(phi / 2) with
    ``phi = (theta mod 2 pi + 2 pi branch) / rate`` (rate 1: the unique t; a joint of rate r reaches each
    angle at r parameters, ``branch`` = 0 .. r - 1). phi = 0 gives t = inf. Broadcasts."""
    phi = (np.mod(np.asarray(theta, float), TWO_PI) + TWO_PI * np.asarray(branch)) / np.asarray(rate, float)
    s, c = np.sin(phi / 2), np.cos(phi / 2)
    zero = (np.abs(s) < 1e-300) | (np.mod(phi, TWO_PI) == 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(zero, np.inf, a + b * c / np.where(zero, 1.0, s))


def driven_angle(a, b, ad, bd, phi, rate=1, driver_rate=1, continued=False) -> np.ndarray:
    """Angle of the joint (a, b, rate) when the driver joint (ad, bd, driver_rate) is at angle ``phi``,
    the driver's parameter being t = ad + bd cot(u), u = phi / (2 driver_rate): with s = sin(u),
    c = cos(u), ``theta = rate * 2 atan2(b s, (ad - a) s + bd c)``, exact at phi = 0 (t = infinity) too.
    In [0, 2 pi), or with ``continued`` continued over whole turns of u (any real phi; 0 at phi = 0):
    every pi of u adds ``rate`` turns, signed by b bd. Broadcasts."""
    u = np.asarray(phi, float) / (2.0 * np.asarray(driver_rate, float))
    turns = np.floor(u / np.pi)
    r = u - turns * np.pi
    full = r >= np.pi  # rounding
    turns, r = np.where(full, turns + 1, turns), np.where(full, r - np.pi, r)  # r in [0, pi)
    s, c = np.sin(r), np.cos(r)
    # the angle from (bd, 0) to (bd c + (ad - a) s, b s): within [0, pi) or (-pi, 0] by the sign of b bd
    g = np.arctan2(bd * b * s, bd * (bd * c + (ad - a) * s))
    th = np.multiply(rate, 2.0 * g + TWO_PI * turns * np.sign(b * bd))
    return th if continued else np.mod(th, TWO_PI)


def driven_speed(a, b, ad, bd, phi, rate=1, driver_rate=1) -> np.ndarray:
    """d theta / d phi of `driven_angle`: ``(rate / driver_rate) b bd / ((bd c + (ad - a) s)^2 + b^2 s^2)``
    with s = sin(u), c = cos(u), u = phi / (2 driver_rate). Broadcasts."""
    u = np.asarray(phi, float) / (2.0 * np.asarray(driver_rate, float))
    s, c = np.sin(u), np.cos(u)
    return np.multiply(np.divide(rate, driver_rate), b * bd / ((bd * c + (ad - a) * s) ** 2 + (b * s) ** 2))


def driven_speed_max(a, b, ad, bd, phi0, phi1, rate=1, driver_rate=1) -> tuple[np.ndarray, np.ndarray]:
    """The largest |`driven_speed`| over the driver's angles [phi0, phi1] (phi0 <= phi1, any real) and a
    driver angle where it is reached, exactly: the denominator of `driven_speed` is the quadratic form
    ``Q(u) = bd^2 c^2 + 2 bd (ad - a) c s + ((ad - a)^2 + b^2) s^2 = m + rho cos(2u - psi)``, smallest at
    ``u* = (psi + pi) / 2 + k pi`` when one lies in the arc (there ``Q = m - rho = (b bd)^2 / (m + rho)``,
    the determinant over the larger eigenvalue), else at an end. Broadcasts; (max, phi)."""
    dr = np.asarray(driver_rate, float)
    u0, u1 = np.asarray(phi0, float) / (2 * dr), np.asarray(phi1, float) / (2 * dr)
    A, B, C = bd * bd, bd * (ad - a), (ad - a) ** 2 + b * b
    m, x = (A + C) / 2, (A - C) / 2
    rho, psi = np.hypot(x, B), np.arctan2(B, x)
    star = (psi + np.pi) / 2
    k = np.ceil((u0 - star) / np.pi)
    inside = star + k * np.pi <= u1
    q0, q1 = m + rho * np.cos(2 * u0 - psi), m + rho * np.cos(2 * u1 - psi)
    u = np.where(inside, star + k * np.pi, np.where(q0 <= q1, u0, u1))
    q = np.where(inside, (b * bd) ** 2 / (m + rho), np.minimum(q0, q1))  # m - rho = det / (m + rho), no cancellation
    speed = np.abs(np.divide(rate, dr) * b * bd) / np.maximum(q, 1e-300)
    return speed, 2 * dr * u
