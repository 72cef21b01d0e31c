"""Bennett synthesis for many pose sets at once, vectorized over the sets.

``bennett_batch(poses)`` takes poses of shape (N, 3, 4, 4) (metres) and runs the whole pipeline of
`synth.synthesis.bennett.bennett` (MATH.md sections 6-7) as array operations over N: conditioning, relative
displacements, the conic, its norm polynomial, the quartic's roots (Ferrari through the resolvent cubic,
then Newton steps; batched companion-matrix eigenvalues for the few sets where that does not converge),
both orders of Algorithm 1, un-conditioning, Plücker lines, joint angles at the poses, and self-checks
(tool pose at every pose's angles; closure and motion at ``check_samples`` sampled parameters). There is
no Python loop over the sets in this numeric core.

Conventions (the same as `synth.synthesis.bennett`):

- joints are ordered ``h1, h2, k1, k2`` (branch h = h1 h2, branch k = k1 k2, C = (t-h1)(t-h2) =
  (t-k1)(t-k2)); h1 and k2 carry the norm factor whose root a + ib has the smaller real part a;
- lines are world Plücker lines at the first pose: ``lines[n, j] = (direction, moment)``, moment =
  point x direction (metres); angle laws ``laws[n, j] = (a, b)`` with theta(t) = 2 atan2(b, t - a);
- pose 0 is at t = inf (all angles 0), pose 1 at t = 0, pose 2 at t = 1; ``pose_angles[n, i, j]`` is
  the angle (rad, in [0, 2 pi)) of joint j at pose i;
- errors are translation (metres) and rotation angle (radians).

Sets that are not clearly generic (degenerate, nearly degenerate, or whose fast numerics are not at
full precision) are handed one by one to `synth.synthesis.bennett.bennett`, which either synthesizes them with the
general engine or refuses them; its message becomes the set's ``status``. One bad set never raises.
For random poses this is well under 1% of the sets; a batch of degenerate sets is therefore slow
(milliseconds per set), but every set gets exactly the answer and the message that `synth.synthesis.bennett` gives.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from synth.checks import DEFAULT_CHECK_SAMPLES
from synth.synthesis.conic import condition, conic, relative_displacements
from synth.algebra.polynomial import norm_poly
from synth.algebra.scalar import FAST_MAX_RESIDUAL, FAST_MIN_B, FAST_MIN_IMAG, FAST_MIN_SEPARATION, qmul

ACCEPT_TOL = 1e-8  # synth.synthesis.bennett.ACCEPT_TOL (checked in tests): sets above 0.1 x this go to synth.synthesis.bennett

JOINTS = ("h1", "h2", "k1", "k2")
TS = np.array([np.inf, 0.0, 1.0])
BATCH_MAX_RESIDUAL = FAST_MAX_RESIDUAL  # multiply-back error above this: the set goes to synth.synthesis.bennett


# ============================================================================ component-first algebra
# Quaternions as 4-tuples of arrays and dual quaternions as 8-tuples of arrays (one array per
# component): every operation is a few dozen ufunc calls on contiguous arrays, whatever the batch shape.
_qm = qmul  # the tuple product of synth.algebra.scalar works on tuples of arrays as well


def _dm(a, b):
    p = _qm(a[:4], b[:4])
    x = _qm(a[:4], b[4:])
    y = _qm(a[4:], b[:4])
    return p + (x[0] + y[0], x[1] + y[1], x[2] + y[2], x[3] + y[3])


def _dinv(h):
    p0, p1, p2, p3, q0, q1, q2, q3 = h
    a = p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3
    b = 2.0 * (p0 * q0 + p1 * q1 + p2 * q2 + p3 * q3)
    ia = 1.0 / a
    f = b / (a * a)
    return (p0 * ia, -p1 * ia, -p2 * ia, -p3 * ia, q0 * ia - p0 * f, -q1 * ia + p1 * f, -q2 * ia + p2 * f,
            -q3 * ia + p3 * f)


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _translation(h):
    """d = 2 vec(p q~)/|p|^2."""
    p0, p1, p2, p3, q0, q1, q2, q3 = h
    n = 2.0 / (p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3)
    return ((-p0 * q1 + p1 * q0 - p2 * q3 + p3 * q2) * n, (-p0 * q2 + p1 * q3 + p2 * q0 - p3 * q1) * n,
            (-p0 * q3 - p1 * q2 + p2 * q1 + p3 * q0) * n)


def _difference(A, B, dA=None):
    """(translation error, rotation angle) between the poses of dual quaternions A and B (``dA``: the
    translation of A if already known)."""
    dA = _translation(A) if dA is None else dA
    dB = _translation(B)
    dt = np.sqrt((dA[0] - dB[0]) ** 2 + (dA[1] - dB[1]) ** 2 + (dA[2] - dB[2]) ** 2)
    E = _qm((A[0], -A[1], -A[2], -A[3]), B[:4])
    dr = 2.0 * np.arctan2(np.sqrt(E[1] * E[1] + E[2] * E[2] + E[3] * E[3]), np.abs(E[0]))
    return dt, dr


def _split(x):
    """(..., 8) array -> tuple of 8 component arrays."""
    return tuple(np.moveaxis(np.asarray(x, float), -1, 0))


# ============================================================================ quartic roots
def _largest_cubic_root(b, c, d):
    """Largest real root of x^3 + b x^2 + c x + d (arrays): trigonometric / Cardano, then Newton."""
    p = c - b * b / 3.0
    q = 2.0 * b ** 3 / 27.0 - b * c / 3.0 + d
    disc = (q / 2.0) ** 2 + (p / 3.0) ** 3
    three = disc < 0
    r = np.sqrt(np.where(three, -p / 3.0, 0.0))
    arg = np.clip(-q / np.where(three, 2.0 * r ** 3, 1.0), -1.0, 1.0)
    x_trig = 2.0 * r * np.cos(np.arccos(arg) / 3.0)
    s = np.sqrt(np.where(three, 0.0, disc))
    x_card = np.cbrt(-q / 2.0 + s) + np.cbrt(-q / 2.0 - s)
    x = np.where(three, x_trig, x_card) - b / 3.0
    for _ in range(3):
        f = ((x + b) * x + c) * x + d
        df = (3.0 * x + 2.0 * b) * x + c
        x = x - np.where(df != 0, f / np.where(df != 0, df, 1.0), 0.0)
    return x


def quartic_upper_roots(n0, n1, n2, n3):
    """Roots with the two largest imaginary parts of the monic quartics t^4 + n3 t^3 + n2 t^2 + n1 t + n0
    (arrays (N,)), polished by 3 Newton steps on the quartic: complex (N, 2). Ferrari (as
    `synth.algebra.scalar.quartic_roots`); sets where Newton does not settle get companion-matrix eigenvalues."""
    s = n3 / 4.0
    p = n2 - 6.0 * s * s
    q = n1 - 2.0 * n2 * s + 8.0 * s ** 3
    r = n0 - n1 * s + n2 * s * s - 3.0 * s ** 4
    m = _largest_cubic_root(p, p * p / 4.0 - r, -q * q / 8.0)
    pos = m > 0
    w = np.sqrt(np.where(pos, 2.0 * m, 1.0))
    k = q / (2.0 * w)
    roots = []
    for sgn in (1.0, -1.0):
        B = -sgn * w
        Cq = p / 2.0 + m + sgn * k
        sq = np.sqrt((B * B / 4.0 - Cq).astype(complex))
        roots += [-B / 2.0 + sq - s, -B / 2.0 - sq - s]
    # biquadratic fallback (q = 0, m = 0)
    sq = np.sqrt((p * p / 4.0 - r).astype(complex))
    bi = []
    for y2 in (-p / 2.0 + sq, -p / 2.0 - sq):
        y = np.sqrt(y2)
        bi += [y - s, -y - s]
    Z = np.where(pos[:, None], np.stack(roots, 1), np.stack(bi, 1))  # (N, 4)
    Z = np.take_along_axis(Z, np.argsort(-Z.imag, axis=1)[:, :2], axis=1)
    coeffs = (n0[:, None], n1[:, None], n2[:, None], n3[:, None])
    Z, step = _newton(coeffs, Z, 3)
    bad = ~(np.abs(step) <= 1e-10 * np.maximum(1.0, np.abs(Z))).all(axis=1)
    bad &= np.isfinite(n0) & np.isfinite(n1) & np.isfinite(n2) & np.isfinite(n3)
    if np.any(bad):
        i = np.flatnonzero(bad)
        comp = np.zeros((len(i), 4, 4))
        comp[:, 0, :] = -np.stack([n3[i], n2[i], n1[i], n0[i]], 1)
        comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
        E = np.linalg.eigvals(comp)
        E = np.take_along_axis(E, np.argsort(-E.imag, axis=1)[:, :2], axis=1)
        Z[i], _ = _newton(tuple(c[i] for c in coeffs), E, 3)
    return Z


def _newton(c, z, iterations):
    n0, n1, n2, n3 = c
    step = np.zeros_like(z)
    for _ in range(iterations):
        f = (((z + n3) * z + n2) * z + n1) * z + n0
        df = ((4.0 * z + 3.0 * n3) * z + 2.0 * n2) * z + n1
        ok = df != 0
        step = np.where(ok, f / np.where(ok, df, 1.0), 0.0)
        z = z - step
    return z, step


# ============================================================================ result
@dataclass
class BennettBatch:
    """Per-set results of `bennett_batch`. Arrays have the sets on axis 0; rows of sets that failed
    (``ok[n]`` False) are NaN and ``status[n]`` says why (the message `synth.synthesis.bennett` raises)."""

    poses: np.ndarray  # (N, 3, 4, 4) input, metres
    ok: np.ndarray  # (N,) bool: a linkage was synthesized
    status: list  # N strings: "" when ok, else the reason (SynthesisError / InputError message)
    lines: np.ndarray  # (N, 4, 2, 3): joints h1, h2, k1, k2; (direction, moment) at the first pose
    laws: np.ndarray  # (N, 4, 2): angle laws (a, b), theta(t) = 2 atan2(b, t - a)
    pose_angles: np.ndarray  # (N, 3, 4): joint angles (rad, [0, 2pi)) at the poses (t = inf, 0, 1)
    factors: np.ndarray  # (N, 4, 8): t - h of joints h1, h2, k1, k2 (world frame, metres)
    motion: np.ndarray  # (N, 3, 8): the monic motion polynomial C (world frame), constant term first
    study_form: np.ndarray  # (N, 3): B01, B02, B12 in metres
    centre: np.ndarray  # (N, 3): conditioning centre (centroid of the positions)
    scale: np.ndarray  # (N,): conditioning scale (RMS spread of the positions)
    residual: np.ndarray  # (N,): largest multiply-back error of the two factorizations (conditioned)
    bennett: dict  # a, alpha, b, beta, opposite_length_mismatch, opposite_twist_mismatch: each (N,)
    errors: dict  # pose_translation, pose_rotation, closure_translation, closure_rotation, motion: (N,)
    relative_error: np.ndarray = None  # (N,): the figure synth.synthesis.bennett's acceptance gate compares to 1e-8
    check_samples: int = DEFAULT_CHECK_SAMPLES
    names: list = field(default_factory=lambda: ["p0", "p1", "p2"])
    general: np.ndarray = None  # (N,) bool: the set went through synth.synthesis.bennett (general engine)

    def __len__(self) -> int:
        return len(self.ok)

    @property
    def max_pose_error(self) -> np.ndarray:
        return self.errors["pose_translation"] + self.errors["pose_rotation"]

    @property
    def max_closure_error(self) -> np.ndarray:
        return self.errors["closure_translation"] + self.errors["closure_rotation"]

    def linkage(self, i: int, names=None):
        """The full `Linkage` of set i (joints, branches, poses, info, checks), equal to
        ``synth.bennett(poses[i], names, check_samples=self.check_samples)`` up to rounding. Raises the
        set's SynthesisError / InputError when it failed."""
        from synth.synthesis.assemble import two_branch_linkage
        from synth.synthesis.bennett import _finish
        from synth.errors import InputError, SynthesisError
        from synth.synthesis.conic import Conditioning

        i = int(i)
        if not self.ok[i]:
            msg = self.status[i]
            raise (InputError if msg.startswith("the poses contain") else SynthesisError)(msg)
        names = list(names) if names is not None else list(self.names)
        if self.general[i]:  # synthesized by synth.synthesis.bennett
            from synth.synthesis.bennett import bennett

            return bennett(self.poses[i], names, check_samples=self.check_samples)
        cond = Conditioning(centre=self.centre[i].copy(), scale=float(self.scale[i]))
        B = self.study_form[i] / cond.scale
        info = {"factorization_residual": float(self.residual[i]),
                "study_form": {k: float(v) for k, v in zip(("B01", "B02", "B12"), self.study_form[i])},
                "conditioning": {"centre": cond.centre.tolist(), "scale": cond.scale}}
        F = self.factors[i]
        linkage = two_branch_linkage("bennett", F[:2], F[2:], self.motion[i], self.poses[i], names, TS, info)
        return _finish(linkage, B.tolist(), cond, self.check_samples)


