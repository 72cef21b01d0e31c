"""`Linkage.info`: what a synthesis found besides the linkage itself, as typed records.

A `LinkageInfo` holds one *synthesis record* (``synthesis``: what the synthesis scanned, scored and chose;
one type per synthesis: `Factorization` (spatial Bennett), `FamilyMember` (planar and spherical families),
`SixbarCandidate`, `PointsCandidate`, `FourBarRecord`, `MultiLoop` (curves and motions)) and the parts
several kinds have (`synth.infoparts`: Bennett parameters, DH table, warnings, a task's fit, the design
choice). Their fields, in order, are linkage.json's ``info`` keys (docs/conventions.md); ``to_dict`` is the
one place that writes them, ``from_dict`` reads them back (``matches(doc)`` tells the synthesis records
apart, `RECORDS` in order). Lengths in metres, angles in radians, world frame."""
from __future__ import annotations

from collections.abc import Mapping
import typing
from dataclasses import dataclass, field, fields, replace

import numpy as np

from synth.algebra.geometry import Conditioning
from synth.infoparts import (BennettParameters, DHRow, FitRecord, FitSummary, Record, ScoreParts, StudyForm,
                              optional)

__all__ = ["Factorization", "PlanarFamily", "Member", "Orders", "FamilyMember", "SixbarCandidate", "PointsCandidate",
           "Plane", "BarLengths", "FourBarFigures", "FourBarRecord", "Alternative", "CurveRecord", "GivenMotion",
           "CouplerMotion", "Ladder", "Parallelogram", "DarbouxMember", "MemberChoice", "Darboux", "Mobility",
           "Counts", "Marker", "MultiLoop", "RECORDS", "LinkageInfo"]

record = dataclass(kw_only=True)


@record
class Factorization(Record):
    """A spatial Bennett linkage's motion (docs/conic.md): the factorization residual, the Study form of
    three poses (exact synthesis only) and the conditioning frame of the poses."""

    MARK = "factorization_residual"

    factorization_residual: float
    study_form: StudyForm | None = optional()
    conditioning: Conditioning


@record
class PlanarFamily(Record):
    """The planar or spherical subgroup of the poses (docs/planar.md): ``kind``, the axes' ``normal``
    (planar) or common ``centre`` (spherical, m), the poses, the family's parameters and its motions."""

    kind: str
    normal: tuple[float, ...] | None = optional()
    centre: tuple[float, ...] | None = optional()
    poses: int
    parameters: tuple[str, ...]
    motion: str


@record
class Member(Record):
    """A member of a planar or spherical family: t3 (six-bars only) and the lambdas."""

    t3: float | None = optional()
    lambda1: float
    lambda2: float
    lambda3: float | None = optional()


@record
class Orders(Record):
    """The orders of the norm factors of each branch (h, k, and g of a Watt six-bar)."""

    h: tuple[int, ...]
    k: tuple[int, ...]
    g: tuple[int, ...] | None = optional()


@record
class FamilyMember(Record):
    """A member of the family of motions through planar or spherical poses, its four-bar or Watt six-bar
    (docs/planar.md): the family, the member and how it was chosen, the Watt chain (1..6), the score, the
    norm roots [re, im], the factorization residual, the Study form (four-bars), the mobility count (six-bars)."""

    family: PlanarFamily
    member: Member
    member_choice: str
    chain: int | None = optional()
    orders: Orders | None = optional()
    t3: float | None = optional()
    score: float
    score_parts: ScoreParts
    norm_roots: tuple[tuple[float, float], ...]
    factorization_residual: float
    study_form: StudyForm | None = optional()
    mobility: str | None = optional()
    conditioning: Conditioning

    @classmethod
    def matches(cls, d: Mapping) -> bool:
        return isinstance(d.get("family"), Mapping)


@record
class SixbarCandidate(Record):
    """A spatial 6R (docs/cubic.md, docs/sixbar_fit.md): ``task`` ("fit", "hermite"; None: four exact
    poses), the family (1, 2) and member lambda1 of the cubic, the pair of factorizations (1..9), t3 and the
    lambdas, the score, the factorization orders, norm roots [re, im] and residual, the quadric's Gram
    signature, each family's t3, the items' parameters (fits; None = infinity)."""

    MARK = "pair"  # (a 6R of points has one too: `PointsCandidate` is tried first)

    task: str | None = optional()
    family: int | None = optional()
    member: float | None = optional()
    pair: int
    t3: float | None = optional()
    lambdas: tuple[float, ...] | None = optional()
    score: float
    score_parts: ScoreParts
    orders: Orders
    norm_roots: tuple[tuple[float, float], ...]
    factorization_residual: float
    gram_signature: tuple[int, ...] | None = optional()
    family_t3: Mapping[str, float] | None = optional()
    parameters: tuple[float | None, ...] | None = optional()
    conditioning: Conditioning


