"""Fast paths of the default 6R synthesis (issues 4 and 7) against their general counterparts: the
plain-float DH table (`synth.sixbar.loop_dh`) bitwise against the vectorized formulas it replaces, and
the direct LAPACK kernels (`synth.lapack`) bitwise against `numpy.linalg`."""
from __future__ import annotations

import importlib
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth import lapack
from synth.cubic import _cross, _pair_geometry
from synth.linkage import Joint, Linkage

from test_sixbar import random_poses

sb = importlib.import_module("synth.sixbar")


def loop_dh_vectorized(linkage, loop):
    """The former `loop_dh` (numpy, all joints at once): the reference."""
    J = [linkage.joint(n) for n in loop]
    u = np.array([j.direction for j in J]).T
    mo = np.array([j.moment for j in J]).T
    nxt = np.r_[1:len(J), 0]
    dist, _, f_out, f_in_next = _pair_geometry(u, mo, u[:, nxt], mo[:, nxt])
    c = _cross(u, u[:, nxt])
    cn = np.sqrt(np.sum(c * c, 0))
    with np.errstate(all="ignore"):
        n = np.where(dist > 1e-12, (f_in_next - f_out) / dist, np.where(cn > 1e-12, c / cn, 0.0))
    twist = np.arctan2(np.sum(c * n, 0), np.sum(u * u[:, nxt], 0))
    prev = np.r_[len(J) - 1, 0:len(J) - 1]
    f_in, n_in = f_in_next[:, prev], n[:, prev]
    d = np.sum((f_out - f_in) * u, 0)
    theta = np.arctan2(np.sum(_cross(n_in, n) * u, 0), np.sum(n_in * n, 0))
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
