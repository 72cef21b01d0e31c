"""Exceptions with the exit codes of the CLI contract (docs/conventions.md): 2 input error, 1 no real linkage."""
from __future__ import annotations


class MpsynthError(Exception):
    """Base class; ``exit_code`` is what the CLI returns, ``str(e)`` the one-line message."""

    exit_code = 1


class InputError(MpsynthError, ValueError):
    """Malformed or invalid input (file, pose, option, expression). Exit code 2.

    The message names the file, the pose and the problem, e.g.
    ``poses.yaml: pose 2 ("grasp"): quaternion has length 0.5, expected 1``."""

    exit_code = 2


class SynthesisError(MpsynthError):
    """Valid input for which no real linkage of the requested kind exists (degenerate geometry,
    no real solution, a prismatic joint needed). Exit code 1. The message says why in plain words."""

    exit_code = 1


class NotGenericError(SynthesisError):
    """The motion polynomial's primal part has a real polynomial factor: Algorithm 1 does not apply."""


class NoFactorizationError(SynthesisError):
    """The motion polynomial admits no factorization into linear factors."""


class OutputError(MpsynthError):
    """The output could not be written (disk full, I/O error, an unwritable standard output). Exit
    code 2, like an unusable output directory; nothing partial is left behind."""

    exit_code = 2
