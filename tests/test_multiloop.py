"""The ladder of Bennett flips (MATH-EXCEPTIONAL.md section 7, worked examples E6, E7)."""
from fractions import Fraction as F

import numpy as np
import pytest

from synth.checks import closure_errors, motion_error, sample_parameters, self_check
from synth.algebra.cofactor import exact_product, factorize_with_cofactor, rationalize_factors
from synth.algebra.geometry import common_normal
from synth.errors import SynthesisError
from synth.algebra.expr import parse_polynomial
from synth.synthesis.multiloop import (choose_m0, ladder_factors, ladder_linkage, loop_sides, mobility,
                             score_linkage)

E2 = [[0, 0, 0, 1, 0, 0, F(-3, 4), 0], [0, 0, 0, -1, 0, 0, F(-3, 4), 0],
      [0, 0, 0, -1, 0, 0, F(-1, 4), 0], [0, 0, 0, 1, 0, 0, F(-1, 4), 0]]
E4 = [[0, 0, 0, -1, 0, 0, F(-1, 4), 0], [0, 0, 0, 1, 0, 0, F(-1, 4), 0], [0, 0, 0, 1, 0, 0, F(-3, 2), 0]]
M0 = [2, 0, 0, F(3, 2), 0, F(3, 2), 0, 0]  # 2 + 3/2 k + 3/2 eps i


def _k(x, y):  # (+-)k + eps(x i + y j)
    return [0, 0, 0, 1, 0, x, y, 0]


def _m(x, y):
    return [2, 0, 0, F(3, 2), 0, x, y, 0]


def _exact_identity(ms, hs, ks):
    """(t - m0)(t - h1)...(t - hN) = (t - k1)...(t - kN)(t - mN), exactly."""
    return exact_product([ms[0]] + list(hs)) == exact_product(list(ks) + [ms[-1]])


def test_e6_table_exact():
    ks, ms = ladder_factors(E2, M0)
    neg = lambda v: [-x if i == 3 else x for i, x in enumerate(v)]  # noqa: E731  (-k instead of k)
    assert ks == [_k(F(48, 41), F(-129, 164)), neg(_k(F(660, 697), F(-513, 2788))),
                  neg(_k(F(288, 289), F(-715, 1156))), _k(F(-8340, 11849), F(22957, 47396))]
    assert ms == [M0, _m(F(27, 82), F(3, 82)), _m(F(-21, 34), F(-9, 17)), _m(F(-933, 578), F(-93, 578)),
                  _m(F(-1269, 1394), F(-624, 697))]
    assert _exact_identity(ms, E2, ks)


def test_e6_linkage_geometry_and_motion():
    lk = ladder_linkage(E2, M0)
    assert len(lk.joints) == 13 and len(lk.closures) == 4
    assert len([n for n, js in lk.links.items() if js]) == 10  # 10 links (+4 welded duplicates)
    ternary = [n for n, js in lk.links.items() if len(js) == 3]
    assert len(ternary) == 6
    pts = {j.name: j.point[:2] for j in lk.joints}
    expect = {"m0": (0, -1), "h1": (-0.75, 0), "k1": (-0.7866, -1.1707), "m1": (0.0244, -0.2195),
              "h2": (0.75, 0), "k2": (0.1840, 0.9469), "m2": (-0.3529, 0.4118), "h3": (0.25, 0),
              "k3": (0.6185, 0.9965), "m3": (-0.1073, 1.0761), "h4": (-0.25, 0), "k4": (0.4844, 0.7039),
              "m4": (-0.5968, 0.6069)}
    for name, xy in expect.items():
        assert np.allclose(pts[name], xy, atol=6e-5), name
    assert all(abs(abs(j.direction[2]) - 1) < 1e-15 for j in lk.joints)  # every axis vertical
    sides = loop_sides(lk)
    for s, (d1, d2) in zip(sides, [(1.25, 0.8049), (0.7581, 1.1773), (0.7301, 1.1339), (1.0855, 0.6990)]):
        assert s[0] == pytest.approx(s[2], abs=1e-12) and s[1] == pytest.approx(s[3], abs=1e-12)
        assert s[0] == pytest.approx(d1, abs=6e-5) and s[1] == pytest.approx(d2, abs=6e-5)
    ct, cr = closure_errors(lk, 201)
    assert ct + cr < 1e-13
    assert motion_error(lk, 201) < 1e-13
    dofs, cond = mobility(lk, sample_parameters(lk, 201))
    assert set(dofs) == {1} and cond > 0
    # the origin of A4 (= coupler) draws the ellipse (x + 1)^2 + (y/2)^2 = 1
    t = sample_parameters(lk, 201)
    disp = lk.displacements(lk.angles_at(t))["coupler"]
    p = disp[:, :3, 3]
    assert np.max(np.abs((p[:, 0] + 1) ** 2 + (p[:, 1] / 2) ** 2 - 1)) < 1e-13 and np.max(np.abs(p[:, 2])) < 1e-14


def test_tree_structure_and_reversed_joint():
    lk = ladder_linkage(E2, M0)
    parents = {}
    for j in lk.joints:
        assert j.child not in parents
        parents[j.child] = j.parent
    assert "base" not in parents and set(parents) | {"base"} == set(lk.links)
    assert lk.closures[0] == ("coupler", "coupler_m4")
    m0 = lk.joint("m0")
    # m0 is traversed from A0 (base) to K0 against product order: its line is reversed
    assert np.allclose(m0.direction, [0, 0, 1]) and np.allclose(m0.point, [0, -1, 0])
    assert (m0.a, m0.b) == (2.0, 1.5)


