"""Self-checks of linkages: pose reproduction at the reported angles and loop closure over the whole
motion (docs/conventions.md). Errors are translation (metres) and rotation angle (radians).

One implementation, vectorized over a leading batch axis of linkages of the same structure
(`check_figures`); `self_check` is the batch of one for a `Linkage`. Forward kinematics uses unit dual
quaternions: a joint at theta about the line (u, m) is ``cos(theta/2) + sin(theta/2) (u - eps m)``; a
link's displacement, the product of its chain's joints, is expanded over products of the joint lines
(per linkage) weighted by products of the joints' cosines and sines (per linkage and sample), and every
comparison runs in the split layout (`synth.algebra.dq.dq_mul_split`): plain arithmetic on (linkages,
samples) arrays per component. The figures are rounding-level numbers: any other order of the same
arithmetic gives other last digits (the BLAS dot products used before, with fused multiply-adds, changed
them by up to 2e-14 on README's 20,000 batch jobs).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from synth.algebra.algorithm1 import identity
from synth.algebra.anglelaw import half_angle
from synth.algebra.dq import dot, dq_mul, dq_mul_split, dq_right_matrix, pose_to_dq, product_support
from synth.algebra.geometry import (dq_pose_difference, feature_difference, pose_difference, pose_difference_split,
                                    pose_features_split)
from synth.algebra.polynomial import evaluate, exponents, product_of_linear
from synth.linkage import Linkage
from synth.memory import pages_kept

_EPS = float(np.finfo(float).eps)
_ULPS16 = 16 * _EPS  # the rounding allowance of `loop_bound`
DEFAULT_CHECK_SAMPLES = 4  # synthesis functions check closure and motion at this many parameters
BOUND_CHECK_SAMPLES = 0  # Bennett: closure and motion bounded over the whole motion (`loop_bound`), no samples
VERIFY_SAMPLES = 200  # the CLI verifies this many before writing anything


def sample_parameters_batch(a, b, samples: int) -> np.ndarray:
    """Parameters (N, samples) covering the real line, ``centre + scale tan(phi)`` with centre and scale
    the mean a and b of each linkage's angle laws (a, b of shape (N, J)), the last one t = infinity."""
    J = a.shape[-1]
    centre = a.sum(axis=-1, keepdims=True) / J
    scale = np.maximum(b.sum(axis=-1, keepdims=True) / J, 1e-12)
    return centre + scale * _tangents(samples)


@functools.lru_cache(maxsize=16)
def _tangents(samples: int) -> np.ndarray:
    """tan(phi) at samples - 1 equally spaced phi in (-pi/2, pi/2), then inf (read-only, cached)."""
    phi = np.linspace(-np.pi / 2, np.pi / 2, samples + 1)[1:-1]
    out = np.concatenate([np.tan(phi), [np.inf]])
    out.flags.writeable = False
    return out


def sample_parameters(linkage: Linkage, samples: int = 200) -> np.ndarray:
    """Parameters t covering the real line (t = centre + scale tan(phi)) plus t = infinity."""
    a = np.array([[j.a for j in linkage.joints]])
    b = np.array([[j.b for j in linkage.joints]])
    return sample_parameters_batch(a, b, samples)[0]


