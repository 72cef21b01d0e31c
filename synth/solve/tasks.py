"""One entry point per task kind: the decisions the CLI, batch jobs and notebooks share.

``solve_bennett(ps, options)``, ``solve_sixbar``, ``solve_fourbar``, ``solve_points``, ``solve_curve`` take a validated task
(`synth.task.PoseSet`, or a parsed curve/motion spec) and `SynthesisOptions` and return a `Result`: the
chosen linkage, its physical design (when asked for) and, for ``top``, the ranked solutions with their
index document. They apply every gate (verification, transmission, collision-freedom when required),
choose the design (collision-free first, then the score: counted work, never time) and raise InputError
(exit 2) or SynthesisError (exit 1) naming the task's source. Nothing is written: `synth.io.writer`
writes a Result's linkages and designs.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable

from synth.checks import VERIFY_SAMPLES
from synth.design.constraints import admissible, compact_first, first_in_envelope, met_sentence
from synth.design.work import GAPS_PER_SECOND
from synth.drive import drive_report
from synth.errors import InputError, SynthesisError
from synth.info import MultiLoop
from synth.solve.choose import Designer
from synth.solve.index import (add_collisions, fourbar_index, point_index, point_solution_id, sixbar_index,
                               sixbar_solution_id, task_index, task_solution_id)
from synth.solve.options import SynthesisOptions

# default designs: the best-scored candidates designed, collision-free first (`Designer.choose`), within
# a budget of gap evaluations (`synth.design.work`: counted work, the same choice on a loaded machine)
BENNETT_CHOICE = dict(limit=4, work=4.0 * GAPS_PER_SECOND)  # members of a planar or spherical family
SIXBAR_CHOICE = dict(limit=8, work=7.0 * GAPS_PER_SECOND)
POINTS_CHOICE = dict(limit=4, work=7.0 * GAPS_PER_SECOND)
TASK_CHOICE = dict(limit=3, work=4.0 * GAPS_PER_SECOND)  # the best fits of a task file, within tolerance
FOURBAR_CHOICE = dict(limit=4, work=4.0 * GAPS_PER_SECOND)  # the best-ranked planar four-bars
CONSTRAINED = 16  # with constraints in the task file: this many candidates filtered by them (sixbar: twice)
POINT_COMMAND = {2: "mpsynth bennett", 3: "mpsynth sixbar"}


@dataclass(slots=True)
class Solution:
    """One ranked solution of ``top``: its id (directory name), linkage and design (None: not designed)."""

    id: str
    linkage: Any
    design: Any = None


@dataclass(slots=True)
class Result:
    """What a task gave. ``linkage``: the chosen one (``top``: the best ranked); ``design``: its
    `synth.design.search.DesignResult` (None when no physical design was asked for); ``solutions`` and
    ``index`` (the index.json document): the ranked solutions of ``top`` (else [] and None);
    ``notes``: remarks on the options (e.g. one that does not apply); ``source``, ``scale`` (metres per
    input unit), ``unit``: the task's, for messages; ``drive`` (docs/drive.md) and ``constraints_met``."""

    linkage: Any
    design: Any = None
    solutions: list[Solution] = field(default_factory=list)
    index: dict | None = None
    notes: list[str] = field(default_factory=list)
    source: str = "<poses>"
    scale: float = 1.0
    unit: str = "m"
    drive: Any = None  # the chosen linkage's `synth.drive.DriveReport`
    constraints_met: str | None = None  # what the design achieves of the task's constraints, in words

    def sentence(self, design=None) -> str:
        """What ``design`` (default: the chosen one's) achieves, in words, lengths in the input unit."""
        from synth.solve.choose import collision_sentence

        return collision_sentence((design or self.design).collision, self.scale, self.unit)


def _designer(ps, options: SynthesisOptions) -> Designer:
    return Designer(options.design.sizes(ps.length_scale), ps.source, ps.length_scale, ps.length_unit,
                    getattr(ps, "constraints", None))


def _finish(linkage, result, designer: Designer, options: SynthesisOptions, constraints=None, **extra) -> Result:
    """The chosen linkage's design (made when asked for, or for an envelope, and not made yet), the
    collision gate, the envelope (`synth.design.constraints.first_in_envelope`) and the drive report."""
    envelope = constraints is not None and constraints.envelope is not None
    if result is None and (options.wants_design or envelope):
        result = designer.design(linkage)
    if result is not None and options.design.require_collision_free:
        designer.require_free(result)
    if envelope:
        first_in_envelope([(linkage, result)], [], None, constraints, source=designer.source, scale=designer.scale,
                          unit=designer.unit)
    drive = drive_report(linkage) if result is not None or constraints is not None else None  # (batch: no cost)
    if result is not None:
        result.drive = drive  # linkage.json's drive (synth.io.jsonout)
    met = (met_sentence(linkage, result.design if result else None, constraints, designer.scale, designer.unit)
           if constraints is not None else None)
    return Result(linkage, result, source=designer.source, scale=designer.scale, unit=designer.unit, drive=drive,
                  constraints_met=met, **extra)


