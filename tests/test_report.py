"""The factorization report of `mpsynth factor` as a library (synth.algebra.report), and the text
helpers shared with `mpsynth flip` (synth.algebra.text, synth.algebra.flip_report)."""
from fractions import Fraction as Fr

import numpy as np
import pytest

from synth.algebra.flip_report import flip_document, flip_report, flip_text
from synth.algebra.polyinput import PolynomialInput
from synth.algebra.polynomial import product_of_linear, relative_error
from synth.algebra.report import FORMAT, compute, compute_cofactor, format_table, report_document
from synth.algebra.text import fmt_dq, fmt_num, fmt_quadratic
from synth.errors import InputError

EX_A = "(t - i - eps j)(t - 1 - 2j - eps(3i + k))"


def _inp(text):
    return PolynomialInput(source="--expr", expression=text)


def test_numeric_and_exact_reports_agree():
    rn, rx = compute(_inp(EX_A)), compute(_inp(EX_A), exact=True)
    assert rn.degree == rx.degree == 2 and rn.generic and rx.generic
    assert len(rn.factorizations) == len(rx.factorizations) == 2
    for fn, fx in zip(rn.factorizations, rx.factorizations):
        H = np.array(fn.factors)
        assert float(relative_error(np.array(fx.factors, float), H)) <= 1e-12
        assert float(relative_error(product_of_linear(H), np.array(rn.coefficients))) <= 1e-12
        for jn, jx in zip(fn.joints, fx.joints):
            assert jn.kind == jx.kind == "revolute"
            assert np.allclose(jn.direction, jx.direction, atol=1e-12)
    assert np.allclose(np.array(rx.norm, float), rn.norm, atol=1e-12)


def test_report_document_format():
    doc = report_document(compute(_inp(EX_A), exact=True))
    assert doc["format"] == FORMAT == "mpsynth.factorization/1"
    assert set(doc) == {"format", "degree", "generic", "exact", "coefficients", "norm", "norm_factors",
                        "factorizations", "failed_orders"}
    assert doc["norm_factors"] == [["1", "0"], ["5", "-2"]]
    assert all(isinstance(x, str) for fz in doc["factorizations"] for h in fz["factors"] for x in h)


def test_table_text():
    text = format_table(compute(_inp(EX_A), exact=True))
    assert "N(C) = (t^2 + 1)(t^2 - 2 t + 5)" in text
    assert "-1/3 i + 2/3 j + 2/3 k + eps(14/9 i + 14/9 j - 7/9 k)" in text


def test_cofactor_report_multiplies_back():
    rep, info = compute_cofactor(_inp("t^2 + 1 + eps*(i + 2*j*t)"), exact=True)
    assert rep.exact and info.R == [1, 0, 1] and info.bound_met
    (row,) = rep.factorizations
    H = np.array(row.factors, float)
    assert float(relative_error(product_of_linear(H), np.array(rep.coefficients, float))) <= 1e-12


def test_input_errors_name_the_source():
    with pytest.raises(InputError, match="^--expr: .*not invertible"):
        compute(_inp("eps t - i"))
    bad = PolynomialInput(source="p.yaml", rows=[[0, 1, 0, 0, 0, 0, 0, "x"], [1, 0, 0, 0, 0, 0, 0, 0]])
    with pytest.raises(InputError, match="^p.yaml: coefficients row 0, entry 7"):
        compute(bad)


def test_text_helpers():
    assert fmt_num(Fr(-4, 3)) == "-4/3" and fmt_num(1e-15) == "0" and fmt_num(2.5) == "2.5"
    assert fmt_num(1 / 3, digits=12) == "0.333333333333"
    assert fmt_dq([1, 0, 2, 0, 0, 3, 0, 1]) == "1 + 2j + eps(3i + k)"
    assert fmt_dq([0, Fr(-1, 3), 0, 0, 0, Fr(14, 9), 0, 0]) == "-1/3 i + eps(14/9 i)"
    assert fmt_dq([0.0, 0, 0, 0, 0, -1, 0, 0]) == "-eps i"
    assert fmt_dq([0.0] * 8) == "0"
    assert fmt_quadratic((Fr(1, 2), Fr(-4, 3))) == "t^2 - 4/3 t + 1/2"


def test_flip_report_exact_and_document():
    rep = flip_report("1 + 2i + 3eps j", "k + eps(i + j)")
    assert rep.exact and rep.residual == 0.0
    assert rep.k == [0, Fr(2, 3), Fr(-2, 3), Fr(-1, 3), 0, Fr(14, 9), Fr(10, 9), Fr(8, 9)]
    doc = flip_document(rep)
    assert doc["format"] == "mpsynth.flip/1" and doc["n"][1] == "4/3" and doc["loop"] == ["m", "h", "n", "k"]
    lhs = product_of_linear(np.array([rep.m, rep.h], float))
    rhs = product_of_linear(np.array([rep.k, rep.n], float))
    assert float(relative_error(rhs, lhs)) <= 1e-14
    assert "h' = 2/3 i - 2/3 j - 1/3 k + eps(14/9 i + 10/9 j + 8/9 k)" in flip_text(rep)
    with pytest.raises(InputError, match="^H: t - m is not a rotation"):
        flip_report("1 + 2i", "1 + eps i")
