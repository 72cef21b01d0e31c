"""Everything `mpsynth factor` prints, computed and formatted here (the CLI only parses its options,
calls `compute` / `compute_cofactor` and prints): every factorization of a monic motion polynomial into
linear factors (docs/algorithm1.md), numeric or exact, or with ``--cofactor`` one factorization of C R
with a real co-factor R (docs/exceptional.md).

`Report` holds the numbers; `report_document` / `cofactor_document` give the ``--json`` document (format
``mpsynth.factorization/1``), `format_table` / `format_cofactor` the text. Units: those of the input.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from synth.algebra.cofactor import exact_result, factorize_with_cofactor
from synth.algebra.exact import check_exact_motion_polynomial, factorize_exact
from synth.algebra.factorize import check_motion_polynomial, classify, factorize
from synth.algebra.family import factorization_family, family_text
from synth.algebra.polyinput import PolynomialInput, exact_rows, float_rows, monic_input, prefixed
from synth.algebra.polynomial import norm_poly, poly_mul
from synth.algebra.text import fmt_dq, fmt_num, fmt_quadratic, fmt_t_minus, fmt_vec, poly_text
from synth.errors import InputError, NotGenericError

FORMAT = "mpsynth.factorization/1"


@dataclass
class Joint:
    kind: str  # "revolute" or "translation"
    a: float
    b: float  # |vec(primal h)|; 0 for a translation
    quadratic: tuple  # N(t - h) = t^2 + c1 t + c0 as (c0, c1) (numbers as in Report.exact)
    point: list | None = None  # revolute: axis point closest to the origin
    direction: list | None = None  # revolute: unit axis u; translation: unit direction of w
    moment: list | None = None  # revolute: Plücker moment m = point x u
    speed: float | None = None  # translation: the point moves by speed / (t - a) along direction


@dataclass
class FactorizationRow:
    factors: list  # n dual quaternions (8 floats or 8 Fractions)
    joints: list  # Joint per factor
    residual: float  # multiply-back relative error (0 in exact mode)


@dataclass
class Report:
    exact: bool
    degree: int
    generic: bool
    norm: list  # N(C), ascending
    norm_factors: list  # (c0, c1) per quadratic, with repetition (degree entries)
    factorizations: list
    coefficients: list  # C, rows of 8
    failed_orders: int = 0
    notes: list = field(default_factory=list)
    leading: list | None = None  # the leading coefficient C was divided by (None: C was monic)
    family: dict | None = None  # a continuum of factorizations through the first one (synth.algebra.family)


def _clean(v) -> list:
    """Floats without negative zeros."""
    return [float(x) + 0.0 for x in v]


def _joint(h_float, quadratic) -> Joint:
    h = np.asarray(h_float, float)
    f = classify(h)
    a, b = f.a, f.b
    if f.kind == "revolute":
        u, m = f.line
        p = np.cross(u, m)
        return Joint("revolute", a + 0.0, b, quadratic, point=_clean(p), direction=_clean(u), moment=_clean(m))
    w = h[5:8]
    nw = float(np.linalg.norm(w))
    d = _clean(w / nw) if nw > 0 else [0.0, 0.0, 0.0]
    return Joint("translation", a + 0.0, b, quadratic, direction=d, speed=2 * nw)


def _numeric_report(C) -> Report:
    res = factorize(C)
    quads = [(float(c0), float(c1)) for c0, c1 in res.quadratics]
    rows = []
    for fz in res.factorizations:
        joints = [_joint(h, quads[q]) for h, q in zip(fz.factors, fz.order)]
        rows.append(FactorizationRow(factors=np.asarray(fz.factors).tolist(), joints=joints, residual=fz.residual))
    return Report(exact=False, degree=C.shape[0] - 1, generic=bool(res.generic),
                  norm=[float(x) for x in res.norm],
                  norm_factors=[q for q, m in zip(quads, res.multiplicity) for _ in range(m)],
                  factorizations=rows, coefficients=np.asarray(C).tolist(),
                  failed_orders=len(res.failed_orders))


def _exact_report(C) -> Report:
    res = factorize_exact(C)
    rows = []
    for fz in res.factorizations:
        joints = [_joint([float(x) for x in h], res.quadratics[q]) for h, q in zip(fz.factors, fz.order)]
        for j, kind in zip(joints, fz.kinds):  # the exact zero test decides the kind
            if j.kind != kind:  # pragma: no cover - only for |v| below the float threshold
                j.kind = kind
        rows.append(FactorizationRow(factors=[list(h) for h in fz.factors], joints=joints, residual=0.0))
    return Report(exact=True, degree=len(res.C) - 1, generic=bool(res.generic), norm=list(res.norm),
                  norm_factors=[q for q, m in zip(res.quadratics, res.multiplicity) for _ in range(m)],
                  factorizations=rows, coefficients=[list(r) for r in res.C],
                  failed_orders=len(res.failed_orders))


def compute(inp: PolynomialInput, *, exact: bool = False) -> Report:
    """Factor the input. Numeric (default) or exact rational arithmetic. Raises InputError (exit 2)
    for invalid polynomials, NotGenericError / NoFactorizationError / SynthesisError (exit 1) when
    no factorization is found."""
    try:
        if exact:
            C, L = prefixed(inp.source, monic_input, exact_rows(inp), True)
            prefixed(inp.source, check_exact_motion_polynomial, C)
            rep = _exact_report(C)
        else:
            C, L = prefixed(inp.source, monic_input, float_rows(inp))
            prefixed(inp.source, check_motion_polynomial, C)
            rep = _numeric_report(C)
    except NotGenericError:
        rep = _family_report(inp, exact)
        if rep is None:
            raise
        return rep
    if L is not None:
        rep.leading = list(L)
        rep.notes.append(monic_note(L))
    return rep


def monic_note(L) -> str:
    """The sentence that says C was divided by its leading coefficient L."""
    if all(x == 0 for x in L[1:]):
        return (f"C was not monic: divided by its leading coefficient {fmt_num(L[0], digits=12)} "
                "(a real number: the same motion)")
    return (f"C was not monic: C = L (t - h1)...(t - hn) with L = {fmt_dq(L, 12)}; the factors are those of "
            "L^-1 C (the same motion seen from the base frame moved by L^-1)")


def _family_report(inp: PolynomialInput, exact: bool) -> Report | None:
    """A non-generic C that factors without a co-factor (R = 1) and whose factorization lies in a
    continuous family (e.g. the circular translation, survey eq. (5)): the report of that family, or
    None (then C has no factorization found without a co-factor)."""
    try:
        rep, info = compute_cofactor(inp, exact=exact)
    except Exception:  # noqa: BLE001 - any failure here means: report the original NotGenericError
        return None
    if len(info.R) != 1 or rep.family is None:
        return None
    rep.notes.append("infinitely many factorizations: a continuous family (the primal part has the real factor "
                     f"{poly_text(info.mrpf)}); the table shows one member")
    return rep


@dataclass
class CofactorInfo:
    """--cofactor: C R = (t - h1)...(t - hm) with the real monic co-factor R (Theorem 2, docs/exceptional.md)."""
    R: list  # ascending coefficients (floats, or Fractions in exact mode)
    mrpf: list  # maximal real factor of the primal part, ascending
    bound_met: bool  # deg R <= deg mrpf
    components: list  # per primary translation: kind ("circular", "ellipse", ...), deg R, rotations


def compute_cofactor(inp: PolynomialInput, *, exact: bool = False) -> tuple[Report, CofactorInfo]:
    """--cofactor: one factorization of C R (`synth.algebra.cofactor`). The report's polynomial is C R. Exact mode
    prints fractions when the rationalized answer passes an exact multiply-back check (otherwise
    floats, with a note). Unbounded motions raise UnboundedMotionError (exit 1, "needs a sliding joint")."""
    C, L = prefixed(inp.source, monic_input, float_rows(inp))
    prefixed(inp.source, check_motion_polynomial, C)
    try:
        Cx = exact_rows(inp)  # exact mrpf detection for rational input
        Cx = monic_input(Cx, True)[0]
    except InputError:  # e.g. a float that is not a finite rational: numeric detection
        Cx = None
    res = factorize_with_cofactor(Cx if Cx is not None else C)
    factors, R = np.asarray(res.factors).tolist(), [float(x) for x in res.R]
    notes = [] if L is None else [monic_note(L)]
    is_exact = False
    if exact:
        got = exact_result(Cx, res) if Cx is not None else None
        if got is not None:
            R, factors = got
            is_exact = True
        else:
            notes.append("--exact: the co-factor answer is not rational (or not certified); floats shown")
    R8 = np.zeros((len(res.R), 8))
    R8[:, 0] = res.R
    CR = poly_mul(C, R8)
    joints = []
    for h in factors:
        hf = [float(x) for x in h]
        a, b2 = h[0], sum(x * x for x in h[1:4])
        joints.append(_joint(hf, (a * a + b2, -2 * a)))
    row = FactorizationRow(factors=factors, joints=joints, residual=0.0 if is_exact else res.residual)
    norm = [float(x) for x in norm_poly(CR)]
    rep = Report(exact=is_exact, degree=len(factors), generic=res.generic, norm=norm,
                 norm_factors=[j.quadratic for j in joints], factorizations=[row],
                 coefficients=CR.tolist(), notes=notes, leading=None if L is None else list(L),
                 family=factorization_family(np.asarray(res.factors, float)))
    info = CofactorInfo(R=R, mrpf=[float(x) for x in res.g], bound_met=res.bound_met,
                        components=[{k: v for k, v in c.items() if k != "family"} for c in res.report])
    return rep, info


def cofactor_document(rep: Report, info: CofactorInfo) -> dict:
    """report_document of C R plus "cofactor" (coefficients of R, ascending), "mrpf", "bound_met"."""
    doc = report_document(rep)
    doc["cofactor"] = [_num_json(x, rep.exact) for x in info.R]
    doc["mrpf"] = info.mrpf
    doc["bound_met"] = info.bound_met
    doc["components"] = info.components
    doc["notes"] = rep.notes
    return doc


def format_cofactor(rep: Report, info: CofactorInfo) -> str:
    """The text of --cofactor: R and mrpf, then the table of C R."""
    deg_r, deg_g = len(info.R) - 1, len(info.mrpf) - 1
    head = [f"real co-factor R = {poly_text(info.R)} (deg R = {deg_r}, mrpf of the primal part = "
            f"{poly_text(info.mrpf)}, deg {deg_g}{'' if info.bound_met else '; above the bound'})",
            "C R = (t - h1)...(t - h" + str(rep.degree) + ") is the same motion as C; components: "
            + (", ".join(c.get("kind", "?") for c in info.components) or "none (generic)")]
    body = format_table(rep).splitlines()[1:]  # its first line would describe C R, not C
    body = [line.replace("N(C) =", "N(C R) =", 1).replace("C = (t", "C R = (t", 1) for line in body]
    return "\n".join(head + body + [n for n in rep.notes if n not in body])


def _num_json(x, exact: bool):
    if exact:
        return str(x)
    return float(x)


def report_document(rep: Report) -> dict:
    """The --json document (format mpsynth.factorization/1). Exact mode writes every exact number as a
    string ("3/4", "-2"); axis geometry involves square roots and stays floating point."""
    ex = rep.exact

    def dq(h):
        return [_num_json(x, ex) for x in h]

    def joint(j: Joint) -> dict:
        d = {"kind": j.kind, "norm_factor": [_num_json(j.quadratic[0], ex), _num_json(j.quadratic[1], ex)],
             "a": j.a, "b": j.b}
        if j.kind == "revolute":
            d.update(point=j.point, direction=j.direction, moment=j.moment)
        else:
            d.update(direction=j.direction, speed=j.speed)
        return d

    return {
        "format": FORMAT,
        "degree": rep.degree,
        "generic": rep.generic,
        "exact": ex,
        "coefficients": [dq(r) for r in rep.coefficients],
        "norm": [_num_json(x, ex) for x in rep.norm],
        "norm_factors": [[_num_json(c0, ex), _num_json(c1, ex)] for c0, c1 in rep.norm_factors],
        "factorizations": [
            {"factors": [dq(h) for h in fz.factors], "residual": fz.residual,
             "joints": [joint(j) for j in fz.joints]}
            for fz in rep.factorizations
        ],
        "failed_orders": rep.failed_orders,
        **({"leading_coefficient": dq(rep.leading)} if rep.leading is not None else {}),
        **({"notes": list(rep.notes)} if rep.notes else {}),
        **({"family": _family_json(rep.family)} if rep.family is not None else {}),
    }


def _family_json(fam: dict) -> dict:
    """The family of factorizations in the --json document: parameter names, pairs (1-based), the basis
    of the offset s of each pair, the base member, and the rule (docs/exceptional.md)."""
    rules = []
    for p, (a, b) in enumerate(fam["pairs"]):
        f, g = fam["parameters"][2 * p], fam["parameters"][2 * p + 1]
        rules.append(f"h{a} - eps*({f}*e1 + {g}*e2), h{b} + eps*({f}*e1 + {g}*e2)")
    return {"parameters": fam["parameters"], "dimension": fam["dimension"], "pairs": fam["pairs"],
            "basis": fam["basis"], "base_factors": fam["factors"],
            "factors": rules,
            "description": "every member multiplies to the same polynomial: for each pair (a, b), "
                           "h_a -> h_a - eps s, h_b -> h_b + eps s, s = f e1 + g e2 perpendicular to the axis"}


def format_table(rep: Report) -> str:
    """The default human-readable output."""
    lines = []
    kind = "exact" if rep.exact else "numeric"
    nf = "".join(f"({fmt_quadratic(q)})" for q in rep.norm_factors)
    generic = "generic" if rep.generic else "NOT generic (the primal part has a real factor)"
    lines.append(f"motion polynomial of degree {rep.degree}, {generic}")
    lines.append(f"N(C) = {nf}")
    n_f = len(rep.factorizations)
    hs = "".join(f"(t - h{i + 1})" for i in range(rep.degree))
    lines.append(f"C = {hs}: {n_f} factorization{'s' if n_f != 1 else ''} ({kind} arithmetic)")
    if rep.failed_orders:
        lines.append(f"({rep.failed_orders} order(s) of the norm factors gave no factorization)")
    lines.append("")
    header = ["#", "i", "h_i", "kind", "axis point", "axis direction", "law"]
    table = [header]
    for fi, fz in enumerate(rep.factorizations, 1):
        for i, (h, j) in enumerate(zip(fz.factors, fz.joints), 1):
            if j.kind == "revolute":
                law = f"theta(t) = 2 atan2({fmt_num(j.b)}, {fmt_t_minus(j.a)})"
                row = [str(fi), str(i), fmt_dq(h), "revolute", fmt_vec(j.point), fmt_vec(j.direction), law]
            else:
                tm = fmt_t_minus(j.a)
                law = (f"shift(t) = {fmt_num(j.speed)}/{tm if tm == 't' else '(' + tm + ')'}" if j.speed
                       else "identity (real factor)")
                row = [str(fi), str(i), fmt_dq(h), "translation", "-", fmt_vec(j.direction), law]
            table.append(row)
    widths = [max(len(r[c]) for r in table) for c in range(len(header))]
    for r in table:
        lines.append("  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip())
    if not rep.exact and rep.factorizations:
        worst = max(fz.residual for fz in rep.factorizations)
        lines.append("")
        lines.append(f"multiply-back check: max relative error {worst:.1e}")
    if rep.family is not None:
        lines.append("")
        lines.append(f"a continuum of factorizations ({rep.family['dimension']} real parameters): every member "
                     "has the same product")
        shown = dict(rep.family, factors=rep.factorizations[0].factors) if rep.factorizations else rep.family
        lines += family_text(shown, fmt_dq, fmt_vec)
    if any(j.kind == "translation" for fz in rep.factorizations for j in fz.joints):
        lines.append("translation factors are prismatic joints: the point moves by shift(t) along the direction")
    lines.extend(rep.notes)
    return "\n".join(lines)