def _admissible(linkages, designer: Designer, options: SynthesisOptions, constraints=None) -> list:
    """The candidates that meet the task's constraints and the extent limit, each driven by
    ``options.driver`` (`synth.design.constraints.admissible`; SynthesisError naming the violations)."""
    if options.max_extent is not None and not options.max_extent > 0:
        raise InputError(f"--max-extent must be a positive length, got {options.max_extent}")
    limit = None if options.max_extent is None else options.max_extent * designer.scale
    return admissible(linkages, constraints, driver=options.driver, max_extent=limit, source=designer.source,
                      scale=designer.scale, unit=designer.unit)


def _ranked(linkages, designer: Designer, options: SynthesisOptions, ident, index, what: str, progress,
            constraints=None) -> Result:
    """The ``top`` ranked solutions that meet the constraints: designed (collision-free first) when asked
    for, ids, index document."""
    results = None
    linkages = _admissible(linkages, designer, options, constraints)
    if options.wants_design:
        linkages, results = designer.rank(linkages, require_free=options.design.require_collision_free, what=what,
                                          progress=progress, constraints=constraints)
    ids = [ident(r, lk) for r, lk in enumerate(linkages, start=1)]
    doc = index(linkages, ids)
    if results is not None:
        add_collisions(doc["solutions"], results, designer.sentence)
    designs = results or [None] * len(linkages)
    sols = [Solution(i, lk, r) for i, lk, r in zip(ids, linkages, designs)]
    return Result(linkages[0] if linkages else None, designs[0] if designs else None, sols, doc, source=designer.source, scale=designer.scale,
                  unit=designer.unit)


def design_solution(ps, linkage, options: SynthesisOptions = SynthesisOptions(physical=True)) -> Result:
    """The physical design of one given solution of ``ps`` (a `Result.solutions` linkage the caller picked,
    e.g. ``--top`` rank k in `mpsynth design`), gated and reported as an entry point's chosen one
    (`_finish`: collision gate, envelope, drive report)."""
    return _finish(linkage, None, _designer(ps, options), options, ps.constraints)


def solve_bennett(ps, options: SynthesisOptions = SynthesisOptions(), *, ready: Callable | None = None,
                  progress=None) -> Result:
    """Three poses: the verified Bennett linkage (planar or spherical poses: the four-bar member given by
    ``options.member``, else the best-scored members designed, collision-free first); five points (a
    point task): `solve_points`. ``ready()``: called once the options are validated, before the work
    (the CLI checks its output directory there); ``progress``: see `Designer.rank`. Tasks (tolerances,
    velocities, an order, more poses or more than five points): `_solve_task`."""
    from synth.synthesis.bennett import bennett_candidates, verify

    from synth.synthesis.bennett_fit import is_task

    designer = _designer(ps, options)
    if ps.has_points and not is_task(ps):
        if options.member is not None:
            raise InputError("--member selects among the quadratic motions through planar or spherical poses; a "
                             "point task has no such family (use --top to see its ranked designs)")
        return solve_points(ps, 2, options, progress=progress)
    if is_task(ps):  # tolerances, velocities, an order or other than three poses (docs/fit.md)
        if ready is not None:
            ready()
        return _solve_task(ps, designer, options, progress)
    if options.top is not None:
        raise InputError("--top applies to point tasks and fits only: three poses give one Bennett linkage")
    if ready is not None:
        ready()
    choose = (options.wants_design or ps.constraints is not None) and options.member is None
    try:
        linkages = bennett_candidates(ps.matrices, ps.names, member=options.member,
                                      top=(CONSTRAINED if ps.constraints else BENNETT_CHOICE["limit"]) if choose else 1)
        for lk in linkages:
            verify(lk)  # the self-check at VERIFY_SAMPLES parameters; refuses a failing linkage
    except SynthesisError as e:  # name the file, like every input error
        raise SynthesisError(f"{ps.source}: {e}") from e
    linkages = _admissible(linkages, designer, options, ps.constraints)
    if ps.constraints is not None or options.max_extent is not None:  # limits: compact members first
        linkages = compact_first(linkages)
    linkage, result = linkages[0], None
    if len(linkages) > 1 and options.wants_design:  # members of a planar or spherical family: collision-free first
        linkage, result = designer.choose(linkages, what="members", constraints=ps.constraints, **BENNETT_CHOICE)
    return _finish(linkage, result, designer, options, ps.constraints)


