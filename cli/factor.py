"""`mpsynth factor FILE | --expr TEXT`: every factorization of a monic motion polynomial into linear
factors (revolute joints, or translations), from Algorithm 1 (docs/algorithm1.md).

The command is three steps, kept apart so that further modes (e.g. a ``--cofactor`` option for
non-generic input, issue 5) only add a branch in `compute`:

1. `load_input`  FILE / --expr  ->  `PolynomialInput` (rows of numbers or expression text, validated);
2. `compute`     PolynomialInput + mode flags  ->  `Report` (numeric or exact, the same shape);
3. `report_document` (``--json``) or `format_table` (default) print it on stdout.
"""
from __future__ import annotations

import json
import math
import os
import sys
from dataclasses import dataclass, field

import click

from .common import debug_option, json_option, print_json, run_guarded

FORMAT = "mpsynth.factorization/1"
MAX_FILE_BYTES = 10 * 1024 * 1024
MAX_DEGREE = 200
MAX_ABS = 1e12
TOP_KEYS = ("coefficients", "expression")

EPILOG = """\b
Input file (YAML or JSON; constant term first, monic):
  coefficients:            # rows [p0, p1, p2, p3, q0, q1, q2, q3] = p + eps q
    - [0, 1, 0, 2, -5, 0, 0, 0]
    - [-1, -1, -2, 0, 0, -3, -1, -1]
    - [1, 0, 0, 0, 0, 0, 0, 0]
or
  expression: "(t - i - eps j)(t - 1 - 2j - eps(3i + k))"
Numbers may be fractions written as strings ("3/4").

\b
Examples:
  mpsynth factor --expr "(t-1)*(t-j) - eps*((i+k)*t - 2*k)"
  mpsynth factor poly.yaml --json
  echo 'expression: (t-2k-eps i)(t-j-eps k)' | mpsynth factor - --exact
  mpsynth factor --cofactor --exact --expr "t^2 + 1 + eps*(i + 2*j*t)"   # C (t^2 + 1) = 4 rotations

\b
Output: C = (t - h1)(t - h2)...(t - hn) for each factorization. A revolute factor
rotates by theta(t) = 2 atan2(b, t - a) about its axis (theta = 0 at t = inf).
Exit codes: 0 factorizations found, 1 none exists (e.g. t^2 + 1 + eps(i + 2j t)),
2 bad input (not monic, not a motion polynomial, unparsable, ...)."""


# ============================================================== 1. input
@dataclass
class PolynomialInput:
    source: str  # file name, "<stdin>" or "--expr"
    rows: list | None = None  # raw rows of numbers (from `coefficients`)
    expression: str | None = None


def _input_error(msg: str):
    from synth.errors import InputError

    return InputError(msg)


def _read_text(path: str) -> tuple[str, str]:
    """(display name, text) of FILE or stdin ('-'), refusing more than 10 MB."""
    if path == "-":
        name = "<stdin>"
        stream = sys.stdin.buffer if hasattr(sys.stdin, "buffer") else None
        data = stream.read(MAX_FILE_BYTES + 1) if stream is not None else sys.stdin.read(MAX_FILE_BYTES + 1)
        if isinstance(data, str):
            data = data.encode("utf-8")
    else:
        name = path
        try:
            size = os.stat(path).st_size
        except FileNotFoundError:
            raise _input_error(f"{name}: no such file") from None
        except OSError as e:
            raise _input_error(f"{name}: cannot read ({e.strerror})") from None
        if os.path.isdir(path):
            raise _input_error(f"{name}: is a directory, expected a YAML or JSON file")
        if size > MAX_FILE_BYTES:
            raise _input_error(f"{name}: file is {size / 1e6:.1f} MB, larger than the 10 MB limit; refusing to read it")
        try:
            with open(path, "rb") as fh:
                data = fh.read(MAX_FILE_BYTES + 1)
        except OSError as e:
            raise _input_error(f"{name}: cannot read ({e.strerror})") from None
    if len(data) > MAX_FILE_BYTES:
        raise _input_error(f"{name}: input is larger than the 10 MB limit; refusing to read it")
    try:
        return name, data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _input_error(f"{name}: not UTF-8 text") from None



def _parse_document(name: str, text: str):
    stripped = text.lstrip()
    if name.lower().endswith(".json") or stripped.startswith("{"):
        try:
            from synth.io.docload import json_object_pairs

            return json.loads(text, object_pairs_hook=json_object_pairs)
        except ValueError as e:
            if name.lower().endswith(".json"):
                raise _input_error(f"{name}: invalid JSON: {e}") from None
            # not JSON after all: YAML flow mappings also start with '{'
    import yaml

    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or "syntax error"
        raise _input_error(f"{name}: invalid YAML{where}: {problem}") from None


