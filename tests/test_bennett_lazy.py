"""The fast path of synth.bennett defers its self-check (issue 7): `error_estimate` decides whether the
self-check can fail; if not, ``checks``, ``info`` and ``motion`` are computed on first access. These
tests check that the deferred values equal the eager ones, that the gate never accepts what the eager
self-check would refuse (and that the estimate really bounds the self-check error), and that deferred
attributes behave like ordinary ones (copies, pickling, equality, JSON)."""
from __future__ import annotations

import copy
import dataclasses
import importlib
import json
import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import synth
from synth.synthesis.assemble import two_branch_linkage
from synth.checks import pose_difference
from synth.errors import SynthesisError
from synth.linkage import Linkage
from synth.algebra.scalar import bennett_core

from conftest import random_poses

sb = importlib.import_module("synth.synthesis.bennett")
thg = importlib.import_module("test_hard_geometry")


def eager(T, samples=4):
    """The pre-issue-7 fast path: self-check now, `_accept` decides. (linkage or refusal message, core)"""
    core = bennett_core(T)
    if core is None:
        return None, None
    info, cond = sb._fast_info(core)
    lk = two_branch_linkage("bennett", core["H"], core["K"], core["C"], T, ["p0", "p1", "p2"], sb._TS, info)
    try:
        return sb._finish(lk, core["B"], cond, samples), core
    except SynthesisError as e:
        return str(e), core


def outcome(T, samples=4):
    try:
        return sb.bennett(T, check_samples=samples)
    except SynthesisError as e:
        return str(e)


def same_linkage(a, b):
    assert [(j.name, j.parent, j.child, j.a, j.b) for j in a.joints] == [(j.name, j.parent, j.child, j.a, j.b)
                                                                          for j in b.joints]
    for ja, jb in zip(a.joints, b.joints):
        assert np.array_equal(ja.direction, jb.direction) and np.array_equal(ja.moment, jb.moment)
    assert [(p.name, p.t, p.joint_angles) for p in a.poses] == [(p.name, p.t, p.joint_angles) for p in b.poses]
    assert a.links == b.links and a.branches == b.branches and a.closures == b.closures
    assert np.array_equal(a.motion, b.motion) and np.array_equal(a.tool_ref, b.tool_ref)
    assert a.checks == b.checks
    assert json.dumps(a.info) == json.dumps(b.info)  # same values, same key order


def generate(kind, rng):
    if kind == "random":
        return random_poses(rng, 3)
    if kind == "sweep":  # as test_bennett's slow sweep
        return random_poses(rng, 3, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 100)
    if kind == "extreme":
        return random_poses(rng, 3, scale=10 ** rng.uniform(-6, 6),
                            offset=rng.normal(size=3) * 10 ** rng.uniform(-3, 7))
    if kind == "near_pi":
        return random_poses(rng, 3, near_pi=True)
    return thg.family(kind, 10 ** rng.uniform(-9, 0), rng)


KINDS = ("random", "sweep", "extreme", "near_pi") + thg.FAMILIES


def check_gate(T, samples=4):
    """The deferred path gives exactly the eager result or refusal; the estimate bounds the error."""
    ref, core = eager(T, samples)
    if core is None:
        return None
    est = sb.error_estimate(core)
    got = outcome(T, samples)
    if isinstance(ref, str):
        assert got == ref
        assert not est <= sb.ESTIMATE_TOL, est  # a refused result is never waved through
        return None
    assert not isinstance(got, str), got
    same_linkage(got, ref)
    rel = ref.info["relative_error"]
    if est <= sb.ESTIMATE_TOL:
        assert "_deferred" in vars(got)
        # the calibration claim of error_estimate's docstring, with its 4x margin to spare
        assert rel <= est, (rel, est)
    return rel / est


@pytest.mark.parametrize("kind", KINDS)
def test_deferred_result_equals_eager(kind):
    rng = np.random.default_rng(sum(map(ord, kind)))
    for _ in range(40):
        check_gate(generate(kind, rng))


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("samples", [4, 200])
def test_gate_sweep(kind, samples):
    rng = np.random.default_rng(1000 + sum(map(ord, kind)) + samples)
    worst = 0.0
    for _ in range(1500 if samples == 4 else 150):
        r = check_gate(generate(kind, rng), samples)
        worst = max(worst, r or 0.0)
    assert worst <= 0.25, worst  # error_estimate's documented calibration


@given(seed=st.integers(0, 2 ** 32 - 1), scale=st.floats(-3, 3), offset=st.floats(-2, 6))
@settings(max_examples=60, deadline=None)
def test_deferred_matches_eager_hypothesis(seed, scale, offset):
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** scale, offset=rng.normal(size=3) * 10 ** offset)
    check_gate(T)


