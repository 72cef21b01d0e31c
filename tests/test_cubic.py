"""The 4-pose quadric and its two families of cubic motions (synth/synthesis/cubic.py), and the factorizations
and loop geometry of their members (synth/synthesis/sixbar_loops.py)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from synth.algebra.algorithm1 import multiply_back, norm_roots, polish, root_conditioning
from synth.algebra.dq import quat_to_matrix
from synth.synthesis.cubic import (PAIRS, PERMS, families, parameter_separation, quadric, ruling_coordinates,
                                   ruling_inverse, ruling_matrix)
from synth.synthesis.sixbar_loops import factor_members, member_geometry
from synth.errors import SynthesisError
from synth.algebra.factorize import factorize
from synth.synthesis.conic import condition, relative_displacements, to_world
from synth.algebra.polynomial import evaluate, norm_poly, product_of_linear, study_residual

# MATH.md section 11 E
E_POSES = [((0, 0, 0), (1, 0, 0, 0)), ((1, 0, 0.5), (0.6, 0, 0, 0.8)), ((0.25, 1, 0.2), (0.6, 0.8, 0, 0)),
           ((-1, 0.5, 0), (0.2, 0.4, 0.4, 0.8))]
E_T3 = (0.841430631387, -0.784826857803)
E_C0 = [0.3, 0, 0, 0.4, 0.1, -0.15, 0.2, -0.075]
E_C1 = [-0.6676567652, 0.3246889073, 0.8343860133, 1.77843858, -0.2448920031, -0.2019373573, -0.6417448627,
        0.3886057611]
E_C2 = [-1.501695253, -1.483824932, -0.8343860133, -2.17843858, 0, 0.4606063597, 0.9923344744, -0.8062385716]
E_N = [0.25, 1.022156805, 1.76646423, -7.499167472, 8.5633062, -3.003390507, 1]  # ascending
E_AB = [(-0.1658995584, 0.1584960916), (0.7454471107, 0.4737237177), (0.922147701, 2.288485132)]
D1 = np.array([0.6, 0, 0, 0.8, 0.2, -0.3, 0.4, -0.15])


def e_poses():
    T = np.tile(np.eye(4), (4, 1, 1))
    for i, (p, q) in enumerate(E_POSES):
        T[i, :3, :3] = quat_to_matrix(np.array(q, float))
        T[i, :3, 3] = p
    return T


def random_poses(rng, scale=1.0, offset=0.0):
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, :3] = Rotation.random(4, random_state=rng).as_matrix()
    T[:, :3, 3] = rng.normal(size=(4, 3)) * scale + offset
    return T


def setup(T, conditioned=True):
    Tc, cond = condition(T) if conditioned else (T, None)
    D = relative_displacements(Tc)
    return D, cond


def family_with_t3(fams, t3):
    return min(fams, key=lambda f: abs(f.t3 - t3))


# ----------------------------------------------------------------------------- worked example E
@pytest.mark.parametrize("conditioned", [False, True])
def test_example_e_signature_and_t3(conditioned):
    D, _ = setup(e_poses(), conditioned)
    assert np.allclose(D[1], D1, atol=1e-15) or conditioned
    q = quadric(D)
    assert q.signature == (2, 2) and q.ruled
    fams, missing = families(q)
    assert not missing and len(fams) == 2
    assert sorted(f.t3 for f in fams) == pytest.approx(sorted(E_T3), abs=1e-11)
    # numbering: family 1 has the larger t3
    assert fams[0].index == 1 and fams[0].t3 == pytest.approx(E_T3[0], abs=1e-11)
    assert fams[1].index == 2 and fams[1].t3 == pytest.approx(E_T3[1], abs=1e-11)


@pytest.mark.parametrize("conditioned", [False, True])
def test_example_e_member_half(conditioned):
    """The member of the family with t3 = -0.7848 whose weight at t = 0 is C(0) = 0.5 D1."""
    D, cond = setup(e_poses(), conditioned)
    fam = family_with_t3(families(quadric(D))[0], E_T3[1])
    C = fam.member(0.5)
    if conditioned:
        C = to_world(C, cond)
    assert np.allclose(C[0], E_C0, atol=1e-13)
    assert np.allclose(C[0], 0.5 * D1, atol=1e-13)
    assert np.allclose(C[1], E_C1, atol=2e-9)
    assert np.allclose(C[2], E_C2, atol=2e-9)
    assert np.allclose(C[3], np.eye(8)[0], atol=0)
    assert np.allclose(norm_poly(C), E_N, atol=2e-9)
    z = norm_roots(norm_poly(C))
    assert np.allclose(np.c_[z.real, z.imag], E_AB, atol=2e-9)
    assert study_residual(C) < 1e-15


def test_example_e_six_factorizations_multiply_back():
    D, cond = setup(e_poses())
    fam = family_with_t3(families(quadric(D))[0], E_T3[1])
    C = to_world(fam.member(0.5), cond)
    mf = factor_members(C[None], polish=True)
    assert mf.ok.all()
    assert mf.residual.max() < 2e-15
    P = product_of_linear(mf.H[0])
    assert np.abs(P - C).max() / np.abs(C).max() < 2e-15
    assert len({tuple(np.round(h.ravel(), 9)) for h in mf.H[0]}) == 6  # six different factorizations
    # agrees with Algorithm 1 of synth.algebra.factorize (sequential division), matched by norm order
    res = factorize(C)
    assert len(res.factorizations) == 6
    theirs = np.array([complex(-q[1] / 2, np.sqrt(q[0] - q[1] ** 2 / 4)) for q in res.quadratics])
    match = [int(np.argmin(np.abs(theirs - w))) for w in mf.roots[0]]
    by_order = {f.order: f.factors for f in res.factorizations}
    for p, perm in enumerate(PERMS):
        assert np.abs(by_order[tuple(match[k] for k in perm)] - mf.H[0, p]).max() < 1e-13
    # equal norms: the leftmost (and the rightmost) factor is fixed by its quadratic
    for p, r in itertools.combinations(range(6), 2):
        if PERMS[p, 0] == PERMS[r, 0]:
            assert np.abs(mf.H[0, p, 0] - mf.H[0, r, 0]).max() < 1e-13
        if PERMS[p, 2] == PERMS[r, 2]:
            assert np.abs(mf.H[0, p, 2] - mf.H[0, r, 2]).max() < 1e-13


# ----------------------------------------------------------------------------- structure
def test_pair_table():
    """9 unordered pairs with different leftmost and different rightmost norms."""
    assert PAIRS.shape == (9, 2)
    assert all(PERMS[i, 0] != PERMS[j, 0] and PERMS[i, 2] != PERMS[j, 2] and i < j for i, j in PAIRS)
    allp = [(i, j) for i in range(6) for j in range(i + 1, 6)
            if PERMS[i, 0] != PERMS[j, 0] and PERMS[i, 2] != PERMS[j, 2]]
    assert [tuple(p) for p in PAIRS] == allp


def test_ruling_matrix_identities():
    rng = np.random.default_rng(1)
    y = rng.normal(size=(20, 4))
    M = ruling_matrix(y)
    assert np.allclose(np.linalg.det(M), y[:, 0] ** 2 + y[:, 1] ** 2 - y[:, 2] ** 2 - y[:, 3] ** 2)
    assert np.allclose(ruling_inverse(M), y)


def test_gram_matrix_bounded_and_rulings_rank_one():
    """|A| <= 1/2 by construction; the poses are rank-1 points of M."""
    rng = np.random.default_rng(2)
    for _ in range(10):
        D, _ = setup(random_poses(rng))
        q = quadric(D)
        assert np.max(np.abs(q.eigenvalues)) <= 0.5 + 1e-12
        assert np.allclose(q.coordinates(D) @ q.A @ q.coordinates(D).T * np.eye(4), 0, atol=1e-14)
        if q.ruled:
            _, _, rel = ruling_coordinates(q)
            assert rel.max() < 1e-12


@pytest.mark.parametrize("seed", range(6))
def test_members_interpolate_the_poses(seed):
    """Every member is a monic motion polynomial with C(t_i) = lambda_i D_i at t = inf, 0, 1, t3 (t3 the
    same for the whole family); affine combinations of members are members; the lambda1 label inverts."""
    rng = np.random.default_rng(100 + seed)
    while True:
        D, _ = setup(random_poses(rng))
        q = quadric(D)
        if q.ruled:
            break
    fams, _ = families(q)
    assert len(fams) == 2 and fams[0].t3 > fams[1].t3
    for fam in fams:
        phi = np.linspace(0.1, 3.0, 7)
        C, lam1 = fam.members(phi)
        assert np.all(study_residual(C) < 1e-13)
        lams = fam.lambdas(phi)
        assert np.allclose(lams[:, 0], lam1)
        vals = evaluate(C, fam.ts[1:])  # (7, 3, 8)
        assert np.allclose(vals, lams[..., None] * D[1:], atol=1e-12 * (1 + np.abs(lams).max()))
        for x, l1 in zip(phi, lam1):
            assert fam.phi_of_lambda1(l1) == pytest.approx(x, abs=1e-9)
            assert np.allclose(fam.member(l1), C[list(phi).index(x)], atol=1e-10 * (1 + np.abs(C).max()))
        mix = 0.3 * C[0] + 0.7 * C[1]
        l1 = 0.3 * lam1[0] + 0.7 * lam1[1]
        assert np.allclose(fam.member(l1), mix, atol=1e-10 * (1 + np.abs(mix).max()))


def test_bad_members_have_a_real_factor():
    D, _ = setup(e_poses())
    for fam in families(quadric(D))[0]:
        bad = fam.bad_members()
        C2 = fam.member(bad["lambda2"])
        assert np.abs(evaluate(C2, 1.0)).max() < 1e-12  # C(1) = 0: the real factor t - 1
        C3 = fam.member(bad["lambda3"])
        assert np.abs(evaluate(C3, fam.t3)).max() < 1e-12
        C1 = fam.member(0.0)
        assert np.abs(C1[0]).max() < 1e-14
        for C in (C1, C2, C3):
            im, _ = root_conditioning(norm_roots(norm_poly(C))[None])
            assert im[0] < 1e-6


def test_parameter_separation():
    assert parameter_separation(0.5) == pytest.approx(0.5 / np.sqrt(1.25) / np.sqrt(2), rel=1e-15)
    assert parameter_separation(1e-3) < 2e-3 and parameter_separation(1 + 1e-3) < 2e-3
    assert parameter_separation(1e4) < 2e-4
    assert parameter_separation(-1.0) > 0.5


def test_member_geometry_matches_direct_computation():
    from synth.algebra.dq import plucker
    from synth.algebra.geometry import common_normal

    D, _ = setup(e_poses())
    fam = family_with_t3(families(quadric(D))[0], E_T3[1])
    mf = factor_members(fam.member(0.5)[None])
    geo = member_geometry(mf)
    for p, (i, j) in enumerate(PAIRS):
        ring = [mf.H[0, i, 0], mf.H[0, i, 1], mf.H[0, i, 2], mf.H[0, j, 2], mf.H[0, j, 1], mf.H[0, j, 0]]
        L = [plucker(h) for h in ring]
        dists, angs, feet = [], [], []
        for a in range(6):
            (u1, m1), (u2, m2) = L[a], L[(a + 1) % 6]
            cn = common_normal(u1, m1, u2, m2)
            ang = abs(float(cn.twist))
            dists.append(float(cn.distance))
            angs.append(min(ang, np.pi - ang))
            feet += list(cn.feet)
        assert geo["min_offset"][0, p] == pytest.approx(min(dists), abs=1e-12)
        assert geo["min_twist"][0, p] == pytest.approx(min(angs), abs=1e-12)
        assert geo["extent"][0, p] == pytest.approx(max(np.linalg.norm(f) for f in feet), abs=1e-12)


# ----------------------------------------------------------------------------- refusals
def test_oval_set_refused_in_plain_words():
    rng = np.random.default_rng(3)
    for _ in range(200):
        D, _ = setup(random_poses(rng))
        q = quadric(D)
        if q.signature in ((3, 1), (1, 3)):
            with pytest.raises(SynthesisError, match="oval"):
                families(q)
            return
    pytest.fail("no oval set found")


def test_planar_poses_refused():
    T = np.tile(np.eye(4), (4, 1, 1))
    for i, (a, p) in enumerate([(0, (0, 0, 0)), (0.5, (1, 0, 0)), (1.2, (0, 1, 0)), (2.0, (1, 2, 0))]):
        T[i, :3, :3] = Rotation.from_rotvec([0, 0, a]).as_matrix()
        T[i, :3, 3] = p
    with pytest.raises(SynthesisError, match="zero pitch"):
        quadric(setup(T)[0])


def test_three_planar_poses_refused():
    """Poses 0-2 planar, pose 3 slightly out of the plane: the Gram matrix has rank 2."""
    T = np.tile(np.eye(4), (4, 1, 1))
    for i, (a, p) in enumerate([(0, (0, 0, 0)), (0.5, (1, 0, 0)), (1.2, (0, 1, 0)), (2.0, (1, 2, 0))]):
        T[i, :3, :3] = Rotation.from_rotvec([0, 0, a]).as_matrix()
        T[i, :3, 3] = p
    T[3, :3, :3] = Rotation.from_rotvec([1e-3, 0, 2.0]).as_matrix()
    with pytest.raises(SynthesisError, match="pair of planes"):
        quadric(setup(T)[0])


def test_dependent_poses_refused():
    """A fourth pose on the Bennett motion of the first three: the four do not span a 3-space."""
    from synth.synthesis.bennett import bennett
    from synth.algebra.polynomial import pose_at

    rng = np.random.default_rng(5)
    T3 = random_poses(rng)[:3]
    L = bennett(T3)
    T = np.concatenate([T3, (pose_at(L.motion, 0.37) @ T3[0])[None]])
    with pytest.raises(SynthesisError, match="not independent"):
        quadric(setup(T)[0])


def test_complex_t3_for_oval_sets():
    """MATH.md section 8: over C the construction still runs for an oval quadric and the two families put
    pose 3 at complex conjugate parameters. Check with complex ruling coordinates."""
    rng = np.random.default_rng(3)
    while True:
        D, _ = setup(random_poses(rng))
        q = quadric(D)
        if q.signature != (2, 2):
            break
    z = (q.coordinates(D) @ q.U) * np.sqrt(q.eigenvalues.astype(complex))  # x^T A x = sum z_i^2
    yy = z * np.array([1, 1, 1j, 1j])  # = y1^2 + y2^2 - y3^2 - y4^2
    M = np.stack([np.stack([yy[:, 0] + yy[:, 2], yy[:, 1] + yy[:, 3]], -1),
                  np.stack([yy[:, 3] - yy[:, 1], yy[:, 0] - yy[:, 2]], -1)], -2)
    assert np.abs(np.linalg.det(M)).max() < 1e-12
    t3s = []
    for transpose in (False, True):
        a = []
        for Mi in M:
            Mi = Mi.T if transpose else Mi
            col = Mi[:, np.argmax(np.linalg.norm(Mi, axis=0))]
            a.append(col / np.linalg.norm(col))
        det = lambda x, w: x[0] * w[1] - x[1] * w[0]  # noqa: E731
        alpha, beta = np.linalg.solve(np.stack([a[0], a[1]], -1), a[2])
        t3s.append(-beta * det(a[1], a[3]) / (alpha * det(a[0], a[3])))
    assert abs(t3s[0].imag) > 1e-6
    assert t3s[0] == pytest.approx(np.conj(t3s[1]), abs=1e-9)


def test_polish_restores_accuracy_for_nearly_real_roots():
    """Seeded set whose best member has nearly real norm roots near t = 1 (t3 ~ 1.0099): the plain
    factorization multiplies back to ~5e-12, Newton polishing to rounding level."""
    rng = np.random.default_rng(198)
    D, _ = setup(random_poses(rng))
    fam = family_with_t3(families(quadric(D))[0], 1.0099)
    assert fam.t3 == pytest.approx(1.0099, abs=1e-3)
    C = fam.member(-0.41519)
    plain = factor_members(C[None])
    assert plain.ok.all() and plain.residual.max() > 1e-13
    H, _ = polish(C[None, None], plain.H)
    assert multiply_back(C[None, None], H).max() < 1e-14
    refined = factor_members(C[None], polish=True)
    assert refined.residual.max() < 1e-14