def _check_rows(name: str, rows) -> list:
    if not isinstance(rows, list):
        raise _input_error(f"{name}: 'coefficients' must be a list of rows of 8 numbers "
                           f"(constant term first), got {type(rows).__name__}")
    if len(rows) < 2:
        raise _input_error(f"{name}: 'coefficients' needs at least 2 rows (degree >= 1), got {len(rows)}")
    if len(rows) > MAX_DEGREE + 1:
        raise _input_error(f"{name}: degree {len(rows) - 1} exceeds the maximum of {MAX_DEGREE}")
    for k, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != 8:
            got = f"{len(row)} entries" if isinstance(row, list) else f"a {type(row).__name__}"
            raise _input_error(f"{name}: coefficients row {k} (coefficient of t^{k}) must hold 8 numbers "
                               f"[p0, p1, p2, p3, q0, q1, q2, q3], got {got}")
    return rows


def load_input(file: str | None, expr: str | None) -> PolynomialInput:
    """Read FILE ('-' = stdin) or take --expr; check the document's shape (not the numbers yet)."""
    if file is not None and expr is not None:
        raise _input_error("give either FILE or --expr, not both")
    if file is None and expr is None:
        raise _input_error("give a FILE (YAML or JSON, '-' for stdin) or --expr TEXT; see --help")
    if expr is not None:
        return PolynomialInput(source="--expr", expression=expr)
    name, text = _read_text(file)
    doc = _parse_document(name, text)
    if not isinstance(doc, dict):
        got = "an empty document" if doc is None else f"a {type(doc).__name__}"
        raise _input_error(f"{name}: expected a mapping with 'coefficients' or 'expression', got {got}")
    unknown = [k for k in doc if k not in TOP_KEYS]
    if unknown:
        import difflib

        k = unknown[0]
        close = difflib.get_close_matches(str(k), TOP_KEYS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else " (allowed: 'coefficients' or 'expression')"
        raise _input_error(f"{name}: unknown key {str(k)!r}{hint}")
    present = [k for k in TOP_KEYS if k in doc]
    if len(present) != 1:
        which = "both 'coefficients' and 'expression'" if present else "neither 'coefficients' nor 'expression'"
        raise _input_error(f"{name}: the file has {which}; give exactly one")
    if present[0] == "expression":
        text = doc["expression"]
        if not isinstance(text, str):
            raise _input_error(f"{name}: 'expression' must be text, got {type(text).__name__}")
        return PolynomialInput(source=name, expression=text)
    return PolynomialInput(source=name, rows=_check_rows(name, doc["coefficients"]))


def _float_rows(inp: PolynomialInput):
    """The numeric polynomial (n+1, 8) of the input."""
    import numpy as np

    from synth.algebra.exact import to_fraction

    if inp.expression is not None:
        from synth.algebra.expr import parse_polynomial

        return parse_polynomial(inp.expression, max_degree=MAX_DEGREE, source=f"{inp.source}: expression"
                                if inp.source != "--expr" else "--expr")
    out = np.empty((len(inp.rows), 8))
    for k, row in enumerate(inp.rows):
        for d, x in enumerate(row):
            what = f"{inp.source}: coefficients row {k}, entry {d}"
            if isinstance(x, bool) or not isinstance(x, (int, float, str)):
                raise _input_error(f"{what}: expected a number, got {type(x).__name__ if x is not None else 'null'}")
            if isinstance(x, str):
                x = to_fraction(x, what)
            try:
                v = float(x)
            except OverflowError:
                v = math.inf
            if not math.isfinite(v):
                raise _input_error(f"{what}: {x!r} is not a finite number (NaN and infinity are not allowed)")
            if abs(v) > MAX_ABS:
                raise _input_error(f"{what}: {v:g} is too large (|x| <= {MAX_ABS:g})")
            out[k, d] = v
    return out


def _exact_rows(inp: PolynomialInput):
    from synth.algebra.exact import to_fraction

    if inp.expression is not None:
        from synth.algebra.expr import parse_polynomial

        return parse_polynomial(inp.expression, exact=True, max_degree=MAX_DEGREE,
                                source=f"{inp.source}: expression" if inp.source != "--expr" else "--expr")
    rows = []
    for k, row in enumerate(inp.rows):
        out = []
        for d, x in enumerate(row):
            what = f"{inp.source}: coefficients row {k}, entry {d}"
            if x is None:
                raise _input_error(f"{what}: expected a number, got null")
            out.append(to_fraction(x, what))
        rows.append(out)
    return rows


# ============================================================== 2. compute
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


def _clean(v) -> list:
    """Floats without negative zeros."""
    return [float(x) + 0.0 for x in v]


def _joint(h_float, quadratic) -> Joint:
    import numpy as np

    from synth.algebra.factorize import classify

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
    import numpy as np

    from synth.algebra.factorize import factorize

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
    from synth.algebra.exact import factorize_exact

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


def _prefixed(source: str, func, *args):
    """Run a validation step, prefixing its InputError message with the input's name."""
    from synth.errors import InputError

    try:
        return func(*args)
    except InputError as e:
        msg = str(e)
        if msg.startswith(source + ":") or source == "--expr" and msg.startswith("--expr"):
            raise
        raise InputError(f"{source}: {msg}") from None


def compute(inp: PolynomialInput, *, exact: bool = False) -> Report:
    """Factor the input. Numeric (default) or exact rational arithmetic. Raises InputError (exit 2)
    for invalid polynomials, NotGenericError / NoFactorizationError / SynthesisError (exit 1) when
    no factorization is found. (A --cofactor mode for non-generic input would branch here.)"""
    if exact:
        from synth.algebra.exact import check_exact_motion_polynomial

        C = _exact_rows(inp)
        _prefixed(inp.source, check_exact_motion_polynomial, C)
        return _exact_report(C)
    from synth.algebra.factorize import check_motion_polynomial

    C = _float_rows(inp)
    _prefixed(inp.source, check_motion_polynomial, C)
    return _numeric_report(C)


@dataclass
class CofactorInfo:
    """--cofactor: C R = (t - h1)...(t - hm) with the real monic co-factor R (Theorem 2, issue 5)."""
    R: list  # ascending coefficients (floats, or Fractions in exact mode)
    mrpf: list  # maximal real factor of the primal part, ascending
    bound_met: bool  # deg R <= deg mrpf
    components: list  # per primary translation: kind ("circular", "ellipse", ...), deg R, rotations


def compute_cofactor(inp: PolynomialInput, *, exact: bool = False) -> tuple[Report, CofactorInfo]:
    """--cofactor: one factorization of C R (synth.algebra.cofactor). The report's polynomial is C R. Exact mode
    prints fractions when the rationalized answer passes an exact multiply-back check (otherwise
    floats, with a note). Unbounded motions raise UnboundedMotionError (exit 1, "needs a sliding joint")."""
    import numpy as np

    from synth.algebra.cofactor import exact_result, factorize_with_cofactor
    from synth.algebra.factorize import check_motion_polynomial
    from synth.algebra.polynomial import norm_poly, poly_mul

    C = _float_rows(inp)
    _prefixed(inp.source, check_motion_polynomial, C)
    try:
        Cx = _exact_rows(inp)  # exact mrpf detection for rational input
    except Exception:  # noqa: BLE001 - e.g. a float that is not a finite rational: numeric detection
        Cx = None
    res = factorize_with_cofactor(Cx if Cx is not None else C)
    factors, R, notes = np.asarray(res.factors).tolist(), [float(x) for x in res.R], []
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
                 coefficients=CR.tolist(), notes=notes)
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
    from synth.algebra.realfactor import poly_text

    deg_r, deg_g = len(info.R) - 1, len(info.mrpf) - 1
    head = [f"real co-factor R = {poly_text(info.R)} (deg R = {deg_r}, mrpf of the primal part = "
            f"{poly_text(info.mrpf)}, deg {deg_g}{'' if info.bound_met else '; above the bound'})",
            "C R = (t - h1)...(t - h" + str(rep.degree) + ") is the same motion as C; components: "
            + (", ".join(c.get("kind", "?") for c in info.components) or "none (generic)")]
    body = format_table(rep).splitlines()[1:]  # its first line would describe C R, not C
    body = [line.replace("N(C) =", "N(C R) =", 1).replace("C = (t", "C R = (t", 1) for line in body]
    return "\n".join(head + body + rep.notes)


