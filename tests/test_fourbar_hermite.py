"""`mpsynth fourbar` with velocities (Hermite conditions: a pose with a velocity counts as two
infinitesimally separated poses) and with the task's constraints (docs/fourbar.md): exact tasks from
random crank-rockers recover them; end to end through the CLI and the shared verifier (velocities, base
box, speed ratio, the collision claim)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fourbar_tasks import coupler_poses, coupler_twist, random_crank_rocker, yaml_text
from synth.errors import InputError
from synth.synthesis.fourbar import fourbar_candidates
from test_cli_bennett import run
from test_cli_fourbar import verifier, verify_claims  # noqa: F401 (a fixture)

SCALE = 0.1  # metres per unit length of `random_crank_rocker`


def hermite_task(seed: int, k: int, with_velocity: int):
    """(lengths in metres, poses (k, 4, 4), velocity (k, 6) with the first ``with_velocity`` rows given,
    ground pivots (2, 3) world) of the coupler of a random crank-rocker in a tilted plane."""
    L = random_crank_rocker(np.random.default_rng(seed))
    phis = np.linspace(0.2, 0.2 + math.radians(200), k)
    T, piv, (o, e1, e2) = coupler_poses(L, phis, plane_seed=seed, scale=SCALE)
    vel = np.full((k, 6), np.nan)
    for i in range(with_velocity):
        vel[i] = np.concatenate(coupler_twist(L, phis[i], plane_seed=seed, scale=SCALE))
    ground = np.array([o + p[0] * e1 + p[1] * e2 for p in (piv[0], piv[2])])
    return np.array(L) * SCALE, T, vel, ground


def lengths(lk) -> np.ndarray:
    d = lk.info.synthesis.fourbar.lengths.to_dict()
    return np.array([d["ground"], d["crank"], d["coupler"], d["rocker"]])


@pytest.mark.parametrize("seed, k, m", [(0, 4, 1), (1, 3, 2), (2, 4, 1), (3, 3, 2)])
def test_five_conditions_recover_the_crank_rocker(seed, k, m):
    """Poses plus velocities, five conditions (Burmester points): the four-bar that made them is found."""
    L, T, vel, _ = hermite_task(seed, k, m)
    out = fourbar_candidates(T, [f"p{i}" for i in range(k)], top=4, velocity=vel)
    assert min(np.max(np.abs(lengths(lk) - L)) for lk in out) < 1e-7 * L.max()


@pytest.mark.parametrize("k, m", [(2, 1), (3, 1)])
def test_fewer_conditions_give_fourbars_meeting_the_velocity(k, m):
    """Three or four conditions (oo^2, oo^1 dyads): the best four-bar's coupler moves along the given
    velocity at the pose (its instant centre is the velocity's): both cranks point at it."""
    _, T, vel, _ = hermite_task(5, k, m)
    lk = fourbar_candidates(T, [f"p{i}" for i in range(k)], velocity=vel)[0]
    w, v = vel[0, :3], vel[0, 3:]
    P = T[0, :3, 3] + np.cross(w, v) / (w @ w)  # the instant centre (on the plane through the tool origin)
    for a, b in (("h1", "h2"), ("k1", "k2")):
        A, B = lk.joint(a), lk.joint(b)
        pa = A.point + ((P - A.point) @ A.direction) * A.direction  # the pivots in P's plane
        pb = B.point + ((P - B.point) @ B.direction) * B.direction
        u, x = pb - pa, P - pa
        assert np.linalg.norm(np.cross(u, x)) <= 1e-8 * np.linalg.norm(u) * max(np.linalg.norm(x), 1e-3)


def test_velocity_out_of_the_plane_and_too_many_conditions_are_refused():
    _, T, vel, _ = hermite_task(0, 4, 1)
    tilted = vel.copy()
    tilted[0, :3] += 0.1 * np.linalg.norm(tilted[0, :3]) * np.cross(tilted[0, :3], [1.0, 0, 0])
    with pytest.raises(InputError, match=r"pose 0 \(p0\): its velocity leaves the plane of motion"):
        fourbar_candidates(T, [f"p{i}" for i in range(4)], velocity=tilted)
    _, T5, vel5, _ = hermite_task(0, 5, 1)
    with pytest.raises(InputError, match="at most 5 conditions"):
        fourbar_candidates(T5, [f"p{i}" for i in range(5)], velocity=vel5)


def task_file(tmp_path, T, vel, constraints: str = "") -> str:
    given = {i: (v[:3], v[3:]) for i, v in enumerate(vel) if not np.isnan(v).any()}
    path = tmp_path / "task.yaml"
    path.write_text(yaml_text(T, extra="units: {length: m, angle: rad}\n" + constraints, velocity=given))
    return path


def test_velocity_and_constraints_end_to_end(tmp_path, verifier):  # noqa: F811
    """Four poses and a velocity, the ground pivots' axes through a box around the known pivots and a
    speed-ratio limit: written, and the verifier accepts the velocity, the constraints and the collision
    claim."""
    L, T, vel, ground = hermite_task(0, 4, 1)
    lo, hi = ground.min(0) - 0.005, ground.max(0) + 0.005
    box = f"constraints:\n  base: {{box: [{lo.tolist()}, {hi.tolist()}]}}\n  max_speed_ratio: 3\n"
    task = task_file(tmp_path, T, vel, box)
    out = tmp_path / "out"
    r = run("fourbar", task, "-o", out)
    assert r.exit_code == 0, r.output
    assert "constraints: met: base box (h1, k1 through it)" in r.output
    doc = json.loads((out / "linkage.json").read_text())
    assert np.max(np.abs(lengths_of(doc) - L)) < 1e-7 * L.max()
    assert doc["drive"]["driver"] == "h1" and doc["drive"]["max_speed_ratio"] <= 3
    report = verify_claims(verifier, task, out)
    assert report is None or ("velocity_err=" in report and "base_box=checked" in report)


def lengths_of(doc) -> np.ndarray:
    d = doc["info"]["fourbar"]["lengths"]
    return np.array([d["ground"], d["crank"], d["coupler"], d["rocker"]])


def test_a_base_box_no_fourbar_meets_is_refused(tmp_path):
    _, T, vel, ground = hermite_task(0, 4, 1)
    far = ground.mean(0) + 1.0
    box = f"constraints:\n  base: {{box: [{(far - 0.01).tolist()}, {(far + 0.01).tolist()}]}}\n"
    out = tmp_path / "out"
    r = run("fourbar", task_file(tmp_path, T, vel, box), "-o", out)
    assert r.exit_code == 1 and "constraints.base: the axis of" in r.output and not out.exists()


def test_fixture_end_to_end(tmp_path, verifier):  # noqa: F811
    """fixtures/fourbar_velocity.yaml (made by `hermite_task(0, 4, 1)`): the crank-rocker that made it, its
    constraints met, accepted by the verifier with its collision claim."""
    from conftest import REPO

    fixture = REPO / "fixtures" / "fourbar_velocity.yaml"
    out = tmp_path / "out"
    r = run("fourbar", fixture, "-o", out)
    assert r.exit_code == 0, r.output
    assert "constraints: met: base box (h1, k1 through it), max speed ratio 1.38 <= 3" in r.output
    L = hermite_task(0, 4, 1)[0]
    assert np.max(np.abs(lengths_of(json.loads((out / "linkage.json").read_text())) - L)) < 1e-7 * L.max()
    verify_claims(verifier, fixture, out)
