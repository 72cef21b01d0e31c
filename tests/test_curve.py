"""Curve- and motion-following linkages (issue 5): joint counts, exact tracing, the tracer frame in the
URDF, spec parsing and refusals."""
import json
import xml.etree.ElementTree as ET
from fractions import Fraction as F

import numpy as np
import pytest

from synth.io.curvespec import parse_real_polynomial, parse_spec
from synth.task import CurveSpec, MotionSpec
from synth.synthesis.curve import (UnboundedCurveError, curve_linkage, motion_linkage,
                                   trace_error)
from synth.algebra.dq import dq_to_pose
from synth.errors import InputError
from synth.algebra.expr import parse_polynomial
from synth.algebra.polynomial import evaluate, poly_mul
from synth.synthesis.multiloop import mobility
from synth.algebra.realfactor import UnboundedMotionError

ELLIPSE = ["1 - t^2", "2*2*t", "0", "1 + t^2"]


def _curve(texts, **kw):
    return curve_linkage(*[parse_real_polynomial(x, "test") for x in texts], texts=list(texts), **kw)


def _full_cycle(lk, n=4001):
    """Parameters covering one full cycle: t = tan(phi) over (-pi/2, pi/2) plus t = infinity."""
    phi = np.linspace(-np.pi / 2, np.pi / 2, n + 1)[1:-1]
    return np.concatenate([np.tan(phi), [np.inf]])


def _tracer_points(lk, t):
    p0 = np.array(lk.info.synthesis.markers["tracer"].position)
    D = lk.displacements(lk.angles_at(t))[lk.tool_link]
    return np.einsum("...ij,j->...i", D[..., :3, :3], p0) + D[..., :3, 3]


@pytest.fixture(scope="module")
def ellipse():
    return _curve(ELLIPSE)


def test_ellipse_has_at_most_10_joints(ellipse):
    lk = ellipse
    assert lk.kind == "curve"
    assert len(lk.joints) <= 10
    assert len(lk.joints) == 10 and lk.info.synthesis.counts.to_dict() == {"joints": 10, "links": 8, "links_with_duplicates": 11,
                                                         "loops": 3}
    assert lk.info.synthesis.curve.method == "rotation"
    assert lk.info.synthesis.motion.deg_R == 0


def test_ellipse_tracer_stays_on_the_curve_through_a_full_cycle(ellipse):
    lk = ellipse
    t = _full_cycle(lk)
    p = _tracer_points(lk, t)
    # x^2 + (y/2)^2 = 1, z = 0, and the point at each t is the curve's point at that t
    assert np.max(np.abs(p[:, 0] ** 2 + (p[:, 1] / 2) ** 2 - 1)) < 1e-9
    assert np.max(np.abs(p[:, 2])) < 1e-9
    tf = t[:-1]
    target = np.stack([(1 - tf**2) / (1 + tf**2), 4 * tf / (1 + tf**2)], -1)
    assert np.max(np.linalg.norm(p[:-1, :2] - target, axis=1)) < 1e-9
    assert np.allclose(p[-1], [-1, 0, 0], atol=1e-12)
    # every joint turns once over the cycle, the loops stay closed, one degree of freedom
    ang = lk.angles_at(t[:-1])
    for name, a in ang.items():
        assert np.ptp(np.unwrap(a)) == pytest.approx(2 * np.pi, abs=0.01), name
    D = lk.displacements(lk.angles_at(t))
    for a, b in lk.closures:
        assert np.max(np.abs(D[a] - D[b])) < 1e-12
    assert set(mobility(lk, t[::40])[0]) == {1}
    assert lk.checks["max_trace_error"] < 1e-12 and trace_error(lk) < 1e-12
    assert lk.checks["max_closure_error"] < 1e-12


def test_elliptic_translation_has_at_most_13_joints():
    lk = motion_linkage(parse_polynomial("t^2 + 1 + eps*(i + 2*j*t)", exact=True))
    assert lk.kind == "motion" and len(lk.joints) <= 13
    assert lk.info.synthesis.counts.joints == 13 and lk.info.synthesis.counts.links == 10
    assert lk.info.synthesis.motion.deg_R == 2 and lk.info.synthesis.motion.bound_met
    assert lk.checks["max_motion_error"] < 1e-12 and lk.checks["max_closure_error"] < 1e-12
    # the coupler translates: every point draws the ellipse (x + 1)^2 + (y/2)^2 = 1 (origin)
    t = _full_cycle(lk, 2001)
    D = lk.displacements(lk.angles_at(t))["coupler"]
    assert np.max(np.abs(D[:, :3, :3] - np.eye(3))) < 1e-12
    p = D[:, :3, 3]
    assert np.max(np.abs((p[:, 0] + 1) ** 2 + (p[:, 1] / 2) ** 2 - 1)) < 1e-12