# ============================================================== 3. output
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
    }


def fmt_num(x, scale: float = 1.0) -> str:
    """Short text of a number: Fractions exactly ("-4/3"), floats with 6 significant digits, values
    below 1e-12 of the scale as 0."""
    from fractions import Fraction

    if isinstance(x, Fraction):
        return str(x)
    x = float(x)
    if abs(x) <= 1e-12 * max(1.0, scale):
        return "0"
    s = f"{x:.6g}"
    return s


def _coef_unit(c: str, unit: str) -> str:
    """Coefficient text times a unit name: '2j', '-i', '4/3 i', '1e-05 k'."""
    if unit == "":
        return c
    if c == "1":
        return unit
    if c == "-1":
        return "-" + unit
    plain = all(ch.isdigit() or ch in ".-" for ch in c)
    return f"{c}{unit}" if plain else f"{c} {unit}"


def _join_terms(terms: list[str]) -> str:
    out = ""
    for t in terms:
        if not out:
            out = t
        elif t.startswith("-"):
            out += " - " + t[1:]
        else:
            out += " + " + t
    return out


def fmt_dq(h) -> str:
    """A dual quaternion in the expression language: '1 + 2j + eps(3i + k)', '-1/3 i + eps(14/9 i)'."""
    from fractions import Fraction

    exact = any(isinstance(x, Fraction) for x in h)
    scale = 1.0 if exact else max(1.0, max(abs(float(x)) for x in h))
    units = ("", "i", "j", "k")

    def part(vals):
        terms = []
        for v, u in zip(vals, units):
            c = fmt_num(v, scale)
            if c != "0":
                terms.append(_coef_unit(c, u))
        return terms

    p, q = part(h[:4]), part(h[4:])
    terms = list(p)
    if len(q) == 1 and q[0].lstrip("-") in ("i", "j", "k"):  # eps i, -eps k
        terms.append(q[0].replace(q[0].lstrip("-"), "eps " + q[0].lstrip("-")))
    elif len(q) == 1 and fmt_num(h[4], scale) != "0":  # a scalar dual part: -5 eps
        terms.append(f"{q[0]} eps")
    elif q:
        terms.append(f"eps({_join_terms(q)})")
    return _join_terms(terms) or "0"


