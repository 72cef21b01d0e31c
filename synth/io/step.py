"""``linkage.step``: the linkage as an assembly of B-rep solids for CAD programs (issue 33), written with
gmsh's OpenCASCADE kernel when the optional extra is installed (``pip install 'mpsynth[cad]'``).

One solid per link with joints and per pin, named as in the URDF (``base``, ``link_a1``, ...,
``pin_<joint>``), in millimetres, at the home configuration (all joint angles 0: the reference
configuration, world coordinates). Each solid is built from the same primitives as its STL
(`synth.io.meshes.link_primitives`, `pin_primitives`): a round bar is its profile revolved about its
segment, a hub a cylinder, minus a cylinder per bore, a pin (coaxial cylinders: shaft, head, groove) its
stepped profile revolved, with no boolean; exact cylinders and spheres where the
STL has facets, so the volumes agree to the facets' accuracy (under 1 %).

Units: the solids are built in metres, the primitives' own unit, and the STEP writer converts them to the
file's millimetres (``Geometry.OCCTargetUnit`` "M": the unit of the model, not of the file). OpenCASCADE
approximates the intersection curves of a boolean (a bar's cylinder with a hub's or a bore's: no conic)
to its fixed confusion tolerance, 1e-7 model units: 0.1 um in metres, where the same solids built in
millimetres asked for 0.1 nm at twice the CPU time (bench/RESULTS_fit.md, session 32) for the same
analytic faces and volumes equal to 1e-6. That unit is a process-wide setting of OpenCASCADE, which gmsh
sets only when it reads or writes a file: `_restore_unit` writes a one-point model in millimetres after
the linkage, so a STEP file read later in the same process (a test's) is read in millimetres again.

The kernel (bench/RESULTS.md, "STEP kernel"): gmsh's PyPI wheel (about 140 MB installed, 0.3 s import)
over cadquery-ocp (over 900 MB with its dependencies). gmsh's STEP writer names every part
"Open CASCADE STEP translator ..."; `name_products` gives them the URDF's names (the PRODUCT entities of
ISO 10303-21, in the order the solids were added). Nothing here imports gmsh until a file is written.
"""
from __future__ import annotations

import importlib.util
import os
import re
import tempfile
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from synth.design.model import capsules
from synth.io.meshes import coaxial_groups, coaxial_profile, link_primitives, pin_primitives
from synth.io.names import MESH_UNIT_SCALE, pin_link_name
from synth.io import interrupts
from synth.io.solid import shell_count, signed_volume
from synth.io.steptext import name_products, part_accuracies, place_products

STEP_FILE = "linkage.step"


def load_kernel():
    """The gmsh module, or None when the ``cad`` extra is not installed or its shared libraries (libGLU,
    X11, fontconfig) do not load. Imports gmsh only when it is installed."""
    if importlib.util.find_spec("gmsh") is None:
        return None
    try:
        import gmsh
    except (ImportError, OSError):
        return None
    return gmsh


def initialise_kernel() -> None:
    """Initialise gmsh once for this process, if the ``cad`` extra is there (idempotent; `step_text` then
    leaves it initialised). The writers call it before their temporary directory exists: gmsh's
    initialisation resets SIGTERM to its default action, and a SIGTERM in that moment must find nothing
    half written (`synth.io.interrupts.held` puts the CLI's handlers back right after)."""
    gmsh = load_kernel()
    if gmsh is not None and not gmsh.isInitialized():
        with interrupts.held():
            gmsh.initialize(readConfigFiles=False, interruptible=False)  # (interruptible: Python's SIGINT)


def have_kernel() -> bool:
    """True when gmsh (the ``cad`` extra) is installed and loads (`load_kernel`)."""
    return load_kernel() is not None


