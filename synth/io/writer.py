"""Write a linkage's output directory (docs/conventions.md): linkage.urdf, linkage.json, meshes/*.stl,
atomically through `synth.io.atomic` (whole-directory replacement, the manifest as the only proof of
ownership; its names are re-exported here)."""
from __future__ import annotations

from pathlib import Path

from synth.io.atomic import (MARKER, MANIFEST_FORMAT, STALE_AGE, atomic_directory,  # noqa: F401
                             atomic_write, check_file_target, check_output_target, check_path, is_mpsynth_output,
                             owned_files, remove_stale_temporaries)
from synth.io.export import EXPORTERS, export, prepare_formats
from synth.io.jsonout import write_json
from synth.io.names import check_package, check_robot_name


def write_linkage_files(linkage, directory, *, robot_name: str, result, package: str | None = None,
                        formats=tuple(EXPORTERS)) -> list[Path]:
    """Write linkage.urdf, linkage.json, meshes/<link>.stl and meshes/pin_<joint>.stl of ``linkage`` with
    its finished design ``result`` (`DesignResult`, from `synth.design.choose.design_for`) into the
    existing ``directory`` (not atomic: use inside ``atomic_directory``, e.g. for ``OUT/<id>/`` layouts;
    ``formats``: keys of `synth.io.export.EXPORTERS`, e.g. `synth.io.export.Outputs.formats`). Returns the
    paths written, relative to ``directory``."""
    return export(linkage, result, directory, robot_name=robot_name, package=package, formats=formats)


def write_output(linkage, out_dir, *, robot_name: str, result, force: bool = False,
                 package: str | None = None, formats=tuple(EXPORTERS)) -> list[Path]:
    """Write OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl of ``linkage`` with its finished
    design ``result`` atomically (``result`` None: the kinematic outputs only, linkage.json and a URDF
    without meshes; ``formats`` as `write_linkage_files`); returns the final paths. Raises InputError for an
    unusable OUT (see the module docstring)."""
    check_robot_name(robot_name)
    check_package(package)
    out = check_path(out_dir)
    if result is not None:
        prepare_formats(formats)
    with atomic_directory(out, force=force) as tmp:
        rel = write_linkage_files(linkage, tmp, robot_name=robot_name, result=result, package=package,
                                  formats=formats)
    return [out / r for r in rel]


def write_solutions(out_dir, solutions, index: dict, *, force: bool = False, package: str | None = None,
                    formats=tuple(EXPORTERS)) -> None:
    """Write several linkages atomically as OUT/<id>/ (each as `write_linkage_files`, ``formats`` too) plus
    OUT/index.json; ``solutions``: (id, linkage, robot name, DesignResult) tuples."""
    if any(result is not None for *_, result in solutions):
        prepare_formats(formats)
    with atomic_directory(Path(out_dir), force=force) as tmp:
        for sid, linkage, robot_name, result in solutions:
            d = tmp / sid
            d.mkdir()
            write_linkage_files(linkage, d, robot_name=robot_name, result=result, package=package, formats=formats)
        write_json(index, tmp / "index.json")

