"""Seeded generator of hard pose sets (issue 20) and the judge of one `mpsynth bennett|sixbar -o` run.

Families (``FAMILIES``), each a function ``(rng, k) -> (k, 4, 4)`` pose matrices in metres:

* ``near-translational``: one orientation rotated by 1e-6..1e-2 rad per pose (random axes), positions
  O(1) or scaled;
* ``mixed-scale``: translations of 1e-3..1e3 m (per pose or per set), far from the origin (up to 1e6 m);
* ``near-coincident``: two poses 1e-7..1e-4 (often 2 µm) apart, rotation and translation together;
* ``coincident-rotation``: two poses with rotations 1e-9..1e-3 rad apart and different positions;
* ``near-translational-far``: near-translational sets far from the origin and at odd scales.

`judge` runs the CLI in-process (click's runner) with ``-o``, then `mpsynth check` (in-process) and the
shared verifier (its ``main``, imported from the file), and classifies the run: ``ok`` (exit 0 and both
accept), ``refused`` (exit 1 with one line), else ``defect`` with the reason."""
from __future__ import annotations

import contextlib
import importlib.util
import io
import math
import shutil
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from conftest import VERIFIER, random_rotation, write_pose_yaml


def _rot(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _poses(R, p):
    T = np.tile(np.eye(4), (len(R), 1, 1))
    T[:, :3, :3] = R
    T[:, :3, 3] = p
    return T


def _far(rng, lo=0.0, hi=6.0):
    d = rng.normal(size=3)
    return d / np.linalg.norm(d) * 10 ** rng.uniform(lo, hi)


def near_translational(rng, k):
    R0 = random_rotation(rng)
    R = [R0 @ _rot(rng.normal(size=3), 10 ** rng.uniform(-6, -2)) if i else R0 for i in range(k)]
    return _poses(R, rng.normal(size=(k, 3)) * 10 ** rng.uniform(-1, 1))


def mixed_scale(rng, k):
    R = [random_rotation(rng) for _ in range(k)]
    if rng.random() < 0.5:  # one scale per set
        p = rng.normal(size=(k, 3)) * 10 ** rng.uniform(-3, 3)
    else:  # one scale per pose
        p = rng.normal(size=(k, 3)) * 10 ** rng.uniform(-3, 3, size=(k, 1))
    return _poses(R, p + _far(rng, 0, 6) * (rng.random() < 0.8))


def near_coincident(rng, k):
    T = _poses([random_rotation(rng) for _ in range(k)], rng.normal(size=(k, 3)) * 10 ** rng.uniform(-1, 1))
    i, j = rng.choice(k, 2, replace=False)
    e = 2e-6 if rng.random() < 0.4 else 10 ** rng.uniform(-7, -4)
    M = np.eye(4)
    M[:3, :3] = _rot(rng.normal(size=3), e * rng.uniform(0, 1))
    v = rng.normal(size=3)
    M[:3, 3] = v / np.linalg.norm(v) * e
    T[j] = M @ T[i] if rng.random() < 0.5 else T[i] @ M
    if rng.random() < 0.3:
        T[:, :3, 3] += _far(rng, 0, 4)
    return T


def coincident_rotation(rng, k):
    R = [random_rotation(rng) for _ in range(k)]
    i, j = rng.choice(k, 2, replace=False)
    R[j] = R[i] @ _rot(rng.normal(size=3), 10 ** rng.uniform(-9, -3))
    return _poses(R, rng.normal(size=(k, 3)) * 10 ** rng.uniform(-2, 2))


def near_translational_far(rng, k):
    T = near_translational(rng, k)
    T[:, :3, 3] *= 10 ** rng.uniform(-3, 3)
    T[:, :3, 3] += _far(rng, 0, 5)
    return T


FAMILIES = {"near-translational": near_translational, "mixed-scale": mixed_scale,
            "near-coincident": near_coincident, "coincident-rotation": coincident_rotation,
            "near-translational-far": near_translational_far}


def hard_set(seed: int, k: int):
    """The seed's (family name, (k, 4, 4) poses): families in turn, parameters from the seed."""
    name = list(FAMILIES)[seed % len(FAMILIES)]
    rng = np.random.default_rng([20, k, seed])
    return name, FAMILIES[name](rng, k)


_verifier = None


def verifier_main():
    global _verifier
    if _verifier is None:
        spec = importlib.util.spec_from_file_location("verify_output", VERIFIER)
        _verifier = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(_verifier)
    return _verifier.main


def run_verifier(poses: Path, out: Path) -> tuple[int, str]:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = verifier_main()([str(poses), str(out)])
    return code, buf.getvalue()


def judge(T, work: Path, command: str, use_verifier: bool = True) -> tuple[str, str]:
    """Run `mpsynth COMMAND POSES -o OUT` in-process; ("ok"|"refused"|"defect", detail)."""
    from cli.main import mpsynth
    from synth.io.poses import load_poses
    from synth.tools.check.verify import check_tree

    work.mkdir(parents=True, exist_ok=True)
    poses = write_pose_yaml(work / "poses.yaml", T)
    out = work / "out"
    shutil.rmtree(out, ignore_errors=True)
    r = CliRunner().invoke(mpsynth, [command, str(poses), "-o", str(out), "-q"])
    err = r.stderr
    if r.exit_code == 1:
        if err.count("\n") == 1 and err.startswith("mpsynth: ") and not out.exists():
            return "refused", err.strip()
        return "defect", f"exit 1 but not one clean line / OUT written: {err!r}"
    if r.exit_code != 0:
        return "defect", f"exit {r.exit_code}: {err.strip()!r} {r.exception!r}"
    res = check_tree(out, load_poses(str(poses)))
    if not res["ok"]:
        return "defect", "check: " + "; ".join(res["problems"])
    if use_verifier and VERIFIER.exists():
        code, text = run_verifier(poses, out)
        if code != 0:
            return "defect", "verifier: " + " | ".join(text.strip().splitlines())
    return "ok", err.strip()
