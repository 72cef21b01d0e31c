"""The design search's evaluation kept exact while made cheaper (issue 36): every shortcut gives the numbers
of the plain formulation bit for bit, so the search's choices cannot change (synth.design.coordinate's
critical entries, synth.design.search.Layout's offsets, synth.io.solid.weld). (The segment distance's
rewrite is held to the smallest distance of points and to worked numbers in test_design_search.py.)"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import REPO
from synth.design.collision import body_paths, speed_coefficients
from synth.design.coordinate import FULL, Scorer, _Critical
from synth.design.search import Layout, initial_stacks, resolved_sizes
from synth.io.poses import load_poses
from synth.io.solid import capsule, concatenate, cylinder, weld
from synth.synthesis.bennett import bennett


class PlainCritical:
    """The critical entries as an ordered dict (least recently seen first): the reference of `_Critical`."""

    def __init__(self, mask, cap):
        self.mask, self.cap, self.keys = mask, cap, {}

    def add(self, d):
        dm = np.where(self.mask[None, None, :], d, np.inf)
        k = dm.argmin(axis=2)
        flat = dm.reshape(len(d), -1)
        top = np.argpartition(flat, min(16, flat.shape[1] - 1), axis=1)[:, :16]
        new = [(p, int(x)) for row in k for p, x in enumerate(row)]
        new += [divmod(int(x), d.shape[2]) for row in top for x in row]
        for key in new:
            self.keys.pop(key, None)
            self.keys[key] = None
        while len(self.keys) > self.cap:
            self.keys.pop(next(iter(self.keys)))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(1, 5), st.integers(1, 7), st.integers(2, 30), st.integers(4, 200))
def test_critical_entries_keep_the_order_of_the_plain_bookkeeping(seed, n, P, K, cap):
    rng = np.random.default_rng(seed)
    mask = rng.random(K) < 0.7
    mask[0] = True
    fast, plain = _Critical(mask, cap), PlainCritical(mask, cap)
    for _ in range(4):
        d = np.round(rng.normal(size=(n, P, K)), 1)  # ties too
        fast.add(d)
        plain.add(d)
        p, k = fast.arrays()
        assert list(zip(p.tolist(), k.tolist())) == list(plain.keys)


@pytest.fixture(scope="module")
def layout():
    lk = bennett(load_poses(REPO / "fixtures" / "bennett_mm_deg.yaml").matrices)
    e = lk.extent()
    sizes = resolved_sizes(0.02 * e, 0.015 * e, 0.06 * e, 0.002 * e)
    return Layout(lk, merged=True, **sizes), Layout(lk, merged=False, **sizes)


def test_layout_offsets_are_the_per_joint_formulas(layout):
    """Mount offsets c + sigma (k - (n - 1) / 2) g per mount and end offsets (mount, lowest or highest
    mount of the joint, crank offset, plus a constant) per end, as the loops over joints wrote them."""
    rng = np.random.default_rng(5)
    for lay in layout:
        J = len(lay.joints)
        c, sigma, g = rng.normal(size=(6, J)), rng.choice([-1.0, 1.0], size=(6, J)), rng.random((6, J)) + 0.1
        S = lay.mount_offsets(c, sigma, g)
        for ji, j in enumerate(lay.joints):
            links = lay.links_of[j]
            for k, link in enumerate(links):
                want = c[:, ji] + sigma[:, ji] * (k - (len(links) - 1) / 2) * g[:, ji]
                assert np.array_equal(S[:, lay.mindex[(link, j)]], want)
        E = lay.end_offsets(S)
        lo = np.stack([S[:, [lay.mindex[(l, j)] for l in lay.links_of[j]]].min(axis=1) for j in lay.joints], 1)
        hi = np.stack([S[:, [lay.mindex[(l, j)] for l in lay.links_of[j]]].max(axis=1) for j in lay.joints], 1)
        for e, (kind, index, const) in enumerate(lay.ends):
            assert np.array_equal(E[:, e], (S, lo, hi)[kind][:, index] + const)
        assert {kind for kind, _, _ in lay.ends} == {0, 1, 2}  # mounts, lowest and highest of a stack


def test_grid_is_at_at_every_entry(layout):
    """`Scorer.grid` (whole blocks of samples) gives `Scorer.at`'s numbers at every pair and the chosen
    samples, bit for bit, and charges as much (the start screen of `design_linkage`)."""
    search = layout[0]
    J = len(search.joints)
    e = search.linkage.extent()
    scorer = Scorer(search, 12 * J, 6 * J, FULL, lambda X: search.end_offsets(
        search.mount_offsets(X[:, :J], X[:, J:2 * J], X[:, 2 * J:])), settled=1e-3)
    assert scorer.once.any() and (~scorer.once).any()
    X = initial_stacks(np.random.default_rng(2), J, 40, search.gap_min, e)
    K, P = len(scorer.phis), len(search.cs.pairs)
    for step in (1, 3, 5):
        samples = np.flatnonzero((np.arange(K) % step == 0) | (np.arange(K) == scorer.once_k))
        pidx, kidx = np.nonzero(np.ones((P, K), bool) & np.isin(np.arange(K), samples)[None])
        w0 = scorer.work.done
        plain = scorer.at(X, pidx, kidx).reshape(len(X), P, -1)
        w1 = scorer.work.done
        fast = scorer.grid(X, samples)
        assert np.array_equal(plain, fast) and scorer.work.done - w1 == w1 - w0


def test_weld_is_numpys_unique_rows():
    """`weld` (one lexsort) gives np.unique(rows)'s vertices and indices; -0.0 and 0.0 are one vertex."""
    mesh = concatenate([capsule(np.zeros(3), np.array([0.3, -0.2, 0.1]), 0.05, 32),
                        cylinder(np.zeros(3), np.array([0.0, 0.0, 0.2]), 0.07, 48)])
    for dtype in (np.float32, np.float64):
        tri = mesh.triangles.astype(dtype)
        tri[0, 0] = [0.0, 0.0, 0.0]
        tri[1, 1] = [-0.0, 0.0, -0.0]
        got = weld(tri)
        corners = np.ascontiguousarray(tri.reshape(-1, 3) + dtype(0.0))
        vertices, index = np.unique(corners, axis=0, return_inverse=True)
        assert np.array_equal(got.vertices, vertices.astype(np.float64))
        assert np.array_equal(got.faces, index.reshape(-1, 3))
        assert got.faces[0, 0] == got.faces[1, 1]


