"""Bounds of the physical-design sizes against the linkage's size: one check for the CLI options, the
batch job fields and the library writer.

Sizes are metres; ``extent`` is `Linkage.extent()` (metres). A part outside ``SIZE_RANGE`` times the
extent cannot be built (``--pin-length 1e300`` was a 1e297 m mesh, ``link_radius 1e-300`` two disconnected
hubs, ``pin_radius 1e8`` mm a failed check); clearances may be 0 but not above the upper bound. A
linkage smaller than ``MIN_EXTENT`` has parts below what the mesh tolerances resolve (non-watertight
meshes) and is refused as a whole.
"""
from __future__ import annotations

import math

from synth.errors import InputError

SIZE_RANGE = (1e-6, 10.0)  # explicit part sizes relative to the extent
MIN_EXTENT = 1e-5  # metres (10 µm): the smallest linkage whose meshes are built
EXTENT_FACTOR = 100.0  # default --max-extent: this many times the task's spread (`synth.design.constraints`)
SIZE_KEYS = ("pin_radius", "link_radius", "pin_length")
CLEARANCE_KEYS = ("clearance", "hole_clearance")


def option_label(key: str) -> str:
    """The command-line spelling of a size key (``--pin-radius``)."""
    return "--" + key.replace("_", "-")


def check_extent(extent: float, *, scale: float = 1.0, unit: str = "m") -> None:
    """InputError when a linkage of size ``extent`` (metres) is too small to be built as meshes."""
    if not extent >= MIN_EXTENT:
        raise InputError(f"the linkage's size is {extent / scale:.3g} {unit}, below the {MIN_EXTENT / scale:.3g} "
                         f"{unit} whose parts can be meshed; give the poses in their real unit (units.length)")


def check_sizes(sizes: dict, extent: float, *, scale: float = 1.0, unit: str = "m", label=option_label) -> None:
    """InputError (one line, values in ``unit``: metres / ``scale``) for a size in ``sizes`` (metres;
    keys of SIZE_KEYS and CLEARANCE_KEYS, None = the default) that is not finite or is absurd for a
    linkage of size ``extent``; also `check_extent`. ``label(key)``: how the message names a key."""
    check_extent(extent, scale=scale, unit=unit)
    lo, hi = SIZE_RANGE
    for key, v in sizes.items():
        if v is None or key in ("slenderness", "pin_fit"):  # a ratio and a choice, not sizes
            continue
        shown = f"{label(key)} {v / scale:.6g} {unit}"
        if key in CLEARANCE_KEYS:
            if not (math.isfinite(v) and 0 <= v <= hi * extent):
                raise InputError(f"{shown} is out of range for a linkage of size {extent / scale:.3g} {unit}: "
                                 f"give a value between 0 and {hi * extent / scale:.3g} {unit}")
            continue
        if key not in SIZE_KEYS:
            raise InputError(f"{label(key)}: not a size (sizes: {', '.join(SIZE_KEYS + CLEARANCE_KEYS)})")
        if not (math.isfinite(v) and lo * extent <= v <= hi * extent):
            raise InputError(f"{shown} is out of range for a linkage of size {extent / scale:.3g} {unit}: give a "
                             f"value between {lo * extent / scale:.3g} and {hi * extent / scale:.3g} {unit}")
