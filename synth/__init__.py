"""mpsynth's Python API: closed-loop linkages from task poses, by factorizing motion polynomials.

    import numpy as np, synth
    L = synth.bennett(poses)            # poses: (3, 4, 4) array, metres -> Linkage
    Ls = synth.fit(many, tolerance=(1e-3, 0.01), order="listed")    # (N, 4, 4): fitted (docs/fit.md)
    Ls = synth.fit(load_poses("task.yaml"), top=3)                   # a task file's PoseSet -> best fits
    L = synth.sixbar(poses4)            # (4, 4, 4) -> the best 6R Linkage (options: family, member, pair)
    Ls = synth.fit(many, tolerance=(1e-3, 0.01), kind="6r")  # (N, 4, 4): fitted 6R linkages (docs/sixbar_fit.md)
                                        # planar/spherical poses: a four-bar / Watt six-bar (docs/planar.md)
    L = synth.fourbar(poses)            # (k, 4, 4) coplanar, k >= 3 -> the best planar four-bar (docs/fourbar.md)
    L = synth.bennett_points(pts)       # (5, 3) points, metres -> Bennett Linkage whose tool point visits them
    L = synth.sixbar_points(pts7)       # (7, 3) -> the best 6R Linkage; synth.point_candidates(.., top=N): ranked
    R = synth.bennett_batch(many)       # (N, 3, 4, 4) -> BennettBatch: arrays over N, per-set status
    F = synth.factorize(C)              # (n+1, 8) monic motion polynomial -> every factorization
    S = synth.sweep(many, client=...)   # bennett_batch over chunks, here or on a Dask cluster
    R = synth.solve_bennett(ps, synth.SynthesisOptions(physical=True))  # what `mpsynth bennett` decides:
                                        # ps = synth.io.poses.load_poses(file); R.linkage, R.design, R.index
                                        # (also solve_sixbar, solve_points, solve_curve: docs/architecture.md)

Layers (data flows one way; see docs/architecture.md): ``synth.algebra`` (dual quaternions, motion
polynomials, factorization), ``synth.synthesis`` (conic, cubic families, Bennett, 6R, curves),
``synth.linkage`` (the plain data object and its checks), ``synth.design`` (physical design),
``synth.solve`` (the entry points: gates, ranking, choice of design), ``synth.io`` (pose files in, URDF / STL / JSON
out, reading an output back) and ``synth.tools`` (render, viewer, collide, simulate, batch jobs).

Nothing in this package's API touches the file system except ``synth.io``. Lengths are in metres (any
unit works as long as it is consistent), angles in radians, poses are 4x4 homogeneous matrices
(rotation R, translation d: a body point b is at R b + d). Errors: `synth.InputError` (malformed input)
and `synth.SynthesisError` (no real linkage; the message says why), both subclasses of
`synth.MpsynthError`.

``import synth`` is cheap: the names below are loaded on first use (PEP 562).
"""
from __future__ import annotations

import importlib

__all__ = ["bennett", "fit", "sixbar", "fourbar", "bennett_points", "sixbar_points", "point_candidates", "bennett_batch", "sweep",
           "factorize", "BennettBatch", "Linkage", "Kind", "MpsynthError",
           "solve_bennett", "solve_sixbar", "solve_fourbar", "solve_points", "solve_curve", "SynthesisOptions", "DesignOptions", "Result",
           "InputError", "SynthesisError"]

_LAZY = {
    "bennett": "synth.synthesis.bennett",
    "fit": "synth.synthesis.tasks",
    "sixbar": "synth.synthesis.sixbar",
    "fourbar": "synth.synthesis.fourbar",
    "bennett_points": "synth.synthesis.points",
    "sixbar_points": "synth.synthesis.points",
    "point_candidates": "synth.synthesis.points",
    "bennett_batch": "synth.synthesis.bennett_batch",
    "BennettBatch": "synth.synthesis.bennett_batch",
    "sweep": "synth.tools.sweep",
    "factorize": "synth.algebra.factorize",
    "Linkage": "synth.linkage",
    "Kind": "synth.linkage",
    "solve_bennett": "synth.solve",
    "solve_sixbar": "synth.solve",
    "solve_fourbar": "synth.solve",
    "solve_points": "synth.solve",
    "solve_curve": "synth.solve",
    "SynthesisOptions": "synth.solve",
    "DesignOptions": "synth.solve",
    "Result": "synth.solve",
    "MpsynthError": "synth.errors",
    "InputError": "synth.errors",
    "SynthesisError": "synth.errors",
}


def lazy_names(table: dict, namespace: dict, owner: str):
    """A package's ``(__getattr__, __dir__)`` (PEP 562) for names loaded on first use: ``table`` maps a name
    to the module that defines it; a loaded name is kept in ``namespace`` (the package's globals)."""
    def __getattr__(name):
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {owner!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__


__getattr__, __dir__ = lazy_names(_LAZY, globals(), "synth")
