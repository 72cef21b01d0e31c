"""Families of factorizations (docs/exceptional.md, "Families of factorizations"): the circular
translation's 2-parameter family (survey eq. (5)), the 4-parameter family of the ellipse's C R, the
parallelogram flip, separating coincident neighbours (the vertical Darboux motion), and the linkages
built from them (parallelogram, Darboux ladder), end to end with the shared verifier when present."""
from __future__ import annotations

from fractions import Fraction as F
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synth.algebra.cofactor import factorize_with_cofactor
from synth.algebra.dq import exact_array
from synth.algebra.expr import parse_polynomial
from synth.algebra.family import (coincident_neighbours, conjugate_pairs, factorization_family, family_member,
                                  family_residual, separate_coincident)
from synth.algebra.flip import FlipError, parallelogram_flip
from synth.algebra.polynomial import product_of_linear, relative_error
from synth.synthesis.curve import curve_linkage, motion_linkage

from conftest import assert_verified

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "fixtures"
DARBOUX = "(t^2 + 1)*(t - k) - eps*t*k*(t - k)"


def poly(text):
    return np.array(parse_polynomial(text), float)


def circular(a):
    return factorize_with_cofactor(parse_polynomial(f"t^2 + 1 + eps*({a}*i + {a}*j*t)", exact=True))


# ------------------------------------------------------------------ the circular translation
@pytest.mark.parametrize("a", [1, 3, F(-5, 2)])
def test_circular_translation_family_is_equation_5(a):
    """R = 1; the family through the min-norm member h1 = k - (a/2) eps j, h2 = -k - (a/2) eps j with the
    offset s = f i + g j is the survey's eq. (5) with f_s = f, g_s = g - a/2 (checked member by member)."""
    a = float(a)
    res = circular(a)
    assert res.deg_R == 0
    fam = factorization_family(res.factors)
    assert fam["parameters"] == ["f", "g"] and fam["pairs"] == [[1, 2]]
    assert np.allclose(res.factors, [[0, 0, 0, 1, 0, 0, -a / 2, 0], [0, 0, 0, -1, 0, 0, -a / 2, 0]])
    for f, g in [(0.0, 0.0), (0.7, -1.3), (-2.0, 5.0)]:
        h1, h2 = family_member(fam, [f, g])
        fs, gs = f, g - a / 2
        assert np.allclose(h1, [0, 0, 0, 1, 0, -fs, -(a + gs), 0])  # k - eps(f i + (a + g) j)
        assert np.allclose(h2, [0, 0, 0, -1, 0, fs, gs, 0])  # -k + eps(f i + g j)
        assert relative_error(product_of_linear(np.stack([h1, h2])), poly(f"t^2 + 1 + eps*({a}*i + {a}*j*t)")) < 1e-15


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-50, 50), min_size=4, max_size=4))
def test_every_member_multiplies_back(values):
    """Ellipse C R = four rotations, two conjugate pairs: a 4-parameter family; every member has the
    product C R (relative error at rounding level, the offsets up to 50 times the ellipse)."""
    res = factorize_with_cofactor(parse_polynomial("t^2 + 1 + eps*(i + 2*j*t)", exact=True))
    fam = factorization_family(res.factors)
    assert fam["parameters"] == ["f1", "g1", "f2", "g2"] and fam["pairs"] == [[1, 2], [3, 4]]
    assert float(family_residual(fam, values)) < 1e-13


def test_generic_factorization_has_no_family():
    hs = np.array([[0, 1, 0, 0, 0, 0, 1, 0], [1, 0, 2, 0, 0, 3, 0, 1]], float)
    assert conjugate_pairs(hs) == [] and factorization_family(hs) is None


# ------------------------------------------------------------------ parallelogram flip
def test_parallelogram_flip_exact():
    """m = 1 + 2i + 3 eps j (axis through (0, 0, -3/2)), h = 1 - 2i + 5 eps j (through (0, 0, 5/2)), d = (0, 0, 4):
    s = (4/5) 2 d - (3/5) (2i x d) = (0, 24/5, 32/5), k = 1 + 2i + eps(-9/5 j - 32/5 k) (through
    (0, -16/5, 9/10)), n = 1 - 2i + eps(49/5 j + 32/5 k), exactly; the product is unchanged."""
    m, h = [1, 2, 0, 0, 0, 0, 3, 0], [1, -2, 0, 0, 0, 0, 5, 0]
    k, n, s = parallelogram_flip(m, h)
    assert k == [1, 2, 0, 0, 0, 0, F(-9, 5), F(-32, 5)] and n == [1, -2, 0, 0, 0, 0, F(49, 5), F(32, 5)]
    assert s == [0, F(24, 5), F(32, 5)]
    assert np.all(product_of_linear(exact_array([k, n])) == product_of_linear(exact_array([m, h])))
    with pytest.raises(FlipError, match="identity"):
        parallelogram_flip(m, [1, -2, 0, 0, 0, 0, -3, 0])  # the same line reversed


