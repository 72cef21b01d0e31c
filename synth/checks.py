"""Self-checks of linkages: pose reproduction at the reported angles and loop closure over the whole
motion (docs/conventions.md). Errors are translation (metres) and rotation angle (radians).

One implementation, vectorized over a leading batch axis of linkages of the same structure
(`check_figures`); `self_check` is the batch of one for a `Linkage`. Forward kinematics uses unit dual
quaternions: a joint at angle theta about the line (u, m) is ``cos(theta/2) + sin(theta/2) (u - eps m)``,
one batched product per joint for all poses and samples at once.
"""
from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from synth.algebra.algorithm1 import identity
from synth.algebra.dq import dot, dq_mul, dq_right_matrix, pose_to_dq
from synth.algebra.geometry import chord_angle, dq_pose_difference, pose_difference, pose_difference_squares
from synth.algebra.polynomial import evaluate, exponents, product_of_linear

if TYPE_CHECKING:  # (annotations only: the batch's chunk path runs without the Linkage modules)
    from synth.linkage import Linkage

_E0 = np.eye(8)[0]
_EPS = float(np.finfo(float).eps)
_ULPS16 = 16 * _EPS  # the rounding allowance of `loop_bound`
DEFAULT_CHECK_SAMPLES = 4  # synthesis functions check closure and motion at this many parameters
BOUND_CHECK_SAMPLES = 0  # Bennett: closure and motion bounded over the whole motion (`loop_bound`), no samples
VERIFY_SAMPLES = 200  # the CLI verifies this many before writing anything
CHECK_ROWS = 4096  # linkage samples per group of `check_figures` (its component arrays stay in the caches)


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
    a, b (N, J) angle laws (``rate`` (N, J) or a scalar: their integer rates, the same in every row,
    `synth.algebra.anglelaw`); pose_angles (N, P, J) the reported joint angles at the poses, given as unit
    dual quaternions pose_dq (N, P, 8) (`synth.algebra.dq.pose_to_dq`); tool_ref_dq (N, 8); motion (N, n+1,
    8) the motion polynomial. Figures: ``pose_translation`` / ``pose_rotation`` (tool frame at the
    reported angles vs the poses), ``closure_translation`` / ``closure_rotation`` (every welded pair at
    ``samples`` parameters covering R, t = inf included) and ``motion`` (tool link vs C(t), translation
    + rotation); ``samples`` = 0: poses only (closure and motion 0; see `loop_bound`).

    The poses by forward kinematics at the reported angles. The samples through the angle laws: a joint
    at t is (t - a) + w, w = b (u - eps m), up to a positive scale that no pose figure sees (rate r: r such
    factors), so a link is a sum over the subsets of its chain's factors of the products of their
    scalars t - a_j (the weights, per sample) times the ordered products of the other factors' w_j (the
    constants, per linkage): `sample_terms`; C(t) = sum C_k t^k likewise. Every link of a linkage at every
    sample is one matrix product (constants x weights), compared in component arrays over linkages x
    samples (`synth.algebra.geometry.pose_difference_squares`), in groups of about CHECK_ROWS linkage
    samples: one code path, cheap for one linkage and per linkage in batches; a linkage's figures do not
    depend on the batch it is in. (The weights are products of the accurate t - a_j, so rounding stays
    relative to the product of the factors' sizes, as in forward kinematics.)"""
    joints, tool_link, closures = structure
    N, P, J = pose_angles.shape
    out = _pose_figures(joints, tool_link, U, M, pose_angles, pose_dq, tool_ref_dq)
    zero = np.zeros(N)
    out.update(closure_translation=zero, closure_rotation=zero, motion=zero.copy())
    if samples <= 0 or N == 0:
        return out
    links = tuple(dict.fromkeys([tool_link] + [x for x, _ in closures] + [y for _, y in closures]))
    terms = sample_terms(tuple(joints), links, tuple(_rates(rate, N, J).tolist()), motion.shape[-2] - 1)
    const, lead = _constants(terms, U, M, b, motion)  # (N, 8 (L + 1), K), (N, 8 (L + 1))
    t = sample_parameters_batch(a, b, samples)  # (N, S), the last t = inf
    L = len(links) + 1
    A = np.array([links.index(tool_link)] + [links.index(x) for x, _ in closures])  # compared with
    B = np.array([L - 1] + [links.index(y) for _, y in closures])  # C, the duplicates
    group = max(1, CHECK_ROWS // samples)
    fig = np.empty((3, N))
    with np.errstate(invalid="ignore"):
        for g in range(0, N, group):
            k = slice(g, g + group)
            X = np.matmul(const[k], _weights(terms[0], t[k], a[k]))  # (G, 8 L, S)
            X[:, :, -1] = lead[k]
            H = np.ascontiguousarray(X.reshape(X.shape[0], L, 8, samples).transpose(2, 1, 0, 3))  # (8, L, G, S)
            dt2, w2 = pose_difference_squares(H, A, B)  # (1 + K, G, S) each
            fig[0, k] = (np.sqrt(dt2[0]) + chord_angle(w2[0])).max(axis=-1)
            fig[1, k] = dt2[1:].max(axis=(0, 2), initial=0.0)
            fig[2, k] = w2[1:].max(axis=(0, 2), initial=0.0)
    out["motion"] = fig[0]
    out["closure_translation"] = np.sqrt(fig[1])
    out["closure_rotation"] = chord_angle(fig[2])
    return out


def _pose_figures(joints, tool_link, U, M, pose_angles, pose_dq, tool_ref_dq) -> dict:
    """``pose_translation`` / ``pose_rotation`` (N,) of `check_figures`: the tool frame by forward
    kinematics at the reported angles (N, P, J) against the poses."""
    N, P, J = pose_angles.shape
    half = 0.5 * pose_angles
    cos, sin = np.cos(half)[..., None], np.sin(half)[..., None]
    # the joint displacement G = cos + sin (u - eps m) multiplies on the right: x G = cos x + sin x R(line),
    # with R the right-multiplication matrix of the line (one 8x8 matrix per set and joint)
    lines = np.zeros(U.shape[:-1] + (8,))
    lines[..., 1:4] = U
    np.negative(M, out=lines[..., 5:8])
    disp = {}
    for j, (parent, child) in enumerate(joints):
        if parent == "base":
            disp[child] = cos[..., j, :] * _E0 + sin[..., j, :] * lines[:, None, j]
        else:
            x = disp[parent]
            disp[child] = cos[..., j, :] * x + sin[..., j, :] * (x @ dq_right_matrix(lines[:, j]))
    X = np.empty((2, N, P, 8))
    np.matmul(disp[tool_link], dq_right_matrix(tool_ref_dq), out=X[0])
    X[1] = pose_dq
    dt, dr = dq_pose_difference(X)
    return {"pose_translation": dt.max(axis=1, initial=0.0), "pose_rotation": dr.max(axis=1, initial=0.0)}


def _rates(rate, N: int, J: int) -> np.ndarray:
    """The joints' integer rates (J,) (the same in every one of the N rows)."""
    if isinstance(rate, int) and rate == 1:
        return np.ones(J, int)
    r = np.broadcast_to(np.asarray(rate), (N, J))
    if (r != r[:1]).any() or (r[0] != np.round(r[0])).any() or (r[0] < 1).any():
        raise ValueError("check_figures needs positive integer rates, the same for every linkage")
    return r[0].astype(int)


@functools.lru_cache(maxsize=64)
def sample_terms(joints: tuple, links: tuple, rates: tuple, n: int) -> tuple[tuple, tuple]:
    """The terms of `check_figures`' samples: each link's chain of factors from the base (joint indices,
    a joint of rate r r times) split every way into the factors that give their scalar t - a_j and the
    others, which give w_j in order; then the motion C's powers t^0 .. t^n. Returns (weights, terms):
    the distinct weights (() for 1, sorted joint tuples for products of scalars, ('t',) * k for t^k,
    the J single scalars first after 1) and the terms (link row, weight index, w joints in order; the
    motion's row L with k for t^k) (cached)."""
    up = {child: (parent, j) for j, (parent, child) in enumerate(joints)}
    weights = {(): 0, **{(j,): j + 1 for j in range(len(joints))}}
    terms = []
    for row, link in enumerate(links):
        chain = []
        while link != "base":
            link, j = up[link]
            chain[:0] = [j] * int(rates[j])
        for mask in range(1 << len(chain)):
            key = tuple(sorted(j for i, j in enumerate(chain) if mask >> i & 1))
            rest = tuple(j for i, j in enumerate(chain) if not mask >> i & 1)
            terms.append((row, weights.setdefault(key, len(weights)), rest))
    terms += [(len(links), weights.setdefault(("t",) * k, len(weights)), k) for k in range(n + 1)]
    return tuple(weights), tuple(terms)


def _constants(terms, U, M, b, motion) -> tuple[np.ndarray, np.ndarray]:
    """The constants of `sample_terms` (N, 8 (L + 1), K), K weights: column k sums the terms of weight k,
    each the ordered product of its w_j = b_j (u_j - eps m_j) (1 for none; the motion's: C_k) in the
    rows of its link; and every link's value at t = inf (N, 8 (L + 1)): its leading term's constant (1,
    and C's leading coefficient)."""
    weights, terms = terms
    N = U.shape[0]
    L = terms[-1][0] + 1
    w = np.zeros(U.shape[:-1] + (8,))
    bb = b[..., None]
    np.multiply(U, bb, out=w[..., 1:4])
    np.multiply(M, -bb, out=w[..., 5:8])
    out = np.zeros((N, L, 8, len(weights)))
    lead = np.zeros((N, L, 8))
    lead[..., 0] = 1.0
    for row, k, rest in terms:
        if row == L - 1:  # C's t^rest
            out[:, row, :, k] = motion[:, rest]
        elif not rest:
            out[:, row, 0, k] += 1.0
        else:
            x = w[:, rest[0]]
            for j in rest[1:]:
                x = dq_mul(x, w[:, j])
            out[:, row, :, k] += x
    lead[:, -1] = motion[:, -1]
    return out.reshape(N, 8 * L, len(weights)), lead.reshape(N, 8 * L)


def _weights(weights, t, a) -> np.ndarray:
    """The weights of `sample_terms` at the parameters t (G, S) (the last one inf, where they are 0: the
    values there are the leading constants, `_constants`): (G, K, S) products of the scalars t - a_j and
    the powers t^k."""
    G, J = a.shape
    W = np.empty((G, len(weights), t.shape[1]))
    W[:, 0] = 1.0
    np.subtract(t[:, None, :], a[:, :, None], out=W[:, 1 : J + 1])
    for k, key in enumerate(weights[J + 1 :], J + 1):
        x = [t if j == "t" else W[:, j + 1] for j in key]
        if len(x) == 1:
            W[:, k] = x[0]
            continue
        np.multiply(x[0], x[1], out=W[:, k])
        for y in x[2:]:
            W[:, k] *= y
    W[:, :, -1] = 0.0
    return W


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