def _solve_task(ps, designer: Designer, options: SynthesisOptions, progress, synthesize=None) -> Result:
    """A task file's linkage (exact, Hermite or fitted: ``synthesize(ps, top=, best_effort=)``, default
    `synth.synthesis.bennett_fit.bennett_task`, for 6R `synth.synthesis.sixbar_task.sixbar_task`;
    ``options.best_effort``: the best fit even when a tolerance is missed); the best fits within tolerance
    designed, collision-free first, or with ``top`` the N best ranked."""
    if synthesize is None:
        from synth.synthesis.bennett_fit import bennett_task as synthesize

    want = options.top or (CONSTRAINED if ps.constraints else TASK_CHOICE["limit"] if options.wants_design else 1)
    linkages = synthesize(ps, top=want, best_effort=options.best_effort)
    if not options.best_effort:  # (steered fits may leave the tolerances: `synth.synthesis.steer`)
        linkages = [lk for lk in linkages if lk.info.fit.within_tolerance]
    if options.top is not None:
        return _ranked(linkages, designer, options, task_solution_id, lambda lks, ids: task_index(lks, ids, ps),
                       "fits", progress, ps.constraints)
    linkages = _admissible(linkages, designer, options, ps.constraints)
    linkage, result = linkages[0], None
    within = [lk for lk in linkages if lk.info.fit.within_tolerance] or linkages
    if options.wants_design and len(within) > 1:
        linkage, result = designer.choose(within, what="fits", constraints=ps.constraints, **TASK_CHOICE)
    return _finish(linkage, result, designer, options, ps.constraints)


def solve_sixbar(ps, options: SynthesisOptions = SynthesisOptions(), *, progress=None) -> Result:
    """Four poses: the 6R linkage (explicit family/member/pair: the best-scored such; else, with a
    physical design, the best-scored candidates designed, collision-free first), or with ``top`` the N
    best ranked; seven points: `solve_points`; a task (tolerances, velocities, an order, other counts):
    `synth.synthesis.sixbar_task.sixbar_task` as `_solve_task`."""
    from synth.synthesis.sixbar import sixbar, sixbar_candidates
    from synth.synthesis.sixbar_task import is_sixbar_task, sixbar_task

    designer = _designer(ps, options)
    if is_sixbar_task(ps):  # tolerances, velocities, an order, other counts, > 7 points (docs/sixbar_fit.md)
        if options.explicit:
            raise InputError("--family, --member and --pair select among the cubics through four exact poses; a "
                             "task with tolerances, velocities or another count ranks its own designs (use --top)")
        return _solve_task(ps, designer, options, progress, sixbar_task)
    if ps.has_points:
        if options.explicit:
            raise InputError("--family, --member and --pair select among the cubics through four poses; a point "
                             "task has no families (use --top to see its ranked designs)")
        return solve_points(ps, 3, options, progress=progress)
    pick = dict(family=options.family, member=options.member, pair=options.pair)
    if options.top is not None:
        linkages = sixbar_candidates(ps.matrices, ps.names, **pick, top=options.top, build=True,
                                     check_samples=VERIFY_SAMPLES)
        return _ranked(linkages, designer, options, sixbar_solution_id, lambda lks, ids: sixbar_index(lks, ids, ps),
                       "6R designs", progress, ps.constraints)
    if (options.wants_design or ps.constraints is not None) and not options.explicit:
        candidates = sixbar_candidates(ps.matrices, ps.names, top=2 * CONSTRAINED if ps.constraints else
                                       SIXBAR_CHOICE["limit"], build=True, check_samples=VERIFY_SAMPLES)
        candidates = _admissible(candidates, designer, options, ps.constraints)
        if ps.constraints is not None or options.max_extent is not None:  # limits: compact members first
            candidates = compact_first(candidates)
        linkage, result = candidates[0], None
        if options.wants_design:
            linkage, result = designer.choose(candidates, what="6R linkages", constraints=ps.constraints,
                                              **SIXBAR_CHOICE)
        return _finish(linkage, result, designer, options, ps.constraints)
    linkage = _admissible([sixbar(ps.matrices, ps.names, **pick, check_samples=VERIFY_SAMPLES)], designer, options,
                          ps.constraints)[0]
    return _finish(linkage, None, designer, options, ps.constraints)


