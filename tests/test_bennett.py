"""Bennett synthesis: the worked example D of docs/conic.md, random pose sets, degenerate inputs."""
from __future__ import annotations

from fractions import Fraction as F

import numpy as np
import pytest

from synth.synthesis.bennett import bennett
from synth.algebra.dq import pose_to_dq, quat_to_matrix
from synth.algebra.geometry import rotation_about_line
from synth.errors import InputError, SynthesisError
from synth.algebra.polynomial import pose_at, product_of_linear, relative_error

from conftest import random_poses


def pose(pos, q):
    T = np.eye(4)
    T[:3, :3] = quat_to_matrix(q)
    T[:3, 3] = pos
    return T


def screw(u, point, theta, pitch):
    u = np.asarray(u, float) / np.linalg.norm(u)
    T = rotation_about_line(u, np.cross(point, u), theta)
    T[:3, 3] += pitch * theta * u
    return T


EXAMPLE_D = np.array([pose([0, 0, 0], [1, 0, 0, 0]), pose([1, 0, 0.5], [0.6, 0, 0, 0.8]),
                      pose([0.25, 1, 0.2], [0.6, 0.8, 0, 0])])


@pytest.fixture(scope="module")
def example_d():
    return bennett(EXAMPLE_D)


def test_example_d_motion_polynomial(example_d):
    c1 = [F(-38, 53), F(40, 53), 0, F(-20, 53), 0, F(15, 212), F(-29, 53), F(83, 212)]
    c0 = [F(15, 53), 0, 0, F(20, 53), F(5, 53), F(-15, 106), F(10, 53), F(-15, 212)]
    expect = np.array([[float(x) for x in c0], [float(x) for x in c1], [1, 0, 0, 0, 0, 0, 0, 0]])
    np.testing.assert_allclose(example_d.motion, expect, atol=1e-15)
    B = example_d.info.synthesis.study_form
    assert B.B01 == pytest.approx(1 / 10, abs=1e-15)
    assert B.B02 == pytest.approx(1 / 20, abs=1e-15)
    assert B.B12 == pytest.approx(53 / 500, abs=1e-15)


def test_example_d_factors_axes_and_angles(example_d):
    J = {j.name: j for j in example_d.joints}
    assert J["h1"].a == pytest.approx(0.2128367441, abs=1e-10)
    assert J["h1"].b == pytest.approx(0.3799257778, abs=1e-10)
    assert J["h2"].a == pytest.approx(0.504144388, abs=1e-9)
    assert J["h2"].b == pytest.approx(0.9586920209, abs=1e-10)
    np.testing.assert_allclose(J["h1"].direction, [-0.2327764841, -0.9407168724, -0.2467121287], atol=1e-10)
    np.testing.assert_allclose(J["h1"].moment, [0.6227965221, -0.02904718285, -0.4768602594], atol=1e-10)
    np.testing.assert_allclose(J["k1"].direction, [0.879484495, -0.372802299, -0.2958470363], atol=1e-9)
    np.testing.assert_allclose(J["k1"].moment, [0.03354705078, 0.5490998426, -0.5922032374], atol=1e-10)
    # opposite joints share angle laws
    assert (J["h1"].a, J["h1"].b) == pytest.approx((J["k2"].a, J["k2"].b), abs=1e-14)
    assert (J["h2"].a, J["h2"].b) == pytest.approx((J["k1"].a, J["k1"].b), abs=1e-14)
    p1, p2 = example_d.poses[1].joint_angles, example_d.poses[2].joint_angles
    assert p1["h1"] == pytest.approx(4.1628830873, abs=1e-9) and p1["k2"] == pytest.approx(4.1628830873, abs=1e-9)
    assert p1["h2"] == pytest.approx(4.1098453272, abs=1e-9) and p1["k1"] == pytest.approx(4.1098453272, abs=1e-9)
    assert p2["h1"] == pytest.approx(0.8993459891, abs=1e-9)
    assert p2["h2"] == pytest.approx(2.1869341004, abs=1e-9)
    assert all(v == 0 for v in example_d.poses[0].joint_angles.values())


def test_example_d_bennett_conditions(example_d):
    b = example_d.info.bennett
    assert b.opposite_length_mismatch < 1e-13
    assert b.opposite_twist_mismatch < 1e-13
    assert b.bennett_condition_residual < 1e-13
    assert all(abs(row.d) < 1e-13 for row in example_d.info.dh)  # Bennett: zero offsets
    # machine precision for poses of unit size: a few hundred ulps (1.12e-13 with OPENBLAS_CORETYPE=Haswell's
    # fused multiply-adds, 9.0e-14 with the kernel OpenBLAS picks on the same machine)
    assert example_d.checks["max_pose_error"] < 1e-12
    assert example_d.checks["max_closure_error"] < 1e-12