def test_motion_with_coefficients_and_leading_coefficient():
    """C c with a constant displacement c (not monic): the tool frame follows pose(C(t) c) exactly."""
    from synth.algebra.dq import dq_mul, pose_to_dq

    C = np.array(parse_polynomial("t^2 + 1 + eps*(i + 2*j*t)"))
    T = np.eye(4)
    T[:3, :3] = [[np.cos(0.6), 0, np.sin(0.6)], [0, 1, 0], [-np.sin(0.6), 0, np.cos(0.6)]]
    T[:3, 3] = [0.2, -0.1, 0.3]
    c = 2.0 * pose_to_dq(T)
    Cc = np.array([dq_mul(row, c) for row in C])
    lk = motion_linkage(Cc.tolist())
    assert np.allclose(lk.tool_ref, T)
    t = _full_cycle(lk, 401)[:-1]
    tool = lk.displacements(lk.angles_at(t))["coupler"] @ lk.tool_ref
    target = dq_to_pose(evaluate(Cc, t))
    assert np.max(np.abs(tool - target)) < 1e-11
    assert len(lk.joints) == 13


def test_motion_real_content_is_removed():
    lk = motion_linkage(parse_polynomial("(t^2 + 4)*(t^2 + 1 + eps*(i + 2*j*t))", exact=True))
    assert len(lk.joints) == 13
    assert np.allclose(lk.info.synthesis.motion.real_content, [4, 0, 1])


def test_generic_motion_gives_a_ladder():
    lk = motion_linkage(parse_polynomial("(t - i - eps*j)*(t - 1 - 2*j - eps*(3*i + k))", exact=True))
    assert len(lk.joints) == 7 and lk.info.synthesis.motion.deg_R == 0
    assert lk.checks["max_motion_error"] < 1e-12 and lk.checks["max_closure_error"] < 1e-12


def test_unbounded_motion_needs_a_sliding_joint():
    with pytest.raises(UnboundedMotionError, match="needs a sliding joint"):
        motion_linkage(parse_polynomial("(t-1)*(t-j) - eps*((i+k)*t - 2*k)", exact=True))


@pytest.mark.parametrize("texts,match", [
    (["t", "0", "0", "1 + t^2 - 3*t"], "real zero"),
    (["t^3", "0", "0", "1 + t^2"], "deg x"),
    (["t", "1", "0", "t^2 - 1"], "real zero"),
])
def test_unbounded_curves(texts, match):
    with pytest.raises(UnboundedCurveError, match=match) as e:
        _curve(texts)
    assert e.value.exit_code == 1 and "unbounded curve" in str(e.value)


def test_single_point_is_an_input_error():
    with pytest.raises(InputError, match="single point"):
        _curve(["1 + t^2", "2 + 2*t^2", "0", "1 + t^2"])


def test_units_scale_to_metres():
    lk = _curve(["1000 - 1000*t^2", "4000*t", "0", "1 + t^2"], scale=1e-3)
    assert len(lk.joints) == 10 and lk.checks["max_trace_error"] < 1e-12
    assert np.allclose(lk.info.synthesis.markers["tracer"].position, [-1, 0, 0])


@pytest.mark.parametrize("name,texts,joints", [
    ("circle (circular translation): a parallelogram", ["1 - t^2", "2*t", "0", "1 + t^2"], 4),
    ("tilted ellipse off the origin", ["2 - t^2", "3*t + 2", "6 + t + 4*t^2", "1 + t^2"], 10),
    ("planar quartic, d = 4: (9/2) d + 1", ["t^3 - t", "t^2 + 2*t", "0", "(1 + t^2)*(4 + t^2)"], 19),
    ("space quartic", ["1 - t^2", "2*t", "t^3 + t^2", "(1 + t^2)*(t^2 + t + 2)"], 19),
])
def test_other_curves(name, texts, joints):
    lk = _curve(texts)
    assert len(lk.joints) == joints, name
    assert lk.checks["max_trace_error"] < 1e-10 and lk.checks["max_closure_error"] < 1e-10
    assert lk.info.synthesis.mobility.dof == 1


def test_repeated_denominator_uses_the_translation():
    """A cardioid-like quartic with w = (1 + t^2)^2 (a k = 2 block, planar)."""
    lk = _curve(["(1-t^2)^2", "2*t*(1-t^2) + 3*t^2", "0", "(1 + t^2)^2"])
    assert lk.info.synthesis.curve.method == "translation" and len(lk.joints) == 25
    assert lk.checks["max_trace_error"] < 1e-10


