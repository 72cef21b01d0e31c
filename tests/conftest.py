"""Shared test helpers: random poses, the shared verifier's location."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
VERIFIER = REPO.parent / "shared" / "tools" / "verify_output.py"


def random_rotation(rng, near_pi: bool = False):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    if near_pi:  # rotation angle within ~1e-3 of pi
        q[0] = rng.uniform(-1e-3, 1e-3)
        q[1:] *= np.sqrt(1 - q[0] ** 2) / np.linalg.norm(q[1:])
    from synth.algebra.dq import quat_to_matrix

    return quat_to_matrix(q)


def random_poses(rng, n: int, scale: float = 1.0, offset=(0.0, 0.0, 0.0), near_pi: bool = False):
    T = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        T[i, :3, :3] = random_rotation(rng, near_pi and i > 0)
        T[i, :3, 3] = rng.normal(size=3) * scale + np.asarray(offset)
    return T


def write_pose_yaml(path: Path, T, names=None) -> Path:
    """A pose file with 4x4 matrices in metres (exact repr of every float)."""
    lines = ["poses:"]
    for i, M in enumerate(T):
        name = names[i] if names else f"p{i}"
        rows = ", ".join("[" + ", ".join(repr(float(x)) for x in row) + "]" for row in M)
        lines.append(f"  - name: {name}\n    matrix: [{rows}]")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def verifier():
    if not VERIFIER.exists():
        pytest.skip("../shared/tools/verify_output.py is not present")
    return VERIFIER
