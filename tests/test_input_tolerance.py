"""Input that the peer package (rational-linkages) accepts: flips of float input whose rotation conditions
hold only to rounding, non-monic motion polynomials (divided by an invertible leading coefficient), a
negative first argument of `mpsynth flip`."""
from __future__ import annotations

import json

import numpy as np
import pytest

from synth.algebra.flip import bennett_flip, flip_residual
from synth.algebra.flip_report import flip_report

from conftest import run


def rotation(rng):
    """8 floats of a rotation t - h: random axis through a random point, random a, b."""
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    p = rng.normal(size=3)
    b = rng.uniform(0.3, 2.0)
    return np.concatenate([[rng.normal()], b * u, [0.0], b * np.cross(p, u)])


@pytest.mark.parametrize("seed", range(4))
def test_flip_of_float_digits(seed):
    """Factors printed from floating point (17 digits) satisfy v . w = 0 only to ~1e-17 as exact
    decimals: flip takes them as floats and agrees with the float flip."""
    rng = np.random.default_rng(seed)
    m, h = rotation(rng), rotation(rng)
    text = [", ".join(repr(float(x)) for x in v) for v in (m, h)]
    rep = flip_report(*text)
    assert not rep.exact and rep.residual < 1e-13
    k, n = bennett_flip(m, h)
    assert np.allclose(rep.k, k, atol=1e-12) and np.allclose(rep.n, n, atol=1e-12)
    assert flip_residual(m, h, rep.k, rep.n) < 1e-13
    r = run("flip", *text)
    assert r.exit_code == 0 and "(t - m)(t - h) = (t - h')(t - m')" in r.stdout and "k =" not in r.stdout


def test_flip_rejects_what_is_not_a_rotation_within_the_tolerance():
    r = run("flip", "0, 1, 0, 0, 0, 1e-6, 0, 0", "k")  # v . w = 1e-6: not rounding
    assert r.exit_code == 2 and "not a rotation" in r.stderr


def test_flip_negative_first_argument():
    r = run("flip", "-1 - 2i + 3eps j", "-k + eps(i + j)")
    assert r.exit_code == 0, r.output
    assert "h' = -2/3 i + 2/3 j + 1/3 k + eps(14/9 i + 10/9 j + 8/9 k)" in r.stdout
    doc = json.loads(run("flip", "-k", "1 + i", "--json").stdout)
    assert doc["h_prime"] == doc["k"] and doc["m_prime"] == doc["n"]


# rational-linkages' own factorization test: C = (t^2 - 2) - 3t k + eps(i + t j), factors
# {k, 2k - eps j} and {2k - 1/3 eps j, k - 2/3 eps j}
C_TEXT = "(t^2 - 2) - 3*t*k + eps*(i + t*j)"
EXPECTED = sorted([[[0, 0, 0, 1, 0, 0, 0, 0], [0, 0, 0, 2, 0, 0, -1, 0]],
                   [[0, 0, 0, 2, 0, 0, -1 / 3, 0], [0, 0, 0, 1, 0, 0, -2 / 3, 0]]])


@pytest.mark.parametrize("lead,exact", [("1", False), ("2", False), ("2", True), ("(1 + i)", False),
                                        ("(3 + 4j)", True)])
def test_non_monic_polynomials_factor(lead, exact):
    r = run("factor", "--expr", f"{lead}*({C_TEXT})", "--json", *(["--exact"] if exact else []))
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    got = sorted([[[float(eval(str(x))) for x in h] for h in fz["factors"]] for fz in doc["factorizations"]])
    assert np.allclose(got, EXPECTED, atol=1e-12)
    if lead == "1":
        assert "notes" not in doc
    else:
        assert doc["leading_coefficient"] and "not monic" in doc["notes"][0]
    text = run("factor", "--expr", f"{lead}*({C_TEXT})").stdout
    assert ("C was not monic" in text) == (lead != "1")


def test_non_invertible_leading_coefficient():
    r = run("factor", "--expr", "eps*t^2 + t*i + 1")
    assert r.exit_code == 2 and "not invertible" in r.stderr


def test_progress_only_on_a_terminal(capsys, monkeypatch):
    """cli.common.progress writes "label i/n" to stderr only when stderr is a terminal."""
    import io
    import sys

    from cli.common import progress

    assert list(progress([1, 2, 3], "x")) == [1, 2, 3]
    assert capsys.readouterr().err == ""

    class Tty(io.StringIO):
        def isatty(self):
            return True

    fake = Tty()
    monkeypatch.setattr(sys, "stderr", fake)
    assert list(progress([1, 2, 3], "design")) == [1, 2, 3]
    assert "design 1/3" in fake.getvalue() and "design 3/3" in fake.getvalue()
    fake2 = Tty()
    monkeypatch.setattr(sys, "stderr", fake2)
    list(progress([1, 2, 3], "design", quiet=True))
    assert fake2.getvalue() == ""