@record
class PointsCandidate(Record):
    """A linkage through prescribed points (docs/points.md): the points' count and parameters (None =
    infinity), the score, the factorization, the points and parameters the scan chose for missing items,
    ``freedom`` (how the free parameters were chosen, in words), the 6R's pair."""

    task: str = "points"
    points: int
    parameters: tuple[float | None, ...]
    score: float
    score_parts: ScoreParts
    orders: Orders
    norm_roots: tuple[tuple[float, float], ...]
    factorization_residual: float
    chosen_points: tuple[tuple[float, float, float], ...]
    chosen_parameters: tuple[float, ...]
    conditioning: Conditioning
    freedom: str
    pair: int | None = optional()

    @classmethod
    def matches(cls, d: Mapping) -> bool:
        return d.get("task") == "points"


@record
class Plane(Record):
    """A planar four-bar's plane: origin, in-plane axes e1, e2 and normal (world frame, metres)."""

    origin: tuple[float, float, float]
    e1: tuple[float, float, float]
    e2: tuple[float, float, float]
    normal: tuple[float, float, float]


@record
class BarLengths(Record):
    """A four-bar's link lengths (metres)."""

    ground: float
    crank: float
    coupler: float
    rocker: float


@record
class FourBarFigures(Record):
    """A planar four-bar's designer figures (docs/fourbar.md): lengths, Grashof type, driver, assembly
    branch, least transmission angle over the task range and the required one (deg), the crank's task range
    (deg), the order, extent, cost, rank among the candidates, candidates and valid ones, the dyads' method."""

    lengths: BarLengths
    grashof: str
    driver: str
    branch: int
    transmission_min_deg: float
    min_transmission_deg: float
    task_range_deg: tuple[float, float]
    order: str
    extent: float
    cost: float
    rank: int
    candidates: int
    valid_candidates: int
    dyads: str


@record
class FourBarRecord(Record):
    """A planar four-bar: its plane, its figures and the rule that ranked it."""

    MARK = "fourbar"

    plane: Plane
    fourbar: FourBarFigures
    score_rule: str


@record
class Alternative(Record):
    """Another construction of the same motion and its joint count."""

    method: str
    joints: int


@record
class CurveRecord(Record):
    """A prescribed curve (x/w, y/w, z/w) (docs/exceptional.md): its texts, the unit, the coefficients
    (metres), the tracer point p0 on the coupler, the method of its motion, the rotation axis (or None),
    the alternatives."""

    x: str
    y: str
    z: str
    w: str
    scale_to_m: float
    xyz_coefficients_m: np.ndarray
    w_coefficients: np.ndarray
    p0_m: np.ndarray
    tracer: str
    method: str
    axis: Mapping | None
    alternatives: tuple[Alternative, ...]


@record
class GivenMotion(Record):
    """A prescribed rational motion (`synth.synthesis.curve.motion_linkage`): the input and its
    expression, the monic motion, leading coefficient, real content, co-factor R, its degree, the mrpf,
    boundedness, the factorization residual and report, C R, the alternatives (a Darboux 7R chosen)."""

    MARK = "input"

    input: tuple
    expression: str | None
    monic: np.ndarray
    leading_coefficient: np.ndarray
    real_content: np.ndarray
    cofactor: np.ndarray
    cofactor_text: str
    deg_R: int
    mrpf: np.ndarray
    mrpf_text: str
    bound_met: bool
    factorization_residual: float
    components: tuple[Mapping, ...]
    C_times_R: np.ndarray
    alternatives: tuple[Alternative, ...] | None = optional()


@record
class CouplerMotion(Record):
    """The coupler motion of a curve: the motion, co-factor R, its degree, the mrpf, the factorization
    residual and report, the rotation co-factor H (when the curve's motion is a rotation's)."""

    coupler: np.ndarray
    cofactor: np.ndarray
    cofactor_text: str
    deg_R: int
    mrpf_text: str
    factorization_residual: float
    components: tuple[Mapping, ...]
    rotation_cofactor_H: np.ndarray | None = optional()


@record
class Ladder(Record):
    """The ladder of Bennett flips (`synth.synthesis.multiloop.ladder_linkage`): N loops, joints, links,
    the factors h, k, m, the flip residual and each loop's joints."""

    N: int
    loops: int
    joints: int
    links: int
    h: np.ndarray
    k: np.ndarray
    m: np.ndarray
    flip_residual: float
    loop_joints: tuple[tuple[str, ...], ...]


@record
class Parallelogram(Record):
    """The 4R parallelogram of a circular translation: factors h, k, the shift s and its family in words."""

    h: np.ndarray
    k: np.ndarray
    shift: np.ndarray
    family: str


@record
class DarbouxMember(Record):
    """A member of the 7R Darboux construction: turn (rad) of the parallel axes and the 3R shift (m)."""

    turn: float
    shift: tuple[float, float]