def _check_linkage(L, T, rel=1e-9):
    spread = np.sqrt(np.mean(np.sum((T[:, :3, 3] - T[:, :3, 3].mean(0)) ** 2, axis=1)))
    size = max(spread, L.extent())
    # World coordinates a distance D from the origin carry an absolute rounding floor: rotations about
    # axes that far out turn a 1e-13 rad angle error into 1e-13 D of translation. 1e-12 D (~5000 ulp)
    # only matters for small linkages far from the origin (e.g. 17 mm at 161 m: closure 1e-10 m).
    floor = 1e-12 * float(np.linalg.norm(T[:, :3, 3].mean(0)))
    c = L.checks
    assert c["max_pose_translation_error"] <= rel * spread + floor, c
    assert c["max_pose_rotation_error"] <= rel, c
    assert c["max_closure_translation_error"] <= rel * size + floor, c
    assert c["max_closure_rotation_error"] <= rel, c
    assert c["max_motion_error"] <= rel * max(1.0, size) + floor
    # both branches multiply back to the motion polynomial
    from synth.synthesis.assemble import joint_from_factor  # noqa: F401 (documentation of the convention)
    # the tool frame through the motion polynomial reproduces every pose
    for rec, Ti in zip(L.poses, T):
        M = pose_at(L.motion, rec.t) @ L.tool_ref
        assert np.abs(M[:3, :3] - Ti[:3, :3]).max() <= rel
        assert np.linalg.norm(M[:3, 3] - Ti[:3, 3]) <= rel * spread
    b = L.info.bennett
    assert b.opposite_length_mismatch < 1e-7 and b.bennett_condition_residual < 1e-7


@pytest.mark.parametrize("seed", range(25))
def test_random_pose_sets(seed):
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3)
    _check_linkage(bennett(T), T)


@pytest.mark.parametrize("case", ["far", "tiny", "huge", "near_pi"])
@pytest.mark.parametrize("seed", range(5))
def test_hard_scales(case, seed):
    rng = np.random.default_rng(100 + seed)
    kw = {"far": dict(offset=(1000.0, -1000.0, 1000.0)), "tiny": dict(scale=1e-3), "huge": dict(scale=1e3),
          "near_pi": dict(near_pi=True)}[case]
    T = random_poses(rng, 3, **kw)
    _check_linkage(bennett(T), T)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(500))
def test_random_pose_sets_sweep(seed):
    rng = np.random.default_rng(10_000 + seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 100)
    _check_linkage(bennett(T), T)


def test_names_and_parameters(example_d):
    L = bennett(EXAMPLE_D, ["a", "b", "c"])
    assert [p.name for p in L.poses] == ["a", "b", "c"]
    assert [p.t for p in L.poses][1:] == [0.0, 1.0] and np.isinf(L.poses[0].t)
    assert L.branches == [["h1", "h2"], ["k1", "k2"]]
    assert L.closures == [("coupler", "coupler_k")]


DEGENERATE = {
    "coincident": ([np.eye(4), np.eye(4), pose([1, 2, 3], [0.6, 0, 0, 0.8])], "coincide"),
    "pure rotation": ([np.eye(4), screw([0, 0, 1], [1, 0, 0], 0.7, 0), EXAMPLE_D[2]], "pure rotation"),
    "pure translation": ([np.eye(4), pose([1, 0, 0], [1, 0, 0, 0]), EXAMPLE_D[2]], "pure translation"),
    # planar poses have a family of four-bars (docs/planar.md); pure translations and one fixed axis do not
    "translations": ([np.eye(4), pose([1, 0, 0], [1, 0, 0, 0]), pose([0, 2, 0], [1, 0, 0, 0])], "pure translations"),
    "one axis": ([np.eye(4), screw([0, 0, 1], [1, 0, 0], 0.7, 0), screw([0, 0, 1], [1, 0, 0], 1.1, 0)], "lower degree"),
    "parallel screws": ([np.eye(4), screw([0, 0, 1], [1, 0, 0], 0.7, 0.3), screw([0, 0, 1], [0, 2, 0], 1.1, 0.5)],
                        "prismatic"),
    "coaxial screws": ([np.eye(4), screw([0, 0, 1], [1, 0, 0], 0.7, 0.3), screw([0, 0, 1], [1, 0, 0], 1.1, 0.5)],
                       "prismatic"),
}


@pytest.mark.parametrize("name", list(DEGENERATE))
def test_degenerate_inputs_are_refused_with_a_reason(name):
    T, needle = DEGENERATE[name]
    with pytest.raises(SynthesisError, match=needle):
        bennett(np.array(T))


def test_wrong_shape_is_input_error():
    with pytest.raises(InputError):
        bennett(np.zeros((4, 4, 4)))


