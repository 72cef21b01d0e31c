"""One synthesis of the designer: a task document -> the linkage(s) the CLI would give, or the reason
there is none, in words. The calls are the `synth.solve` entry points of `mpsynth bennett|sixbar|fourbar`
without the physical design (that runs behind, `synth.tools.designer.background`).
"""
from __future__ import annotations

import copy
import enum
import math
import time
from dataclasses import dataclass, field

import numpy as np

from synth.algebra.geometry import pose_difference
from synth.errors import MpsynthError
from synth.io.poses import parse_pose_document
from synth.solve import SynthesisOptions, solve_bennett, solve_fourbar, solve_sixbar

TOP = 5  # candidates offered where the entry point ranks them


class Kind(enum.StrEnum):
    """The linkage kind the designer asks for: the command of the same name."""

    BENNETT = "bennett"
    SIXBAR = "sixbar"
    FOURBAR = "fourbar"


SOLVERS = {Kind.BENNETT: solve_bennett, Kind.SIXBAR: solve_sixbar, Kind.FOURBAR: solve_fourbar}


def default_kind(ps) -> Kind:
    """The kind a task asks for: four poses or seven points a 6R; coplanar poses other than three or four
    (`synth.synthesis.fourbar_plane.plane_of_motion`) the planar four-bar; else a Bennett linkage (three
    poses, which may be planar or spherical, five points, a fit of any count)."""
    n = len(ps)
    if ps.has_points:
        return Kind.SIXBAR if n == 7 else Kind.BENNETT
    if n == 4:
        return Kind.SIXBAR
    if n != 3 and _coplanar(ps):
        return Kind.FOURBAR
    return Kind.BENNETT


def _coplanar(ps) -> bool:
    from synth.synthesis.fourbar_plane import plane_of_motion

    try:
        plane_of_motion(ps.matrices, ps.names, ps.source)
    except MpsynthError:
        return False
    return True


def reader_options(kind: Kind | None) -> dict:
    """The counts `parse_pose_document` checks for ``kind``, as its command does (None: any task)."""
    from synth.solve.tasks import point_count

    if kind is None:
        return dict(count=((1, None), "mpsynth design"), points=((1, None), "mpsynth design"))
    if kind is Kind.FOURBAR:
        return dict(count=((3, None), "mpsynth fourbar"))
    degree = 2 if kind is Kind.BENNETT else 3
    points = ((point_count(2)[0][0], None), "mpsynth bennett") if degree == 2 else point_count(3)
    return dict(count=((2, None), f"mpsynth {kind.value}"), points=points)


def kind_problems(doc, source: str, normalize: bool = False) -> dict[Kind, str | None]:
    """Why each kind cannot apply to the task document ``doc`` (None: it may): its command's reading of the
    file fails (the one-line message), or, for the four-bar, the items are points or not coplanar poses.
    Only what reading shows: a kind that reads may still find no real linkage (`synthesize` says why)."""
    out: dict[Kind, str | None] = {}
    for kind in Kind:
        try:
            ps = parse_pose_document(copy.deepcopy(doc), source=source, normalize=normalize, **reader_options(kind))
            out[kind] = None
            if kind is Kind.FOURBAR and (ps.has_points or not _coplanar(ps)):
                out[kind] = ("a four-bar needs poses, not points" if ps.has_points else
                             "a four-bar needs coplanar poses (a planar motion): these are not")
        except MpsynthError as e:
            out[kind] = str(e)
    return out


def ranks(kind: Kind, ps) -> bool:
    """Whether the entry point of ``kind`` ranks candidates for ``ps`` (``--top``): 6R and four-bar
    tasks, and Bennett fits and point tasks (three exact poses give one Bennett linkage)."""
    if kind is not Kind.BENNETT:
        return True
    from synth.synthesis.bennett_fit import is_task

    return bool(ps.has_points or is_task(ps))


@dataclass(slots=True)
class PoseError:
    """How far the tool frame passes from a task item: ``position`` (task unit), ``angle`` (degrees; None
    for a point), ``tolerance`` (position, angle) or None for an exact item, ``within`` it."""

    name: str
    position: float
    angle: float | None
    tolerance: tuple[float, float] | None
    within: bool

    def to_json(self) -> dict:
        tol = None if self.tolerance is None else [None if math.isinf(x) else x for x in self.tolerance]
        return {"name": self.name, "position": self.position, "angle": self.angle, "tolerance": tol,
                "within": self.within}


@dataclass(slots=True)
class Synthesis:
    """What one synthesis gave: ``linkages`` (best first; [] when none) with their ``labels``, the pose
    set, or ``problem``: why there is no linkage, in words; ``ranked``: the linkages are ranked solutions;
    ``seconds``: its wall time (for the bench
    and the page, never for a decision)."""

    kind: Kind
    ps: object = None
    linkages: list = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    problem: str | None = None
    ranked: bool = False  # the linkages are the entry point's ranked solutions (``--top``), else its one choice
    exit_code: int = 0
    seconds: float = 0.0


def synthesize(doc, source: str, kind: Kind | None, normalize: bool = False) -> Synthesis:
    """The linkages of the task document ``doc`` (a file's parsed content, task units) for ``kind``
    (None: `default_kind`), read as its command reads it (``normalize``: its --normalize); an input or
    synthesis error becomes ``problem`` (its one-line message)."""
    t0 = time.perf_counter()
    out = Synthesis(kind or Kind.BENNETT)
    try:
        if kind is None:
            out.ps = parse_pose_document(copy.deepcopy(doc), source=source, normalize=normalize, **reader_options(None))
            kind = default_kind(out.ps)
        out.kind = kind
        out.ps = ps = parse_pose_document(copy.deepcopy(doc), source=source, normalize=normalize, **reader_options(kind))
        top = TOP if ranks(kind, ps) else None
        result = SOLVERS[kind](ps, SynthesisOptions(top=top))
        if result.solutions:
            out.linkages = [s.linkage for s in result.solutions]
            out.labels = [s.id for s in result.solutions]
            out.ranked = True
        else:
            out.linkages, out.labels = [result.linkage], ["the linkage"]
    except MpsynthError as e:
        out.problem, out.exit_code = str(e), e.exit_code
    out.seconds = time.perf_counter() - t0
    return out


def task_misses(linkage, scale: float) -> list[PoseError]:
    """The tool frame's miss at every task item (at the item's parameter), in task units and degrees."""
    recs = linkage.poses
    if not recs:
        return []
    T = np.stack([linkage.tool_pose({k: np.asarray(v, float) for k, v in r.joint_angles.items()}) for r in recs])
    want = np.stack([r.matrix for r in recs])
    dt, dr = pose_difference(T, want)
    out = []
    exact = (1e-6 * max(linkage.extent() / scale, 1e-12), 1e-4)  # what "exact" allows: verified linkages are far within
    for r, p, a in zip(recs, dt, dr):
        tol = None if r.exact or r.tolerance is None else (r.tolerance[0] / scale, math.degrees(r.tolerance[1]))
        point = r.kind == "point"
        ang = None if point else math.degrees(float(a))
        pos = float(p) / scale
        limit = tol or exact
        within = pos <= limit[0] * (1 + 1e-9) and (point or ang <= limit[1] * (1 + 1e-9))
        out.append(PoseError(r.name, pos, ang, tol, bool(within)))
    return out
