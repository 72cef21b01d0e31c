"""The block-arrow KKT step (synth.synthesis.arrow) against the dense KKT system it replaces, and the
linear cost of a fit's step in the number of items."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.synthesis.arrow import DAMPING_FLOOR, ArrowJacobian


EXTRA_COLS = np.array([[5, 4], [4, 5], [6, 5], [1, 3], [4, 4]])  # neighbours, twice one item, and 1 with 3


def random_arrow(rng, S=2, N=7, R=3, G=4, E=2, exact_items=(2,)):
    """An ArrowJacobian with extra rows coupling items EXTRA_COLS, constraints on the globals and on
    ``exact_items``."""
    item_r, item_g, item_p = rng.normal(size=(S, N, R)), rng.normal(size=(S, N, R, G)), rng.normal(size=(S, N, R))
    item_r[:, 1, 0] = item_g[:, 1, 0] = item_p[:, 1, 0] = 0.0  # a row that does not count
    Jc = np.zeros((S, E + len(exact_items), G + N))
    Jc[:, :, :G] = rng.normal(size=(S, E + len(exact_items), G))
    for k, i in enumerate(exact_items):
        Jc[:, E + k, G + i] = rng.uniform(1.0, 2.0, size=S)  # (well away from a singular system)
    jac = ArrowJacobian.of_items(item_r, item_g, item_p, rng.normal(size=(S, Jc.shape[1])), Jc)
    cols, m = EXTRA_COLS, len(EXTRA_COLS)
    vals = rng.normal(size=(S, m, 2))
    vals[0, 0] = 0.0
    return jac.with_rows(rng.normal(size=(S, m)), rng.normal(size=(S, m, G)), cols, vals)


def dense(jac: ArrowJacobian):
    """(J (S, M, P), r (S, M)) of all residual rows."""
    S, N, R, G = jac.item_g.shape
    J = np.zeros((S, N, R, G + N))
    J[..., :G] = jac.item_g
    J[:, np.arange(N), :, G + np.arange(N)] = np.moveaxis(jac.item_p, 1, 0)
    m = jac.extra_r.shape[1]
    Je = np.zeros((S, m, G + N))
    Je[..., :G] = jac.extra_g
    for slot in range(jac.extra_cols.shape[1]):
        Je[:, np.arange(m), G + jac.extra_cols[:, slot]] += jac.extra_vals[:, :, slot]
    return np.concatenate([J.reshape(S, N * R, -1), Je], 1), np.concatenate([jac.item_r.reshape(S, -1), jac.extra_r], 1)


def dense_step(jac, fixed, lam):
    """The damped KKT step of the dense system (the textbook form)."""
    J, r = dense(jac)
    J = np.where(fixed[:, None], 0.0, J)
    A = np.where(fixed[:, None], 0.0, jac.Jc)
    S, P = fixed.shape
    out = np.zeros((S, P))
    for s in range(S):
        H = J[s].T @ J[s]
        d = np.where(fixed[s], 1.0, np.diag(H) + lam[s] * (np.diag(H) + DAMPING_FLOOR))
        H[np.diag_indices(P)] = d
        E = A.shape[1]
        K = np.block([[H, A[s].T], [A[s], np.zeros((E, E))]])
        out[s] = np.linalg.solve(K, np.concatenate([-J[s].T @ r[s], -jac.c[s]]))[:P]
    return out


def solve(K, rhs):
    return np.linalg.solve(K, rhs[..., None])[..., 0]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), lam=st.floats(1e-9, 1e3), hold=st.integers(0, 10))
def test_the_arrow_step_is_the_dense_kkt_step(seed, lam, hold):
    rng = np.random.default_rng(seed)
    jac = random_arrow(rng)
    S, G, N = 2, 4, 7
    fixed = np.zeros((S, G + N), bool)
    fixed[:, G + 0] = True  # a gauge item
    fixed[1, hold] = True  # a global or an item held in one seed only
    system = jac.system(fixed)
    assert set(system.core.tolist()) == {1, 2, 3}  # the exact item and those coupled to a non-neighbour
    assert system.e.any()  # 4 - 5 - 6: a tridiagonal block
    lams = np.array([lam, 10 * lam])
    got, want = system.step(lams, solve), dense_step(jac, fixed, lams)
    assert np.allclose(got, want, rtol=1e-7, atol=1e-9 * (1 + np.abs(want).max()))
    assert np.all(got[fixed] == 0.0)


def test_cost_is_the_sum_of_squares_of_every_row():
    jac = random_arrow(np.random.default_rng(3))
    J, r = dense(jac)
    assert np.allclose(jac.cost, (r * r).sum(1))


def test_worked_step_of_one_item_and_one_global():
    """Rows r = (x + p - 1, 2 p): the undamped Gauss-Newton step from 0 solves x + p = 1, p = 0."""
    jac = ArrowJacobian.of_items(np.array([[[-1.0, 0.0]]]), np.array([[[[1.0], [0.0]]]]), np.array([[[1.0, 2.0]]]),
                                 np.zeros((1, 0)), np.zeros((1, 0, 2)))
    dx = jac.system(np.zeros((1, 2), bool)).step(np.array([0.0]), solve)
    assert dx == pytest.approx(np.array([[1.0, 0.0]]), abs=1e-9)


def test_motion_constraints_are_those_of_the_full_jacobians():
    """`MotionModel.constraints` (the exact items alone) gives the rows and Jacobian of `jacobians`."""
    from conftest import random_poses
    from synth.algebra.dq import pose_to_dq
    from synth.synthesis.fit import Layout, MotionModel, task_arrays

    rng = np.random.default_rng(5)
    T = random_poses(rng, 9)
    tol = np.tile([0.1, 0.05], (9, 1))
    tol[[0, 4]] = 0.0
    tol[6, 0] = 0.0  # an exact position, a free angle
    task = task_arrays(pose_to_dq(T), T[:, :3, 3], tol, None, 1.0)
    layout = Layout(2, 9, np.array([[0, 3, 6], [0, 2, 5]]))
    model = MotionModel(layout, task, pose_to_dq(T[[0, 1]]))
    x = rng.normal(size=(2, layout.size)) * 0.3
    c, Jc = model.constraints(x)
    jac = model.jacobians(x)
    assert c.shape == (2, 6 + 6 + 3 + 4) and np.allclose(c, jac.c) and np.allclose(Jc, jac.Jc)


def _big_task(kind: str, n: int):
    """n noisy poses of a known motion (bench/bench_fit_scale.py: pose 0 exact, 1e-4 noise, tolerances
    2e-3 spread / 2e-3 rad for Bennett, 5e-3 spread / 0.5 deg for 6R)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
    from bench_fit_scale import bennett_set, sixbar_set

    return (bennett_set if kind == "bennett" else sixbar_set)(n, "any")


