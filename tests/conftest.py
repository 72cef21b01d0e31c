"""Shared test helpers: running the command line (`run`, `invoke`, `run_process`, `run_python`), random poses,
pose files, and the shared verifier (``../shared/tools/verify_output.py`` beside the repository: the tests
that need it skip cleanly without it, the others run on a plain copy of the repository, no git needed)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
VERIFIER = REPO.parent / "shared" / "tools" / "verify_output.py"

# A shell without job control starts its background commands with SIGINT ignored (POSIX), and an ignored
# signal stays ignored in every child: the tests of ^C would then see nothing arrive. The suite runs as if
# started in the foreground: Python's own handler here, so the command lines the tests start get the default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def run(*args, input=None):
    """`mpsynth ARGS` in this process (click's CliRunner, stdout and stderr apart): the click Result. An
    exception escaping the command line propagates (a bug: shown, not turned into an exit code)."""
    from click.testing import CliRunner

    from cli.main import mpsynth

    return CliRunner().invoke(mpsynth, [str(a) for a in args], input=input, catch_exceptions=False)


def invoke(args, cwd, input=None) -> tuple[int, str, str]:
    """`mpsynth ARGS` in this process with ``cwd`` as working directory: (exit code, stdout, stderr)."""
    old = os.getcwd()
    os.chdir(cwd)
    try:
        r = run(*args, input=input)
    finally:
        os.chdir(old)
    return r.exit_code, r.stdout, r.stderr


def run_process(args, cwd=REPO, input=None, stdin=None, stdout=subprocess.PIPE, timeout=120) -> tuple[int, str, str]:
    """`python -m cli.main ARGS` in a fresh interpreter with this checkout first on the path: (exit code,
    stdout, stderr) as text (signals, closed streams, exit codes as a shell sees them)."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.run([sys.executable, "-m", "cli.main", *map(str, args)], cwd=cwd, env=env, input=input,
                       stdin=stdin, stdout=stdout, stderr=subprocess.PIPE, timeout=timeout)
    out = p.stdout.decode("utf-8", "replace") if isinstance(p.stdout, bytes) else (p.stdout or "")
    return p.returncode, out, p.stderr.decode("utf-8", "replace")


def run_python(*args, timeout=600) -> subprocess.CompletedProcess:
    """`python ARGS` (a script, e.g. the verifier, or ``-m cli.main ...``) in the repository, text output."""
    return subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True, cwd=REPO, timeout=timeout)


def assert_verified(*args, timeout=600) -> str | None:
    """The shared verifier on ARGS must say "verify OK" (exit 0); its last line, or None when it is absent."""
    r = run_verifier(*args, timeout=timeout)
    if r is None:
        return None
    lines = (r.stdout + r.stderr).strip().splitlines()
    assert r.returncode == 0 and r.stdout.strip().splitlines()[-1].startswith("verify OK"), r.stdout + r.stderr
    return lines[-1]


def run_verifier(*args, timeout=600) -> subprocess.CompletedProcess | None:
    """The shared verifier on ARGS (task, output directory, options), or None when it is absent (a plain
    copy of the repository): the caller checks what it can without it."""
    if not VERIFIER.exists():
        return None
    return run_python(VERIFIER, *args, timeout=timeout)


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
    """A pose file with 4x4 matrices in metres, said explicitly (exact repr of every float)."""
    lines = ["units: {length: m}", "poses:"]
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


@pytest.fixture
def first_sets_only(monkeypatch):
    """The search as it was before issue 33's full-cycle work: two sets of starts per range, no cranked bars
    over the full cycle. With it seed 22 collides at the default radii, which the thinning needs (with the
    full search no random Bennett set of bench seeds 0-103 collides: tests/test_full_cycle.py)."""
    from synth.design import choose, search

    monkeypatch.setattr(search, "MORE_WORK", 0.0)
    monkeypatch.setattr(choose, "CRANK_FULL_WORK", 0.0)