def fmt_quadratic(q) -> str:
    c0, c1 = q
    s1, s0 = fmt_num(c1, 1.0), fmt_num(c0, 1.0)
    text = "t^2"
    if s1 != "0":
        text += f" - {s1[1:]} t" if s1.startswith("-") else f" + {s1} t"
    if s0 != "0":
        text += f" - {s0[1:]}" if s0.startswith("-") else f" + {s0}"
    return text


def _vec(v) -> str:
    return "(" + ", ".join(fmt_num(x, 1.0) for x in v) + ")"


def _t_minus(a) -> str:
    s = fmt_num(a)
    if s == "0":
        return "t"
    return f"t + {s[1:]}" if s.startswith("-") else f"t - {s}"


def format_table(rep: Report) -> str:
    """The default human-readable output."""
    lines = []
    kind = "exact" if rep.exact else "numeric"
    nf = "".join(f"({fmt_quadratic(q)})" for q in rep.norm_factors)
    lines.append(f"motion polynomial of degree {rep.degree}, {'generic' if rep.generic else 'NOT generic (the primal part has a real factor)'}")
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
                law = f"theta(t) = 2 atan2({fmt_num(j.b)}, {_t_minus(j.a)})"
                row = [str(fi), str(i), fmt_dq(h), "revolute", _vec(j.point), _vec(j.direction), law]
            else:
                tm = _t_minus(j.a)
                law = (f"shift(t) = {fmt_num(j.speed)}/{tm if tm == 't' else '(' + tm + ')'}" if j.speed
                       else "identity (real factor)")
                row = [str(fi), str(i), fmt_dq(h), "translation", "-", _vec(j.direction), law]
            table.append(row)
    widths = [max(len(r[c]) for r in table) for c in range(len(header))]
    for r in table:
        lines.append("  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip())
    if not rep.exact and rep.factorizations:
        worst = max(fz.residual for fz in rep.factorizations)
        lines.append("")
        lines.append(f"multiply-back check: max relative error {worst:.1e}")
    if any(j.kind == "translation" for fz in rep.factorizations for j in fz.joints):
        lines.append("translation factors are prismatic joints: the point moves by shift(t) along the direction")
    return "\n".join(lines)


# ============================================================== command
@click.command(epilog=EPILOG)
@click.argument("file", required=False, metavar="[FILE]")
@click.option("--expr", "expr", metavar="TEXT",
              help="The polynomial as an expression in t, i, j, k, eps instead of a FILE.")
@click.option("--exact", is_flag=True,
              help="Exact rational arithmetic (rational input whose norm factors over Q); prints fractions.")
@click.option("--cofactor", is_flag=True,
              help="Non-generic input (the primal part has a real factor): find a real co-factor R with "
                   "C R = (t - h1)...(t - hm), the same motion (Theorem 2). Unbounded motions: exit 1.")
@json_option
@debug_option
@run_guarded
def factor(file, expr, exact, cofactor, as_json, debug):
    """Factorize the monic motion polynomial C in FILE (YAML or JSON, '-' for stdin) or --expr into
    linear factors C = (t - h1)...(t - hn): every factorization (n! when the norm's quadratic
    factors are distinct), each factor a revolute joint (axis, angle law) or a translation."""
    inp = load_input(file, expr)
    if cofactor:
        rep, info = compute_cofactor(inp, exact=exact)
        if as_json:
            print_json(cofactor_document(rep, info))
        else:
            click.echo(format_cofactor(rep, info))
        return
    rep = compute(inp, exact=exact)
    if as_json:
        print_json(report_document(rep))
    else:
        click.echo(format_table(rep))