def _check_big_fit(lk, ps):
    from synth.algebra.geometry import pose_difference

    angles = {j.name: np.array([r.joint_angles[j.name] for r in lk.poses]) for j in lk.joints}
    dt, dr = pose_difference(lk.tool_pose(angles), ps.matrices)
    assert lk.info.fit.within_tolerance
    assert np.all(dt <= ps.tolerance[:, 0] * (1 + 1e-9) + 1e-12) and np.all(dr <= ps.tolerance[:, 1] * (1 + 1e-9) + 1e-12)
    pos = ps.matrices[:, :3, 3]
    assert dt[0] < 1e-9 * np.sqrt(np.mean(np.sum((pos - pos.mean(0)) ** 2, 1))) and dr[0] < 1e-9  # pose 0: exact


def test_a_bennett_fit_of_four_hundred_poses_is_within_tolerance():
    """The items' columns eliminated per step: 400 poses fit (the dense KKT system was 406 + columns, O(N^3))."""
    from synth.synthesis.bennett_fit import bennett_task

    ps = _big_task("bennett", 400)
    _check_big_fit(bennett_task(ps)[0], ps)


@pytest.mark.slow
def test_a_6r_fit_of_a_thousand_poses_is_within_tolerance():
    from synth.synthesis.sixbar_task import sixbar_task

    ps = _big_task("sixbar", 1000)
    _check_big_fit(sixbar_task(ps)[0], ps)


@pytest.mark.parametrize("n, velocity", [(2, False), (2, True), (3, False), (3, True)])
def test_motion_jacobians_are_the_derivatives_of_the_rows(n, velocity):
    """`MotionModel.jacobians` (the closed-form pose rows chained through P = C Q, complex steps only for
    the twist rows) against central differences of `MotionModel.rows` along random directions: item rows,
    their phi columns and the constraints (exact items and the Study condition), with and without a
    prescribed twist direction, for a conic and a cubic."""
    from conftest import random_poses
    from synth.algebra.dq import pose_to_dq
    from synth.synthesis.fit import Layout, MotionModel, task_arrays

    rng = np.random.default_rng(11 + n + 2 * velocity)
    N = 7
    T = random_poses(rng, N)
    tol = np.tile([0.1, 0.05], (N, 1))
    tol[0] = 0.0
    vel = None
    if velocity:
        vel = np.full((N, 6), np.nan)
        vel[2] = [0.3, -0.2, 0.5, 0.1, 0.4, -0.3]  # a full twist direction
        vel[5, 3:] = [1.0, 0.5, -0.2]  # a linear velocity only
    task = task_arrays(pose_to_dq(T), T[:, :3, 3], tol, vel, 1.0)
    layout = Layout(n, N, np.zeros((0, 3), int))
    model = MotionModel(layout, task, pose_to_dq(T[[0, 1]]))
    x = rng.normal(size=(2, layout.size)) * 0.3
    jac = model.jacobians(x)
    G = jac.item_g.shape[-1]
    assert G + N == layout.size and not jac.extra_r.size
    for _ in range(3):
        v = rng.normal(size=x.shape)
        h = 1e-6
        (rp, cp), (rm, cm) = model.rows(x + h * v), model.rows(x - h * v)
        Jv = np.einsum("snrg,sg->snr", jac.item_g, v[:, :G]) + jac.item_p * v[:, G:, None]
        free = model.free.reshape(N, -1)  # the twist rows (past the item rows' width) are constraints
        assert not free[:, Jv.shape[-1]:].any()
        free = free[:, :Jv.shape[-1]].ravel()
        Jv = Jv.reshape(2, -1)[:, free]
        r0, c0 = model.rows(x)
        assert np.allclose(jac.item_r.reshape(2, -1)[:, free], r0, rtol=1e-12, atol=1e-12)
        assert np.allclose(Jv, (rp - rm) / (2 * h), rtol=1e-5, atol=1e-6 * np.abs(Jv).max())
        Jcv = np.einsum("seg,sg->se", jac.Jc, v)
        assert np.allclose(Jcv, (cp - cm) / (2 * h), rtol=1e-5, atol=1e-6 * np.abs(Jcv).max())