@record
class MemberChoice(Record):
    """Why a Darboux 7R member was chosen (`synth.design.members.choose_member`): the member (None: the
    default), members tried, collision-free ones found, singular configurations and design size of the
    chosen one, the reason in words."""

    member: DarbouxMember | None
    tried: int
    free_found: int | None = optional()
    singular_configurations: int | None = optional()
    design_size: float | None = optional()
    reason: str

    def to_dict(self) -> dict:
        d = super().to_dict()
        if self.member is None:
            d["member"] = "default"
        return d

    @classmethod
    def from_dict(cls, d: Mapping) -> MemberChoice:
        d = dict(d)
        if d.get("member") == "default":
            d["member"] = None
        return super().from_dict(d)


@record
class Darboux(Record):
    """The 7R loop of a Darboux motion (docs/exceptional.md, section 6): branches h, g, joint rates, the
    products in words, M, the residuals of both products, the member, the singular parameters and the
    driver's angles there (deg), the member choice."""

    h: np.ndarray
    g: np.ndarray
    rates: Mapping[str, int]
    products: str
    M: np.ndarray
    residuals: Mapping[str, float]
    member: DarbouxMember
    singular_t: tuple[float, ...] | None = optional()
    singular_driver_deg: tuple[float, ...] | None = optional()
    member_choice: MemberChoice | None = optional()


@record
class Mobility(Record):
    """The sampled mobility of a multi-loop linkage (`synth.synthesis.multiloop.score_linkage`): largest and
    smallest degree of freedom, worst conditioning of the loop Jacobian, size."""

    dof: int
    dof_min: int
    conditioning: float
    size: float


@record
class Counts(Record):
    """Joints, links (without the welded duplicates), links with them, loops (`Linkage.counts`)."""

    joints: int
    links: int
    links_with_duplicates: int
    loops: int


@record
class Marker(Record):
    """A frame fixed to a tree link (e.g. the tracer of a curve): the link and its world position at the
    reference configuration (m); the URDF exporter writes it as a link and a fixed joint."""

    link: str
    position: tuple[float, float, float]


@record
class MultiLoop(Record):
    """A multi-loop linkage of a curve or a motion (docs/exceptional.md): the curve, the motion, the
    coincident factors separated (pairs, 1-based), the ladder, markers, parallelogram or Darboux 7R, the
    ladder's m0, the mobility and the counts."""

    curve: CurveRecord | None = optional()
    motion: GivenMotion | CouplerMotion | None = optional()
    separated_pairs: tuple[tuple[int, int], ...] | None = optional()
    ladder: Ladder | None = optional()
    markers: Mapping[str, Marker] | None = optional()
    parallelogram: Parallelogram | None = optional()
    darboux: Darboux | None = optional()
    m0: tuple[float, ...] | None = optional()
    mobility: Mobility | None = optional()
    counts: Counts | None = optional()

    @classmethod
    def matches(cls, d: Mapping) -> bool:
        return "counts" in d or "motion" in d or "curve" in d


RECORDS = (FourBarRecord, MultiLoop, PointsCandidate, FamilyMember, SixbarCandidate, Factorization)


@dataclass
class LinkageInfo(Record):
    """Everything a synthesis says about its linkage (module docstring). ``fit_summary`` (not written):
    a task synthesis's `FitSummary`, until `synth.synthesis.taskfit.annotate` turns it into ``fit``."""

    synthesis: typing.Any = None  # one of the records above (`RECORDS`), or None
    bennett: BennettParameters | None = optional()
    dh: tuple[DHRow, ...] | None = optional()
    relative_error: float | None = optional()  # the self-check's error relative to the pose spread
    condition_estimate: float | None = optional()  # `synth.synthesis.bennett.sensitivity` when it ran
    warnings: tuple[str, ...] | None = optional()
    fit: FitRecord | None = optional()
    design_choice: str | None = optional()  # which candidate the design choice kept, and why
    fit_summary: FitSummary | None = field(default=None, metadata={"internal": True})

    def to_dict(self) -> dict:
        """linkage.json's ``info``: the synthesis record's keys, then the other parts (a Hermite 6R's fit
        right after its record, where the interpolation it is belongs)."""
        out = {} if self.synthesis is None else self.synthesis.to_dict()
        rest = super().to_dict()
        rest.pop("synthesis", None)
        if "fit" in rest and getattr(self.synthesis, "task", None) == "hermite":
            out["fit"] = rest.pop("fit")
        out.update(rest)
        return out

    @classmethod
    def from_dict(cls, d: Mapping) -> LinkageInfo:
        own = {f.name for f in fields(cls)}
        kind = next((r for r in RECORDS if r.matches(d)), None)
        base = super().from_dict({k: v for k, v in d.items() if k in own})
        return replace(base, synthesis=None if kind is None else kind.from_dict(d))

    def with_synthesis(self, **changes) -> LinkageInfo:
        """A copy whose synthesis record has ``changes``."""
        return replace(self, synthesis=replace(self.synthesis, **changes))
