"""Pins with a head and a retention feature (`--pin-fit`, synth/io/meshes.py pin_primitives): worked
volumes of the head, the clip groove and the press fit's interference on the shipped Bennett."""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import REPO  # noqa: E402

import synth  # noqa: E402
from synth.design.choose import design_for  # noqa: E402
from synth.design.model import PhysicalDesign  # noqa: E402
from synth.errors import InputError  # noqa: E402
from synth.io import meshes  # noqa: E402
from synth.io.poses import load_poses  # noqa: E402
from synth.io.solid import boolean, signed_volume  # noqa: E402

AREA = 48 / (2 * math.pi) * math.sin(2 * math.pi / 48)  # a 48-gon's area over its circle's


@pytest.fixture(scope="module")
def bennett():
    lk = synth.bennett(load_poses(str(REPO / "fixtures/bennett_mm_deg.yaml")).matrices)
    plain = design_for(lk, pin_fit="plain").design  # with the base's mounting plate (under h1's hub)
    assert plain.mounting is not None
    return lk, plain


def _with(design, fit):
    return PhysicalDesign.from_dict({**design.to_dict(), "pin_fit": fit})


def _pin_volume(lk, design, joint):
    return signed_volume(meshes.pin_solid(lk, design, joint).triangles)


def test_head_and_groove_volumes(bennett):
    lk, plain = bennett
    for joint in ("h1", "k2"):
        v0 = _pin_volume(lk, plain, joint)
        ends = meshes.pin_ends(lk, plain, joint)
        r, t = plain.pin_radius, ends.thickness
        annulus = AREA * math.pi * (ends.head ** 2 - r ** 2) * t  # the head beyond the shaft
        groove = AREA * math.pi * (r ** 2 - (0.8 * r) ** 2) * t / 3
        assert _pin_volume(lk, _with(plain, "press"), joint) - v0 == pytest.approx(annulus, rel=1e-6)
        assert _pin_volume(lk, _with(plain, "clip"), joint) - v0 == pytest.approx(annulus - groove, rel=1e-6)
        assert ends.head > r + plain.hole_clearance  # the head holds on the turning link's face
        assert ends.counterbore < plain.hub_radius  # its counterbore leaves a wall


def _overlap(lk, design, joint, link):
    pin = boolean([meshes.primitive_solid(p) for p in meshes.pin_primitives(lk, design, joint)])
    parts, bores = meshes.link_parts(lk, design, link)
    body = boolean(parts, bores)
    both = boolean([pin, body])  # |A u B| = |A| + |B| - |A n B|
    return signed_volume(pin.triangles) + signed_volume(body.triangles) - signed_volume(both.triangles)


def test_heads_sit_in_counterbores_and_the_press_fit_interferes(bennett):
    """The head adds no overlap with the link it sits on (its counterbore); a press fit overlaps the
    carrier by the interference ring 2 pi r delta times the length of the pin in its bore."""
    lk, plain = bennett
    joint = "h1"
    pin = plain.pin(joint)
    turning = next(m.link for m in plain.mounts if m.joint == joint and m.link != pin.carrier)
    delta = min(meshes.PRESS_INTERFERENCE, 0.02 * plain.pin_radius)
    for fit in ("press", "clip"):
        design = _with(plain, fit)
        assert _overlap(lk, design, joint, turning) == pytest.approx(_overlap(lk, plain, joint, turning),
                                                                     abs=1e-3 * plain.pin_radius ** 3)
    r = plain.pin_radius
    ring = AREA * math.pi * (r ** 2 - (r - delta) ** 2)  # per unit length of the pin in the carrier's bore
    # measured directly, not as press minus plain: a plain pin's facets coincide with its bore's, and the
    # volume of that union is the boolean's rounding (1.6 to 3.8 mm^3 on h1, more with the plate than without:
    # that difference made the ring 0.983 of the hub length "with the plate", 1.12 without; session 32)
    press = _overlap(lk, _with(plain, "press"), joint, pin.carrier)
    # at least along the hub, at most along the whole bore (it runs on through the bar's round end)
    bore = 2 * (1.01 * max(plain.hub_length / 2, plain.bar_radius) + 0.01 * plain.hub_radius)
    assert 0.99 * ring * plain.hub_length <= press <= 1.01 * ring * bore
    bare = dataclasses.replace(_with(plain, "press"), mounting=None)
    assert _overlap(lk, bare, joint, pin.carrier) == pytest.approx(press, rel=1e-4)  # the plate changes nothing


def test_pin_fit_is_recorded_and_checked(bennett):
    lk, plain = bennett
    doc = plain.to_dict()
    assert doc["pin_fit"] == "plain" and _with(plain, "clip").pin_fit == "clip"
    del doc["pin_fit"]
    assert PhysicalDesign.from_dict(doc).pin_fit == "plain"  # written before pins had heads
    with pytest.raises(InputError):
        design_for(lk, pin_fit="glue")


def test_written_pins_and_links_stay_closed_solids(bennett):
    lk, plain = bennett
    for fit in ("press", "clip"):
        for name, solid in meshes.design_solids(lk, _with(plain, fit)).items():
            meshes.stl_file(solid, name)  # raises unless the STL is a closed solid
            assert np.isfinite(signed_volume(solid.triangles))