def test_bench_like_inputs_take_the_deferred_path():
    rng = np.random.default_rng(7)
    deferred = sum("_deferred" in vars(synth.bennett(random_poses(rng, 3))) for _ in range(200))
    assert deferred >= 190


# ------------------------------------------------------------------ deferred attributes
@pytest.fixture
def pair():
    rng = np.random.default_rng(3)
    T = random_poses(rng, 3)
    lazy = synth.bennett(T)
    assert {"checks", "info", "motion"} <= set(vars(lazy)["_deferred"])
    return lazy, eager(T)[0], T


def test_deferred_attributes_are_computed_once_and_stored(pair):
    lazy, ref, _ = pair
    c = lazy.checks
    assert c == ref.checks and lazy.checks is c and "checks" not in vars(lazy)["_deferred"]
    assert lazy.info == ref.info and lazy.info is lazy.info
    assert not vars(lazy)["_deferred"]


def test_deferred_linkage_equality_repr_asdict(pair):
    lazy, ref, _ = pair
    assert repr(copy.deepcopy(lazy)) == repr(ref)
    d = dataclasses.asdict(copy.copy(lazy))
    assert d["checks"] == ref.checks and d["info"] == ref.info
    a, b = synth.bennett(pair[2]), synth.bennett(pair[2])
    same_linkage(dataclasses.replace(a), b)  # replace reads the deferred attributes


def test_deferred_linkage_copy_and_pickle(pair):
    lazy, ref, _ = pair
    c = copy.copy(lazy)
    c.tool_ref = np.eye(4)  # a copy changed before the checks ran: they are the original's, as when eager
    assert c.checks == ref.checks
    assert lazy.checks == ref.checks
    p = pickle.loads(pickle.dumps(synth.bennett(pair[2])))
    same_linkage(p, ref)


def test_deferred_linkage_json_export(pair):
    from synth.io import jsonout

    lazy, ref, _ = pair
    assert jsonout._dumps(jsonout.linkage_document(lazy)) == jsonout._dumps(jsonout.linkage_document(ref))


def test_setting_a_deferred_attribute_overrides_it(pair):
    lazy = synth.bennett(pair[2])
    lazy.checks = {"x": 1.0}
    assert lazy.checks == {"x": 1.0}
    with pytest.raises(AttributeError):
        lazy.no_such_attribute  # noqa: B018


def test_defer_on_a_plain_linkage():
    lk = Linkage("motion", [], {}, [], [], np.eye(4), np.zeros((1, 8)))
    calls = []
    lk.defer(checks=lambda self: calls.append(self) or {"a": 1.0})
    assert calls == [] and lk.checks == {"a": 1.0} and lk.checks == {"a": 1.0} and calls == [lk]


def test_refusal_safety_net_when_deferred_check_fails(monkeypatch):
    """Should the estimate ever be wrong, reading info of the returned linkage raises the refusal."""
    rng = np.random.default_rng(5)
    T = random_poses(rng, 3)
    lk = synth.bennett(T)
    monkeypatch.setattr(sb, "ACCEPT_TOL", 1e-30)
    with pytest.raises(SynthesisError, match="misses them"):
        lk.info  # noqa: B018


# ------------------------------------------------------------------ check_distinct
@given(seed=st.integers(0, 2 ** 32 - 1), e=st.floats(-13, 0))
@settings(max_examples=100, deadline=None)
def test_scalar_pose_difference_matches_numpy(seed, e):
    rng = np.random.default_rng(seed)
    T = random_poses(rng, 2, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 100)
    T[1] = thg.small_motion(rng, 10 ** e, 10 ** rng.uniform(-3, 3)) @ T[0] if rng.uniform() < 0.7 else T[1]
    dt, dr = sb._pose_difference(T[0].tolist(), T[1].tolist())
    nt, nr = pose_difference(T[0], T[1])
    assert math.isclose(dt, nt, rel_tol=1e-14, abs_tol=1e-300)
    assert abs(dr - nr) <= 4e-16 * max(1.0, nr)


def _check_distinct_numpy(T, names, tol=sb.COINCIDENT_TOL):
    """The former numpy implementation."""
    T = np.asarray(T, float)
    pos = T[:, :3, 3]
    L = max(float(np.sqrt(np.mean(np.sum((pos - pos.mean(0)) ** 2, axis=1)))), 1e-300)
    for i in range(len(T)):
        for j in range(i + 1, len(T)):
            dt, dr = pose_difference(T[i], T[j])
            if dt <= tol * max(L, 1e-300) and dr <= tol or (dt == 0 and dr <= tol):
                raise SynthesisError(f"poses {i} ({names[i]!r}) and {j} ({names[j]!r}) coincide: "
                                     "three distinct poses are needed")


