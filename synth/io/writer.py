"""Write a linkage's output directory (docs/conventions.md): linkage.urdf, linkage.json, meshes/*.stl,
atomically through `synth.io.atomic` (whole-directory replacement, the manifest as proof of ownership;
its names are re-exported here)."""
from __future__ import annotations

from pathlib import Path

from synth.io.atomic import (MARKER, MANIFEST_FORMAT, STALE_AGE, _commit, atomic_directory,  # noqa: F401
                             atomic_write, check_file_target, check_output_target, check_path, is_mpsynth_output,
                             owned_files, remove_stale_temporaries)
from synth.design.sizes import check_sizes
from synth.io.jsonout import linkage_document, write_json
from synth.io.names import check_package, check_robot_name
from synth.io.meshes import design_for, design_solids, mesh_inertials, stl_file
from synth.io import urdf


def write_linkage_files(linkage, directory, *, robot_name: str, package: str | None = None,
                        pin_radius=None, link_radius=None, pin_length=None, hole_clearance=None, clearance=None,
                        result=None) -> list[Path]:
    """Write linkage.urdf, linkage.json, meshes/<link>.stl and meshes/pin_<joint>.stl into the existing
    ``directory`` (not atomic: use inside ``atomic_directory``, e.g. for ``OUT/<id>/`` layouts).
    ``result``: the `DesignResult` to write (default: `meshes.design_for` with the given sizes and
    clearances, metres).
    Returns the paths written, relative to ``directory``."""
    check_robot_name(robot_name)
    check_package(package)
    directory = Path(directory)
    if result is None:
        result = design_for(linkage, pin_radius, link_radius, pin_length, hole_clearance, clearance)
    meshes = design_solids(linkage, result.design)
    written = []
    if meshes:
        (directory / "meshes").mkdir()
    offsets = {}
    for name, mesh in meshes.items():
        rel = Path("meshes") / f"{name}.stl"
        # stored about its own centre, in millimetres, placed by the URDF visual/collision origin
        data, offsets[name] = stl_file(mesh, f"mesh of {name}")
        (directory / rel).write_bytes(data)
        written.append(rel)
    text = urdf.urdf_text(linkage, robot_name, mesh_dir="meshes", package=package, masses=mesh_inertials(meshes),
                     mesh_offsets=offsets, design=result.design, collision=result.collision)
    (directory / "linkage.urdf").write_text(text, encoding="utf-8")
    write_json(linkage_document(linkage, result.design, result.collision), directory / "linkage.json")
    return [Path("linkage.urdf"), Path("linkage.json")] + written


def write_output(linkage, out_dir, *, robot_name: str, force: bool = False, package: str | None = None,
                 pin_radius=None, link_radius=None, pin_length=None, hole_clearance=None, clearance=None,
                 result=None) -> list[Path]:
    """Write OUT/linkage.urdf, OUT/linkage.json and OUT/meshes/*.stl atomically; returns the final
    paths. Raises InputError for an unusable OUT (see the module docstring) or bad sizes."""
    check_sizes(dict(pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                     hole_clearance=hole_clearance, clearance=clearance), linkage.extent(),
                label=lambda key: key.replace("_", " "))  # bad sizes fail before touching disk
    check_robot_name(robot_name)
    check_package(package)
    out = check_path(out_dir)
    with atomic_directory(out, force=force) as tmp:
        rel = write_linkage_files(linkage, tmp, robot_name=robot_name, package=package,
                                  pin_radius=pin_radius, link_radius=link_radius, pin_length=pin_length,
                                  hole_clearance=hole_clearance, clearance=clearance, result=result)
    return [out / r for r in rel]


def write_solutions(out_dir, solutions, index: dict, *, force: bool = False, package: str | None = None) -> None:
    """Write several linkages atomically as OUT/<id>/ (each as `write_linkage_files`) plus OUT/index.json;
    ``solutions``: (id, linkage, robot name, DesignResult) tuples."""
    with atomic_directory(Path(out_dir), force=force) as tmp:
        for sid, linkage, robot_name, result in solutions:
            d = tmp / sid
            d.mkdir()
            write_linkage_files(linkage, d, robot_name=robot_name, package=package, result=result)
        write_json(index, tmp / "index.json")