def test_e7_ellipse_drawing_linkage_exact():
    C = parse_polynomial("(t^2 + 1 + eps*(i + 2*j*t))*(t - k)", exact=True)
    hs = rationalize_factors(factorize_with_cofactor(C).factors)
    assert hs == E4
    ks, ms = ladder_factors(hs, M0)
    assert ks[0] == [0, 0, 0, -1, 0, 0, F(5, 4), 0]
    assert ms[1] == _m(F(3, 2), F(-3, 2))
    assert ks[1] == _k(F(12, 41), F(-227, 164)) and ms[2] == _m(F(99, 82), F(-15, 41))
    assert ks[2] == _k(F(2226, 1681), F(-3537, 3362)) and ms[3] == _m(F(-393, 3362), F(-1368, 1681))
    assert _exact_identity(ms, hs, ks)
    lk = ladder_linkage(hs, M0)
    assert len(lk.joints) == 10 and len([n for n, js in lk.links.items() if js]) == 8
    assert np.allclose(lk.joint("k1").point, [-1.25, 0, 0]) and np.allclose(lk.joint("m1").point, [-1, -1, 0])
    for s, (d1, d2) in zip(loop_sides(lk), [(1.0308, 1.6008), (1.25, 0.8049), (1.4918, 0.9606)]):
        assert s[0] == pytest.approx(d1, abs=6e-5) and s[1] == pytest.approx(d2, abs=6e-5)
    t = sample_parameters(lk, 201)
    disp = lk.displacements(lk.angles_at(t))["coupler"]
    p = disp[:, :3, 3]  # the origin of A3 (it lies on the axis of H = t - k)
    assert np.max(np.abs((p[:, 0] + 1) ** 2 + (p[:, 1] / 2) ** 2 - 1)) < 1e-13
    ct, cr = closure_errors(lk, 201)
    assert ct + cr < 1e-13
    assert set(mobility(lk, t)[0]) == {1}


@pytest.mark.parametrize("with_h,joints,links", [(False, 13, 10), (True, 10, 8)])
def test_gallet_ellipse_counts(with_h, joints, links):
    """(x + 1)^2 + 4 y^2 = 1: a = 1, b = -1/2 gives 13 joints / 10 links and 10 / 8 (Gallet et al.)."""
    text = "t^2 + 1 + eps*(i - 1/2*j*t)"
    C = parse_polynomial(f"({text})*(t - k)" if with_h else text, exact=True)
    res = factorize_with_cofactor(C)
    lk = ladder_linkage(res.factors, M0)
    assert len(lk.joints) == joints and len([n for n, js in lk.links.items() if js]) == links
    t = sample_parameters(lk, 201)
    p = lk.displacements(lk.angles_at(t))["coupler"][:, :3, 3]
    assert np.max(np.abs((p[:, 0] + 1) ** 2 + 4 * p[:, 1] ** 2 - 1)) < 1e-12
    assert set(mobility(lk, t)[0]) == {1}


def test_same_norm_m0_is_refused():
    with pytest.raises(SynthesisError, match="same norm"):
        ladder_linkage(E2, [0, 0, 0, 1, 0, 1, 0, 0])


def test_perturbed_joint_breaks_closure():
    lk = ladder_linkage(E2, M0)
    j = lk.joint("k2")
    j.moment = j.moment + np.array([1e-3, 0, 0])
    ct, cr = closure_errors(lk, 201)
    assert ct + cr > 1e-5


def _random_rotation(rng):
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    d = rng.normal(size=3)
    d -= (d @ n) * n
    h = np.zeros(8)
    h[0], h[1:4], h[5:8] = rng.normal(), rng.uniform(0.4, 2) * n, d
    return h


@pytest.mark.parametrize("seed", range(4))
def test_spatial_ladders_have_one_dof(seed):
    rng = np.random.default_rng(seed)
    hs = np.array([_random_rotation(rng) for _ in range(3)])
    m0, lk, score = choose_m0(hs)
    assert score.dof == 1 and score.dof_min == 1
    chk = self_check(lk, 201)
    assert chk["max_closure_error"] < 1e-11 and chk["max_motion_error"] < 1e-11
    assert lk.info.synthesis.ladder.flip_residual < 1e-12
    for loop in lk.info.synthesis.ladder.loop_joints:  # every loop is a Bennett linkage
        J = [lk.joint(n) for n in loop]
        cn = [common_normal(J[i].direction, J[i].moment, J[(i + 1) % 4].direction, J[(i + 1) % 4].moment)
              for i in range(4)]
        da = [(float(c.distance), abs(float(c.twist))) for c in cn]
        assert da[0][0] == pytest.approx(da[2][0], rel=1e-8, abs=1e-10)
        assert da[1][0] == pytest.approx(da[3][0], rel=1e-8, abs=1e-10)


def test_choose_m0_planar_keeps_the_plane():
    m0, lk, score = choose_m0(np.array([[float(x) for x in h] for h in E2]))
    assert np.allclose(np.abs(m0[1:4]) / np.linalg.norm(m0[1:4]), [0, 0, 1])
    assert score.dof == 1 and score.conditioning > 0
    assert score_linkage(lk).dof == 1
