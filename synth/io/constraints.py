"""The ``constraints:`` key of a task file (../shared/docs/OUTPUT.md, "Additions (turn 3)").

Placeholder hook: the "drive" work parses ``base``, ``envelope`` and ``max_speed_ratio`` into
`synth.task.Constraints` here; until then the key is accepted and ignored (None).
"""
from __future__ import annotations

from typing import Any

from synth.task import Constraints

__all__ = ["parse_constraints"]


def parse_constraints(value: Any, *, source: str, length_scale: float) -> Constraints | None:
    """`synth.task.Constraints` of a task file's ``constraints:`` value (None when absent)."""
    return None