# ============================================================================ the pipeline
def bennett_batch(poses, *, check_samples: int = DEFAULT_CHECK_SAMPLES, names=None) -> BennettBatch:
    """Bennett linkages for N pose sets, array of shape (N, 3, 4, 4) in metres (see the module
    docstring for conventions). ``check_samples``: parameters (covering R, as `synth.checks`) at which
    closure and motion are verified for each set. Raises InputError only for a wrong overall shape."""
    from synth.errors import InputError

    T = np.asarray(poses, float)
    if T.ndim != 4 or T.shape[1:] != (3, 4, 4):
        raise InputError(f"bennett_batch needs poses of shape (N, 3, 4, 4), got {T.shape}")
    names = list(names) if names is not None else ["p0", "p1", "p2"]
    with np.errstate(all="ignore"):
        out = _core(T, check_samples)
    out.update(poses=T, check_samples=check_samples, names=names)
    res = BennettBatch(**out)
    _fallback(res, np.flatnonzero(res.general), names)
    return res


def _nan(*shape):
    return np.full(shape, np.nan)


def _core(T, S):
    N = T.shape[0]
    finite = np.isfinite(T).all(axis=(1, 2, 3))
    Tf = np.where(finite[:, None, None, None], T, np.eye(4))
    Tc, cond = condition(Tf)
    c, L = cond.centre, cond.scale  # (N, 3), (N,)
    D = relative_displacements(Tc)  # (N, 3, 8)
    con = conic(D)
    C = con.C  # (N, 3, 8) conditioned
    B = con.B  # (N, 3)
    Nc = norm_poly(C)  # (N, 5)
    Z = quartic_upper_roots(Nc[:, 0], Nc[:, 1], Nc[:, 2], Nc[:, 3])
    # sort the two roots by (real, imag): za has the smaller real part (h1, k2)
    swap = (Z[:, 1].real < Z[:, 0].real) | ((Z[:, 1].real == Z[:, 0].real) & (Z[:, 1].imag < Z[:, 0].imag))
    Z = np.where(swap[:, None], Z[:, ::-1], Z)
    absz = np.abs(Z)
    good = (finite & (np.min(np.abs(B), axis=1) > FAST_MIN_B)
            & np.all(Z.imag > FAST_MIN_IMAG * np.maximum(1.0, absz), axis=1)
            & (np.abs(Z[:, 0] - Z[:, 1]) > FAST_MIN_SEPARATION * np.maximum(1.0, absz.max(axis=1))))
    quads = np.stack([absz ** 2, -2.0 * Z.real], -1)  # (N, 2, [c0, c1])
    c0, c1 = _split(C[:, 0]), _split(C[:, 1])
    prim_scale = np.maximum(np.sqrt(c0[0] ** 2 + c0[1] ** 2 + c0[2] ** 2 + c0[3] ** 2),
                            np.maximum(np.sqrt(c1[0] ** 2 + c1[1] ** 2 + c1[2] ** 2 + c1[3] ** 2), 1.0))
    cmax = np.maximum(1.0, np.abs(C[:, :2]).max(axis=(1, 2)))
    fac = {}
    residual = np.zeros(N)
    for branch, right in (("h", 1), ("k", 0)):
        m0, m1 = quads[:, right, 0], quads[:, right, 1]
        r1 = (c1[0] - m1,) + c1[1:]
        r0 = (c0[0] - m0,) + c0[1:]
        good &= np.sqrt(r1[0] ** 2 + r1[1] ** 2 + r1[2] ** 2 + r1[3] ** 2) > 1e-9 * prim_scale
        g = _dm(_dinv(r1), r0)
        h2 = tuple(-x for x in g)
        h1 = tuple(-(a + b) for a, b in zip(c1, h2))
        p0 = _dm(h1, h2)
        res = np.maximum(np.max(np.abs(np.stack(p0) - np.stack(c0)), axis=0),
                         np.max(np.abs(-(np.stack(h1) + np.stack(h2)) - np.stack(c1)), axis=0)) / cmax
        residual = np.maximum(residual, res)
        for h in (h1, h2):
            good &= np.sqrt(h[1] ** 2 + h[2] ** 2 + h[3] ** 2) > 1e-7 * (1 + np.abs(h[0]))
        fac[branch] = (h1, h2)
    good &= residual <= BATCH_MAX_RESIDUAL

    # ---------------------------------------------------------------- world frame
    cx, cy, cz = c[:, 0], c[:, 1], c[:, 2]

    def world(h):
        p1, p2, p3 = h[1], h[2], h[3]
        return (h[0], p1, p2, p3, h[4] * L, h[5] * L + (p2 * cz - p3 * cy), h[6] * L + (p3 * cx - p1 * cz),
                h[7] * L + (p1 * cy - p2 * cx))

    Fw = [world(h) for h in (fac["h"][0], fac["h"][1], fac["k"][0], fac["k"][1])]  # h1 h2 k1 k2
    factors = np.stack([np.stack(h, -1) for h in Fw], 1)  # (N, 4, 8)
    motion = np.stack([np.stack(world(_split(C[:, k])), -1) for k in range(3)], 1)  # (N, 3, 8)
    a = np.stack([h[0] for h in Fw], 1)  # (N, 4)
    v = [np.stack([h[k] for h in Fw], 1) for k in (1, 2, 3)]
    w = [np.stack([h[k] for h in Fw], 1) for k in (5, 6, 7)]
    b = np.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    U = tuple(-x / b for x in v)
    M = tuple(x / b for x in w)
    lines = np.stack([np.stack(U, -1), np.stack(M, -1)], 2)  # (N, 4, 2, 3)
    laws = np.stack([a, b], -1)
    th = np.mod(2.0 * np.arctan2(b[:, None, :], TS[None, 1:, None] - a[:, None, :]), 2 * np.pi)
    pose_angles = np.concatenate([np.zeros((N, 1, 4)), th], axis=1)  # (N, 3, 4)

    # ---------------------------------------------------------------- Bennett parameters: loop h1 h2 k2 k1
    loop = (0, 1, 3, 2)
    geo = [_pair_geometry(tuple(x[:, loop[i]] for x in U), tuple(x[:, loop[i]] for x in M),
                          tuple(x[:, loop[(i + 1) % 4]] for x in U), tuple(x[:, loop[(i + 1) % 4]] for x in M))
           for i in range(4)]
    (a1, al1), (b1, be1), (a2, al2), (b2, be2) = geo
    scale_ab = np.maximum(np.maximum(a1, b1), 1e-300)
    bennett = {"a": a1, "alpha": al1, "b": b1, "beta": be1,
               "opposite_length_mismatch": np.maximum(np.abs(a1 - a2), np.abs(b1 - b2)) / scale_ab,
               "opposite_twist_mismatch": np.maximum(np.abs(np.abs(al1) - np.abs(al2)),
                                                     np.abs(np.abs(be1) - np.abs(be2)))}

    # ---------------------------------------------------------------- self-checks
    errors = _checks(T, Tf, U, M, a, b, pose_angles, motion, S)
    # the acceptance gate of synth.synthesis.bennett (`_accept`): sets near its threshold go to synth.synthesis.bennett
    rel = _relative_error(Tf, U, M, c, L, errors)
    good &= rel <= 0.1 * ACCEPT_TOL

    bad = ~good
    for arr in [lines, laws, pose_angles, factors, motion, residual, *bennett.values(), *errors.values()]:
        arr[bad] = np.nan
    status = ["" if g else "?" for g in good.tolist()]
    for i in np.flatnonzero(~finite).tolist():
        status[i] = "the poses contain NaN or infinity"
    rel[bad] = np.nan
    return dict(ok=good.copy(), status=status, lines=lines, laws=laws, pose_angles=pose_angles, factors=factors,
                motion=motion, study_form=B * L[:, None], centre=c, scale=L, residual=residual, bennett=bennett,
                errors=errors, relative_error=rel, general=finite & ~good)