def solve_fourbar(ps, options: SynthesisOptions = SynthesisOptions(), *, min_transmission_deg: float = 40.0,
                  ready=None, progress=None) -> Result:
    """Three or more coplanar poses (a `synth.task.PoseSet`; velocities count as poses, docs/fourbar.md): the
    best planar four-bar (`synth.synthesis.fourbar.fourbar_candidates`; with a physical design the best
    four designed, collision-free first), or with ``options.top`` the N best ranked. The task's constraints
    filter the ranked candidates, the crank h1 driving (`_admissible`); ``ready()`` is called before the
    work."""
    from synth.synthesis.fourbar import fourbar_candidates

    if not 0.0 <= min_transmission_deg <= 90.0:  # NaN included (it passes click's range check)
        raise InputError(f"--min-transmission must be between 0 and 90 degrees, got {min_transmission_deg}")
    if ps.has_points:
        raise InputError(f"{ps.source}: mpsynth fourbar needs poses (position and orientation), not points")
    designer = _designer(ps, options)
    if ready is not None:
        ready()
    want = options.top or (CONSTRAINED if ps.constraints else FOURBAR_CHOICE["limit"] if options.wants_design else 1)
    try:
        linkages = fourbar_candidates(ps.matrices, ps.names, top=want, min_transmission_deg=min_transmission_deg,
                                      order=ps.order, tolerance=ps.tolerance, velocity=ps.velocity, source=ps.source)
    except SynthesisError as e:  # name the file, like every input error
        raise SynthesisError(e.args[0] if str(e).startswith(ps.source) else f"{ps.source}: {e}") from e
    crank = replace(options, driver=options.driver or "h1")
    if options.top is not None:
        return _ranked(linkages, designer, crank, lambda r, lk: f"{r:02d}-fourbar",
                       lambda lks, ids: fourbar_index(lks, ids, ps), "four-bars", progress, ps.constraints)
    linkages = _admissible(linkages, designer, crank, ps.constraints)
    linkage, result = linkages[0], None
    if options.wants_design and len(linkages) > 1:
        linkage, result = designer.choose(linkages, what="four-bars", constraints=ps.constraints, **FOURBAR_CHOICE)
    return _finish(linkage, result, designer, options, ps.constraints)


def point_count(degree: int):
    """The count spec of a point file for `synth.io.poses.parse_pose_document` (``points=``)."""
    from synth.task import MINIMUM, NEEDED

    return (MINIMUM[degree], NEEDED[degree]), POINT_COMMAND[degree]


def solve_points(ps, degree: int, options: SynthesisOptions = SynthesisOptions(), *, progress=None) -> Result:
    """A point task (docs/points.md): the tool point of a Bennett (``degree`` 2) or 6R (3) linkage passes
    through the points; the best-scored interpolants designed, collision-free first, or with ``top`` the
    N best ranked."""
    from synth.synthesis.points import oriented_item, point_candidates

    designer = _designer(ps, options)
    try:
        oriented, rot = oriented_item(ps.matrices, ps.kinds, ps.names)
    except InputError as e:
        raise InputError(f"{ps.source}: {e}") from e
    want = options.top or ((CONSTRAINED if ps.constraints else POINTS_CHOICE["limit"]) if options.wants_design
                           or ps.constraints else 1)
    try:
        linkages = point_candidates(ps.positions, ps.names, degree=degree, top=want, tool_rotation=rot,
                                    oriented=oriented, check_samples=VERIFY_SAMPLES,
                                    base_box=ps.constraints.base if ps.constraints else None)
    except (SynthesisError, InputError) as e:
        raise type(e)(f"{ps.source}: {e}") from e
    if options.top is not None:
        return _ranked(linkages, designer, options, point_solution_id, lambda lks, ids: point_index(lks, ids, ps),
                       "designs", progress, ps.constraints)
    linkages = _admissible(linkages, designer, options, ps.constraints)
    linkage, result = linkages[0], None
    if options.wants_design:
        linkage, result = designer.choose(linkages, what="interpolants", constraints=ps.constraints, **POINTS_CHOICE)
    return _finish(linkage, result, designer, options, ps.constraints)


def solve_curve(spec, options: SynthesisOptions = SynthesisOptions(), *, scale: float = 1.0, unit: str = "m",
                source: str = "<spec>", ready: Callable | None = None) -> Result:
    """A curve or motion spec (`synth.io.curvespec.load_spec`; lengths in ``unit``, ``scale`` metres
    each): the multi-loop linkage (`synth.synthesis.curve.spec_linkage`); a 7R Darboux loop gets the
    collision-free member of its family when a design is made (`synth.design.members.choose_member`)."""
    from synth.design.members import choose_member
    from synth.synthesis.curve import spec_linkage
    from synth.task import CurveSpec

    designer = Designer(options.design.sizes(scale), source, scale, unit)
    if ready is not None:
        ready()
    notes = []
    if options.method != "auto" and not isinstance(spec, CurveSpec):
        notes.append("--method applies to curves only; ignored for a motion")
    linkage = _admissible([spec_linkage(spec, scale=scale, method=options.method)], designer, options)[0]
    result = None
    if isinstance(linkage.info.synthesis, MultiLoop) and linkage.info.synthesis.darboux is not None \
            and options.wants_design:  # a collision-free member first
        linkage, result = choose_member(linkage, lambda lk, ranges, full_work, effort, spent: designer.design(
            lk, ranges=ranges, full_work=full_work, effort=effort, work=spent))
    return _finish(linkage, result, designer, options, notes=notes)
