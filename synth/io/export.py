"""The output formats of a finished design, keyed by format (as trimesh keys its exporters): each exporter
writes its files of one linkage into a directory and returns their paths relative to it.

An exporter is ``write(job: ExportJob, directory: Path) -> list[Path]``; adding an output format is one
module with such a function and one line in `EXPORTERS`. Exporters are pure: they write the design they
are given (`synth.design.model.DesignResult`, made by `synth.design.choose.design_for`) and search nothing.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from synth.design.model import DesignResult
from synth.io import jsonout, meshes, step, urdf
from synth.io.names import check_package, check_robot_name


@dataclass
class ExportJob:
    """One linkage and its finished design, with what several formats share: the solids (each in its
    link frame, metres), their masses and the STL files' origins (computed once, on first use)."""

    linkage: object
    result: DesignResult | None  # None: kinematic outputs only (linkage.json, a URDF without meshes)
    robot_name: str
    package: str | None = None
    formats: tuple | None = None  # the formats written (keys of `EXPORTERS`; None: all)
    _solids: dict | None = field(default=None, repr=False)
    _masses: dict | None = field(default=None, repr=False)
    _step: tuple | None = field(default=None, repr=False)

    @property
    def solids(self) -> dict:
        """{URDF link: Solid} (`meshes.design_solids`)."""
        if self._solids is None:
            self._solids = meshes.design_solids(self.linkage, self.result.design)
        return self._solids

    @property
    def masses(self) -> dict:
        """{URDF link: (mass kg, centre of mass (3,), inertia 3x3)} of the solids (`meshes.mesh_inertials`)."""
        if self._masses is None:
            self._masses = meshes.mesh_inertials(self.solids)
        return self._masses

    @property
    def step(self) -> str | None:
        """The linkage.step text, or None when it is not written (`step.built_step`; built once)."""
        if self._step is None:
            self._step = (step.built_step(self) if "step" in (EXPORTERS if self.formats is None else self.formats) else None,)
        return self._step[0]

    @property
    def mesh_offsets(self) -> dict:
        """{URDF link: (3,) origin of its STL file in the link frame} (`meshes.stl_offset`)."""
        return {name: meshes.stl_offset(mesh) for name, mesh in self.solids.items()}


EXPORTERS = {
    "urdf": urdf.write_urdf,  # linkage.urdf
    "json": jsonout.write_linkage_json,  # linkage.json
    "stl": meshes.write_stl,  # meshes/<link>.stl, meshes/pin_<joint>.stl
    "step": step.write_step,  # linkage.step, with the cad extra (gmsh); nothing without it
}


PREPARE = {"step": step.initialise_kernel}  # what a format must do before an output's temporary directory exists


def prepare_formats(formats=tuple(EXPORTERS)) -> None:
    """Run the `PREPARE` steps of ``formats`` (before `export`, outside the atomic write)."""
    for f in formats:
        if f in PREPARE:
            PREPARE[f]()


def export(linkage, result: DesignResult, directory, *, robot_name: str, package: str | None = None,
           formats=tuple(EXPORTERS)) -> list[Path]:
    """Write ``formats`` (keys of `EXPORTERS`) of ``linkage`` with its finished design ``result`` into
    the existing ``directory`` (not atomic: use inside `synth.io.writer.atomic_directory`). Returns the
    paths written, relative to ``directory``."""
    check_robot_name(robot_name)
    check_package(package)
    job = ExportJob(linkage, result, robot_name, package, tuple(formats))
    directory = Path(directory)
    return [p for f in formats for p in EXPORTERS[f](job, directory)]