def _relative_error(T, U, M, c, L, errors):
    """`synth.synthesis.bennett._accept`'s figure: largest self-check error relative to the pose spread (closure:
    to the axes' largest distance from the centroid), with its rounding floor of the coordinates."""
    from synth.synthesis.bennett import EPS, FLOOR_ULPS

    cu = _cross(tuple(x[:, None] for x in (c[:, 0], c[:, 1], c[:, 2])), U)  # (N, 4) each
    dist = np.sqrt(sum((m - x) ** 2 for m, x in zip(M, cu))).max(axis=1)
    size = np.maximum(L, dist)
    floor = FLOOR_ULPS * EPS * np.abs(T[:, :, :3, 3]).max(axis=(1, 2))
    return np.maximum.reduce([errors["pose_translation"] / (L + floor / ACCEPT_TOL), errors["pose_rotation"],
                              errors["closure_translation"] / (size + floor / ACCEPT_TOL),
                              errors["closure_rotation"]])


def _pair_geometry(u1, m1, u2, m2):
    """Distance and signed twist (as `synth.algebra.scalar.pair_geometry`) of line pairs, arrays (N,)."""
    p1, p2 = _cross(u1, m1), _cross(u2, m2)
    cr = _cross(u1, u2)
    s2 = _dot(cr, cr)
    par = s2 < 1e-24
    s2s = np.where(par, 1.0, s2)
    d = tuple(y - x for x, y in zip(p1, p2))
    s1 = _dot(_cross(d, u2), cr) / s2s
    s2_ = _dot(_cross(d, u1), cr) / s2s
    k = _dot(tuple(x - y for x, y in zip(p1, p2)), u2)
    f1 = tuple(np.where(par, p, p + s1 * u) for p, u in zip(p1, u1))
    f2 = tuple(np.where(par, p + k * u, p + s2_ * u) for p, u in zip(p2, u2))
    dv = tuple(y - x for x, y in zip(f1, f2))
    dist = np.sqrt(_dot(dv, dv))
    nc = np.sqrt(s2)
    use_d = dist > 1e-12
    use_c = ~use_d & (nc > 1e-12)
    n = tuple(np.where(use_d, x / np.where(use_d, dist, 1.0), np.where(use_c, y / np.where(use_c, nc, 1.0), 0.0))
              for x, y in zip(dv, cr))
    twist = np.arctan2(_dot(cr, n), _dot(u1, u2))
    return dist, twist


