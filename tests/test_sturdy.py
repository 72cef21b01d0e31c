"""Parts sized to be built (issue 33): bar slenderness and bore walls, worked numbers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from synth.design.choose import LINK_RADIUS, default_sizes, design_for
from synth.design.model import MIN_WALL, hub_radius_for
from synth.design.sturdy import SLENDERNESS, bar_lengths, bar_radius_for, slenderness_of
from synth.errors import InputError
from synth.synthesis.bennett import bennett

from test_design_thin import THIN, linkage  # noqa: F401  (the module fixture)


def test_hub_wall_is_at_least_1_2_mm_for_printable_pins():
    # pin 3 mm, clearance 0.2 mm: half a pin radius (1.5 mm) is over the 1.2 mm minimum
    assert hub_radius_for(3e-3, 1e-3, 2e-4) == pytest.approx(3e-3 + 2e-4 + 1.5e-3)
    # pin 1 mm: half a radius (0.5 mm) is too thin, the wall is 1.2 mm
    assert hub_radius_for(1e-3, 1e-4, 1e-4) == pytest.approx(1e-3 + 1e-4 + MIN_WALL)
    # a 0.1 mm pin (a linkage too small to print): the wall is at most the pin's diameter
    assert hub_radius_for(1e-4, 1e-5, 0.0) == pytest.approx(1e-4 + 2e-4)


def test_bar_radius_follows_the_longest_bar(linkage):  # noqa: F811
    lengths = bar_lengths(linkage)
    assert lengths.shape == (4,) and np.all(lengths > 0)  # Bennett: four links, one bar each
    r = bar_radius_for(linkage, 0.0)
    assert r == pytest.approx(lengths.max() / 50)
    assert slenderness_of(linkage, r) == pytest.approx(SLENDERNESS)
    assert bar_radius_for(linkage, 10 * r) == 10 * r  # a thicker bar is kept
    assert bar_radius_for(linkage, 0.0, 10.0) == pytest.approx(lengths.max() / 20)


def test_default_sizes_respect_the_slenderness(linkage):  # noqa: F811
    bar = default_sizes(linkage)[1]
    assert bar == pytest.approx(max(LINK_RADIUS * linkage.extent(), bar_lengths(linkage).max() / 50))
    assert slenderness_of(linkage, bar) <= SLENDERNESS + 1e-9
    assert default_sizes(linkage, link_radius=1e-3)[1] == 1e-3  # explicit radii are kept
    with pytest.raises(InputError, match="slenderness"):
        design_for(linkage, slenderness=-1.0)
    with pytest.raises(InputError, match="slenderness"):
        design_for(linkage, slenderness=math.nan)
