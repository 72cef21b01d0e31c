"""Bennett flip (docs/exceptional.md, worked example E5)."""
from fractions import Fraction as F

import numpy as np
import pytest

from synth.algebra.dq import plucker
from synth.algebra.geometry import common_normal
from synth.errors import SynthesisError
from synth.algebra.dq import exact_array
from synth.algebra.flip import FlipError, bennett_flip, flip_residual, is_rotation
from synth.algebra.polynomial import product_of_linear


def _product(a, b):
    """(t - a)(t - b) exactly, as nested lists of Fractions."""
    return product_of_linear(exact_array([a, b])).tolist()


def _norm(h):
    """(a, b^2) of N(t - h) = (t - a)^2 + b^2."""
    return h[0], sum(x * x for x in h[1:4])


def test_e5_exact():
    m = [1, 2, 0, 0, 0, 0, 3, 0]  # 1 + 2i + 3 eps j
    h = [0, 0, 0, 1, 0, 1, 1, 0]  # k + eps(i + j)
    k, n = bennett_flip(m, h)
    assert k == [0, F(2, 3), F(-2, 3), F(-1, 3), 0, F(14, 9), F(10, 9), F(8, 9)]
    assert n == [1, F(4, 3), F(2, 3), F(4, 3), 0, F(-5, 9), F(26, 9), F(-8, 9)]
    assert all(isinstance(x, F) for x in k + n)
    assert _product(m, h) == _product(k, n)
    assert _norm(n) == _norm(m) and _norm(k) == _norm(h)
    assert is_rotation(k) and is_rotation(n)


def test_math_section_9_example():
    """docs/exceptional.md: m = 2k + eps i, h = j + eps k."""
    k, n = bennett_flip([0, 0, 0, 2, 0, 1, 0, 0], [0, 0, 1, 0, 0, 0, 0, 1])
    assert k == [0, 0, F(-3, 5), F(4, 5), 0, F(2, 5), F(12, 25), F(9, 25)]
    assert n == [0, 0, F(8, 5), F(6, 5), 0, F(3, 5), F(-12, 25), F(16, 25)]


def _random_rotation(rng, a=None, b=None):
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    d = rng.normal(size=3)
    d -= (d @ u) * u
    h = np.zeros(8)
    h[0] = rng.normal() if a is None else a
    h[1:4] = (rng.uniform(0.3, 2) if b is None else b) * u
    h[5:8] = d
    return h


@pytest.mark.parametrize("seed", range(20))
def test_random_flips_are_bennett_loops(seed):
    rng = np.random.default_rng(seed)
    m, h = _random_rotation(rng), _random_rotation(rng)
    k, n = bennett_flip(m, h)
    assert isinstance(k, np.ndarray)
    assert flip_residual(m, h, k, n) < 1e-13
    assert is_rotation(k, 1e-12) and is_rotation(n, 1e-12)
    assert np.allclose(_norm(n), _norm(m)) and np.allclose(_norm(k), _norm(h))
    # loop m, h, n, k: opposite sides have equal distances and twists, d / sin(alpha) equal
    lines = [plucker(x) for x in (m, h, n, k)]
    cn = [common_normal(*lines[i], *lines[(i + 1) % 4]) for i in range(4)]
    da = [(float(c.distance), abs(float(c.twist))) for c in cn]
    assert da[0][0] == pytest.approx(da[2][0], rel=1e-9, abs=1e-12)
    assert da[1][0] == pytest.approx(da[3][0], rel=1e-9, abs=1e-12)
    assert da[0][1] == pytest.approx(da[2][1], abs=1e-9)
    assert da[1][1] == pytest.approx(da[3][1], abs=1e-9)
    assert da[0][0] / np.sin(da[0][1]) == pytest.approx(da[1][0] / np.sin(da[1][1]), rel=1e-8)


def test_coaxial_flip_is_trivial():
    m = [F(1), 0, 0, F(2), 0, F(1), 0, 0]
    h = [F(-1), 0, 0, F(5), 0, F(5, 2), 0, 0]  # same axis (direction -k through (0, 1/2, 0))
    k, n = bennett_flip(m, h)
    assert k == h and n == m


def test_flip_fails_for_a_translation():
    m = [1, 2, 0, 0, 0, 0, 3, 0]
    h = [1, -2, 0, 0, 0, 0, 5, 0]  # primal(h) = conj(primal(m))
    with pytest.raises(FlipError) as e:
        bennett_flip(m, h)
    assert isinstance(e.value, SynthesisError) and e.value.exit_code == 1
    with pytest.raises(FlipError):
        bennett_flip(np.array(m, float), np.array(h, float) + 1e-14)


def test_exactness_is_kept_or_not():
    k, n = bennett_flip([1, 2, 0, 0, 0, 0, 3, 0], [0.0, 0, 0, 1, 0, 1, 1, 0])
    assert isinstance(k, np.ndarray)
    assert np.allclose(k, [0, 2 / 3, -2 / 3, -1 / 3, 0, 14 / 9, 10 / 9, 8 / 9])
