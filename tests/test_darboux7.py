"""The 7R linkage of a general Darboux motion (synth/synthesis/darboux.py, docs/exceptional.md section 6):
the two chains by the general construction, random Darboux motions in random frames, the vertical and
planar cases it refuses, and `mpsynth curve` end to end (yourdfpy FK, mpsynth check, the shared verifier)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from synth.algebra.dq import dq_conj, dq_mul, qmul
from synth.algebra.expr import parse_polynomial
from synth.algebra.polynomial import poly_mul
from synth.synthesis.darboux import chain_residuals, chains, darboux_linkage, darboux_structure

from conftest import assert_verified

REPO = Path(__file__).resolve().parents[1]
GENERAL = "(t^2 + 1)*(t - k) + eps*(i + k/2 - (j + k/2)*t)*(t - k)"  # fixtures/motion_darboux_general.yaml
VERTICAL = "(t^2 + 1)*(t - k) - eps*t*k*(t - k)"  # fixtures/motion_darboux.yaml


def _C(expr):
    return np.array(parse_polynomial(expr), float)


def test_chains_of_the_fixture_are_the_documented_ones():
    """The minimum-norm members: h1, h2 along -+(4, 4, -7)/9 with dual part (-1/16, 1/2, 1/4), h3 = k + (1/8)
    eps i; g4 = k - eps i (the segment translation's axis), g1 g2 g3 parallel, perpendicular to the segment
    direction (1, 1, 1/2)/(3/2); both products multiply back."""
    C = _C(GENERAL)
    H, G = chains(C)
    u = np.array([4, 4, -7]) / 9
    assert np.allclose(H[0], [0, *u, 0, -1 / 16, 1 / 2, 1 / 4], atol=1e-14)
    assert np.allclose(H[1], [0, *-u, 0, -1 / 16, 1 / 2, 1 / 4], atol=1e-14)
    assert np.allclose(H[2], [0, 0, 0, 1, 0, 1 / 8, 0, 0], atol=1e-14)
    assert np.allclose(G[3], [0, 0, 0, 1, 0, -1, 0, 0], atol=1e-14)
    d = np.array([1, 1, 0.5]) / 1.5
    for g in G[:3]:
        assert abs(np.linalg.norm(np.cross(g[1:4], G[0, 1:4]))) < 1e-14 and abs(g[1:4] @ d) < 1e-14
    rh, rg = chain_residuals(C, H, G)
    assert rh < 1e-14 and rg < 1e-14


def test_vertical_and_planar_darboux_motions_are_refused():
    assert darboux_structure(_C(VERTICAL)) is not None and chains(_C(VERTICAL)) is None  # circular eqs singular
    assert chains(_C("(t^2 + 1)*(t - k) + eps*(i - 2*j*t)*(t - k)")) is None  # planar: no segment axis
    assert darboux_structure(_C("t^2 + 1 + eps*(i + j*t)")) is None  # not cubic
    assert chains(_C("(t - i)*(t - j - eps*k)*(t - k + eps*i)")) is None  # no real factor of the primal


def _random_darboux(rng):
    """A general Darboux motion T (t - k), T = t^2 + 1 + eps(a + b t), moved by a random rigid change of
    frame X C X~ and reparametrized t -> (t - t0)/s, made monic."""
    a, b = rng.normal(size=(2, 3))
    T = np.zeros((3, 8))
    T[0, 0] = T[2, 0] = 1
    T[0, 5:8], T[1, 5:8] = a, b
    R = np.zeros((2, 8))
    R[0, 3], R[1, 0] = -1, 1  # t - k
    C = poly_mul(T, R)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    X = np.concatenate([q, 0.5 * qmul(np.concatenate([[0], 0.5 * rng.normal(size=3)]), q)])  # q + eps d q / 2
    Cx = dq_mul(dq_mul(X, C), dq_conj(X))
    t0, s = rng.normal(), rng.uniform(0.5, 2)
    out = np.zeros_like(Cx)
    for k, coef in enumerate(Cx):  # C((t - t0)/s) s^3
        for m in range(k + 1):
            out[m] += coef * math.comb(k, m) * (-t0) ** (k - m) * s ** (3 - k)
    return out / out[3, 0]


@pytest.mark.parametrize("seed", range(4))
def test_random_darboux_motions_get_a_mobile_seven_joint_loop(seed):
    from synth.synthesis.multiloop import mobility

    C = _random_darboux(np.random.default_rng(seed))
    lk = darboux_linkage(C, check_samples=60)
    assert lk is not None
    rh, rg = lk.info.synthesis.darboux.residuals.values()
    assert rh < 1e-12 and rg < 1e-12
    assert len(lk.joints) == 7 and [j.rate for j in lk.joints] == [1, 1, 1, 1, 2, 1, 1]
    assert lk.checks["max_closure_error"] < 1e-10 and lk.checks["max_motion_error"] < 1e-10
    ts = np.array([-1.7, 0.05, 0.9, 3.1])
    dofs, _ = mobility(lk, ts)
    assert dofs == [1, 1, 1, 1]


def test_members_of_the_construction():
    """Other turns of the parallel axes and members of the 3R family multiply back and close mobile loops;
    the turn pi/2 (u in the plane of d and vec p) gives 2 degrees of freedom and is refused."""
    C = _C(GENERAL)
    for turn, shift in ((5 * np.pi / 8, (-0.5, 0.0)), (3 * np.pi / 4, (0.0, 0.3))):
        H, G = chains(C, turn, shift)
        assert max(chain_residuals(C, H, G)) < 1e-14
        lk = darboux_linkage(C, turn=turn, shift=shift, check_samples=20, singular=False)
        assert lk.info.synthesis.mobility.dof == 1 and lk.checks["max_closure_error"] < 1e-12
    assert chains(C, np.pi / 2) is not None and darboux_linkage(C, turn=np.pi / 2, singular=False) is None


def test_singular_configurations_are_recorded():
    """Where the three parallel axes k1 k2 k3 become coplanar the loop Jacobian loses rank: for the fixture
    at t = +-1 +- sqrt 2 (h1 at 45, 135, 225, 315 degrees); another branch of the configuration curve
    crosses the motion there."""
    lk = darboux_linkage(_C(GENERAL), check_samples=20)
    r2 = np.sqrt(2)
    assert np.allclose(sorted(lk.info.synthesis.darboux.singular_t), [-1 - r2, 1 - r2, r2 - 1, 1 + r2], atol=1e-6)
    assert lk.info.synthesis.mobility.dof == 1


def test_curve_builds_the_7r_end_to_end(tmp_path):
    """`mpsynth curve` on the fixture: 7 joints, k2 of rate 2 in linkage.json; the default member's design
    collides, so a collision-free member is chosen (synth/design/members.py) and said in words; the URDF
    (yourdfpy) at the law angles closes the weld and its tool traces the Darboux path; `mpsynth collide`,
    `mpsynth check` (through its branch crossing) and the shared verifier (with --trace tool --curve and
    --collisions at the written clearance over the full cycle) accept it."""
    import yourdfpy
    from click.testing import CliRunner

    from cli.main import mpsynth
    from synth.algebra.anglelaw import angle_law

    out = tmp_path / "d7"
    r = CliRunner().invoke(mpsynth, ["curve", str(REPO / "fixtures/motion_darboux_general.yaml"), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert "singular configurations: h1 at 45, 127, 135, 225, 307, 315 deg" in r.output  # in words, not only in info
    # (turn 45.0 deg, singular at 117 and 297 deg, before the stacks of links that share a joint, issue 33)
    assert "member: turn 22.5 deg of the parallel axes, 3R shift (-0.482, 0) m" in r.output
    assert "design: collision-free over the full cycle" in r.output
    doc = json.loads((out / "linkage.json").read_text())
    col = doc["collision"]
    assert col["free"] and col["range"] == "full" and col["certified"] and col["min_distance"] >= col["clearance"]
    choice = doc["info"]["darboux"]["member_choice"]
    assert choice["member"] == doc["info"]["darboux"]["member"] and choice["free_found"] >= 1
    assert len(doc["joints"]) == 7 and doc["info"]["counts"]["loops"] == 1
    rates = {j["name"]: j["angle_law"].get("rate", 1) for j in doc["joints"]}
    assert rates == {"h1": 1, "h2": 1, "h3": 1, "k1": 1, "k2": 2, "k3": 1, "k4": 1}
    assert doc["info"]["motion"]["alternatives"][1]["joints"] == 10  # the ladder it replaces
    robot = yourdfpy.URDF.load(str(out / "linkage.urdf"), build_scene_graph=True, load_meshes=False)
    weld = np.linalg.inv(robot.get_transform("coupler")) @ robot.get_transform("coupler_k")  # all angles 0
    for t in (-2.0, -0.3, 0.7, 4.0):
        cfg = {j["name"]: float(angle_law(j["angle_law"]["a"], j["angle_law"]["b"], t, rates[j["name"]]))
               for j in doc["joints"]}
        robot.update_cfg(cfg)
        A, B = robot.get_transform("coupler"), robot.get_transform("coupler_k")
        assert np.allclose(A @ weld, B, atol=1e-12)
        th = 2 * np.arctan2(1, t)  # the tool origin runs on (cos - 1, sin, (cos - 1 + sin) / 2)
        p = robot.get_transform("tool")[:3, 3]
        assert np.allclose(p, [np.cos(th) - 1, np.sin(th), (np.cos(th) - 1 + np.sin(th)) / 2], atol=1e-12)
    r = CliRunner().invoke(mpsynth, ["check", str(out), "--no-meshes"])
    assert r.exit_code == 0 and "branch crossing(s) passed" in r.output, r.output
    r = CliRunner().invoke(mpsynth, ["collide", str(out), "-q"])
    assert r.exit_code == 0, r.output
    curve = tmp_path / "path.yaml"
    curve.write_text('curve:\n  x: "-2"\n  y: "2*t"\n  z: "t - 1"\n  w: "t^2 + 1"\n')
    assert_verified(out, "--steps", "90", "--trace", "tool", "--curve", curve, "--collisions", repr(col["clearance"]),
                    "--collision-range", "full")