def test_export_writes_the_tracer_frame(ellipse, tmp_path):
    """URDF: link `tracer` on `coupler` by a fixed joint; FK at all-zero angles puts it at p0 and
    every loop closure pair is a <gazebo> weld; linkage.json has kind, closures, links, curve."""
    from synth.io.writer import write_output
    from synth.design.choose import design_for

    out = tmp_path / "ell"
    write_output(ellipse, out, robot_name="ellipse", result=design_for(ellipse))
    root = ET.parse(out / "linkage.urdf").getroot()
    joints = {j.get("name"): j for j in root.findall("joint")}
    tj = joints["tracer_mount"]
    assert tj.get("type") == "fixed" and tj.find("parent").get("link") == "coupler"
    assert tj.find("child").get("link") == "tracer"
    # world position of tracer at the reference configuration = sum of origins along the path
    parent = {j.find("child").get("link"): j for j in root.findall("joint")}
    pos, link = np.zeros(3), "tracer"
    while link in parent:
        j = parent[link]
        pos += np.array([float(v) for v in j.find("origin").get("xyz").split()])
        link = j.find("parent").get("link")
    assert np.allclose(pos, [-1, 0, 0], atol=1e-12)
    welds = [(g.find("joint/parent").text, g.find("joint/child").text) for g in root.findall("gazebo")]
    names = [g.find("joint").get("name") for g in root.findall("gazebo")]
    assert names == ["loop_closure", "loop_closure_2", "loop_closure_3"]
    doc = json.loads((out / "linkage.json").read_text())
    assert doc["kind"] == "curve" and doc["poses"] == []
    assert [tuple(c) for c in doc["closures"]] == welds
    assert doc["links"]["link_a1"] == ["h1", "m1", "h2"]
    assert doc["info"]["curve"]["x"] == "1 - t^2" and doc["info"]["counts"]["joints"] == 10
    assert doc["info"]["markers"]["tracer"]["link"] == "coupler"


# ------------------------------------------------------------------ spec parsing
def test_parse_curve_spec():
    spec = parse_spec({"curve": {"x": "1 - t^2", "y": "2*2*t", "z": 0, "w": "1 + t^2"}}, "s.yaml")
    assert isinstance(spec, CurveSpec)
    assert spec.polys == [[1, 0, -1], [0, 4], [0], [1, 0, 1]]


def test_parse_motion_specs():
    spec = parse_spec({"motion": {"expression": "t^2 + 1 + eps*(i + 2*j*t)"}})
    assert isinstance(spec, MotionSpec) and spec.C[1][6] == 2
    spec = parse_spec({"motion": {"coefficients": [[1, 0, 0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 0, 2, 0],
                                                   [1, 0, 0, 0, 0, 0, 0, 0.5 * 0]]}})
    assert spec.C[0][5] == F(1) and all(isinstance(x, F) for r in spec.C for x in r)


@pytest.mark.parametrize("doc,match", [
    ({"curve": {"x": "t", "y": "0", "w": "1+t^2"}}, "missing 'z'"),
    ({"curve": {"x": "t", "y": "0", "z": "i*t", "w": "1+t^2"}}, "real polynomial"),
    ({"curve": {"x": "t", "y": "0", "z": "0", "w": "1+t^2", "q": 1}}, "unknown key 'q'"),
    ({"curv": {}}, "did you mean 'curve'"),
    ({"curve": {"x": "t", "y": "0", "z": "0", "w": "1+t^2"}, "motion": {"expression": "t"}}, "exactly one"),
    ({"motion": {"coefficients": [[1, 2, 3]]}}, "8 numbers"),
    ({"motion": {"coefficients": [[1, 0, 0, 0, 0, 0, 0, "x"]]}}, "expected a number"),
    ({"motion": {"expression": "t^2 + __import__('os')"}}, "unexpected character"),
    ({"motion": {}}, "exactly one"),
    ([1, 2], "top level"),
])
def test_spec_errors(doc, match):
    with pytest.raises(InputError, match=match):
        parse_spec(doc, "spec.yaml")


@pytest.mark.parametrize("text,match", [
    ("t^2 + 1 + eps*(1 + i)", "Study|not a motion"),
    ("eps*i*t + 1", "leading coefficient"),
    ("3", "constant"),
])
def test_bad_motions(text, match):
    with pytest.raises(InputError, match=match):
        motion_linkage(parse_polynomial(text, exact=True))


def test_rotation_cofactor_reproduces_e4():
    """For the translation of the origin by E2's C, the rotation co-factor is H = t -+ k about the
    vertical axis through the origin: the coupler moves by C (t - k) (E4) or C (t + k)."""
    lk = _curve(["-2", "-4*t", "0", "1 + t^2"])
    C = np.array(parse_polynomial("t^2 + 1 + eps*(i + 2*j*t)"))
    options = [poly_mul(C, np.array(parse_polynomial(h))) for h in ("t - k", "t + k")]
    coupler = np.asarray(lk.info.synthesis.motion.coupler)
    assert min(np.max(np.abs(coupler - o)) for o in options) < 1e-12
    assert len(lk.joints) == 10 and lk.info.synthesis.motion.deg_R == 0


def test_common_factor_of_the_curve_is_cancelled_exactly():
    """x, y, z, w sharing (t^2 + 2)(t - 3) draw the same ellipse as the reduced curve (exact division)."""
    base = ["2 - t^2", "3*t + 2", "6 + t + 4*t^2", "1 + t^2"]
    lk0 = _curve(base)
    lk = _curve([f"({p})*(t^2 + 2)*(t - 3)" for p in base])
    assert len(lk.joints) == len(lk0.joints) == 10
    assert np.allclose(lk.info.synthesis.markers["tracer"].position, lk0.info.synthesis.markers["tracer"].position)
    assert lk.checks["max_trace_error"] < 1e-10
