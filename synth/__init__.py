"""mpsynth's Python API: closed-loop linkages from task poses, by factorizing motion polynomials.

    import numpy as np, synth
    L = synth.bennett(poses)            # poses: (3, 4, 4) array, metres -> Linkage
    L = synth.sixbar(poses4)            # (4, 4, 4) -> the best 6R Linkage (options: family, member, pair)
    R = synth.bennett_batch(many)       # (N, 3, 4, 4) -> BennettBatch: arrays over N, per-set status
    F = synth.factorize(C)              # (n+1, 8) monic motion polynomial -> every factorization

Nothing here touches the file system (see ``synth.export`` for URDF / JSON / STL). Lengths are in
metres (any unit works as long as it is consistent), angles in radians, poses are 4x4 homogeneous
matrices (rotation R, translation d: a body point b is at R b + d). Conventions of the result are in
`synth.linkage` (joints as Plücker lines at the first pose, angle laws theta(t) = 2 atan2(b, t - a)).
Errors: `synth.InputError` (malformed input) and `synth.SynthesisError` (no real linkage; the message
says why), both subclasses of `synth.MpsynthError`.

``import synth`` is cheap: the submodules (and numpy) load on first use. Note that ``synth.bennett``
and ``synth.sixbar`` are the API *functions*; the modules of the same name are reached with
``from synth.bennett import ...`` or ``importlib.import_module("synth.bennett")``.
"""
from __future__ import annotations

import sys
import types

__all__ = ["bennett", "sixbar", "bennett_batch", "factorize", "BennettBatch", "Linkage", "MpsynthError",
           "InputError", "SynthesisError"]

DEFAULT_CHECK_SAMPLES = 4  # synth.bennett / bennett_batch: closure + motion checked at this many parameters

_bennett_impl = None


def bennett(poses, names=None, *, check_samples: int = DEFAULT_CHECK_SAMPLES):
    """The Bennett 4R linkage whose coupler passes through three poses.

    ``poses``: array-like (3, 4, 4), metres. ``names``: optional pose names (default p0, p1, p2).
    Returns a `synth.linkage.Linkage` with joints ``h1, h2, k1, k2`` (branches h1-h2 and k1-k2, welded at
    the coupler), each a Plücker line at the first pose plus its angle law; ``poses[i].joint_angles``
    (pose 0 at t = inf with all angles 0, pose 1 at t = 0, pose 2 at t = 1); ``info`` (Bennett
    parameters, DH table, Study form, conditioning, warnings) and ``checks`` (measured errors: tool pose
    at every pose's angles, and loop closure and motion at ``check_samples`` parameters covering the
    whole motion; the CLI verifies 200 before writing files).

    Raises `synth.SynthesisError` (degenerate poses, parallel screw axes, ...) with a plain-language
    reason, `synth.InputError` for a wrong shape or NaN."""
    global _bennett_impl
    if _bennett_impl is None:
        from .bennett import bennett as impl

        _bennett_impl = impl
    return _bennett_impl(poses, names, check_samples=check_samples)


def sixbar(poses, names=None, **options):
    """The best spatial 6R linkage (by the engineering score) whose coupler visits four poses.

    ``poses``: array-like (4, 4, 4), metres. ``options`` (see `synth.sixbar.sixbar`): ``family`` (1|2),
    ``member`` (lambda1, the weight of pose 1), ``pair`` (1..9), ``grid``, ``check_samples``. Returns a
    `synth.linkage.Linkage` (joints h1..h3, k1..k3). Raises `synth.SynthesisError` (oval quadric: no real
    6R of this kind; degenerate poses; ...) or `synth.InputError`."""
    from .sixbar import sixbar as impl

    return impl(poses, names, **options)


_LAZY = {
    "bennett_batch": ("synth.batch", "bennett_batch"),
    "BennettBatch": ("synth.batch", "BennettBatch"),
    "factorize": ("synth.factor", "factorize"),
    "Linkage": ("synth.linkage", "Linkage"),
    "MpsynthError": ("synth.errors", "MpsynthError"),
    "InputError": ("synth.errors", "InputError"),
    "SynthesisError": ("synth.errors", "SynthesisError"),
}
_API_FUNCTIONS = {"bennett": bennett, "sixbar": sixbar}


def __getattr__(name):
    target = _LAZY.get(name)
    if target is None:
        raise AttributeError(f"module 'synth' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(target[0]), target[1])
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


class _Package(types.ModuleType):
    """Keeps ``synth.bennett`` / ``synth.sixbar`` bound to the API functions when the submodules of the
    same name are imported (the import system would otherwise set the package attribute to the module;
    the module stays available in sys.modules)."""

    def __setattr__(self, name, value):
        if name in _API_FUNCTIONS and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
