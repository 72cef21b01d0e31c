"""Planar and spherical pose sets (docs/planar.md): the conic and cubic families, the four-bar and the Watt
six-bar, the CLI and the shared verifier."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from conftest import REPO
from cli.main import mpsynth
from synth.algebra.dq import quat_to_matrix
from synth.algebra.factorize import factorize
from synth.algebra.polynomial import evaluate, norm_poly, study_residual
from synth.errors import InputError, SynthesisError
from synth.synthesis.assemble import two_branch_linkage
from synth.synthesis.bennett import bennett
from synth.synthesis.conic import conic, conic_member, relative_displacements
from synth.synthesis.cubic import cubic_member
from synth.synthesis.multiloop import mobility
from synth.synthesis.planar import zero_pitch
from synth.synthesis.sixbar import sixbar

VERIFIER = REPO.parent / "shared" / "tools" / "verify_output.py"
FIX = REPO / "fixtures"


def planar_poses(k, seed, normal=(0, 0, 1)):
    """k random poses rotating about axes parallel to ``normal``, translating perpendicular to it."""
    rng = np.random.default_rng(seed)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    e1 = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    out = []
    for i in range(k):
        T = np.eye(4)
        T[:3, :3] = Rotation.from_rotvec(n * (0 if i == 0 else rng.uniform(-1.5, 1.5))).as_matrix()
        T[:3, 3] = 0.3 * n + rng.normal(scale=0.5) * e1 + rng.normal(scale=0.5) * e2
        out.append(T)
    return np.array(out)


def spherical_poses(k, seed, centre=(0.2, 0.3, 0.5), arm=(0.3, -0.2, 0.4)):
    rng = np.random.default_rng(seed)
    out = []
    for i in range(k):
        R = np.eye(3) if i == 0 else Rotation.from_rotvec(rng.normal(size=3) * 0.6).as_matrix()
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, np.asarray(centre) + R @ np.asarray(arm)
        out.append(T)
    return np.array(out)


def worked_poses():
    def pose(q, p):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = quat_to_matrix(np.array(q, float)), p
        return T
    return np.array([np.eye(4), pose([0.8, 0, 0, 0.6], [1, 0, 0]), pose([0.6, 0, 0, 0.8], [1, 1, 0])])


# ------------------------------------------------------------------ docs/planar.md, section 5
def test_worked_example():
    T = worked_poses()
    D = relative_displacements(T)
    assert D[1] == pytest.approx([0.8, 0, 0, 0.6, 0, -0.4, 0.3, 0], abs=1e-15)
    assert D[2] == pytest.approx([0.6, 0, 0, 0.8, 0, -0.7, 0.1, 0], abs=1e-15)
    C = conic_member(D, [1.0, 1.0])
    assert C[1] == pytest.approx([-1.2, 0, 0, 0.2, 0, -0.3, -0.2, 0], abs=1e-15)
    assert C[0] == pytest.approx(D[1], abs=1e-15)
    assert norm_poly(C) == pytest.approx([1, -1.68, 3.08, -2.4, 1], abs=1e-14)  # ascending
    res = factorize(C, validate=False)
    np.testing.assert_allclose(res.quadratics, [[0.5218473271, -0.3066262799], [1.9162692767, -2.0933737201]],
                               atol=1e-9)
    by = {f.order: f for f in res.factorizations}
    L = two_branch_linkage("planar_4r", by[(0, 1)].factors, by[(1, 0)].factors, C, T, "abc", (np.inf, 0, 1))
    pts = {j.name: j.point for j in L.joints}
    assert all(abs(abs(j.direction[2]) - 1) < 1e-14 for j in L.joints)
    assert pts["h1"][:2] == pytest.approx([0.1899445213, 0.4407896372], abs=1e-9)
    assert pts["h2"][:2] == pytest.approx([-0.0727556086, 0.6746280178], abs=1e-9)
    assert pts["k2"][:2] == pytest.approx([0.5279794891, 1.0492525792], abs=1e-9)
    assert pts["k1"][:2] == pytest.approx([0.1906524936, 1.1487626016], abs=1e-9)
    d = lambda a, b: float(np.linalg.norm(pts[a] - pts[b]))  # noqa: E731
    assert d("h1", "h2") == pytest.approx(0.3516983743, abs=1e-9) and d("k2", "k1") == pytest.approx(d("h1", "h2"))
    assert d("h2", "k2") == pytest.approx(0.7079733185, abs=1e-9) and d("k1", "h1") == pytest.approx(d("h2", "k2"))
    diag1, diag2 = pts["k2"] - pts["h1"], pts["k1"] - pts["h2"]
    assert abs(np.cross(diag1, diag2)[2]) < 1e-12  # anti-parallelogram: parallel diagonals


# ------------------------------------------------------------------ the families
def test_conic_member_is_the_conic_for_spatial_poses():
    T = np.array([np.eye(4), worked_poses()[1], worked_poses()[2]])
    T[1, 2, 3], T[2, :3, :3] = 0.4, Rotation.from_rotvec([0.3, 0.5, 0.9]).as_matrix()  # spatial
    D = relative_displacements(T)
    con = conic(D)
    B01, B02, B12 = con.B
    assert conic_member(D, [B02 / B12, B01 / B12]) == pytest.approx(con.C, abs=1e-15)


@pytest.mark.parametrize("seed", range(3))
def test_every_member_is_a_motion_through_the_poses(seed):
    rng = np.random.default_rng(seed)
    for poses, k in ((planar_poses(4, seed), 4), (spherical_poses(4, seed), 4)):
        D = relative_displacements(poses)
        lam = rng.normal(size=(5, 3))
        C3 = conic_member(D[None, :3], lam[:, :2])
        t3 = rng.choice([-2.0, 0.4, 3.0], size=5)
        C4 = cubic_member(D[None], t3, lam)
        assert np.max(study_residual(C3)) < 1e-14 and np.max(study_residual(C4)) < 1e-14
        assert evaluate(C3, np.array(0.0)) == pytest.approx(lam[:, :1] * D[1], abs=1e-14)
        assert evaluate(C4, np.array(1.0)) == pytest.approx(lam[:, 1:2] * D[2], abs=1e-14)
        vals = np.array([evaluate(C4[i], t3[i]) for i in range(5)])
        assert vals == pytest.approx(lam[:, 2:3] * D[3], abs=1e-13)


def test_classification():
    zp = zero_pitch(planar_poses(3, 0, normal=(1, 2, 2)), "abc")
    assert zp.kind == "planar" and zp.normal == pytest.approx(np.array([1, 2, 2]) / 3, abs=1e-12)
    zs = zero_pitch(spherical_poses(3, 1), "abc")
    assert zs.kind == "spherical" and zs.centre == pytest.approx([0.2, 0.3, 0.5], abs=1e-12)
    assert zero_pitch(np.array([np.eye(4), worked_poses()[1], spherical_poses(3, 1)[2]]), "abc") is None


# ------------------------------------------------------------------ syntheses
@pytest.mark.parametrize("seed", range(1))  # more seeds: test_random_sets_sweep (slow)
def test_planar_and_spherical_four_bars(seed):
    for poses, kind in ((planar_poses(3, 10 + seed), "planar"), (spherical_poses(3, 20 + seed), "spherical")):
        L = bennett(poses)
        assert L.kind == f"{kind}_4r" and len(L.joints) == 4
        assert L.checks["max_pose_error"] < 1e-10 and L.checks["max_closure_error"] < 1e-10
        U = np.array([j.direction for j in L.joints])
        if kind == "planar":
            assert np.all(np.abs(np.abs(U[:, 2]) - 1) < 1e-12)  # parallel axes (normal z)
        else:
            c = np.array(L.info.synthesis.family.centre)
            assert max(np.linalg.norm(np.cross(c - j.point, j.direction)) for j in L.joints) < 1e-12
        bp = L.info.bennett  # opposite sides equal: lengths (planar) or angles (spherical)
        assert (bp.opposite_length_mismatch if kind == "planar" else bp.opposite_twist_mismatch) < 1e-9
        assert set(L.info.synthesis.member.to_dict()) == {"lambda1", "lambda2"}


def test_planar_watt_sixbar_has_mobility_one():
    L = sixbar(planar_poses(4, 3))
    assert L.kind == "planar_sixbar" and len(L.joints) == 7 and len(L.closures) == 2
    assert L.checks["max_pose_error"] < 1e-10 and L.checks["max_closure_error"] < 1e-10
    assert all(abs(abs(j.direction[2]) - 1) < 1e-12 for j in L.joints)
    dofs, _ = mobility(L, [-2.0, 0.3, 5.0], tol=1e-9)
    assert dofs == [1, 1, 1]


def test_member_options_and_refusals():
    T = planar_poses(3, 5)
    L = bennett(T, member=(-0.5, 2.0))
    assert L.info.synthesis.member.to_dict() == {"lambda1": -0.5, "lambda2": 2.0}
    with pytest.raises(InputError, match="nonzero"):
        bennett(T, member=(0.0, 1.0))
    spatial = np.array([np.eye(4), worked_poses()[1], spherical_poses(3, 1)[2]])
    with pytest.raises(InputError, match="spatial"):
        bennett(spatial, member=(1.0, 1.0))
    trans = np.array([np.eye(4)] * 3)
    trans[1, :3, 3], trans[2, :3, 3] = [1, 0, 0], [0, 1, 0]
    with pytest.raises(SynthesisError, match="pure translations"):
        bennett(trans)
    with pytest.raises(InputError, match="T3,L1,L2,L3"):
        sixbar(planar_poses(4, 3), member=2.0)


# ------------------------------------------------------------------ CLI + the shared verifier
def test_cli_member_option():
    """(The fixtures' end-to-end runs with the shared verifier: tests/test_cli_bennett.py, which takes every
    fixtures/bennett_*.yaml, and the slow test below.)"""
    r = CliRunner().invoke(mpsynth, ["bennett", str(FIX / "bennett_planar.yaml"), "--member=-0.5,2"])
    assert r.exit_code == 0 and "member lambda1 = -0.5, lambda2 = 2 " in r.output
    r = CliRunner().invoke(mpsynth, ["bennett", str(FIX / "bennett_planar.yaml"), "--member", "1"])
    assert r.exit_code == 2 and "--member needs 2 comma-separated finite numbers" in r.output


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bennett_planar", "bennett_spherical", "sixbar_planar", "sixbar_spherical"])
def test_fixtures_pass_the_verifier_with_collisions(tmp_path, name):
    out = tmp_path / "o"
    r = CliRunner().invoke(mpsynth, [name.split("_")[0], str(FIX / f"{name}.yaml"), "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    if not VERIFIER.exists():
        pytest.skip("shared verifier not present")
    res = subprocess.run([sys.executable, str(VERIFIER), str(FIX / f"{name}.yaml"), str(out), "--collisions"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_random_sets_sweep(seed):
    for T in (planar_poses(3, 100 + seed), spherical_poses(3, 200 + seed)):
        L = bennett(T)
        assert L.checks["max_pose_error"] < 1e-9 and L.kind.endswith("_4r")
    for T in (planar_poses(4, 300 + seed), spherical_poses(4, 400 + seed)):
        L = sixbar(T)
        assert L.checks["max_pose_error"] < 1e-9 and mobility(L, [0.5], tol=1e-9)[0] == [1]