def plain_speed_coefficients(linkage, cs, offsets, sites) -> list[np.ndarray]:
    """`speed_coefficients` pair by pair and path by path: its reference."""
    jindex = {j.name: i for i, j in enumerate(linkage.joints)}
    P, J = len(cs.pairs), len(linkage.joints)
    pts = cs.ends_base + np.asarray(offsets, float)[:, None] * cs.ends_dir
    S = np.array([sites[j.name] for j in linkage.joints])
    w = pts[:, None] - S[None]
    u = np.array([j.direction for j in linkage.joints])
    reach = np.linalg.norm(w, axis=2)
    off_axis = np.sqrt(np.maximum(reach ** 2 - np.einsum("ejk,jk->ej", w, u) ** 2, 0.0))
    per_pair = [[] for _ in range(P)]
    for p, (a0, a1, b0, b1) in enumerate(cs.pairs):
        A, B = cs.body_pairs[cs.body_pair[p]]
        if cs.axial is not None and cs.axial[p, 0]:
            per_pair[p].append(np.zeros(J))
            continue
        for src, (e0, e1), dst in ((A, (b0, b1), B), (B, (a0, a1), A)):
            for path in body_paths(linkage, src, dst):
                if not path:
                    continue
                coef = np.zeros(J)
                last = jindex[path[-1]]
                acc = max(reach[e0, last], reach[e1, last])
                coef[last] = max(off_axis[e0, last], off_axis[e1, last])
                for i in range(len(path) - 2, -1, -1):
                    acc += np.linalg.norm(sites[path[i + 1]] - sites[path[i]])
                    coef[jindex[path[i]]] = acc
                per_pair[p].append(coef)
        if not per_pair[p]:
            per_pair[p].append(np.full(J, 1e300))
    width = max(len(c) for c in per_pair)
    return [np.array([c[min(k, len(c) - 1)] for c in per_pair]) for k in range(width)]


