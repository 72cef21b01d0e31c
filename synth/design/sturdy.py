"""Parts sized to be built (issue 33): bars no more slender than a limit, walls around bores a printer
can lay down.

- **Slenderness** of a round bar: its length over its diameter. A bar of a link runs between the joint
  sites of two of the link's joints (`synth.linkage.Linkage.joint_sites`, the feet of the common
  normals: the mounts the search starts from); `bar_radius_for` raises the bar radius so the longest bar
  of the linkage is at most ``slenderness`` (default `SLENDERNESS`, 1:25) diameters long.
- **Walls** around a bore: the hub radius is at least bore radius + `MIN_WALL` (1.2 mm, three
  perimeters of a 0.4 mm nozzle), `synth.design.model.hub_radius_for`.

Lengths in metres. The collision search sees the raised radii (they are the design's sizes), so its
capsules bound the solids that are written.
"""
from __future__ import annotations

import numpy as np

SLENDERNESS = 25.0  # longest bar length / bar diameter, at most


def bar_lengths(linkage) -> np.ndarray:
    """Lengths (n,) in metres of the straight bars of ``linkage`` between consecutive joint sites of each
    link (reference configuration); empty for a linkage without bars."""
    sites = linkage.joint_sites()
    pairs = [(a, b) for names in linkage.links.values() for a, b in zip(names, names[1:])]
    if not pairs:
        return np.zeros(0)
    a = np.array([sites[p] for p, _ in pairs])
    b = np.array([sites[q] for _, q in pairs])
    return np.linalg.norm(b - a, axis=-1)


def bar_radius_for(linkage, bar_radius: float, slenderness: float = SLENDERNESS) -> float:
    """The bar radius (metres): ``bar_radius``, raised so that no bar of ``linkage`` (`bar_lengths`) is
    longer than ``slenderness`` times its diameter."""
    lengths = bar_lengths(linkage)
    longest = float(lengths.max()) if lengths.size else 0.0
    return max(float(bar_radius), longest / (2.0 * float(slenderness)))


def slenderness_of(linkage, bar_radius: float) -> float:
    """The largest length / diameter of the bars of ``linkage`` with round bars of ``bar_radius`` (metres)."""
    lengths = bar_lengths(linkage)
    return float(lengths.max() / (2.0 * bar_radius)) if lengths.size else 0.0