# ------------------------------------------------------------------ Darboux: coincident neighbours
def test_darboux_cofactor_has_coincident_neighbours_and_they_are_separated():
    """C (t^2 + 1) = 5 rotations with h2 = h3 = i + (1/4) eps k; moving the pair (h3, h4) by s = (0, -1/2, 0)
    puts h3 at (0, 1/4, -1/2), keeps the product and leaves no coincident neighbours."""
    res = factorize_with_cofactor(parse_polynomial(DARBOUX, exact=True))
    assert res.deg_R == 2 and coincident_neighbours(res.factors) == [1]
    hs, moved = separate_coincident(res.factors)
    assert moved == [(2, 3)] and coincident_neighbours(hs) == []
    assert np.allclose(hs[2], [0, 1, 0, 0, 0, 0, 0.5, 0.25]) and np.allclose(hs[3], [0, -1, 0, 0, 0, 0, -0.5, 0.25])
    assert relative_error(product_of_linear(hs), product_of_linear(res.factors)) < 1e-15


def test_darboux_motion_linkage_has_distinct_joints():
    lk = motion_linkage(parse_polynomial(DARBOUX, exact=True))
    assert len(lk.joints) == 16 and lk.info.synthesis.separated_pairs == ((3, 4),)
    assert lk.checks["max_closure_error"] < 1e-12 and lk.checks["max_motion_error"] < 1e-12
    lines = {(tuple(np.round(j.direction, 9)), tuple(np.round(j.moment, 9))) for j in lk.joints}
    assert len(lines) == 16


# ------------------------------------------------------------------ parallelogram linkages
def test_circle_and_circular_translation_give_a_parallelogram():
    lk = curve_linkage([F(1), F(0), F(-1)], [F(0), F(2)], [F(0)], [F(1), F(0), F(1)])  # the unit circle
    assert len(lk.joints) == 4 and len(lk.closures) == 1 and lk.info.synthesis.curve.method == "translation"
    assert lk.checks["max_trace_error"] < 1e-12
    lk = motion_linkage(parse_polynomial("t^2 + 1 + eps*(i + j*t)", exact=True))
    assert len(lk.joints) == 4 and lk.info.synthesis.mobility.dof == 1
    pts = {j.name: j.point for j in lk.joints}
    # a rhombus: ground h1-k1 = coupler h2-k2 = (3/5, 4/5, 0), cranks h1-h2 = k1-k2 = (1, 0, 0)
    assert np.allclose(pts["h1"], [-0.5, 0, 0]) and np.allclose(pts["h2"], [0.5, 0, 0])
    assert np.allclose(pts["k1"], [0.1, 0.8, 0]) and np.allclose(pts["k2"], [1.1, 0.8, 0])


def _verify(out, *extra):
    """The shared verifier's last line ("verify OK ..."), or None when it is absent."""
    return assert_verified(out, *extra, "--steps", "90", timeout=1800)


def test_parallelogram_tool_translates_along_the_circle(tmp_path):
    from click.testing import CliRunner

    from cli.main import mpsynth

    out = tmp_path / "circ"
    r = CliRunner().invoke(mpsynth, ["curve", str(FIXTURES / "motion_circular.yaml"), "-o", str(out), "-q"])
    assert r.exit_code == 0, r.output
    last = _verify(out, "--trace", "tool", "--curve", FIXTURES / "motion_circular_path.yaml")
    assert last is None or "curve_dist" in last


@pytest.mark.slow
def test_circle_and_darboux_pass_the_verifier(tmp_path):
    from click.testing import CliRunner

    from cli.main import mpsynth

    for name, extra in (("curve_circle", ["--trace", "tracer", "--curve", FIXTURES / "curve_circle.yaml"]),
                        ("motion_darboux", [])):
        out = tmp_path / name
        r = CliRunner().invoke(mpsynth, ["curve", str(FIXTURES / f"{name}.yaml"), "-o", str(out), "-q"])
        assert r.exit_code == 0, r.output
        _verify(out, *extra)


@pytest.mark.slow
def test_auto_keeps_the_smaller_linkage_for_a_viviani_quartic():
    """w = (1 + t^2)^2 (a repeated factor): rotation 19 joints, translation 25; auto keeps 19 (~20 s)."""
    from synth.io.curvespec import parse_real_polynomial
    from synth.synthesis.curve import curve_motions

    texts = ["2*(1 - t^2)^2", "4*t*(1 - t^2)", "4*t*(1 + t^2)", "(1 + t^2)^2"]
    cands, _ = curve_motions([parse_real_polynomial(x, "test") for x in texts], method="auto")
    assert [(c["method"], c["joints"]) for c in cands] == [("rotation", 19), ("translation", 25)]
