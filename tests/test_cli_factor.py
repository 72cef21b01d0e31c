"""`mpsynth factor`: table and JSON output, --exact, input files and stdin, exit codes 0/1/2."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

from synth.algebra.polynomial import product_of_linear

from conftest import REPO, run

EX_A = "(t - i - eps j)(t - 1 - 2j - eps(3i + k))"
EX_A_ROWS = [[0, 1, 0, 2, -5, 0, 0, 0], [-1, -1, -2, 0, 0, -3, -1, -1], [1, 0, 0, 0, 0, 0, 0, 0]]
EXC = "(t-1)*(t-j) - eps*((i+k)*t - 2*k)"
FLIP = "(t - 2k - eps i)(t - j - eps k)"


def run_json(*args, input=None):
    r = run("factor", *args, "--json", input=input)
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def frac(x):
    return Fraction(x)


# ------------------------------------------------------------------ table
def test_table_output():
    r = run("factor", "--expr", EX_A)
    assert r.exit_code == 0, r.output
    out = r.stdout
    assert "degree 2, generic" in out
    assert "N(C) = (t^2 + 1)(t^2 - 2 t + 5)" in out
    assert "C = (t - h1)(t - h2): 2 factorizations" in out
    lines = out.splitlines()
    header = next(ln for ln in lines if ln.startswith("#"))
    for col in ("h_i", "kind", "axis point", "axis direction", "law"):
        assert col in header
    rows = [ln.split() for ln in lines if ln[:1].isdigit()]
    assert [(r_[0], r_[1]) for r_ in rows] == [("1", "1"), ("1", "2"), ("2", "1"), ("2", "2")]
    assert any("1 + 2j + eps(3i + k)" in ln and "(-0.5, 0, 1.5)" in ln and "(0, -1, 0)" in ln
               and "theta(t) = 2 atan2(2, t - 1)" in ln for ln in lines)
    assert any("i + eps j" in ln and "theta(t) = 2 atan2(1, t)" in ln for ln in lines)
    assert "multiply-back check" in out


def test_table_translation_factors():
    r = run("factor", "--expr", EXC)
    assert r.exit_code == 0, r.output
    assert "NOT generic" in r.stdout
    assert r.stdout.count("translation") >= 2
    assert "1 + eps i" in r.stdout and "1 - eps k" in r.stdout
    assert "shift(t) = 2/(t - 1)" in r.stdout


def test_table_exact():
    r = run("factor", "--expr", EX_A, "--exact")
    assert r.exit_code == 0, r.output
    assert "(exact arithmetic)" in r.stdout
    assert "1 + 4/3 i + 4/3 j - 2/3 k + eps(13/9 i - 5/9 j + 16/9 k)" in r.stdout
    assert "-1/3 i + 2/3 j + 2/3 k + eps(14/9 i + 14/9 j - 7/9 k)" in r.stdout


def test_printed_factors_parse_back():
    """The h column is in the expression language: the factors multiply back to C."""
    from synth.algebra.expr import parse_polynomial

    r = run("factor", "--expr", FLIP, "--exact")
    assert r.exit_code == 0
    rows = [ln for ln in r.stdout.splitlines() if ln[:1].isdigit()]
    hs = {}
    for ln in rows:
        cells = [c for c in ln.split("  ") if c.strip()]
        hs.setdefault(cells[0].strip(), []).append(cells[2].strip())
    C = parse_polynomial(FLIP, exact=True)
    for f in hs.values():
        text = "".join(f"(t - ({h}))" for h in f)
        assert parse_polynomial(text, exact=True) == C


# ------------------------------------------------------------------ JSON
def test_json_schema():
    doc = run_json("--expr", EX_A)
    assert doc["format"] == "mpsynth.factorization/1"
    assert doc["degree"] == 2
    assert doc["generic"] is True
    assert doc["exact"] is False
    assert np.allclose(doc["coefficients"], EX_A_ROWS)
    assert len(doc["norm_factors"]) == 2
    assert all(len(q) == 2 for q in doc["norm_factors"])
    prod = np.array([1.0])
    for c0, c1 in doc["norm_factors"]:
        prod = np.convolve(prod, [c0, c1, 1.0])
    assert np.allclose(prod, [5, -2, 6, -2, 1])
    assert np.allclose(doc["norm"], [5, -2, 6, -2, 1])
    assert len(doc["factorizations"]) == 2
    for fz in doc["factorizations"]:
        H = np.array(fz["factors"])
        assert H.shape == (2, 8)
        assert np.allclose(product_of_linear(H), EX_A_ROWS, atol=1e-14)
        assert fz["residual"] < 1e-14
        for h, j in zip(H, fz["joints"]):
            assert j["kind"] == "revolute"
            assert j["a"] == pytest.approx(h[0])
            assert j["b"] == pytest.approx(np.linalg.norm(h[1:4]))
            assert np.allclose(j["direction"], -h[1:4] / np.linalg.norm(h[1:4]))
            assert np.allclose(j["moment"], h[5:8] / np.linalg.norm(h[1:4]))
            assert np.allclose(j["point"], np.cross(j["direction"], j["moment"]))
            assert np.allclose(j["norm_factor"], [h[0] ** 2 + h[1:4] @ h[1:4], -2 * h[0]])
    assert np.allclose(doc["factorizations"][0]["factors"], [[0, 1, 0, 0, 0, 0, 1, 0], [1, 0, 2, 0, 0, 3, 0, 1]])


def test_json_exact_fractions():
    doc = run_json("--expr", FLIP, "--exact")
    assert doc["exact"] is True
    assert doc["norm_factors"] == [["1", "0"], ["4", "0"]]
    facts = [[[frac(x) for x in h] for h in fz["factors"]] for fz in doc["factorizations"]]
    assert all(isinstance(x, str) for fz in doc["factorizations"] for h in fz["factors"] for x in h)
    k = [0, 0, frac("-3/5"), frac("4/5"), 0, frac("2/5"), frac("12/25"), frac("9/25")]
    m2 = [0, 0, frac("8/5"), frac("6/5"), 0, frac("3/5"), frac("-12/25"), frac("16/25")]
    assert [k, m2] in facts
    assert "-3/5" in doc["factorizations"][0]["factors"][0]


def test_json_translation_joint():
    doc = run_json("--expr", "t - eps i")
    assert doc["generic"] is False
    (fz,) = doc["factorizations"]
    (j,) = fz["joints"]
    assert j["kind"] == "translation"
    assert j["direction"] == [1.0, 0.0, 0.0]
    assert j["speed"] == pytest.approx(2.0)


def test_json_survey_degree_one_and_square():
    doc = run_json("--expr", "(t - i)^2")
    assert len(doc["factorizations"]) == 1
    assert np.allclose(doc["factorizations"][0]["factors"], [[0, 1, 0, 0, 0, 0, 0, 0]] * 2)
    assert np.allclose(doc["norm_factors"], [[1, 0], [1, 0]])


def test_cubic_six_factorizations():
    rng = np.random.default_rng(5)
    hs = []
    for a in (-1.0, 0.2, 1.5):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        b = rng.uniform(0.5, 2)
        hs.append(np.concatenate([[a], -b * u, [0], b * np.cross(rng.normal(size=3), u)]))
    C = product_of_linear(np.stack(hs))
    doc = run_json("-", input=json.dumps({"coefficients": C.tolist()}))
    assert doc["degree"] == 3
    assert len(doc["factorizations"]) == 6
    for fz in doc["factorizations"]:
        assert np.allclose(product_of_linear(np.array(fz["factors"])), C, atol=1e-12)


# ------------------------------------------------------------------ files and stdin
def test_yaml_file_with_fraction_strings(tmp_path):
    p = tmp_path / "poly.yaml"
    p.write_text("coefficients:\n"
                 "  - [0, 1, 0, 2, -5, 0, 0, 0]\n"
                 "  - [-1, -1, -2, 0, 0, '-6/2', -1, -1]\n"
                 "  - [1, 0, 0, 0, 0, 0, 0, 0]\n")
    doc = run_json(p)
    assert len(doc["factorizations"]) == 2
    doc = run_json(p, "--exact")
    assert ["1", "4/3", "4/3", "-2/3", "0", "13/9", "-5/9", "16/9"] in [f["factors"][0] for f in doc["factorizations"]]


def test_json_file_and_expression_key(tmp_path):
    p = tmp_path / "poly.json"
    p.write_text(json.dumps({"expression": EX_A}))
    doc = run_json(p)
    assert np.allclose(doc["coefficients"], EX_A_ROWS)
    q = tmp_path / "poly.yaml"
    q.write_text(f"expression: \"{EXC}\"\n")
    assert len(run_json(q)["factorizations"]) == 2


def test_stdin_yaml_and_json():
    doc = run_json("-", input="expression: (t-2k-eps i)(t-j-eps k)\n")
    assert len(doc["factorizations"]) == 2
    doc = run_json("-", input=json.dumps({"coefficients": EX_A_ROWS}))
    assert len(doc["factorizations"]) == 2


def test_decimal_input_exact():
    """0.5 in a file is the rational 1/2 in exact mode (shortest decimal of the float)."""
    doc = run_json("-", "--exact", input="coefficients: [[0, 0.5, 0, 0, 0, 0, 0.25, 0], [1, 0, 0, 0, 0, 0, 0, 0]]\n")
    assert doc["factorizations"][0]["factors"] == [["0", "-1/2", "0", "0", "0", "0", "-1/4", "0"]]


# ------------------------------------------------------------------ exit codes
def test_exit_1_no_factorization():
    r = run("factor", "--expr", "t^2 + 1 + eps(i + 2j t)")
    assert r.exit_code == 1
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "not generic" in lines[0] and "t^2 + 1" in lines[0]

def test_circular_translation_reports_its_family():
    """a = b: not generic, but a 2-parameter family of factorizations (survey eq. (5)); exit 0, the
    family in the JSON (parameters f, g, offset basis i, j) and in the text; every member multiplies back."""
    from synth.algebra.family import family_residual

    doc = run_json("--expr", "t^2 + 1 + eps*(3*i + 3*j*t)")
    fam = doc["family"]
    assert fam["parameters"] == ["f", "g"] and fam["pairs"] == [[1, 2]] and fam["dimension"] == 2
    assert fam["basis"] == [[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]
    # the min-norm member: h1 = k - (3/2) eps j, h2 = -k - (3/2) eps j
    assert np.allclose(fam["base_factors"], [[0, 0, 0, 1, 0, 0, -1.5, 0], [0, 0, 0, -1, 0, 0, -1.5, 0]])
    vals = np.random.default_rng(1).normal(size=(20, 2)) * 5
    assert np.max(family_residual({**fam, "factors": fam["base_factors"]}, vals)) < 1e-14
    r = run("factor", "--expr", "t^2 + 1 + eps(3i + 3j t)")
    assert r.exit_code == 0 and "a continuum of factorizations (2 real parameters)" in r.stdout


def test_exit_1_exact_unavailable():
    r = run("factor", "--expr", "(t - i - eps j)(t - 1 - 2j - eps(3i + k)) + 0", "--exact")
    assert r.exit_code == 0
    # N(C) irreducible over Q (docs/algorithm1.md, example D)
    rows = [["15/53", 0, 0, "20/53", "5/53", "-15/106", "10/53", "-15/212"],
            ["-38/53", "40/53", 0, "-20/53", 0, "15/212", "-29/53", "83/212"],
            [1, 0, 0, 0, 0, 0, 0, 0]]
    r = run("factor", "-", "--exact", input=json.dumps({"coefficients": rows}))
    assert r.exit_code == 1
    assert "does not factor over the rationals" in r.stderr and "drop --exact" in r.stderr
    # numerically the same input factors
    assert run("factor", "-", input=json.dumps({"coefficients": rows})).exit_code == 0


@pytest.mark.parametrize("args,input,message", [
    (["--expr", "eps t - i"], None, "not invertible"),
    (["--expr", "(t - i)(t - j) + eps k"], None, "not a motion polynomial"),
    (["--expr", "t - i + $"], None, "unexpected character"),
    (["--expr", "t - q"], None, "unknown name"),
    (["--expr", "3"], None, "degree"),
    (["-"], '{"coefficients": [[0,1,0,0,0,0,0,0],[1,0,0,0,0,0,0]]}', "8 numbers"),
    (["-"], '{"coefficients": [[0,1,0,0,0,0,0,NaN],[1,0,0,0,0,0,0,0]]}', "not a finite number"),
    (["-"], "coefficients: [[0,1,0,0,0,0,0,.nan],[1,0,0,0,0,0,0,0]]", "not a finite number"),
    (["-"], "coefficients: [[0,1,0,0,0,0,0,'x'],[1,0,0,0,0,0,0,0]]", "not a number"),
    (["-"], "coefficients: [[0,1,0,0,0,0,0,true],[1,0,0,0,0,0,0,0]]", "expected a number"),
    (["-"], "coefficients: [[1,0,0,0,0,0,0,0]]", "at least 2 rows"),
    (["-"], "coefficients: 5", "must be a list"),
    (["-"], "coefficients: [[0,1,0,0,0,0,0,0],[0,0,0,0,2,0,0,0]]", "not invertible"),
    (["-"], "expression: t - i\ncoefficients: [[0,1,0,0,0,0,0,0],[1,0,0,0,0,0,0,0]]", "both"),
    (["-"], "{}", "neither"),
    (["-"], "coeficients: []", "did you mean 'coefficients'"),
    (["-"], "expression: t\nname: x", "unknown key 'name'"),
    (["-"], "- 1\n- 2", "expected a mapping"),
    (["-"], "", "empty document"),
    (["-"], "expression: [1]", "must be text"),
    (["-"], "coefficients: [[0,1,0,0", "invalid YAML"),
    (["-"], "expression: 't - i +'", "unexpected end"),
    (["--exact", "--expr", "eps t + i"], None, "not invertible"),
    (["--exact", "-"], "coefficients: [[0,1,0,0,0,0,0,'1/0'],[1,0,0,0,0,0,0,0]]", "not a number"),
    ([], None, "give a FILE"),
    (["x.yaml", "--expr", "t"], None, "not both"),
    (["/nonexistent/poly.yaml"], None, "no such file"),
])
def test_exit_2_bad_input(args, input, message):
    r = run("factor", *args, input=input)
    assert r.exit_code == 2, (r.exit_code, r.output)
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert r.stdout == ""


def test_exit_2_invalid_json_file(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text('{"coefficients": [[0,1,0,0,0,0,0,0], [1,0,0,0,0,0,0,0]],}')
    r = run("factor", p)
    assert r.exit_code == 2 and "invalid JSON" in r.stderr
    p.write_text('{"expression": "t - i", "expression": "t - j"}')
    r = run("factor", p)
    assert r.exit_code == 2 and "duplicate key" in r.stderr


def test_refuses_large_files(tmp_path):
    p = tmp_path / "big.yaml"
    with open(p, "wb") as fh:
        fh.seek(10 * 1024 * 1024 + 10)
        fh.write(b"\n")
    r = run("factor", p)
    assert r.exit_code == 2 and "10 MB" in r.stderr
    r = run("factor", "-", input="#" * (10 * 1024 * 1024 + 5))
    assert r.exit_code == 2 and "10 MB" in r.stderr


def test_help_has_example():
    r = run("factor", "--help")
    assert r.exit_code == 0
    assert "Example" in r.output and "mpsynth factor --expr" in r.output
    assert "--exact" in r.output and "--json" in r.output


def test_subprocess_stdin_and_exit_codes():
    """The installed entry point end to end (real stdin, real exit status)."""
    exe = [sys.executable, "-m", "cli.main", "factor"]
    p = subprocess.run([*exe, "-", "--json"], input=f"expression: \"{EXC}\"\n", capture_output=True, text=True,
                       cwd=REPO, timeout=60)
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    kinds = sorted(tuple(j["kind"] for j in fz["joints"]) for fz in doc["factorizations"])
    assert kinds == [("revolute", "translation"), ("translation", "revolute")]
    p = subprocess.run([*exe, "--expr", "t^2 + 1 + eps(i + 2j t)"], capture_output=True, text=True, cwd=REPO,
                       timeout=60)
    assert p.returncode == 1 and p.stdout == "" and p.stderr.startswith("mpsynth: not generic")
    p = subprocess.run([*exe, "--expr", "eps t"], capture_output=True, text=True, cwd=REPO, timeout=60)
    assert p.returncode == 2


def test_angle_law_in_json_reproduces_poses():
    """theta(t) = 2 atan2(b, t - a) about (direction, moment) of each joint gives the pose of C(t)."""
    from synth.algebra.geometry import rotation_about_line
    from synth.algebra.polynomial import pose_at

    doc = run_json("--expr", EX_A)
    C = np.array(doc["coefficients"])
    for fz in doc["factorizations"]:
        for t in (-1.0, 0.5, 3.0):
            T = np.eye(4)
            for j in fz["joints"]:
                T = T @ rotation_about_line(j["direction"], j["moment"], 2 * math.atan2(j["b"], t - j["a"]))
            assert np.allclose(T, pose_at(C, t), atol=1e-12)


def test_huge_coefficients_are_a_clean_input_error():
    """(t + 10^100)^3: the norm polynomial overflows double precision: exit 2 with one line saying so
    (was an internal error); (t + 10^50)^3 is refused as non-generic without numpy warning lines."""
    for expr, code, needle in (("(t+10^100)^3", 2, "too large for double precision"),
                               ("(t+10^50)^3", 1, "not generic")):
        r = subprocess.run([sys.executable, "-m", "cli.main", "factor", "--expr", expr], capture_output=True,
                           text=True, timeout=120)
        assert r.returncode == code, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0] and "Warning" not in r.stderr, r.stderr