def _checks(T, Tf, U, M, a, b, pose_angles, motion, S):
    """Pose errors (tool frame of branch h at each pose's angles), closure (coupler vs coupler_k) and
    motion (coupler vs C(t)) errors at S parameters t = centre + scale tan(phi) and t = inf (as
    `synth.checks.sample_parameters`). Returns a dict of (N,) arrays."""
    from synth.algebra.dq import pose_to_dq

    N = T.shape[0]
    centre = a.mean(axis=1)
    scale = np.maximum(b.mean(axis=1), 1e-12)
    phi = np.linspace(-np.pi / 2, np.pi / 2, S + 1)[1:-1]
    t = centre[:, None] + scale[:, None] * np.tan(phi)[None, :]  # (N, S-1); plus t = inf below
    # half-angle cos/sin, joint-major (4, N, 3 + S) so that every component array is contiguous: poses
    # from the reported angles, samples from the angle law, t = inf last
    aj, bj = np.ascontiguousarray(a.T)[:, :, None], np.ascontiguousarray(b.T)[:, :, None]  # (4, N, 1)
    hp = 0.5 * np.moveaxis(pose_angles, 2, 0)  # (4, N, 3)
    e = t[None] - aj  # (4, N, S-1)
    r = np.hypot(e, bj)
    cs = np.concatenate([np.cos(hp), e / r, np.ones((4, N, 1))], axis=2)
    sn = np.concatenate([np.sin(hp), bj / r, np.zeros((4, N, 1))], axis=2)
    Uj = [np.ascontiguousarray(x.T)[:, :, None] for x in U]  # (4, N, 1)
    Mj = [np.ascontiguousarray(x.T)[:, :, None] for x in M]

    def G(j):
        c, s = cs[j], sn[j]
        return (c, s * Uj[0][j], s * Uj[1][j], s * Uj[2][j], np.zeros_like(c), -s * Mj[0][j], -s * Mj[1][j],
                -s * Mj[2][j])

    P = 3
    coupler = _dm(G(0), G(1))  # branch h: h1 then h2, at the poses and the samples
    sample = (slice(None), slice(P, None))
    coupler_k = _dm(tuple(x[sample] for x in G(2)), tuple(x[sample] for x in G(3)))  # samples only
    Hd = _split(pose_to_dq(Tf))  # components (N, 3)
    ref = tuple(x[:, :1] for x in Hd)  # tool_ref = pose 0
    tool = _dm(tuple(x[:, :P] for x in coupler), ref)
    pt, pr = _difference(tool, Hd)
    cs_ = tuple(x[sample] for x in coupler)
    d_cs = _translation(cs_)
    ct, cr = _difference(cs_, coupler_k, d_cs)
    # C(t) by Horner; t = inf -> leading coefficient
    Cm = _split(motion)  # components (N, 3)
    Ct = tuple((x[:, 2:3] * t + x[:, 1:2]) * t + x[:, 0:1] for x in Cm)
    Ct = tuple(np.concatenate([y, x[:, 2:3]], axis=1) for x, y in zip(Cm, Ct))
    mt, mr = _difference(cs_, Ct, d_cs)
    return {"pose_translation": pt.max(axis=1), "pose_rotation": pr.max(axis=1),
            "closure_translation": ct.max(axis=1), "closure_rotation": cr.max(axis=1),
            "motion": (mt + mr).max(axis=1)}