@pytest.mark.parametrize("fixture", ["bennett_mm_deg.yaml", "sixbar_example.yaml"])
def test_speed_coefficients_are_the_plain_path_by_path_bound(fixture):
    """The certificate's speed bounds with the paths found once per capsule set: the plain numbers, bit for
    bit, for several designs of one capsule set (the cached paths do not depend on the design)."""
    from synth.synthesis.sixbar import sixbar
    T = load_poses(REPO / "fixtures" / fixture).matrices
    lk = bennett(T) if fixture.startswith("bennett") else sixbar(T)
    e = lk.extent()
    rng = np.random.default_rng(3)
    for merged in (False, True):
        cs = Layout(lk, merged=merged, **resolved_sizes(0.02 * e, 0.015 * e, 0.06 * e)).cs
        for _ in range(3):
            off = rng.normal(size=len(cs.ends_base)) * e * 0.2
            fast, plain = speed_coefficients(lk, cs, off, lk.joint_sites()), plain_speed_coefficients(
                lk, cs, off, lk.joint_sites())
            assert len(fast) == len(plain)
            for a, b in zip(fast, plain):
                assert a.shape == b.shape and np.array_equal(a, b)


def test_joint_sites_follow_a_changed_axis():
    """`Linkage.joint_sites` is remembered for the same axes only: a moved axis gives its new sites."""
    lk = bennett(load_poses(REPO / "fixtures" / "bennett_mm_deg.yaml").matrices)
    before = lk.joint_sites()
    before["h1"][:] = 7.0  # the caller's copy: not the remembered sites
    assert not np.allclose(lk.joint_sites()["h1"], 7.0)
    j = lk.joints[1]
    j.moment = j.moment + np.cross(j.direction, [0.0, 0.0, 0.1])  # the axis shifted
    fresh = type(lk)(**{f: getattr(lk, f) for f in lk.__dataclass_fields__})
    assert all(np.array_equal(a, b) for a, b in zip(lk.joint_sites().values(), fresh.joint_sites().values()))


@pytest.mark.parametrize("P", [1, 2, 7, None])
def test_gaps_by_kind_are_the_per_element_selection(layout, P):
    """`collision._gaps` takes each kind's pairs as whole rows along the pairs' axis: the numbers of the
    plain per-element selection, bit for bit, for the full grid (pairs x samples) and for chosen entries,
    in single and double precision, with one pair too."""
    from synth.design.collision import _gaps, axial_distance, legs_distance, segment_distance

    def plain(cs, pts, rows, radii):
        kind = np.broadcast_to(cs.axial[rows, 0], pts[0].shape[1:])
        d = np.empty(kind.shape, pts[0].dtype)
        for group in ((0,), (1, 2), (3,)):
            sel = np.nonzero(np.isin(kind, group))
            if not len(sel[0]):
                continue
            p0, p1, q0, q1 = (p[(slice(None),) + sel] for p in pts)
            if group == (0,):
                d[sel] = segment_distance(p0, p1, q0, q1)
            elif group == (3,):
                d[sel] = legs_distance(p0, p1, q0, q1)
            else:
                a_hub = kind[sel] == 1
                rad = np.broadcast_to(cs.axial[rows, 1], kind.shape)[sel].astype(d.dtype)
                d[sel] = axial_distance(np.where(a_hub, q0, p0), np.where(a_hub, q1, p1), np.where(a_hub, p0, q0),
                                        np.where(a_hub, p1, q1), rad)
        return d - radii

    cs = layout[1].cs
    rng = np.random.default_rng(P or 0)
    for dtype in (np.float32, np.float64):
        rows = np.arange(len(cs.pairs)) if P is None else rng.choice(len(cs.pairs), P, replace=P > len(cs.pairs))
        grid = [rng.normal(size=(3, 2, len(rows), 5)).astype(dtype) for _ in range(4)]
        r = rows[None, :, None]
        assert np.array_equal(_gaps(cs, grid, r, cs.radii[r]), plain(cs, grid, r, cs.radii[r]))
        entries = [rng.normal(size=(3, 3, len(rows))).astype(dtype) for _ in range(4)]
        assert np.array_equal(_gaps(cs, entries, rows[None], cs.radii[rows][None]),
                              plain(cs, entries, rows[None], cs.radii[rows][None]))
