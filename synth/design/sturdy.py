"""Parts sized to be built (issue 33): bars no more slender than a limit, walls around bores a printer
can lay down.

- **Slenderness** of a round bar: its length over its diameter. The rule holds for the bars *as written*
  (`written_slenderness`): a bar's length is that of its centre line (`synth.design.model.bar_polyline`),
  from its mount on one axis through its crank points to its mount on the other, because a cranked bar
  loaded at its ends bends over its whole length, not over the chord between its mounts. Before the search
  the mounts are not known: `bar_radius_for` sizes the bars from the distances of the joint sites
  (`synth.linkage.Linkage.joint_sites`, the feet of the common normals, where the search starts), a lower
  bound; `synth.design.choose.design_for` then raises the radius in counted rounds (`next_radius`) until
  the written bars meet the limit (default `SLENDERNESS`, 1:25), or says by how much they do not.
- **Walls** around a bore: the hub radius is at least bore radius + `MIN_WALL` (1.2 mm, three
  perimeters of a 0.4 mm nozzle), `synth.design.model.hub_radius_for`.

Lengths in metres. The collision search sees the raised radii (they are the design's sizes), so its
capsules bound the solids that are written.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from synth.design.model import bar_polyline

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


def written_bar_lengths(linkage, design) -> np.ndarray:
    """Lengths (n,) in metres of the bars of ``design`` as written, one per ``design.bars``: the length of
    each bar's centre line `bar_polyline` (mount -> crank points -> mount, reference configuration)."""
    sites = linkage.joint_sites()
    return np.array([np.linalg.norm(np.diff(np.array(bar_polyline(linkage, design, b, sites)), axis=0), axis=-1).sum()
                     for b in design.bars])


@dataclass(frozen=True)
class Slenderness:
    """The slenderness of a design's bars as written (`written_slenderness`): the largest length /
    diameter ``ratio``, of the bar of ``link`` between ``joints`` (its written ``length`` and the bar
    ``radius``, metres), against the ``limit``; ``given``: the bar radius was given (``--link-radius``),
    not sized; ``searched``: the thickest bar radius the sizing rounds searched (0: none);
    ``sturdier``: the radius that would meet the limit for these bars."""

    ratio: float
    limit: float
    link: str = ""
    joints: tuple = ()
    length: float = 0.0
    radius: float = 0.0
    given: bool = False
    searched: float = 0.0

    @property
    def met(self) -> bool:
        return self.ratio <= self.limit * (1 + 1e-9)

    @property
    def sturdier(self) -> float:
        return self.length / (2.0 * self.limit)

    def to_dict(self) -> dict:
        return {"ratio": float(self.ratio), "limit": float(self.limit), "met": self.met, "link": self.link,
                "joints": list(self.joints), "length": float(self.length), "radius": float(self.radius),
                "given": self.given, **({} if self.met else {"radius_needed": float(self.sturdier)}),
                **({"radius_searched": float(self.searched)} if self.searched else {})}

    def sentence(self, scale: float = 1.0, unit: str = "m") -> str:
        """The slenderness in words (lengths in ``unit``, metres / ``scale``), and why the limit is not met."""

        def length(x):
            return f"{x / scale:.3g} {unit}"

        where = f"{self.link} {'-'.join(self.joints)}, {length(self.length)} from mount to mount"
        out = f"the most slender bar as written ({where}) is 1:{self.ratio:.1f}"
        if self.met:
            return out + f", within the 1:{self.limit:g} limit"
        why = ("the bar radius was given" if self.given else
               f"the sizing rounds searched bars up to {length(self.searched)} radius: none that met it was as "
               "collision-free" if self.searched else "no thicker bar was searched")
        return out + (f", over the 1:{self.limit:g} limit: a bar radius of {length(self.sturdier)} would meet "
                      f"it ({why})")


def written_slenderness(linkage, design, limit: float = SLENDERNESS, given: bool = False) -> Slenderness:
    """The `Slenderness` of the bars of ``design`` as written (`written_bar_lengths`) against ``limit``;
    ratio 0 for a design without bars."""
    lengths = written_bar_lengths(linkage, design)
    if not lengths.size:
        return Slenderness(0.0, float(limit), radius=design.bar_radius, given=given)
    i = int(np.argmax(lengths))
    bar = design.bars[i]
    return Slenderness(float(lengths[i] / (2.0 * design.bar_radius)), float(limit), bar.link, tuple(bar.joints),
                       float(lengths[i]), float(design.bar_radius), given)


ROUND_MARGIN = 0.01  # the first round aims this fraction thicker than the fixed point it predicts, ...
ROUND_GROWTH = 3.0  # ... each next one this many times that fraction (the searched mounts vary)


def next_radius(tried: list[tuple[float, float]], limit: float = SLENDERNESS) -> float:
    """The bar radius (metres) of the next sizing round from the rounds ``tried`` [(bar radius, longest
    written bar length)] (metres): the fixed point r = L(r) / (2 limit) of the written length L, which
    grows as the thicker bars push the mounts apart; L is taken as linear through the last two rounds
    (secant), constant after the first one or when the secant does not give a larger radius; times
    1 + `ROUND_MARGIN` `ROUND_GROWTH` ** (rounds tried - 1) (the mounts of each search differ, so the
    written length is not a smooth function of the radius), and never below the last radius."""
    r1, l1 = tried[-1]
    r = l1 / (2.0 * limit)
    if len(tried) > 1:
        r0, l0 = tried[-2]
        k = (l1 - l0) / (r1 - r0) if r1 != r0 else 0.0
        if 0.0 < k < 2.0 * limit:
            r = max(r, (l1 - k * r1) / (2.0 * limit - k))
    return max(r * (1.0 + ROUND_MARGIN * ROUND_GROWTH ** (len(tried) - 1)), r1)
