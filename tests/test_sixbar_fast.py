"""Fast paths of the default 6R synthesis (issues 4 and 7) against their general counterparts: the
plain-float DH table (`synth.synthesis.sixbar.loop_dh`) bitwise against the vectorized formulas it replaces, and
the direct LAPACK kernels (`synth.algebra.lapack`) bitwise against `numpy.linalg`."""
from __future__ import annotations

import importlib
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra import lapack
from synth.synthesis.cubic import _cross, _pair_geometry
from synth.linkage import Joint, Linkage

from test_sixbar import random_poses

sb = importlib.import_module("synth.synthesis.sixbar")


def _atan2(y, x):
    """Elementwise libm atan2 (math.atan2, which `loop_dh` calls). numpy's np.arctan2 takes a SIMD kernel
    on some CPUs (AVX-512: ~7% of random arguments differ from libm in the last bit), so the former
    vectorized formula is not bitwise the same number on every machine; everything else in it is."""
    return np.array([math.atan2(a, b) for a, b in zip(y, x)])


def loop_dh_vectorized(linkage, loop):
    """The former `loop_dh` (numpy, all joints at once; atan2 from libm, see `_atan2`): the reference."""
    J = [linkage.joint(n) for n in loop]
    u = np.array([j.direction for j in J]).T
    mo = np.array([j.moment for j in J]).T
    nxt = np.r_[1:len(J), 0]
    dist, _, f_out, f_in_next = _pair_geometry(u, mo, u[:, nxt], mo[:, nxt])
    c = _cross(u, u[:, nxt])
    cn = np.sqrt(np.sum(c * c, 0))
    with np.errstate(all="ignore"):
        n = np.where(dist > 1e-12, (f_in_next - f_out) / dist, np.where(cn > 1e-12, c / cn, 0.0))
    twist = _atan2(np.sum(c * n, 0), np.sum(u * u[:, nxt], 0))
    prev = np.r_[len(J) - 1, 0:len(J) - 1]
    f_in, n_in = f_in_next[:, prev], n[:, prev]
    d = np.sum((f_out - f_in) * u, 0)
    theta = _atan2(np.sum(_cross(n_in, n) * u, 0), np.sum(n_in * n, 0))
    return [{"joint": loop[i], "next": loop[int(nxt[i])], "a": float(dist[i]), "alpha": float(twist[i]),
             "d": float(d[i]), "theta": float(theta[i])} for i in range(len(J))]


def ring(U, M):
    """A linkage whose joints h1.. carry the lines (U[i], M[i]) (only the lines matter to loop_dh)."""
    names = [f"j{i}" for i in range(len(U))]
    joints = [Joint(n, "base", f"l{i}", np.array(u, float), np.array(m, float), 0.0, 1.0)
              for i, (n, u, m) in enumerate(zip(names, U, M))]
    return Linkage("6r", joints, {}, [names], [], np.eye(4), None), names


def same(a, b):
    assert json.dumps(a) == json.dumps(b)  # bitwise, signed zeros included


@pytest.mark.parametrize("seed", range(20))
def test_loop_dh_bitwise_on_synthesized_linkages(seed):
    T = random_poses(np.random.default_rng(8000 + seed), scale=10 ** (seed % 5 - 2), offset=(seed % 3) * 100.0)
    try:
        lk = sb.sixbar(T)
    except Exception:
        return
    same(sb.loop_dh(lk, sb.LOOP), loop_dh_vectorized(lk, sb.LOOP))


unit = st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).filter(lambda v: 1e-3 < sum(x * x for x in v))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(unit, st.tuples(*[st.floats(-10, 10, allow_nan=False)] * 3)), min_size=3, max_size=6),
       st.integers(0, 3))
def test_loop_dh_bitwise_on_random_lines(lines, special):
    U, M = [], []
    for u, p in lines:
        u = np.array(u) / np.linalg.norm(u)
        U.append(u)
        M.append(np.cross(p, u))
    if special == 1:  # consecutive parallel axes
        U[1] = U[0].copy()
    elif special == 2:  # consecutive intersecting axes (through a common point)
        M[1] = np.cross(np.cross(U[0], M[0]), U[1])
    elif special == 3:  # coincident axes, and signed zeros in the data
        U[1], M[1] = U[0].copy(), M[0].copy()
        U[2] = np.array([0.0, -0.0, 1.0])
        M[2] = np.array([-0.0, 0.0, 0.0])
    lk, names = ring(U, M)
    same(sb.loop_dh(lk, names), loop_dh_vectorized(lk, names))


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([(4, 8), (8, 4), (3, 5), (2, 2), (6, 6)]))
def test_lapack_kernels_bitwise(seed, shape):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=shape) * 10 ** rng.uniform(-3, 3)
    assert np.array_equal(lapack.qr_q(a), np.linalg.qr(a)[0])
    assert np.array_equal(lapack.svd_values(a), np.linalg.svd(a, compute_uv=False))
    for x, y in zip(lapack.svd(a), np.linalg.svd(a)):
        assert np.array_equal(x, y)
    batch = rng.normal(size=(3,) + shape)
    for x, y in zip(lapack.svd(batch), np.linalg.svd(batch)):
        assert np.array_equal(x, y)
    s = a[:, :shape[0]] if shape[1] >= shape[0] else a[:shape[1]]
    s = s + s.T
    for x, y in zip(lapack.eigh(s), np.linalg.eigh(s)):
        assert np.array_equal(x, y)


def test_lapack_kernels_defer_errors_to_numpy():
    bad = np.full((4, 4), np.nan)
    with pytest.raises(np.linalg.LinAlgError):
        lapack.svd(bad)
    with pytest.raises(np.linalg.LinAlgError):
        lapack.svd_values(bad)
    with pytest.raises(np.linalg.LinAlgError):
        lapack.eigh(bad)