@pytest.mark.parametrize("n", [3, 4])
def test_check_distinct_matches_numpy(n):
    rng = np.random.default_rng(n)
    names = [f"q{i}" for i in range(n)]
    for k in range(400):
        T = random_poses(rng, n, scale=10 ** rng.uniform(-3, 3), offset=rng.normal(size=3) * 10)
        i, j = rng.choice(n, 2, replace=False)
        e = 10 ** rng.uniform(-12, -7)
        T[j] = thg.small_motion(rng, e, 10 ** rng.uniform(-3, 3)) @ T[i] if k % 3 else T[i]
        results = []
        for f in (sb.check_distinct, _check_distinct_numpy):
            try:
                f(T, names)
                results.append(None)
            except SynthesisError as err:
                results.append(str(err))
        assert results[0] == results[1]


def test_check_distinct_accepts_lists_and_nan():
    sb.check_distinct([np.eye(4).tolist(), np.diag([1.0, -1, -1, 1]).tolist()], ["a", "b"])
    T = np.array([np.eye(4), np.eye(4)])
    T[1, 0, 3] = np.nan
    sb.check_distinct(T, ["a", "b"])  # NaN compares false: not 'coincident' (as before)


# ------------------------------------------------------------------ two_branch_linkage
def _two_branch_reference(kind, H, K, motion, poses, names, ts, info=None):
    """The former two_branch_linkage (one numpy array per Plücker vector, per-call layout)."""
    from synth.synthesis.assemble import _angle, joint_from_factor
    from synth.linkage import PoseRecord

    n = len(H)
    joints, links = [], {"base": ["h1", "k1"]}
    for branch, F in (("h", H), ("k", K)):
        for i in range(n):
            parent = "base" if i == 0 else f"link_{branch}{i}"
            if i == n - 1:
                child = "coupler" if branch == "h" else "coupler_k"
            else:
                child = f"link_{branch}{i + 1}"
                links[child] = [f"{branch}{i + 1}", f"{branch}{i + 2}"]
            joints.append(joint_from_factor(f"{branch}{i + 1}", parent, child, F[i]))
    links["coupler"] = [f"h{n}", f"k{n}"]
    links["coupler_k"] = []
    lk = Linkage(kind=kind, joints=joints, links=links,
                 branches=[[f"h{i + 1}" for i in range(n)], [f"k{i + 1}" for i in range(n)]],
                 closures=[("coupler", "coupler_k")], tool_ref=np.asarray(poses[0], float),
                 motion=np.asarray(motion, float), info=dict(info or {}))
    for name, T, t in zip(names, np.asarray(poses, float), np.asarray(ts, float).tolist()):
        ang = {j.name: _angle(j.a, j.b, t) for j in joints}
        lk.poses.append(PoseRecord(name=name, matrix=T, t=t, joint_angles=ang))
    return lk


@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("as_array", [False, True])
def test_two_branch_linkage_matches_reference(n, as_array):
    rng = np.random.default_rng(n)
    H, K = rng.normal(size=(n, 8)), rng.normal(size=(n, 8))
    H[:, 4] = K[:, 4] = 0.0
    if not as_array:
        H, K = [tuple(h.tolist()) for h in H], [list(k) for k in K]  # tuples of floats, lists of numpy floats
    poses = random_poses(rng, n + 1)
    ts = [np.inf, 0.0, 1.0, -np.inf][:n + 1]
    names = [f"q{i}" for i in range(n + 1)]
    C = rng.normal(size=(n + 1, 8))
    a = two_branch_linkage("6r", H, K, C, poses, names, ts, {"x": 1})
    b = _two_branch_reference("6r", H, K, C, poses, names, ts, {"x": 1})
    assert repr(a) == repr(b)
    assert all(type(j.a) is float and type(j.b) is float for j in a.joints)
    assert all(type(x) is float for p in a.poses for x in [p.t, *p.joint_angles.values()])
    same_linkage(a, b)


# ------------------------------------------------------------------ fused core
@pytest.mark.parametrize("kind", KINDS)
def test_fused_core_is_bitwise_the_scalar_core(kind):
    from synth.synthesis.bennett_fast import bennett_core as fused

    rng = np.random.default_rng(77 + sum(map(ord, kind)))
    for _ in range(150):
        T = generate(kind, rng)
        assert repr(fused(T)) == repr(bennett_core(T))  # repr: signs of zeros and every last bit


@given(seed=st.integers(0, 2 ** 32 - 1), scale=st.floats(-8, 8), offset=st.floats(-8, 8),
       flip=st.booleans())
