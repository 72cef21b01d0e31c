"""No tests here any more (synth.bennett returns a fully computed linkage; see test_bennett.py).
`same_linkage` stays only because tests/test_sixbar_lazy.py (engine-sixbar's) still imports it; it goes
with that file."""
from __future__ import annotations

import json

import numpy as np


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