def _fallback(res: BennettBatch, idx, names):
    """Sets not handled by the vectorized core: synth.synthesis.bennett decides (result or message)."""
    from synth.synthesis.bennett import bennett
    from synth.errors import MpsynthError

    for i in idx.tolist():
        try:
            L = bennett(res.poses[i], names, check_samples=res.check_samples)
        except MpsynthError as e:
            res.status[i] = str(e)
            continue
        except Exception as e:  # never let one set break the batch
            res.status[i] = f"internal error: {type(e).__name__}: {e}"
            continue
        _fill(res, i, L)


def _fill(res: BennettBatch, i, L):
    J = {j.name: j for j in L.joints}
    for n, name in enumerate(JOINTS):
        j = J[name]
        res.lines[i, n] = (j.direction, j.moment)
        res.laws[i, n] = (j.a, j.b)
        res.factors[i, n] = np.concatenate([[j.a], -j.direction * j.b, [0.0], j.moment * j.b])
        for k, rec in enumerate(L.poses):
            res.pose_angles[i, k, n] = rec.joint_angles[name]
    res.motion[i] = L.motion
    res.study_form[i] = [L.info["study_form"][k] for k in ("B01", "B02", "B12")]
    res.residual[i] = L.info["factorization_residual"]
    for k in res.bennett:
        res.bennett[k][i] = L.info["bennett"][k]
    c = L.checks
    res.errors["pose_translation"][i] = c["max_pose_translation_error"]
    res.errors["pose_rotation"][i] = c["max_pose_rotation_error"]
    res.errors["closure_translation"][i] = c["max_closure_translation_error"]
    res.errors["closure_rotation"][i] = c["max_closure_rotation_error"]
    res.errors["motion"][i] = c["max_motion_error"]
    res.relative_error[i] = L.info.get("relative_error", np.nan)
    res.ok[i] = True
    res.status[i] = ""
