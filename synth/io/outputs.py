"""What a synthesis writes into an output directory (``mpsynth batch --no-design``, ``--no-step``)."""
from __future__ import annotations

import enum


class Outputs(enum.Enum):
    """What an output directory gets: ``FULL`` the designed linkage's files, every format of
    `synth.io.export.EXPORTERS` (linkage.step with the ``cad`` extra); ``NO_STEP`` the same without
    linkage.step (~0.5 s of CPU for a Bennett linkage, more than the design and the meshes together;
    ``mpsynth export OUT --step`` adds it later); ``KINEMATIC`` no physical design: linkage.json and a URDF
    without meshes."""

    FULL = "full"
    NO_STEP = "no-step"
    KINEMATIC = "kinematic"

    @classmethod
    def chosen(cls, design: bool = True, step: bool = True) -> "Outputs":
        """The outputs of the flags ``--no-design`` (``design`` False: kinematic, whatever ``step``) and
        ``--no-step`` (``step`` False)."""
        return cls.KINEMATIC if not design else cls.FULL if step else cls.NO_STEP

    @property
    def design(self) -> bool:
        """Whether the physical design (the collision-free search, the meshes) is made."""
        return self is not Outputs.KINEMATIC

    @property
    def formats(self) -> tuple:
        """The keys of `synth.io.export.EXPORTERS` written (imported here, not at the top: a batch without
        outputs never loads the exporters)."""
        from synth.io.export import EXPORTERS

        return tuple(f for f in EXPORTERS if not (self is Outputs.NO_STEP and f == "step"))