def missing_sentence(files) -> str | None:
    """The summary's line for an output whose paths ``files`` hold no ``linkage.step`` although the ``cad``
    extra is installed (`write_step` left it out: a B-rep boolean failed); None otherwise."""
    if any(Path(f).name == STEP_FILE for f in files) or not have_kernel():
        return None
    return ("no linkage.step: OpenCASCADE could not build every part as one solid (the STL meshes are the "
            "geometry; `mpsynth export OUT --step` names the part)")


def step_parts(linkage, design) -> dict[str, tuple[list, list]]:
    """{URDF link name: (parts, bores)} (`synth.io.meshes.Primitive` lists, world coordinates, metres):
    every link with joints, then every pin (no bores)."""
    out = {}
    sites = linkage.joint_sites()
    caps = capsules(linkage, design, sites)
    for name in linkage.link_names:
        parts, bores = link_primitives(linkage, design, name, sites, caps)
        if parts:
            out[name] = (parts, bores)
    for p in design.pins:
        out[pin_link_name(p.joint)] = (pin_primitives(linkage, design, p.joint, sites), [])
    return out


@contextmanager
def _quiet_stdout():
    """OpenCASCADE's STEP translator prints its statistics on file descriptor 1, past gmsh's own
    verbosity setting: keep them off the CLI's stdout (a --json document)."""
    saved = os.dup(1)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _occ_capsule(occ, a, b, r) -> int:
    """The gmsh volume of a round bar with round ends (radius ``r`` around the segment a-b): its profile (a
    half disc at each end joined by a line) revolved about the segment, one solid. (A cylinder fused
    with two spheres touches them tangentially along its rims, which OpenCASCADE may answer with nothing
    when a hub crosses that rim.)"""
    d = (b - a) / np.linalg.norm(b - a)
    n = np.cross(d, [1.0, 0, 0] if abs(d[0]) < 0.9 else [0, 1.0, 0])
    n /= np.linalg.norm(n)
    south, side_a, centre_a, side_b, centre_b, north = (occ.addPoint(*x) for x in (a - r * d, a + r * n, a, b + r * n,
                                                                                   b, b + r * d))
    loop = occ.addCurveLoop([occ.addCircleArc(south, centre_a, side_a), occ.addLine(side_a, side_b),
                             occ.addCircleArc(side_b, centre_b, north), occ.addLine(north, south)])
    out = occ.revolve([(2, occ.addPlaneSurface([loop]))], *a, *d, 2 * np.pi)
    return next(t for dim, t in out if dim == 3)


