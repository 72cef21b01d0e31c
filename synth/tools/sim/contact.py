"""Contact geometry for ``mpsynth simulate --contacts``: the physical design's capsules.

The engines collide meshes as their convex hulls (the bores filled, a cranked bar's hull spanning its
bend), which is coarser than the parts. linkage.json's ``design`` section gives the geometry the
collision search certified (docs/design.md): every bar segment, hub and pin as a capsule (segment and
radius) that bounds the written solid from outside. With ``--contacts`` the engines collide these
capsules instead (meshes stay for the looks), so a design that is collision-free by its claim runs
without contacts, and a contact means that two bodies' capsules really overlap.
"""
from __future__ import annotations

import json

import numpy as np

from synth.design.model import PhysicalDesign, capsules
from synth.io.readback import linkage_from_document
from synth.io.names import pin_link_name


def contact_capsules(setup) -> dict | None:
    """{URDF link: [(p0 (3,), p1 (3,), radius)]} in each link's frame (metres): the capsules of the design
    in OUT/linkage.json (pins on their own links ``pin_<joint>`` when the URDF has them, else on their
    carrier), or None when linkage.json has no design section."""
    try:
        doc = json.loads((setup.out / "linkage.json").read_text(encoding="utf-8"))
        design = PhysicalDesign.from_dict(doc["design"])
        linkage = linkage_from_document(doc)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    F0 = setup.urdf.fk({})
    out: dict[str, list] = {}
    for c in capsules(linkage, design):
        link = c.link
        if c.part == "pin" and pin_link_name(c.joint) in F0:
            link = pin_link_name(c.joint)
        if link not in F0:
            continue
        inv = np.linalg.inv(F0[link])
        p0, p1 = (inv[:3, :3] @ p + inv[:3, 3] for p in (c.p0, c.p1))
        out.setdefault(link, []).append((p0, p1, float(c.radius)))
    return out