# ----------------------------------------------------------------------------- prepare: plain-float parts
def condition_vectorized(T):
    pos = T[..., :3, 3]
    c = pos.mean(axis=-2)
    L = np.sqrt(np.mean(np.sum((pos - c[..., None, :]) ** 2, axis=-1), axis=-1))
    L = np.where(L > 0, L, 1.0)
    Tc = T.copy()
    Tc[..., :3, 3] = (pos - c[..., None, :]) / L[..., None, None]
    return Tc, c, L


def random_set(rng, k):
    from scipy.spatial.transform import Rotation

    T = np.tile(np.eye(4), (k, 1, 1))
    T[:, :3, :3] = Rotation.random(k, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(size=(k, 3)) * 10 ** rng.uniform(-8, 8) + rng.normal(size=3) * 10 ** rng.uniform(-3, 9)
    return T


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(1, 12), st.sampled_from(["plain", "zeros", "repeat", "near_pi"]))
def test_condition_and_displacements_bitwise(seed, k, kind):
    from scipy.spatial.transform import Rotation

    from synth.algebra.dq import pose_to_dq
    from synth.synthesis.conic import _pose_to_dq_few, condition

    rng = np.random.default_rng(seed)
    T = random_set(rng, k)
    if kind == "zeros":
        T[:, :3, 3] = -0.0
    elif kind == "repeat":
        T[-1] = T[0]
    elif kind == "near_pi":
        T[:, :3, :3] = Rotation.from_rotvec(rng.normal(size=(k, 3)) * 1e-3 + [np.pi, 0, 0]).as_matrix()
    Tc, cond = condition(T)
    Tr, c, L = condition_vectorized(T)
    assert np.array_equal(Tc, Tr) and np.array_equal(cond.centre, c) and np.array_equal(cond.scale, L)
    assert np.array_equal(np.signbit(cond.centre), np.signbit(c)) and np.shape(cond.scale) == np.shape(L)
    assert np.array_equal(_pose_to_dq_few(Tc), pose_to_dq(Tc))


@pytest.mark.parametrize("seed", range(10))
def test_grid_members_bitwise(seed):
    T = random_poses(np.random.default_rng(9000 + seed))
    try:
        problem = sb.prepare(T)
    except Exception:
        return
    for fams in (problem.families, problem.families[:1], problem.families[::-1]):
        for grid in (24, 5):
            C, lam, phi, fl = sb.grid_members(fams, grid)
            ph = sb.grid_angles(grid)
            with np.errstate(all="ignore"):
                assert np.array_equal(C, np.concatenate([f.members(ph)[0] for f in fams]), equal_nan=True)
                assert np.array_equal(lam, np.concatenate([f.lambdas(ph) for f in fams]), equal_nan=True)
            assert np.array_equal(phi, np.tile(ph, len(fams))) and fl == [f for f in fams for _ in range(grid)]


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(0, 4))
def test_ruling_parameters_as_vectorized(seed, special):
    """`synth.synthesis.cubic._ruling_parameters` (plain floats) against the vectorized formulas it replaces."""
    from synth.synthesis.cubic import RULING_TOL, _det2, _ruling_parameters

    rng = np.random.default_rng(seed)
    A = rng.normal(size=(4, 2))
    if special == 1:
        A[1] = A[0] * 2.0  # poses 0 and 1 on one ruling line
    elif special == 2:
        A[2] = A[0] * 3.0  # alpha = 0
    elif special == 3:
        A[3] = -A[0]  # d03 = 0
    elif special == 4:
        A[3] = A[2] * 0.5  # t3 = 1
    a = A[None]
    d01r = _det2(a[:, 0], a[:, 1])
    d01 = np.where(np.abs(d01r) < RULING_TOL, 1.0, d01r)
    alpha = _det2(a[:, 2], a[:, 1]) / d01
    beta = _det2(a[:, 0], a[:, 2]) / d01
    with np.errstate(all="ignore"):
        t3 = -beta * _det2(a[:, 1], a[:, 3]) / (alpha * _det2(a[:, 0], a[:, 3]))
    why, al, be, t = _ruling_parameters(A.tolist())
    assert (al, be) == (alpha[0], beta[0])
    assert t == t3[0] or (np.isnan(t) and np.isnan(t3[0]))
    d03 = _det2(a[:, 0], a[:, 3])[0]
    expected = ("poses 0 and 1" if abs(d01r[0]) < RULING_TOL else
                "pose 2 lies" if abs(alpha[0]) < RULING_TOL or abs(beta[0]) < RULING_TOL else
                "pose 3 lies on the ruling line through pose 0" if abs(d03) < RULING_TOL else
                "pose 3 lies on a ruling line through pose 1" if min(abs(t3[0]), abs(t3[0] - 1)) < RULING_TOL else None)
    assert why == expected if expected is None else why.startswith(expected)
    assert special == 0 or why is not None


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(0, 11))
def test_to_world_bitwise(seed, n):
    """`to_world` with its cross product unrolled against np.cross (the former code)."""
    from synth.synthesis.conic import Conditioning, to_world

    rng = np.random.default_rng(seed)
    h = rng.normal(size=(n, 8)) * 10 ** rng.uniform(-5, 5, size=8) if n else rng.normal(size=8)
    cond = Conditioning(centre=rng.normal(size=3) * 10 ** rng.uniform(-3, 8),
                        scale=np.asarray(10 ** rng.uniform(-6, 6)))
    ref = np.array(h, float)
    ref[..., 4:] *= cond.scale
    ref[..., 5:8] += np.cross(ref[..., 1:4], np.broadcast_to(cond.centre, ref[..., 1:4].shape))
    assert np.array_equal(to_world(h, cond), ref)