def check_figures(structure, U, M, a, b, pose_angles, pose_dq, tool_ref_dq, motion, samples: int, rate=1) -> dict:
    """Self-check figures of N linkages of one structure, each an (N,) array.

    ``structure`` = (joints [(parent link, child link)] in tree order, tool link, closures [(link,
    duplicate)]); U, M (N, J, 3) Plücker lines (unit direction, moment) at the reference configuration;
    a, b (N, J) angle laws (``rate`` (N, J) or a scalar: their rates, `synth.algebra.anglelaw`); pose_angles (N, P, J) the reported joint angles at the poses, given as unit
    dual quaternions pose_dq (N, P, 8) (`synth.algebra.dq.pose_to_dq`); tool_ref_dq (N, 8); motion (N, n+1, 8) the motion polynomial. Figures: ``pose_translation`` /
    ``pose_rotation`` (tool frame at the reported angles vs the poses), ``closure_translation`` /
    ``closure_rotation`` (every welded pair at ``samples`` parameters covering R, t = inf included) and
    ``motion`` (tool link vs C(t), translation + rotation); ``samples`` = 0: poses only (closure and
    motion 0; see `loop_bound`). Forward kinematics in the split layout (`synth.algebra.dq.dq_mul_split`):
    every component an (N, P + samples) array over linkages x (poses, then samples)."""
    closures = structure[2]
    N, P, J = pose_angles.shape
    rows = max(1, (ROW_ELEMENTS_KEPT if pages_kept() else ROW_ELEMENTS) // (P + samples * (1 + len(closures))))
    rate = np.broadcast_to(rate, a.shape) if np.ndim(rate) else rate
    parts = [_check_rows(structure, *(x[k] for x in (U, M, a, b, pose_angles, pose_dq, tool_ref_dq, motion)), samples,
                         rate[k] if np.ndim(rate) else rate) for k in map(slice, range(0, N, rows), range(rows, N + rows, rows))]
    if len(parts) == 1:
        return parts[0]
    return {f: np.concatenate([p[f] for p in parts]) for f in parts[0]} if parts else {f: np.zeros(0) for f in _FIGURES}


_FIGURES = ("pose_translation", "pose_rotation", "closure_translation", "closure_rotation", "motion")
ROW_ELEMENTS = 8_000  # `check_figures` takes linkages in groups whose (group, P + S (1 + closures)) arrays hold
# at most this many numbers (64 kB: below the C allocator's threshold for fresh pages, `synth.memory`), or
ROW_ELEMENTS_KEPT = 64_000  # this many in a process that keeps freed pages (fewer numpy calls per linkage)


def _check_rows(structure, U, M, a, b, pose_angles, pose_dq, tool_ref_dq, motion, samples: int, rate) -> dict:
    """`check_figures` of a group of linkages."""
    joints, tool_link, closures = structure
    N, P, J = pose_angles.shape
    t = sample_parameters_batch(a, b, samples) if samples > 0 else np.zeros((N, 0))  # (N, S), the last t = inf
    S = t.shape[1]
    lines = np.zeros((N, J, 8))  # the joints' lines u - eps m
    lines[..., 1:4] = U
    np.negative(M, out=lines[..., 5:8])
    disp = {}
    for j, (parent, child) in enumerate(joints):
        c, s = _joint_cos_sin(a[:, j], b[:, j], t, pose_angles[..., j], rate if np.ndim(rate) == 0 else rate[:, j])
        disp[child] = _joint_product(disp.get(parent), c, s, lines[:, j])
    split = {}

    def link(name):  # a link's displacement in components
        if name not in split:
            split[name] = _components(disp[name])
        return split[name]

    # the pairs compared: the tool at the poses against the poses, the tool link along the motion against
    # C(t), the closure links against their duplicates (the features of each link once)
    tool = link(tool_link)
    poses, along = slice(None, P), slice(P, None)
    ref = [tool_ref_dq[:, k : k + 1] for k in range(8)]
    dt_p, dr_p = pose_difference_split(dq_mul_split(_columns(tool, poses), ref), pose_dq.transpose(2, 0, 1))
    features = {}

    def moving(name):
        if name not in features:
            features[name] = pose_features_split(_columns(link(name), along))
        return features[name]

    dt_m, dr_m = feature_difference(moving(tool_link), pose_features_split(_motion_at(motion, t)))
    closed = [feature_difference(moving(x), moving(y)) for x, y in closures]
    clo_t = np.concatenate([np.zeros((N, 0))] + [c[0] for c in closed], axis=1)
    clo_r = np.concatenate([np.zeros((N, 0))] + [c[1] for c in closed], axis=1)
    return {"pose_translation": dt_p.max(axis=1, initial=0.0), "pose_rotation": dr_p.max(axis=1, initial=0.0),
            "closure_translation": clo_t.max(axis=1, initial=0.0),
            "closure_rotation": clo_r.max(axis=1, initial=0.0),
            "motion": (dt_m + dr_m).max(axis=1, initial=0.0)}


MAX_TERMS = 8  # a link's displacement is kept expanded over products of joint lines up to this many terms
_ONE, _LINE = frozenset((0,)), frozenset((1, 2, 3, 5, 6, 7))  # the nonzero components of 1 and of a line


def _joint_product(parent, c, s, line) -> list:
    """The displacement of a joint's child link, ``parent`` (None: the base) times the joint's cos + sin
    line (c, s (N, R); line (N, 8) = u - eps m): expanded, a list of terms (weight (N, R), dual quaternion
    (N, 8), its nonzero components) (the base's 1 times the joint: c 1 + s line; a term w B times it:
    w c B + w s (B line)), or, once that would exceed MAX_TERMS terms, its split components
    (`synth.algebra.dq.dq_mul_split`)."""
    if parent is None:
        one = np.zeros_like(line)
        one[:, 0] = 1.0
        return [(c, one, _ONE), (s, line, _LINE)]
    if isinstance(parent, list) and 2 * len(parent) <= MAX_TERMS:
        return ([(w * c, B, nz) for w, B, nz in parent]
                + [(w * s, dq_mul(B, line), product_support(nz, _LINE)) for w, B, nz in parent])
    X = _components(parent)
    G = [c] + [s * line[:, k : k + 1] if k in _LINE else None for k in range(1, 8)]
    return dq_mul_split(X, G)


def _components(disp) -> list:
    """The split components (8 arrays (N, R), None where zero) of a displacement of `_joint_product`."""
    if not isinstance(disp[0], tuple):
        return disp
    out = []
    for k in range(8):
        acc = None
        for w, B, nz in disp:
            if k not in nz:
                continue
            x = w if nz is _ONE else w * B[:, k : k + 1]
            acc = (x.copy() if x is w else x) if acc is None else np.add(acc, x, out=acc)
        out.append(acc)
    return out


def _columns(X, columns) -> list:
    """The columns of the (N, P + S) components of split X (None stays None)."""
    return [None if x is None else x[:, columns] for x in X]


def _joint_cos_sin(a, b, t, pose_angles, rate):
    """cos and sin (N, P + S) of one joint's half angle at the reported pose angles (N, P) and at the
    parameters t (N, S) (a, b (N,)): for a joint of rate 1 ``atan2(b, t - a)`` by its cosine (t - a) / r
    and sine b / r, r = sqrt((t - a)^2 + b^2) (1 and 0 at t = inf), else by `half_angle`."""
    N, P = pose_angles.shape
    S = t.shape[1]
    cos = np.empty((N, P + S))
    sin = np.empty((N, P + S))
    half = 0.5 * pose_angles
    np.cos(half, out=cos[:, :P])
    np.sin(half, out=sin[:, :P])
    if S == 0:
        return cos, sin
    a, b = a[:, None], b[:, None]
    if np.ndim(rate) or rate != 1:
        half_s = half_angle(a, b, t, rate[:, None] if np.ndim(rate) else rate)
        np.cos(half_s, out=cos[:, P:])
        np.sin(half_s, out=sin[:, P:])
        return cos, sin
    x = cos[:, P:]
    np.subtract(t, a, out=x)  # t - a
    r = x * x
    r += b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        np.sqrt(r, out=r)
        np.divide(1.0, r, out=r)
        np.multiply(b, r, out=sin[:, P:])
        x *= r
    inf = np.isinf(t)
    np.copyto(x, 1.0, where=inf)
    np.copyto(sin[:, P:], 0.0, where=inf)
    return cos, sin


def _motion_at(motion, t) -> list:
    """C(t) (8 components (N, S)) of motion polynomials (N, n+1, 8) by Horner; t = inf gives the leading
    coefficient."""
    inf = np.isinf(t)
    tf = np.where(inf, 0.0, t)
    out = []
    for k in range(8):
        c = motion[:, :, k]
        y = np.repeat(c[:, -1:], t.shape[1], axis=1)
        for i in range(motion.shape[1] - 2, -1, -1):
            y *= tf
            y += c[:, i : i + 1]
        np.copyto(y, c[:, -1:], where=inf)
        out.append(y)
    return out


def loop_bound(U, M, a, b, branches, motion) -> dict:
    """Certified bounds, over the whole motion (every real t and t = inf), of the closure and motion errors
    of N single loops of two branches from the base to the coupler (docs/conventions.md, "Certified
    closure"). U, M (N, J, 3) lines, a, b (N, J) angle laws (b > 0); ``branches`` = (h, k) index arrays
    of equal length n, base to coupler; motion (N, n+1, 8) the monic motion polynomial.

    A joint at theta = 2 atan2(b, t - a) is ((t - a) + b (u - eps m)) / |t - z|, z = a + i b, so
    branch h is the unit P_h(t) / R(t), P_h = prod (t - f_j), f_j = a_j - b_j u_j + eps b_j m_j,
    R = prod |t - z_j|. Branch k and the motion are the poses of P_k(t) and C(t); a difference E of
    degree <= n from P_h has the partial fractions E(t) / prod (t - z_j) = E_n + sum_j rho_j / (t - z_j),
    rho_j = E(z_j) / prod_{m != j} (z_j - z_m), so |E(t)| / R(t) <= |E_n| + sum_j |rho_j| / b_j for
    every t (primal and dual parts separately), with |E(z_j)| <= sum_c |E_c| |z_j|^c (no complex arithmetic;
    on random sets 1% above the exact value at the median). Joints of rate 1 only (a joint of rate r is a repeated
    root, where no bound applies: such linkages are checked at samples, `check_figures`). Returns ``closure_translation``, ``closure_rotation``,
    ``motion`` (N,) (metres, radians; inf where no bound applies, e.g. repeated roots), with an
    allowance of 16 ulps for rounding."""
    hk = np.asarray(branches)  # (2, n)
    h = hk[0]
    n = h.shape[0]
    N = a.shape[0]
    F = np.empty(a.shape + (8,))
    F[..., 0] = a
    F[..., 4] = 0.0
    bb = b[..., None]
    np.multiply(U, -bb, out=F[..., 1:4])
    np.multiply(M, bb, out=F[..., 5:8])
    P = product_of_linear(F.take(hk, axis=1))  # (N, 2, n+1, 8): P_h, P_k
    E = np.empty(P.shape)  # P_h - P_k, P_h - C
    np.subtract(P[:, 0], P[:, 1], out=E[:, 0])
    np.subtract(P[:, 0], motion, out=E[:, 1])
    z = np.empty(a.shape, complex)  # (N, J) a + i b, then branch h's (N, n)
    z.real, z.imag = a, b
    z = z.take(h, axis=1)
    bh = z.imag
    with np.errstate(all="ignore"):
        # |E(z_j)| <= sum_c |E_c| |z_j|^c (primal and dual part), divided by b_j prod_{m != j} |z_j - z_m|:
        # sum_j |rho_j| / b_j <= sum_c W_c |E_c|, W_c = sum_j |z_j|^c / (b_j prod_{m != j} |z_j - z_m|)
        En = E.reshape(N, 2, n + 1, 2, 4)
        En = np.sqrt(dot(En, En))  # |E_c| (N, 2, n+1, primal / dual)
        gaps = np.abs((z[:, :, None] - z[:, None, :] + identity(n)).prod(axis=-1)) * bh  # (N, n)
        W = np.matmul((1.0 / gaps)[:, None, :], np.abs(z)[..., None] ** exponents(n))  # (N, 1, n+1)
        W[..., n] += 1.0  # |E_n|
        e = np.matmul(W[:, None], En)[:, :, 0]  # (N, 2, primal / dual): |E_n| + sum_j |rho_j| / b_j
        # with 16 ulps for the rounding of a forward-kinematics evaluation, so that the bound also covers
        # sampled figures (`check_figures`); Q bounds the dual part of branch h's unit dual quaternion
        Mh = M.take(h, axis=1)
        Q = np.sqrt(dot(Mh, Mh)).sum(axis=-1, keepdims=True)
        ep = e[..., 0] + _ULPS16
        ed = e[..., 1] + _ULPS16 * np.maximum(Q, 1.0)
        # poses of a unit X and of Y = X - D, |D| <= (ep, ed): rotation <= 4 asin(ep), translation
        # <= 2 s (ed (1 + ep) + Q ep (3 - ep)) with s = 1 / (1 - ep)^2 >= 1 / |primal Y|^2
        rot = 4.0 * np.arcsin(ep)
        tra = (2.0 / (1.0 - ep) ** 2) * (ed * (1.0 + ep) + Q * ep * (3.0 - ep))
        near = ep < 0.5  # (NaN: False)
        if not near.all():
            rot = np.where(near, rot, np.inf)
            tra = np.where(near, tra, np.inf)
    return {"closure_translation": tra[:, 0], "closure_rotation": rot[:, 0], "motion": tra[:, 1] + rot[:, 1],
            "motion_translation": tra[:, 1], "motion_rotation": rot[:, 1]}


def pose_bound(motion, ts, pose_dq, ref_dq, bound) -> dict:
    """Certified pose errors of N single loops at the reported angles (the angle laws at the finite pose
    parameters ``ts`` (P,)), without forward kinematics: there the tool link is the monic motion C at
    t_i to within the motion bound of `loop_bound` (``bound``), so the tool frame misses pose i by at
    most that bound plus the distance of C(t_i) Q_0 from Q_i (translation also plus the rotation bound
    times |d_0|: the reference pose Q_0 moves with the tool). The reference pose itself, at t = inf where
    C = 1 and every angle is 0, is exact. motion (N, n+1, 8), pose_dq (N, P, 8) and ref_dq (N, 8) unit
    dual quaternions (`synth.algebra.dq.pose_to_dq`). Returns ``pose_translation``, ``pose_rotation``
    (N,) in metres and radians."""
    X = np.empty((2,) + pose_dq.shape)
    np.matmul(evaluate(motion, ts), dq_right_matrix(ref_dq), out=X[0])  # C(t_i) Q_0
    X[1] = pose_dq
    dt, dr = dq_pose_difference(X)
    reach = 2.0 * np.sqrt(dot(ref_dq[:, 4:], ref_dq[:, 4:]))  # |d_0| (unit ref_dq)
    rot = bound["motion_rotation"]
    return {"pose_translation": dt.max(axis=1, initial=0.0) + bound["motion_translation"] + rot * reach,
            "pose_rotation": dr.max(axis=1, initial=0.0) + rot}


def structure(linkage: Linkage) -> tuple:
    """The `check_figures` structure of a linkage (joint tree, tool link, closures)."""
    return (tuple((j.parent, j.child) for j in linkage.joints), linkage.tool_link, tuple(map(tuple, linkage.closures)))


def linkage_figures(linkage: Linkage, samples: int) -> dict:
    """`check_figures` for one linkage (a batch of one), as floats (`loop_law_figures` for a linkage whose
    joints follow a loop law)."""
    js = linkage.joints
    if any(j.law is not None for j in js):
        return loop_law_figures(linkage, samples)
    lines = np.array([(j.direction, j.moment) for j in js], float)  # (J, 2, 3)
    a = np.array([[j.a for j in js]])
    b = np.array([[j.b for j in js]])
    rate = np.array([[j.rate for j in js]]) if any(j.rate != 1 for j in js) else 1
    ang = np.array([[[rec.joint_angles[j.name] for j in js] for rec in linkage.poses]], float).reshape(1, -1, len(js))
    T = np.array([rec.matrix for rec in linkage.poses] + [linkage.tool_ref], float)
    Q = pose_to_dq(T)
    out = check_figures(structure(linkage), lines[None, :, 0], lines[None, :, 1], a, b, ang, Q[None, :-1], Q[None, -1],
                        np.asarray(linkage.motion, float)[None], samples, rate)
    return {k: float(v[0]) for k, v in out.items()}


def loop_law_figures(linkage: Linkage, samples: int) -> dict:
    """The figures of `linkage_figures` for a linkage with loop laws (a planar four-bar, docs/fourbar.md),
    by forward kinematics: the tool frame at every pose's joint angles against the pose, and every welded
    pair along the joint angles at ``samples`` parameters covering the cycle. No motion polynomial: the
    motion figure is NaN."""
    T = np.array([rec.matrix for rec in linkage.poses], float).reshape(-1, 4, 4)
    disp = [linkage.tool_pose(rec.joint_angles) for rec in linkage.poses]
    pt, pr = pose_difference(np.array(disp).reshape(-1, 4, 4), T) if len(T) else (np.zeros(1), np.zeros(1))
    D = linkage.displacements(linkage.angles_at(sample_parameters(linkage, samples)))
    ct = cr = 0.0
    for a, b in linkage.closures:
        dt, dr = pose_difference(D[a], D[b])
        ct, cr = max(ct, float(np.max(dt))), max(cr, float(np.max(dr)))
    return {"pose_translation": float(np.max(pt, initial=0.0)), "pose_rotation": float(np.max(pr, initial=0.0)),
            "closure_translation": ct, "closure_rotation": cr, "motion": math.nan}


def as_checks(fig: dict, samples: int, length_scale: float, bounded: bool = False) -> dict[str, float]:
    """linkage.json's ``checks`` from the figures of one linkage; ``bounded``: the closure and motion
    figures are certified bounds over the whole motion (`loop_bound`), not only sampled."""
    pt, pr = fig["pose_translation"], fig["pose_rotation"]
    ct, cr = fig["closure_translation"], fig["closure_rotation"]
    out = {"max_pose_error": pt + pr, "max_pose_translation_error": pt, "max_pose_rotation_error": pr,
           "max_closure_error": ct + cr, "max_closure_translation_error": ct, "max_closure_rotation_error": cr,
           "max_motion_error": fig["motion"], "length_scale": length_scale, "samples": samples}
    if bounded:
        out["bounded"] = True
    return out


def link_displacements(linkage: Linkage, angles) -> dict[str, np.ndarray]:
    """Unit dual quaternions (..., 8) of every link's world displacement from the reference
    configuration for joint angles ``angles`` (J, ...) in the order of ``linkage.joints``."""
    th = 0.5 * np.asarray(angles, float)
    U = np.array([j.direction for j in linkage.joints], float)
    M = np.array([j.moment for j in linkage.joints], float)
    ex = (slice(None),) + (None,) * (th.ndim - 1)
    s = np.sin(th)[..., None]
    G = np.concatenate([np.cos(th)[..., None], s * U[ex], np.zeros(s.shape), -s * M[ex]], axis=-1)
    out: dict[str, np.ndarray] = {"base": np.broadcast_to(np.eye(8)[0], th.shape[1:] + (8,))}
    for i, j in enumerate(linkage.joints):
        out[j.child] = G[i] if j.parent == "base" else dq_mul(out[j.parent], G[i])
    return out


def pose_errors(linkage: Linkage) -> tuple[float, float]:
    """Largest (translation, rotation) error of the tool frame at every pose's joint angles."""
    f = linkage_figures(linkage, 2)
    return f["pose_translation"], f["pose_rotation"]


def closure_errors(linkage: Linkage, samples: int = 200) -> tuple[float, float]:
    """Largest (translation, rotation) mismatch of every welded pair over the sampled motion."""
    f = linkage_figures(linkage, samples)
    return f["closure_translation"], f["closure_rotation"]


def motion_error(linkage: Linkage, samples: int = 200) -> float:
    """Largest deviation (translation + rotation, over the sample) of the tool link's displacement from
    the motion polynomial C(t)."""
    return linkage_figures(linkage, samples)["motion"]


def self_check(linkage: Linkage, samples: int = 200) -> dict[str, float]:
    """All self-check figures (metres / radians) for linkage.json's ``checks``: pose errors at the
    reported angles of every pose, closure and motion errors at ``samples`` parameters covering R."""
    return as_checks(linkage_figures(linkage, samples), samples, linkage.extent())