@settings(max_examples=150, deadline=None)
def test_fused_core_is_bitwise_the_scalar_core_hypothesis(seed, scale, offset, flip):
    from synth.synthesis.bennett_fast import bennett_core as fused

    rng = np.random.default_rng(seed)
    T = random_poses(rng, 3, scale=10 ** scale, offset=rng.normal(size=3) * 10 ** offset, near_pi=flip)
    if seed % 7 == 0:  # coincident / non-finite / exactly planar inputs
        T[seed % 3] = T[(seed + 1) % 3] if seed % 2 else T[seed % 3]
        T[0, 0, 3] = [np.nan, np.inf, T[0, 0, 3]][seed % 3]
    assert repr(fused(T)) == repr(bennett_core(T))


# ------------------------------------------------------------------ small-sample checks
def _evaluate_small_reference(linkage, samples):
    """The former synth.checks._evaluate_small (every pose and t = inf evaluated)."""
    from synth.checks import _pose_dq
    from synth.algebra.scalar import dq_mul, dq_translation

    joints = linkage.joints
    slot = {"base": 0}
    for j in joints:
        slot.setdefault(j.child, len(slot))
    chain = [(slot[j.parent], slot[j.child], j.direction.tolist(), j.moment.tolist()) for j in joints]
    identity = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def fk(cs):
        disp = [identity] * len(slot)
        for (p, ch, u, m), (c, s) in zip(chain, cs):
            G = (c, s * u[0], s * u[1], s * u[2], 0.0, -s * m[0], -s * m[1], -s * m[2])
            disp[ch] = G if p == 0 else dq_mul(disp[p], G)
        return disp

    def diff(A, B):
        dA, dB = dq_translation(A), dq_translation(B)
        dt = math.sqrt((dA[0] - dB[0]) ** 2 + (dA[1] - dB[1]) ** 2 + (dA[2] - dB[2]) ** 2)
        a0, a1, a2, a3 = A[0], -A[1], -A[2], -A[3]
        b0, b1, b2, b3 = B[0], B[1], B[2], B[3]
        e0 = a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3
        e1 = a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2
        e2 = a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1
        e3 = a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0
        return dt, 2.0 * math.atan2(math.sqrt(e1 * e1 + e2 * e2 + e3 * e3), abs(e0))

    tool = slot[linkage.tool_link]
    pt = pr = 0.0
    Href = _pose_dq(linkage.tool_ref)
    for rec in linkage.poses:
        cs = [(math.cos(0.5 * rec.joint_angles[j.name]), math.sin(0.5 * rec.joint_angles[j.name])) for j in joints]
        dt, dr = diff(dq_mul(fk(cs)[tool], Href), _pose_dq(rec.matrix))
        pt, pr = max(pt, dt), max(pr, dr)
    a, b = [j.a for j in joints], [j.b for j in joints]
    centre, scale = sum(a) / len(a), max(sum(b) / len(b), 1e-12)
    ts = [centre + scale * math.tan(-math.pi / 2 + math.pi * (k + 1) / samples) for k in range(samples - 1)]
    C = linkage.motion.tolist()
    ct = cr = me = 0.0
    for t in ts + [math.inf]:
        if t == math.inf:
            cs, Ct = [(1.0, 0.0)] * len(joints), C[-1]
        else:
            cs = [((t - aj) / math.hypot(t - aj, bj), bj / math.hypot(t - aj, bj)) for aj, bj in zip(a, b)]
            Ct = C[-1]
            for row in C[-2::-1]:
                Ct = [x * t + y for x, y in zip(Ct, row)]
        disp = fk(cs)
        for x, y in linkage.closures:
            dt, dr = diff(disp[slot[x]], disp[slot[y]])
            ct, cr = max(ct, dt), max(cr, dr)
        dt, dr = diff(disp[tool], Ct)
        me = max(me, dt + dr)
    return (pt, pr), (ct, cr), me


@pytest.mark.parametrize("samples", [1, 2, 4, 32])
def test_small_sample_checks_equal_the_former_ones(samples):
    from synth.checks import _evaluate_small

    rng = np.random.default_rng(samples)
    for k in range(30):
        lk = eager(random_poses(rng, 3), samples)[0]
        if k % 3 == 1:  # a non-monic motion: t = inf is checked
            lk.motion = lk.motion * 1.5
        if k % 3 == 2:  # the tool frame off pose 0, where every angle is 0: the pose error is not 0
            lk.tool_ref = lk.tool_ref @ thg.small_motion(rng, 1e-3)
        assert repr(_evaluate_small(lk, samples)) == repr(_evaluate_small_reference(lk, samples))


def test_small_sample_checks_equal_the_former_ones_6r():
    from synth.checks import _evaluate_small

    rng = np.random.default_rng(9)
    done = 0
    while done < 3:
        try:
            lk = synth.sixbar(random_poses(rng, 4))
        except SynthesisError:
            continue
        done += 1
        for samples in (4, 32):
            assert repr(_evaluate_small(lk, samples)) == repr(_evaluate_small_reference(lk, samples))
