"""Point tasks (docs/points.md): the interpolation, the scan, linkages from points of known linkages, the
file format, the CLI (with the shared verifier), batch jobs and the API."""
from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import synth
from synth.algebra import algorithm1 as a1
from synth.algebra.dq import act_on_points
from synth.algebra.polynomial import evaluate, norm_poly, study_residual
from synth.errors import InputError, SynthesisError
from synth.io.poses import parse_pose_document
from synth.synthesis.bennett import bennett
from synth.synthesis.pointfit import parameter_samples, point_motion, scan
from synth.synthesis.points import bennett_points, point_candidates, sixbar_points

from conftest import REPO, assert_verified, random_poses, run


def write_points(path, P, unit="m"):
    lines = [f"units: {{length: {unit}}}", "points:"] + [f"  - [{', '.join(repr(float(x)) for x in p)}]" for p in P]
    path.write_text("\n".join(lines) + "\n")
    return path


def tool_points(linkage, ts):
    """Positions of the tool frame's origin of a linkage at parameters ts."""
    return np.array([linkage.tool_pose({k: float(v) for k, v in linkage.angles_at(t).items()})[:3, 3] for t in ts])


def known_bennett_points(seed):
    """Five points of the tool origin of a random Bennett linkage (so a solution exists)."""
    rng = np.random.default_rng(seed)
    L = bennett(random_poses(rng, 3, scale=0.3, offset=(0.2, -0.1, 0.5)))
    return tool_points(L, np.concatenate([[np.inf], np.sort(rng.normal(size=4))]))


def known_sixbar_points(seed):
    """Seven points of the tool origin of a random 6R linkage (the first seed from ``seed`` on whose four
    random poses have one: about 15% of pose sets have an oval quadric)."""
    for s in range(seed, seed + 50):
        rng = np.random.default_rng(s)
        try:
            L = synth.sixbar(random_poses(rng, 4, scale=0.3))
            break
        except SynthesisError:
            continue
    return tool_points(L, np.concatenate([[np.inf], np.sort(rng.normal(size=6))]))


def assert_visits(linkage, P, tol=1e-9):
    """Every point record: kind point, the tool origin at the given point at the record's angles."""
    spread = np.sqrt(np.mean(np.sum((P - P.mean(0)) ** 2, 1)))
    for rec, p in zip(linkage.poses, P):
        assert rec.kind == "point"
        assert np.linalg.norm(linkage.tool_pose(rec.joint_angles)[:3, 3] - p) < tol * spread
    assert linkage.checks["max_closure_error"] < tol * max(1.0, spread)


