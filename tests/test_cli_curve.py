"""`mpsynth curve` and `mpsynth flip` end to end, including the shared verifier on the outputs."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import run

REPO = Path(__file__).resolve().parents[1]
FIXTURES = REPO / "fixtures"
VERIFIER = Path(__file__).resolve().parents[2] / "shared/tools/verify_output.py"


def verify(out, *extra, steps=None):
    if not VERIFIER.exists():
        pytest.skip("../shared/tools/verify_output.py is not present")
    cmd = [sys.executable, str(VERIFIER), str(out), *map(str, extra)]
    if steps:
        cmd += ["--steps", str(steps)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    last = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ""
    assert r.returncode == 0 and last.startswith("verify OK"), r.stdout + r.stderr
    return last


# ------------------------------------------------------------------ curve
def test_curve_ellipse_writes_output(tmp_path):
    out = tmp_path / "ellipse"
    r = run("curve", FIXTURES / "curve_ellipse.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    assert "10 revolute joints, 8 links (+3 welded loop duplicates), 3 loops" in r.stderr
    assert "tracer stays on the curve" in r.stderr
    doc = json.loads((out / "linkage.json").read_text())
    assert doc["kind"] == "curve" and len(doc["joints"]) == 10 and len(doc["closures"]) == 3
    assert doc["poses"] == [] and doc["info"]["counts"]["links"] == 8
    assert len(list((out / "meshes").glob("*.stl"))) == 18  # 8 links, 10 pins
    assert "tracer" in (out / "linkage.urdf").read_text()


def test_curve_ellipse_passes_the_verifier(tmp_path):
    """The verifier with fewer sweep steps (the full 180-step run is in the slow tests)."""
    out = tmp_path / "ellipse"
    assert run("curve", FIXTURES / "curve_ellipse.yaml", "-o", out, "-q").exit_code == 0
    last = verify(out, "--trace", "tracer", "--curve", FIXTURES / "curve_ellipse.yaml", steps=60)
    assert "curve_dist" in last


@pytest.mark.slow
def test_curve_ellipse_passes_the_full_verifier(tmp_path):
    out = tmp_path / "ellipse"
    assert run("curve", FIXTURES / "curve_ellipse.yaml", "-o", out, "-q").exit_code == 0
    verify(out, "--trace", "tracer", "--curve", FIXTURES / "curve_ellipse.yaml")


@pytest.mark.slow
def test_motion_elliptic_passes_the_full_verifier(tmp_path):
    out = tmp_path / "elliptic"
    r = run("curve", FIXTURES / "motion_elliptic.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    assert "13 revolute joints, 10 links" in r.stderr
    verify(out)


@pytest.mark.slow
def test_planar_quartic_curve_passes_the_verifier(tmp_path):
    spec = tmp_path / "quartic.yaml"
    spec.write_text('curve:\n  x: "t^3 - t"\n  y: "t^2 + 2*t"\n  z: "0"\n  w: "(1 + t^2)*(4 + t^2)"\n')
    out = tmp_path / "quartic"
    assert run("curve", spec, "-o", out, "-q").exit_code == 0
    verify(out, "--trace", "tracer", "--curve", spec)


def test_motion_json_on_stdout(tmp_path):
    r = run("curve", FIXTURES / "motion_elliptic.yaml", "--json", "-q")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["kind"] == "motion" and len(doc["joints"]) == 13 and len(doc["closures"]) == 4
    assert doc["info"]["motion"]["cofactor"] == [1.0, 0.0, 1.0]
    assert doc["links"]["coupler"] == ["h4", "m4"]


def test_motion_coefficients_and_units(tmp_path):
    spec = tmp_path / "m.yaml"
    spec.write_text("motion:\n  coefficients:\n    - [1, 0, 0, 0, 0, 1000, 0, 0]\n"
                    "    - [0, 0, 0, 0, 0, 0, 2000, 0]\n    - [1, 0, 0, 0, 0, 0, 0, 0]\n")
    r = run("curve", spec, "--units", "mm", "--json", "-q")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["motion_polynomial"][0][5] == pytest.approx(1.0)  # metres


def test_curve_units_mm(tmp_path):
    spec = tmp_path / "c.yaml"
    spec.write_text('curve: {x: "1000 - 1000*t^2", y: "4000*t", z: "0", w: "1 + t^2"}\n')
    r = run("curve", spec, "--units", "mm", "--json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["info"]["markers"]["tracer"]["position"] == pytest.approx([-1, 0, 0])
    assert "mm" in r.stderr


def test_unbounded_curve_exit_1(tmp_path):
    spec = tmp_path / "u.yaml"
    spec.write_text('curve: {x: "t", y: "1", z: "0", w: "t^2 - 1"}\n')
    out = tmp_path / "out"
    r = run("curve", spec, "-o", out)
    assert r.exit_code == 1
    assert "unbounded curve" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_unbounded_motion_exit_1(tmp_path):
    spec = tmp_path / "u.yaml"
    spec.write_text('motion: {expression: "(t-1)*(t-j) - eps*((i+k)*t - 2*k)"}\n')
    r = run("curve", spec)
    assert r.exit_code == 1 and "needs a sliding joint" in r.stderr


@pytest.mark.parametrize("text,match", [
    ('curve: {x: "t", y: "0", w: "1 + t^2"}\n', "missing 'z'"),
    ('motion: {expression: "t^2 + 1 + eps*(i + 2*j*t"}\n', "missing ')'"),
    ('motion: {expression: "t^2 + 1 + eps*1"}\n', "not a motion polynomial"),
    ('poses: []\n', "unknown key 'poses'"),
    ('curve: [1, 2\n', "YAML"),
])
def test_bad_input_exit_2(tmp_path, text, match):
    spec = tmp_path / "bad.yaml"
    spec.write_text(text)
    r = run("curve", spec, "-o", tmp_path / "out")
    assert r.exit_code == 2, r.output
    assert match in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_missing_file_exit_2(tmp_path):
    r = run("curve", tmp_path / "nope.yaml")
    assert r.exit_code == 2 and "no such file" in r.stderr


def test_stdin(tmp_path):
    r = run("curve", "-", "--json", "-q", input='curve: {x: "1 - t^2", y: "2*t", z: "0", w: "1 + t^2"}\n')
    assert r.exit_code == 0, r.output
    assert len(json.loads(r.stdout)["joints"]) == 4  # a circle: the parallelogram of its circular translation


# ------------------------------------------------------------------ flip
def test_flip_e5_exact():
    r = run("flip", "1 + 2i + 3eps j", "k + eps(i + j)")
    assert r.exit_code == 0, r.output
    assert "h' = 2/3 i - 2/3 j - 1/3 k + eps(14/9 i + 10/9 j + 8/9 k)" in r.stdout
    assert "m' = 1 + 4/3 i + 2/3 j + 4/3 k + eps(-5/9 i + 26/9 j - 8/9 k)" in r.stdout


def test_flip_lists_and_json():
    r = run("flip", "[0, 0, 0, 2, 0, 1, 0, 0]", "0,0,1,0,0,0,0,1", "--json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["exact"] and doc["k"] == ["0", "0", "-3/5", "4/5", "0", "2/5", "12/25", "9/25"]
    assert doc["n"] == ["0", "0", "8/5", "6/5", "0", "3/5", "-12/25", "16/25"]


def test_flip_float_input():
    r = run("flip", "[0.5, 0.1, 0, 0, 0, 0, 0.3, 0]", "t - 0.25 - 1.5 j - eps(0.1 k)", "--json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["exact"]  # decimal literals are exact rationals
    r = run("flip", "[0.5, 0.1, 0, 0, 0, 0, 0.3, 0]", "[1e400, 0, 0, 0, 0, 0, 0, 0]")
    assert r.exit_code == 2


def test_flip_does_not_exist_exit_1():
    r = run("flip", "1 + 2i + 3eps j", "1 - 2i - 3eps j")  # the same axis reversed: the identity
    assert r.exit_code == 1 and "no Bennett flip" in r.stderr


def test_parallelogram_flip():
    """primal(h) = conj(primal(m)): a circular translation; the flip is one member of the parallelogram
    family k = m - eps s, n = h + eps s (axes through z = -3/2 and 5/2; the pair moves by 4 (0, -4/5, 3/5),
    s = (0, 24/5, 32/5))."""
    r = run("flip", "1 + 2i + 3eps j", "1 - 2i + 5eps j", "--json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["k"] == ["1", "2", "0", "0", "0", "0", "-9/5", "-32/5"]
    assert doc["n"] == ["1", "-2", "0", "0", "0", "0", "49/5", "32/5"]
    assert doc["parallelogram"]["shift"] == ["0", "24/5", "32/5"]
    ax = doc["axes"]
    # opposite sides parallel and equal: a parallelogram (here a rhombus of side 4)
    pm, ph, pn, pk = (np.array(ax[x]["point"]) for x in "mhnk")
    assert np.allclose(ph - pm, pn - pk) and np.allclose(np.linalg.norm(pk - pm), 4.0)
    r = run("flip", "1 + 2i + 3eps j", "1 - 2i + 5eps j")
    assert r.exit_code == 0 and "parallelogram flip" in r.stdout


@pytest.mark.parametrize("m,h,match", [
    ("1 + 2i + 3eps i", "k", "not a rotation"),
    ("1, 2, 3", "k", "8 numbers"),
    ("1 + eps i", "k", "not a rotation"),
    ("t^2", "k", "degree"),
    ("2*t - i", "k", "monic"),
])
def test_flip_bad_input_exit_2(m, h, match):
    r = run("flip", m, h)
    assert r.exit_code == 2 and match in r.stderr, r.output


# ------------------------------------------------------------------ factor --cofactor
def test_factor_cofactor_elliptic_exact_json():
    r = run("factor", "--cofactor", "--exact", "--json", "--expr", "t^2 + 1 + eps*(i + 2*j*t)")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["cofactor"] == ["1", "0", "1"] and doc["exact"] and doc["bound_met"]
    assert doc["factorizations"][0]["factors"][0] == ["0", "0", "0", "1", "0", "0", "-3/4", "0"]
    assert len(doc["factorizations"][0]["factors"]) == 4


def test_factor_cofactor_numeric_table():
    r = run("factor", "--cofactor", "--expr", "(t^2 + 1 + eps*(i + 2*j*t))*(t - k)")
    assert r.exit_code == 0, r.output
    assert "real co-factor R = 1" in r.stdout and "C R = (t - h1)(t - h2)(t - h3)" in r.stdout
    r = run("factor", "--cofactor", "--json", "--expr", "t^2 + 1 + eps*(i + 2*j*t)")
    assert json.loads(r.stdout)["cofactor"] == [1.0, 0.0, 1.0]


def test_factor_cofactor_unbounded_exit_1():
    r = run("factor", "--cofactor", "--expr", "(t-1)*(t-j) - eps*((i+k)*t - 2*k)")
    assert r.exit_code == 1 and "needs a sliding joint" in r.stderr


def test_factor_cofactor_bad_input_exit_2():
    r = run("factor", "--cofactor", "--expr", "eps*t^2 + 1")
    assert r.exit_code == 2
