"""The Python API in synth/__init__.py: names, laziness, equivalence with the modules."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import synth

from conftest import REPO, random_poses
from synth.checks import DEFAULT_CHECK_SAMPLES


def test_import_synth_is_cheap():
    code = ("import sys, synth; heavy = [m for m in ('numpy', 'sympy', 'scipy', 'trimesh', 'click') "
            "if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    assert out.stdout.strip() == "[]"


def test_api_names_are_the_library_functions():
    from synth.algebra.factorize import factorize
    from synth.synthesis.sixbar import sixbar
    from synth.synthesis.tasks import bennett  # the exact synthesis for three poses, the task one for tasks

    assert synth.bennett is bennett and synth.sixbar is sixbar and synth.factorize is factorize
    assert synth.SynthesisError.__name__ == "SynthesisError"
    with pytest.raises(AttributeError):
        synth.no_such_name  # noqa: B018


def test_bennett_api_equals_module_function():
    from synth.synthesis.bennett import bennett as module_bennett

    T = random_poses(np.random.default_rng(7), 3)
    A = synth.bennett(T)
    B = module_bennett(T, check_samples=DEFAULT_CHECK_SAMPLES)
    assert A.checks["samples"] == 0 and A.checks["bounded"]  # closure bounded over the whole motion
    assert B.checks["samples"] == DEFAULT_CHECK_SAMPLES and B.checks["bounded"]
    for ja, jb in zip(A.joints, B.joints):
        np.testing.assert_allclose(ja.direction, jb.direction, atol=1e-14)
        np.testing.assert_allclose(ja.moment, jb.moment, atol=1e-14)
    full = synth.bennett(T, check_samples=200)
    assert full.checks["samples"] == 200 and full.checks["max_closure_error"] < 1e-12


def test_bennett_api_errors():
    with pytest.raises(synth.InputError):
        synth.bennett(np.zeros((4, 4, 4)))
    with pytest.raises(synth.SynthesisError, match="coincide"):
        synth.bennett(np.stack([np.eye(4)] * 3))