def test_nearly_pure_translation_is_solved_with_a_warning():
    T = np.array([np.eye(4), screw([0, 0, 1], [1, 0, 0], 1e-3, 1000), EXAMPLE_D[2]])
    L = bennett(T)
    assert L.info.warnings
    assert L.checks["max_pose_error"] < 1e-8 * L.extent()


def test_factorizations_multiply_back(example_d):
    L = example_d
    H = np.array([_factor(L.joint(n)) for n in ("h1", "h2")])
    K = np.array([_factor(L.joint(n)) for n in ("k1", "k2")])
    assert relative_error(product_of_linear(H), L.motion) < 1e-14
    assert relative_error(product_of_linear(K), L.motion) < 1e-14


def _factor(j):
    """Rebuild h = a + v + eps w from a joint (u = -v/|v|, m = w/|v|)."""
    v = -j.direction * j.b
    w = j.moment * j.b
    return np.concatenate([[j.a], v, [0.0], w])


def test_pose_to_dq_consistency():
    np.testing.assert_allclose(pose_to_dq(EXAMPLE_D[1]), [0.6, 0, 0, 0.8, 0.2, -0.3, 0.4, -0.15], atol=1e-15)


# ------------------------------------------------------------------ a plain, fully computed linkage
def test_the_linkage_is_fully_computed(example_d):
    """No deferred attributes: checks, motion and info are plain values in the instance."""
    L = bennett(EXAMPLE_D)
    d = vars(L)
    assert "_deferred" not in d
    assert set(("checks", "motion", "info")) <= set(d)
    assert d["checks"]["samples"] == 0 and d["checks"]["bounded"] and d["motion"].shape == (3, 8)
    assert {"bennett", "dh", "relative_error", "warnings", "conditioning", "study_form"} <= set(d["info"].to_dict())


def test_verify_recomputes_the_checks_and_refuses_failures(monkeypatch):
    from synth.synthesis import bennett as sb
    from synth.checks import VERIFY_SAMPLES

    rng = np.random.default_rng(5)
    L = bennett(random_poses(rng, 3))
    checks = sb.verify(L)
    assert checks is L.checks and checks["samples"] == VERIFY_SAMPLES
    assert checks["max_closure_error"] <= 1e-9 * checks["length_scale"]
    monkeypatch.setattr(sb, "ACCEPT_TOL", 1e-30)
    with pytest.raises(SynthesisError, match="misses them"):
        sb.verify(L)


@pytest.mark.parametrize("seed", range(6))
def test_invariants_pose_reproduction_study_and_closure_along_the_motion(seed):
    """The factors satisfy the Study condition, both branches multiply back to C, every pose is C at
    its parameter, and both branches give the same coupler all along the motion."""
    from synth.algebra.algorithm1 import study_violation
    from synth.checks import link_displacements
    from synth.algebra.polynomial import evaluate
    from synth.algebra.geometry import dq_pose_difference

    rng = np.random.default_rng(100 + seed)
    T = random_poses(rng, 3, scale=10 ** rng.uniform(-2, 2), offset=rng.normal(size=3) * 10)
    L = bennett(T)
    size = max(L.extent(), 1.0)
    H = np.array([[_factor(L.joint(n)) for n in ("h1", "h2")], [_factor(L.joint(n)) for n in ("k1", "k2")]])
    assert np.all(study_violation(H) <= 1e-12)
    assert np.all(relative_error(product_of_linear(H), L.motion) <= 1e-12)
    for rec in L.poses:
        dt, dr = dq_pose_difference(evaluate(L.motion, rec.t), pose_to_dq(rec.matrix @ np.linalg.inv(T[0])))
        assert dt <= 1e-9 * size and dr <= 1e-9
    t = np.concatenate([np.linspace(-50, 50, 101), [np.inf]])
    disp = link_displacements(L, [j.angle(t) for j in L.joints])
    dt, dr = dq_pose_difference(disp["coupler"], disp["coupler_k"])
    assert dt.max() <= 1e-9 * size and dr.max() <= 1e-9


def test_check_distinct_accepts_lists_and_nan():
    from synth.synthesis.bennett import check_distinct

    check_distinct([np.eye(4).tolist(), np.diag([1.0, -1, -1, 1]).tolist()], ["a", "b"])
    T = np.array([np.eye(4), np.eye(4)])
    T[1, 0, 3] = np.nan
    check_distinct(T, ["a", "b"])  # NaN compares false: not 'coincident'
    with pytest.raises(SynthesisError, match=r"poses 0 \('a'\) and 1 \('b'\) coincide"):
        check_distinct(np.array([np.eye(4), np.eye(4), EXAMPLE_D[1]]), ["a", "b", "c"])
