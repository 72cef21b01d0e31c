"""synth.io.bounded: a build whose attempt does not return is ended at its CPU limit in a forked child,
the attempt banned and the next one tried (OpenCASCADE's fuse of motion_darboux's link_k4 never returned)."""
from __future__ import annotations

import os

import pytest

from synth.io.bounded import Hung, bounded_build

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")


def _build(parts, *, banned, trying):
    """Each part's first construction that is not banned; construction 0 of "b" spins for ever."""
    out = []
    for part in parts:
        for k in range(3):
            if (part, k) in banned:
                continue
            trying((part, k))
            if (part, k) == ("b", 0):
                while True:  # a kernel call that never returns
                    pass
            out.append((part, k))
            break
    return out


def test_an_attempt_that_does_not_return_is_banned_and_the_next_one_taken():
    assert bounded_build(_build, ["a", "b", "c"], cpu_seconds=1) == [("a", 0), ("b", 1), ("c", 0)]
    assert bounded_build(_build, ["a", "c"], cpu_seconds=1) == [("a", 0), ("c", 0)]  # nothing hangs: one child


def test_every_child_hung():
    with pytest.raises(Hung) as e:
        bounded_build(_build, ["b"], cpu_seconds=1, rounds=1)
    assert e.value.banned == {("b", 0)} and "did not return" in str(e.value)


def test_an_error_of_the_build_is_raised_again():
    def fails(*, banned, trying):
        raise RuntimeError("the B-rep booleans gave volumes none")

    with pytest.raises(RuntimeError, match="gave volumes none"):
        bounded_build(fails)
