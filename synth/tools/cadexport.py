"""`mpsynth export OUT --step`: formats added to an output that was written without them (issue 33).

``export_step(OUT)`` writes ``linkage.step`` (`synth.io.step`) next to every linkage.json of OUT (OUT
itself, or each solution of a multi-solution OUT), from the linkage and the physical design that
linkage.json records: the same solids the STL files hold. The file replaces an older one atomically
and is added to the output's manifest (a later run into OUT replaces it too).
"""
from __future__ import annotations

import json
from pathlib import Path

from synth.design.model import PhysicalDesign
from synth.errors import InputError, SynthesisError
from synth.io.atomic import atomic_write, owned_files, write_manifest
from synth.io.jsonout import write_json
from synth.io.readback import read_output, solution_dirs
from synth.io.meshes import design_solids
from synth.io.step import STEP_FILE, bounded_step_text, have_kernel, mesh_figures


def export_step(out) -> list[Path]:
    """Write ``linkage.step`` into every linkage directory of ``out``; the paths written. InputError when
    the ``cad`` extra is missing, OUT is not an mpsynth output or a linkage.json has no design;
    SynthesisError when OpenCASCADE's booleans do not give a solid the volume of its STL."""
    if not have_kernel():
        raise InputError("linkage.step needs gmsh's OpenCASCADE kernel: pip install 'mpsynth[cad]'")
    written = []
    for _, directory in solution_dirs(out):
        rb = read_output(directory)
        doc = rb.document.get("design")
        if not isinstance(doc, dict):
            raise InputError(f"{rb.root / 'linkage.json'}: no 'design' section to build solids from")
        try:
            design = PhysicalDesign.from_dict(doc)
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"{rb.root / 'linkage.json'}: unreadable 'design' section ({e})") from None
        solids = design_solids(rb.linkage, design)
        try:
            text = bounded_step_text(rb.linkage, design, *mesh_figures(solids))
        except RuntimeError as e:
            raise SynthesisError(f"{rb.root}: no linkage.step: {e}") from None
        path = rb.root / STEP_FILE
        atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="ascii"), "STEP file")
        if rb.document.get("step") is False:  # linkage.json said the output had none: now it has
            doc = json.loads((rb.root / "linkage.json").read_text(encoding="utf-8"))
            doc["step"] = True
            atomic_write(rb.root / "linkage.json", lambda tmp: write_json(doc, tmp), "linkage.json")
        owned = owned_files(rb.root)
        if owned is not None and STEP_FILE not in owned:
            write_manifest(rb.root, owned | {STEP_FILE})
        written.append(path)
    return written