# ----------------------------------------------------------------------------- the interpolation
def test_points_doc_example():
    """docs/points.md, section 2: the worked quadratic through five points."""
    X = np.array([[[2, 0, 0], [2, 2, 0], [0, 2, 2], [0, 0, 2]]], float)
    C = point_motion(X, np.array([[-1, -1 / 3, 1 / 3, 1]]), 2)[0]
    f = 4 / 3
    assert np.allclose(C, [[-1, -f, 0, f, 0, -f, 2 * f, -f], [0, -f, -2 * f, -f, 0, -f, 0, f], np.eye(8)[0]],
                       atol=1e-14)
    assert np.allclose(norm_poly(C), [41 / 9, 0, 26 / 3, 0, 1], atol=1e-13)
    z = a1.norm_roots(norm_poly(C)[None])[0]
    assert np.allclose(z, [0.749731j, 2.846853j], atol=1e-6)
    assert np.allclose(z.imag ** 2, [(13 - 8 * np.sqrt(2)) / 3, (13 + 8 * np.sqrt(2)) / 3])


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([2, 3]))
def test_point_motion_interpolates(seed, n):
    """Property: the solution is a motion polynomial (Study residual at rounding level) that moves the
    origin to every point at its parameter; a batch equals its rows solved alone."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(3, 2 * n, 3))
    t = parameter_samples(3, 2 * n - 2, seed)
    C = point_motion(X, t, n)
    for b in range(3):
        assert study_residual(C[b]) < 1e-9
        got = act_on_points(evaluate(C[b], t[b]), np.zeros(3))
        assert np.abs(got - X[b]).max() < 1e-8 * max(1.0, np.abs(C[b]).max())
        assert np.allclose(point_motion(X[b:b + 1], t[b:b + 1], n)[0], C[b], rtol=1e-9, atol=1e-12)


def test_scan_scores_and_parameters():
    """The scan: evenly spaced row 0, ordered parameters in [-1, 1], valid loops scored in (0, inf)."""
    Y = np.random.default_rng(3).normal(size=(5, 3))
    sc = scan(Y, 2, samples=40)
    assert np.allclose(sc.t[0], [-1, -1 / 3, 1 / 3, 1])
    assert np.all(np.diff(sc.t, axis=1) > 0)
    assert sc.valid.any() and np.all(sc.score[sc.valid] > 0) and np.all(sc.score[~sc.valid] == 0)


# ----------------------------------------------------------------------------- linkages from points
@pytest.mark.parametrize("seed", [0, 1])
def test_bennett_through_points_of_a_known_linkage(seed):
    P = known_bennett_points(seed)
    L = bennett_points(P, check_samples=50)
    assert L.kind == "bennett" and len(L.joints) == 4
    assert_visits(L, P)
    bp = L.info.bennett
    assert abs(bp.bennett_condition_residual) < 1e-8  # a genuine Bennett linkage


def test_sixbar_through_points_of_a_known_linkage():
    P = known_sixbar_points(5)
    Ls = point_candidates(P, degree=3, top=3, check_samples=50)
    assert 1 <= len(Ls) <= 3 and all(L.kind == "6r" for L in Ls)
    assert [L.info.synthesis.score for L in Ls] == sorted((L.info.synthesis.score for L in Ls), reverse=True)
    for L in Ls:
        assert_visits(L, P)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(10, 30))
def test_known_linkage_sweep(seed):
    assert_visits(bennett_points(known_bennett_points(seed)), known_bennett_points(seed))
    P = known_sixbar_points(seed)
    assert_visits(sixbar_points(P), P)


def test_fewer_points_are_completed():
    """Four points for a Bennett linkage: one more is chosen, reported, and not listed as a pose."""
    P = known_bennett_points(7)[:4]
    L = bennett_points(P, check_samples=20)
    assert len(L.poses) == 4 and len(L.info.synthesis.chosen_points) == 1
    assert "missing point" in L.info.synthesis.freedom
    assert_visits(L, P)


@pytest.mark.parametrize("oriented", [0, 3])
def test_one_item_may_carry_the_orientation(oriented):
    """One full pose among the points: the tool frame reaches it (item 0 stays the reference configuration,
    the scan's order starts at the oriented item and the motion is re-referenced), every point is visited
    and the parameters keep the given order."""
    P = known_bennett_points(2)
    R = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    L = point_candidates(P, degree=2, top=1, tool_rotation=R, oriented=oriented, check_samples=20)[0]
    assert [r.kind for r in L.poses] == ["pose" if i == oriented else "point" for i in range(5)]
    assert np.allclose(L.tool_pose(L.poses[oriented].joint_angles)[:3, :3], R, atol=1e-12)
    assert np.allclose(L.poses[oriented].matrix[:3, :3], R)
    spread = np.sqrt(np.mean(np.sum((P - P.mean(0)) ** 2, 1)))
    for rec, p in zip(L.poses, P):
        assert np.linalg.norm(L.tool_pose(rec.joint_angles)[:3, 3] - p) < 1e-9 * spread
    ts = [r.t for r in L.poses[1:]]
    assert np.isinf(L.poses[0].t) and ts == sorted(ts)


def test_rereference_example():
    """docs/points.md, section 3: D(s) = s^n C(t0 - 1/s) C(t0)^-1 for the worked quadratic."""
    from synth.algebra.dq import dq_inv, dq_mul
    from synth.algebra.polynomial import product_of_linear
    from synth.synthesis.pointfit import rereference

    C = point_motion(np.array([[[2, 0, 0], [2, 2, 0], [0, 2, 2], [0, 0, 2]]], float),
                     np.array([[-1, -1 / 3, 1 / 3, 1]]), 2)[0]
    z = a1.norm_roots(norm_poly(C)[None])
    H, ok = a1.algorithm1(C[None], a1.quadratics(z))
    assert ok[0]
    D = product_of_linear(rereference(H[0], 1.0))
    for s in (-2.0, 0.5, 3.0):
        want = s ** 2 * dq_mul(evaluate(C, 1.0 - 1.0 / s), dq_inv(evaluate(C, 1.0)))
        assert np.allclose(evaluate(D, s), want, atol=1e-12)
    assert np.allclose(D[-1], np.eye(8)[0])


@pytest.mark.parametrize("P, err, text", [
    (np.zeros((6, 3)), InputError, "needs 5 points"),
    (np.r_[np.zeros((1, 3)), np.full((4, 3), np.nan)], InputError, "NaN"),
    (np.outer(np.arange(5.0), [1, 2, 3]), SynthesisError, "collinear"),
    (np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0], [0, 1, 1], [2, 1, 0]], float), SynthesisError, "coincide"),
    (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 2, 0], [3, 1, 0]], float), SynthesisError, "coplanar"),
])
def test_bad_point_sets(P, err, text):
    with pytest.raises(err, match=text):
        bennett_points(P)


# ----------------------------------------------------------------------------- files
def test_point_documents():
    doc = {"units": {"length": "mm"}, "poses": [{"name": "a", "position": [1, 2, 3], "rpy": [0, 0, 0]},
                                                {"name": "b", "position": [4, 5, 6]}],
           "points": [[7, 8, 9], {"name": "d", "position": [0, 0, 1]}]}
    ps = parse_pose_document(doc, points=(1, None))
    assert ps.kinds == ["pose", "point", "point", "point"] and ps.names == ["a", "b", "p2", "d"]
    assert np.allclose(ps.positions[2], [0.007, 0.008, 0.009])
    with pytest.raises(InputError, match="accepted by mpsynth bennett and mpsynth sixbar only"):
        parse_pose_document({"points": [[0, 0, 0]]})
    with pytest.raises(InputError, match="point 1: unknown key \"rpy\" of a point"):
        parse_pose_document({"points": [[0, 0, 0], {"position": [1, 1, 1], "rpy": [0, 0, 0]}]}, points=(1, None))
    with pytest.raises(InputError, match="needs between 3 and 5 points, got 2 for a point task"):
        parse_pose_document({"points": [[0, 0, 0], [1, 1, 1]]}, points=((3, 5), "mpsynth bennett"))


# ----------------------------------------------------------------------------- CLI
def test_cli_bennett_points_fixture_verifies(tmp_path):
    fixture = REPO / "fixtures" / "bennett_points.yaml"
    out = tmp_path / "out"
    r = run("bennett", fixture, "-o", out)
    assert r.exit_code == 0, r.output
    assert "point design: parameters" in r.output
    doc = json.loads((out / "linkage.json").read_text())
    assert [p["kind"] for p in doc["poses"]] == ["point"] * 5
    assert np.allclose(doc["poses"][1]["position"], [0.228939, -0.35069, 0.474726])
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(out / "linkage.urdf"), load_meshes=False, build_collision_scene_graph=False)
    for rec in doc["poses"]:
        urdf.update_cfg({k: v for k, v in rec["joint_angles"].items() if k in urdf.actuated_joint_names})
        assert np.linalg.norm(urdf.get_transform("tool", "base")[:3, 3] - rec["position"]) < 1e-9
    assert run("check", out, "--poses", fixture, "--no-meshes", "-q").exit_code == 0
    assert_verified(fixture, out)


def test_cli_bennett_points_top(tmp_path):
    out = tmp_path / "top"
    r = run("bennett", REPO / "fixtures" / "bennett_points.yaml", "--top", "2", "-o", out)
    assert r.exit_code == 0, r.output
    index = json.loads((out / "index.json").read_text())
    assert index["task"] == "points" and [s["rank"] for s in index["solutions"]] == [1, 2]
    assert all((out / s["id"] / "linkage.urdf").exists() for s in index["solutions"])
    assert "the 2 best of the scan" in r.output


@pytest.mark.slow
def test_cli_sixbar_points_top_verifies(tmp_path):
    fixture = REPO / "fixtures" / "sixbar_points.yaml"
    out = tmp_path / "top"
    r = run("sixbar", fixture, "--top", "2", "-o", out, "-q")
    assert r.exit_code == 0, r.output
    index = json.loads((out / "index.json").read_text())
    assert index["task"] == "points" and len(index["solutions"]) == 2
    for s in index["solutions"]:
        assert_verified(fixture, out / s["id"])


def test_cli_known_random_points_verify(tmp_path):
    """Seeded random point sets from known linkages: a 5-point Bennett and a 7-point 6R task written by the
    CLI and accepted by the shared verifier."""
    for cmd, P in (("bennett", known_bennett_points(11)), ("sixbar", known_sixbar_points(14))):
        f = write_points(tmp_path / f"{cmd}.yaml", P * 1000, unit="mm")
        r = run(cmd, f, "-o", tmp_path / cmd, "-q")
        assert r.exit_code == 0, r.output
        assert_verified(f, tmp_path / cmd)


@pytest.mark.parametrize("text, code, msg", [
    ("points: [[0,0,0],[1,0,0]]", 2, "needs at least 3 points, got 2"),  # (more than 5: fitted, docs/fit.md)
    ("points: [[0,0,0],[1,0,0],[2,0,0],[3,0,0],[4,0,0]]", 1, "collinear"),
    ("points: [[0,0,0],[1,0,.nan],[2,1,0],[3,0,1],[4,0,0]]", 2, "not finite"),
    ("poses: [{position: [0,0,0], rpy: [0,0,0]}, {position: [1,0,0], rpy: [0,0,1]}, {position: [1,1,0]}]", 2,
     "both have one, a point task takes at most one"),
])
def test_cli_bad_points(tmp_path, text, code, msg):
    f = tmp_path / "p.yaml"
    f.write_text(text + "\n")
    r = run("bennett", f, "-o", tmp_path / "out")
    assert r.exit_code == code and msg in r.output
    assert len(r.output.strip().splitlines()) == 1 and not (tmp_path / "out").exists()


def test_cli_top_needs_points():
    r = run("bennett", REPO / "fixtures" / "bennett_quat.yaml", "--top", "2")
    assert r.exit_code == 2 and "point tasks and fits only" in r.output


def test_batch_and_api_accept_points():
    from synth.tools.batchjobs import run_job

    P = known_bennett_points(4)
    job = json.dumps({"id": "p", "kind": "bennett", "points": P.tolist()})
    res = run_job((1, job))
    assert res["ok"] and res["joints"] == 4, res
    assert synth.bennett_points(P, check_samples=10).kind == "bennett"
