"""Volume overlap of the written solids (issue 33, bench/bench_overlap.py): the measurement on worked
numbers; links that share a joint keep apart in the search (`synth.design.search.tested`) and in the
solids written (fixtures/bennett_mm_deg.yaml's design, fixtures/bennett_fit.yaml's output)."""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

from synth.io.solid import box, capsule

REPO = Path(__file__).resolve().parents[1]


def _bench():
    spec = importlib.util.spec_from_file_location("bench_overlap", REPO / "bench" / "bench_overlap.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _mesh(solid):
    return solid.vertices, solid.faces


def test_intersection_volume_of_boxes_and_balls():
    iv = _bench().intersection_volume
    # two 2 x 2 x 2 cubes, shifted by 0.5 along x: overlap 1.5 x 2 x 2 = 6
    edges = [(1.0, 0, 0), (0, 1.0, 0)]
    a = box((0, 0, -1), (0, 0, 1), edges)
    b = box((0.5, 0, -1), (0.5, 0, 1), edges)
    assert iv(_mesh(a), _mesh(b)) == pytest.approx(6.0, rel=1e-9)
    # apart: nothing
    c = box((3, 0, -1), (3, 0, 1), edges)
    assert iv(_mesh(a), _mesh(c)) == 0.0
    # two balls of radius R with centres d apart: the lens pi (4R + d)(2R - d)^2 / 12 (faceted: 2 %)
    R, d = 1.0, 1.2
    p = capsule((0, 0, 0), (0, 0, 0), R, 96)
    q = capsule((d, 0, 0), (d, 0, 0), R, 96)
    lens = math.pi * (4 * R + d) * (2 * R - d) ** 2 / 12
    assert iv(_mesh(p), _mesh(q)) == pytest.approx(lens, rel=0.02)


def _world_solids(lk, design) -> tuple[dict, dict]:
    """({link: solid}, {joint: pin solid}) of a design at the reference configuration (world frame)."""
    from synth.io.meshes import link_parts, pin_primitives, primitive_solid
    from synth.io.solid import boolean

    links = {}
    for name, joints in lk.links.items():
        if joints:
            parts, bores = link_parts(lk, design, name)
            links[name] = boolean(parts, bores)
    pins = {p.joint: boolean([primitive_solid(q) for q in pin_primitives(lk, design, p.joint)]) for p in design.pins}
    return links, pins


def test_links_sharing_a_joint_keep_apart_in_the_design():
    """fixtures/bennett_mm_deg.yaml: a bar thicker than half its hub (R 7.5 mm, hub length 12.2 mm) holds
    the bore in its round end, so the two mounts of a joint are at least 2R + clearance apart, and no
    two links or a pin and the link turning on it overlap (main before the fix: 9.4 mm^3 for two links,
    4.1 for a pin in its bore); a pressed pin only by its interference."""
    from synth.design.choose import design_for
    from synth.design.collision import adjacent_pairs
    from synth.design.model import joint_links
    from synth.io.meshes import PRESS_INTERFERENCE
    from synth.io.poses import load_poses
    from synth.io.solid import intersection_volume
    from synth.synthesis.bennett import bennett

    lk = bennett(load_poses(REPO / "fixtures" / "bennett_mm_deg.yaml").matrices)
    result = design_for(lk)
    d = result.design
    assert result.collision.free and result.collision.range == "full"
    assert 2 * d.bar_radius > d.hub_length  # the case of the round ends
    for j, (a, b) in ((j, ls) for j, ls in joint_links(lk).items() if len(ls) == 2):
        assert abs(d.mount(a, j).offset - d.mount(b, j).offset) >= 2 * d.bar_radius + d.clearance - 1e-12
    links, pins = _world_solids(lk, d)
    mm3 = 1e-9
    for pair in adjacent_pairs(lk):
        a, b = sorted(pair)
        assert intersection_volume(links[a], links[b]) < 1e-3 * mm3, (a, b)
    press = min(PRESS_INTERFERENCE, 0.02 * d.pin_radius)
    for p in d.pins:
        turning = next(n for n in joint_links(lk)[p.joint] if n != p.carrier)
        assert intersection_volume(pins[p.joint], links[turning]) < 1e-3 * mm3, p.joint
        fit = 2 * math.pi * d.pin_radius * press * (d.hub_length + 2 * d.bar_radius)  # the hub and the round end
        assert 0 < intersection_volume(pins[p.joint], links[p.carrier]) < fit, p.joint


@pytest.mark.slow
def test_links_sharing_a_joint_do_not_overlap(tmp_path):
    from tests.conftest import run

    out = tmp_path / "out"
    r = run("bennett", REPO / "fixtures" / "bennett_fit.yaml", "-o", out, "-q")
    assert r.exit_code == 0, r.stderr
    rows = _bench().overlaps(out)
    assert rows, "no pair of parts measured"
    worst = max((v for kind, _, _, v in rows if kind != "press"), default=0.0)
    assert worst < 1.0, rows


def test_axial_distance_of_a_leg_and_a_hub_worked_numbers():
    """`collision.axial_distance`: a leg from the axis against a hub (cylinder of radius 2 around z in
    [-1, 1]): square to the axis at height 3, 2 from the face; leaning down from (0, 3) to (r, z) = (4, 0),
    0.4 from the rim corner (2, 1) ((3 * 2 + 4 * 1 - 12) / 5); through the hub, or from inside it, 0; the
    same whatever the leg's turn about the axis."""
    import numpy as np

    from synth.design.collision import axial_distance

    def ax(p0, p1):
        return float(axial_distance(np.array(p0, float), np.array(p1, float), np.array([0.0, 0, -1]),
                                    np.array([0.0, 0, 1]), 2.0))

    assert ax((0, 0, 3), (5, 0, 3)) == pytest.approx(2.0)
    for c, s in ((1, 0), (0, 1), (-0.6, 0.8)):
        assert ax((0, 0, 3), (4 * c, 4 * s, 0)) == pytest.approx(0.4)
    assert ax((0, 0, 3), (0, 4, -3)) == 0.0
    assert ax((0, 0, 0.5), (0, 4, 3)) == 0.0


def test_legs_distance_is_the_least_over_every_turn_worked_numbers():
    """`collision.legs_distance`: two legs leaving the z axis at heights 0 and 3; square to it: 3; the
    second leaning down to (r, z) = (4, 1): 1 (its end over the first leg's end), the 3D distance of the
    legs at every turn of the second about the axis at least that and equal at the aligned turn; leaning
    through the first leg's height inside its reach: 0."""
    import numpy as np

    from synth.design.collision import legs_distance, segment_distance

    def legs(p1, q1):
        return [np.array(p, float)[:, None] for p in ((0, 0, 0), p1, (0, 0, 3), q1)]  # (3, 1)

    assert legs_distance(*legs((4, 0, 0), (0, 4, 3)))[0] == pytest.approx(3.0)
    assert legs_distance(*legs((4, 0, 0), (0, 4, 1)))[0] == pytest.approx(1.0)
    turns = np.linspace(0, 2 * np.pi, 73)
    q1 = np.stack([4 * np.cos(turns), 4 * np.sin(turns), np.ones_like(turns)])
    p0, p1, q0 = (np.array(p, float)[:, None] for p in ((0, 0, 0), (4, 0, 0), (0, 0, 3)))
    d3 = segment_distance(p0, p1, q0, q1)
    assert d3.min() == pytest.approx(1.0) and (d3 >= 1.0 - 1e-12).all()
    assert legs_distance(*legs((4, 0, 0), (3, 0, -1)))[0] == pytest.approx(0.0, abs=1e-12)


def test_axial_pairs_do_not_change_with_the_motion_and_need_no_speed_bound():
    """The pairs of `CapsuleSet.axial` (two links' parts about the axis they share: a leg against the
    neighbour's hub, two legs) have the same gap at every sample of the cycle, for any mount offsets, so
    the certificate bounds their speed by 0 (`collision.speed_coefficients`); most other pairs move."""
    import numpy as np

    from synth.design.collision import _dist_at, speed_coefficients
    from synth.design.sampling import even_samples
    from synth.design.search import Layout, resolved_sizes
    from synth.io.poses import load_poses
    from synth.synthesis.bennett import bennett

    lk = bennett(load_poses(REPO / "fixtures" / "bennett_mm_deg.yaml").matrices)
    e = lk.extent()
    layout = Layout(lk, merged=False, **resolved_sizes(0.02 * e, 0.03 * e, 0.06 * e, 0.001 * e))
    kinds = layout.cs.axial[:, 0]
    assert sorted(set(kinds.astype(int))) == [0, 1, 2, 3]
    rng = np.random.default_rng(1)
    phis = even_samples(lk, -np.pi / 2, np.pi / 2, 40)
    for S in (layout.natural_offsets(), layout.natural_offsets() + rng.normal(0, 0.1 * e, len(layout.mounts))):
        offsets = layout.end_offsets(S[None])[0]
        d = _dist_at(lk, layout.cs, offsets, phis)
        spread = d.max(axis=1) - d.min(axis=1)
        assert spread[kinds > 0].max() < 1e-9 * e
        assert (spread[kinds == 0] > 1e-3 * e).sum() > len(spread) / 2  # most of the others move
        coef = speed_coefficients(lk, layout.cs, offsets, lk.joint_sites())
        assert all((c[kinds > 0] == 0).all() and (c[kinds == 0].sum(axis=1) > 0).all() for c in coef)


def test_only_the_leading_feasible_starts_move_on():
    """`coordinate._behind`: nothing is held back while no start is feasible (scores <= 0); once one is
    (score 1e6 - size), the feasible starts more than `BEHIND` times its size stop, the rest move on."""
    import numpy as np

    from synth.design.coordinate import BEHIND, _behind

    assert not _behind(np.array([-0.3, -0.1, -2.0])).any()
    best = 1e6 - np.array([0.2, 0.2 * BEHIND * 1.01, 0.2 * BEHIND * 0.99])
    assert _behind(np.append(best, -0.5)).tolist() == [False, True, False, False]