def _occ_box(occ, a, b, edges) -> int:
    """The gmsh volume of a `meshes.Primitive` box (millimetres): its rectangle at ``a`` extruded to ``b``."""
    e1, e2 = edges
    corners = [occ.addPoint(*(a + s1 * e1 + s2 * e2)) for s1, s2 in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    lines = [occ.addLine(corners[k], corners[(k + 1) % 4]) for k in range(4)]
    out = occ.extrude([(2, occ.addPlaneSurface([occ.addCurveLoop(lines)]))], *(b - a))
    return next(t for dim, t in out if dim == 3)


def _occ_balls(occ, a, b, r, spheres, axes=()) -> list[int]:
    """A round bar as a cylinder and a sphere at each end not already in ``spheres`` (list of (centre, r),
    appended to): consecutive segments of a cranked bar share one sphere. A sphere centred on one of
    ``axes`` ((point, unit direction) of the part's hubs) has its poles on that axis: the hub's cylinder
    then meets it in two of its parallels (measured: sixbar_points' link_h1, whose hubs are thinner than
    its bar, fused with spheres posed otherwise to OpenCASCADE tolerances of 0.5 to 2 mm)."""
    tags = [occ.addCylinder(*a, *(b - a), r)]
    for c in (a, b):
        if not any(np.allclose(c, q, rtol=0, atol=1e-9 * r) and abs(r - k) <= 1e-9 * r for q, k in spheres):
            spheres.append((c, r))
            tags.append(occ.addSphere(*c, r))
            u = next((d for o, d in axes if np.linalg.norm(np.cross(c - o, d)) <= 1e-9 * r), None)
            w = None if u is None else np.cross([0.0, 0.0, 1.0], u)  # gmsh's sphere: poles on z
            if w is not None and np.linalg.norm(w) > 1e-12:
                occ.rotate([(3, tags[-1])], *c, *(w / np.linalg.norm(w)), float(np.arctan2(np.linalg.norm(w), u[2])))
    return tags


def _occ_revolution(occ, origin, direction, profile, scale: float) -> int:
    """The gmsh volume of the `coaxial_profile` (times ``scale``) revolved a full turn about its axis:
    cylinders and flat rings, no boolean."""
    n = np.cross(direction, [1.0, 0, 0] if abs(direction[0]) < 0.9 else [0, 1.0, 0])
    n /= np.linalg.norm(n)
    pts = [occ.addPoint(*((origin + s * direction + r * n) * scale)) for s, r in profile]
    loop = occ.addCurveLoop([occ.addLine(pts[k], pts[(k + 1) % len(pts)]) for k in range(len(pts))])
    out = occ.revolve([(2, occ.addPlaneSurface([loop]))], *(origin * scale), *direction, 2 * np.pi)
    return next(t for dim, t in out if dim == 3)


def _occ_solids(occ, prims, bores, scale: float, revolved: bool = True, one_by_one: bool = False) -> list[int]:
    """The gmsh volume tags of the union of ``prims`` minus the union of ``bores`` (times ``scale``): one
    volume, or several where the bores cut the union apart (as they cut the STL's mesh: a bar thinner
    than a bore running along that bore's axis). Round bars revolved (`_occ_capsule`) or, not
    ``revolved``, cylinders and balls (`_occ_balls`). ``one_by_one``: a boolean per primitive and per bore
    (slower; OpenCASCADE's batch of nearly tangent hubs and bars can leave nothing where the sequence does
    not). RuntimeError when nothing is left."""
    profile = None if bores or len(prims) < 2 else coaxial_profile(prims)
    if profile is not None:  # a pin: its profile revolved, no fuse (whose cost is the same as a link's)
        return [_occ_revolution(occ, *profile, scale)]
    tags, spheres = [], []
    axes = [(np.asarray(p.p0) * scale, (np.asarray(p.p1) - p.p0) / np.linalg.norm(np.asarray(p.p1) - p.p0))
            for p in prims if p.kind == "cylinder"]
    for p in prims:
        a, b = np.asarray(p.p0) * scale, np.asarray(p.p1) * scale
        r = p.radius * scale
        if p.kind == "box":
            tags.append(_occ_box(occ, a, b, np.asarray(p.edges) * scale))
        elif p.kind != "capsule":
            tags.append(occ.addCylinder(*a, *(b - a), r))
        else:
            tags += [_occ_capsule(occ, a, b, r)] if revolved else _occ_balls(occ, a, b, r, spheres, axes)
    body, step = [(3, tags[0])], 1 if one_by_one else max(len(tags), 1)
    for k in range(1, len(tags), step):
        body, _ = occ.fuse(body, [(3, t) for t in tags[k : k + step]])
    cuts = [(3, _occ_revolution(occ, *profile, scale) if profile is not None else
             occ.addCylinder(*(np.asarray(p.p0) * scale), *((np.asarray(p.p1) - p.p0) * scale), p.radius * scale))
            for p, profile in coaxial_groups(bores)]
    step = 1 if one_by_one else max(len(cuts), 1)
    for k in range(0, len(cuts), step):
        body, _ = occ.cut(body, cuts[k : k + step]) if body else (body, None)
    if not body:
        raise RuntimeError("the B-rep boolean left no solid")
    return [t for _, t in body]


def _hide_free_entities(gmsh) -> None:
    """Leave out of the STEP file the surfaces, curves and points that bound no volume (a boolean can
    leave a stray point behind: the writer would make it a wireframe part of its own): hidden, and only
    what is visible exported."""
    level = gmsh.model.getEntities(3)
    bound = set()
    for _ in range(3):  # the volumes' surfaces, their curves, their points
        level = sorted({(d, abs(t)) for d, t in gmsh.model.getBoundary(level, combined=False, oriented=False)}) \
            if level else []
        bound |= set(level)
    free = [e for dim in (2, 1, 0) for e in gmsh.model.getEntities(dim) if e not in bound]
    if free:
        gmsh.model.setVisibility(free, 0)
    gmsh.option.setNumber("Geometry.OCCExportOnlyVisible", 1)


VOLUME_TOLERANCE = 0.02  # relative: a B-rep solid's volume against its faceted STL's (measured: +0.3 to +0.7 %)


def _checked_solids(occ, prims, bores, scale: float, volume: float | None, bodies: int | None = None, *,
                    name: str = "", banned=frozenset(), coarse=None, trying=lambda key: None) -> tuple[list[int], int]:
    """`_occ_solids` with revolved round bars, else with cylinders and balls, then both again one boolean at
    a time (measured: 2 of 20 README jobs' bases, a hub 0.9 times the bar's radius), whichever first gives the
    ``volume`` (the STL's, in the model's unit; None: unchecked) within `VOLUME_TOLERANCE` in as many solids
    as the STL has ``bodies`` (None: unchecked): OpenCASCADE's booleans of solids whose faces coincide or
    touch (the balls of a cranked bar's segments, a bar's rims) may fail, lose pieces or leave a sliver
    solid (a bore through a bar's rim: measured on 3 of 20 README jobs, whose STEP model then failed as a
    whole) without a word. (tags, construction index); RuntimeError when none does. ``banned``: the
    (``name``, construction index) pairs not tried (`synth.io.bounded`: they did not return), nor those of
    ``coarse`` ({pair: accuracy mm}: written too coarse, `step_text`); ``trying(key)`` is called before each."""
    got, coarse = [], coarse or {}
    for k, (revolved, one_by_one) in enumerate(((True, False), (False, False), (True, True), (False, True))):
        if (name, k) in banned or (name, k) in coarse:
            got.append(f"construction {k}: " + (f"accuracy {coarse[name, k]:g} mm" if (name, k) in coarse else
                                                "no return"))
            continue
        trying((name, k))
        before = set(occ.getEntities(3))
        try:
            tags = _occ_solids(occ, prims, bores, scale, revolved, one_by_one)
        except Exception:  # noqa: BLE001  (gmsh reports a failed boolean as a bare Exception)
            occ.remove(sorted(set(occ.getEntities(3)) - before), recursive=True)  # what it left half done
            continue
        total = sum(occ.getMass(3, t) for t in tags)
        if (volume is None or abs(total / volume - 1) <= VOLUME_TOLERANCE) and bodies in (None, len(tags)):
            return tags, k
        got.append(f"{total} in {len(tags)} solids")
        occ.remove([(3, t) for t in tags], recursive=True)
    raise RuntimeError(f"{name or 'a part'}: the B-rep booleans gave volumes {', '.join(got) or 'none'}, not the "
                       f"mesh's {volume} (model units cubed){f' in {bodies} solids' if bodies is not None else ''}")


def mesh_figures(solids: dict) -> tuple[dict, dict]:
    """({URDF link: volume mm^3}, {URDF link: separate bodies}) of the meshes ``solids`` {URDF link:
    `synth.io.solid.Solid`, metres}: what `step_text` checks each B-rep solid against."""
    return ({n: signed_volume(m.triangles) / MESH_UNIT_SCALE ** 3 for n, m in solids.items()},
            {n: shell_count(m.faces) for n, m in solids.items()})


MODEL_UNITS = (("M", 1.0), ("MM", 1e3), ("UM", 1e6))  # OpenCASCADE's unit names, model units per metre


def model_unit(design) -> tuple[str, float]:
    """(OpenCASCADE unit name, model units per metre) the solids of ``design`` are built in: the largest
    of metres, millimetres, micrometres in which the bar radius is at least 1e-3 model units (README's
    jobs: metres, bars of 5 to 12 mm; poses a millimetre apart: millimetres, bars of 0.06 mm). OpenCASCADE's
    fixed tolerances (1e-7 model units) are then at most 1e-4 of a bar's radius, where smaller parts
    failed its booleans (module docstring)."""
    return next(((u, k) for u, k in MODEL_UNITS if design.bar_radius * k >= 1e-3), MODEL_UNITS[-1])


def local_origin(prims) -> np.ndarray:
    """The point (3,) a part's solid is built around (metres, world): its first primitive's start. Each
    part is built near the origin and then placed: OpenCASCADE's booleans failed on parts whose size
    is 1e-9 of their distance from it (a millimetre linkage 2,000 km out)."""
    return np.asarray(prims[0].p0, float)


def _shifted(prims, origin) -> list:
    """``prims`` with their end points relative to ``origin`` (3,)."""
    return [replace(p, p0=np.asarray(p.p0, float) - origin, p1=np.asarray(p.p1, float) - origin) for p in prims]


ACCURACY = 0.25  # a part's B-rep accuracy at most this times the smaller of the bore clearance and the bar radius


def step_text(linkage, design, volumes: dict | None = None, bodies: dict | None = None, *, banned=frozenset(),
              trying=lambda key: None) -> str:
    """The ``linkage.step`` file of ``linkage`` with its physical ``design`` (see the module docstring);
    ``volumes`` {URDF link: mm^3} and ``bodies`` {URDF link: count}: the STL solids' volumes and pieces each
    B-rep solid is checked against (`mesh_figures`). A part whose written accuracy (OpenCASCADE's largest
    tolerance, `part_accuracies`) exceeds `ACCURACY` times the bore clearance or bar radius is built again
    with its next construction (measured: sixbar_points' link_h1 at 0.5 mm read back with 5 % of its volume).
    Imports gmsh (ImportError without the ``cad`` extra); RuntimeError when a boolean fails.
    ``banned``, ``trying``: `_checked_solids`'s (`bounded_step_text`)."""
    gmsh = load_kernel()
    if gmsh is None:
        raise ImportError("linkage.step needs gmsh: pip install 'mpsynth[cad]'")
    limit = ACCURACY * min(design.hole_clearance, design.bar_radius) / MESH_UNIT_SCALE  # mm: the file's unit
    started = gmsh.isInitialized()
    if not started:
        # gmsh's initialisation resets SIGTERM to its default action (seen in /proc/self/status): inside
        # `interrupts.held` the handlers installed before (the CLI's) are put back when it is done
        with interrupts.held():
            gmsh.initialize(readConfigFiles=False, interruptible=False)  # (interruptible: Python's SIGINT)
    coarse: dict = {}
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        while True:
            text, used = _model_text(gmsh, linkage, design, volumes, bodies, banned, coarse, trying)
            owner = {n: next(p for p in used if n == p or n.startswith(p + "_piece")) for n in part_accuracies(text)}
            worse = {(owner[n], used[owner[n]]): a for n, a in part_accuracies(text).items() if a > limit}
            if not worse:
                return text
            coarse.update(worse)
    finally:
        if not started:
            gmsh.finalize()


def _model_text(gmsh, linkage, design, volumes, bodies, banned, coarse, trying) -> tuple[str, dict]:
    """(STEP text, {part: construction index}) of one build of every part (`step_text`)."""
    parts = step_parts(linkage, design)
    unit, scale = model_unit(design)
    to_model = (MESH_UNIT_SCALE * scale) ** 3  # volumes from mm^3
    gmsh.model.add("linkage")
    occ = gmsh.model.occ
    want = {name: v * to_model for name, v in (volumes or {}).items()}
    pieces, origins, used = {}, {}, {}
    try:
        for name, (prims, bores) in parts.items():
            o = local_origin(prims)
            pieces[name], used[name] = _checked_solids(occ, _shifted(prims, o), _shifted(bores, o), scale,
                                                       want.get(name), (bodies or {}).get(name), name=name,
                                                       banned=banned, coarse=coarse, trying=trying)
            origins[name] = o / MESH_UNIT_SCALE  # mm: the file's unit
        try:
            occ.synchronize()
        except Exception as e:  # noqa: BLE001  (a boolean that failed above may surface only here, bare)
            raise RuntimeError(f"OpenCASCADE could not build the model: {e}") from e
        _hide_free_entities(gmsh)
        tags = {t: name if k == 0 else f"{name}_piece{k + 1}" for name, ts in pieces.items() for k, t in enumerate(ts)}
        volumes = [t for _, t in gmsh.model.getEntities(3)]
        if volumes != sorted(tags):
            raise RuntimeError(f"the B-rep model holds volumes {volumes}, expected {sorted(tags)}")
        order = [tags[t] for t in volumes]  # the writer's order: by volume tag
        places = [origins[next(n for n, ts in pieces.items() if t in ts)] for t in volumes]
        gmsh.option.setString("Geometry.OCCTargetUnit", unit)  # the model's unit; the file's stays mm
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / STEP_FILE
            try:
                with _quiet_stdout():
                    gmsh.write(str(path))
            finally:
                gmsh.model.remove()
                _restore_unit(gmsh, Path(tmp))
            text = path.read_text(encoding="ascii")
    except BaseException:
        if "linkage" in gmsh.model.list():
            gmsh.model.setCurrent("linkage")
            gmsh.model.remove()
        raise
    return place_products(name_products(text, order), places), used


def _restore_unit(gmsh, directory: Path) -> None:
    """OpenCASCADE's process-wide STEP unit back to millimetres (its default), after a write in metres
    (module docstring): gmsh sets it when it writes a file, so a one-point model goes to ``directory``."""
    gmsh.model.add("unit")
    gmsh.model.occ.addPoint(0, 0, 0)
    gmsh.model.occ.synchronize()
    gmsh.option.setString("Geometry.OCCTargetUnit", "MM")
    with _quiet_stdout():
        gmsh.write(str(directory / "unit.step"))
    gmsh.model.remove()


def bounded_step_text(linkage, design, volumes: dict | None = None, bodies: dict | None = None) -> str:
    """`step_text` in a child bounded in CPU time (`synth.io.bounded`): a part's construction whose
    OpenCASCADE booleans do not return is given up and the next one tried. RuntimeError as `step_text`,
    or when every construction of a part failed or did not return."""
    from synth.io.bounded import bounded_build

    return bounded_build(step_text, linkage, design, volumes, bodies)


def built_step(job) -> str | None:
    """The ``linkage.step`` text of an `synth.io.export.ExportJob` (its linkage, design and STL solids), or
    None: kinematic outputs only, no ``cad`` extra, or a part OpenCASCADE could not build with its STL's
    volume (`_checked_solids`; the STL files are the output's geometry: an optional format does not fail
    a run; `mpsynth export OUT --step` says why)."""
    if job.result is None or not have_kernel():
        return None
    try:
        return bounded_step_text(job.linkage, job.result.design, *mesh_figures(job.solids))
    except RuntimeError:
        return None


def write_step(job, directory: Path) -> list[Path]:
    """The ``step`` exporter (`synth.io.export`): ``linkage.step`` when `built_step` gives it (``job.step``,
    built once: linkage.json records whether it was written); nothing otherwise."""
    if job.step is None:
        return []
    (Path(directory) / STEP_FILE).write_text(job.step, encoding="ascii")
    return [Path(STEP_FILE)]
