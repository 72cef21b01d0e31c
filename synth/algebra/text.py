"""Text of numbers, dual quaternions, real quadratics and real polynomials as the CLI prints them, in the expression
language of `synth.algebra.expr` (``1 + 2j + eps(3i + k)``, ``t^2 - 2 t + 5``). Fractions print exactly
("-4/3"); floats with ``digits`` significant digits, values below 1e-12 of the scale as 0. Conventions
of the dual quaternion layout: docs/conventions.md."""
from __future__ import annotations

from fractions import Fraction


def fmt_num(x, scale: float = 1.0, digits: int = 6) -> str:
    """Short text of a number: Fractions exactly ("-4/3"), floats with ``digits`` significant digits,
    values below 1e-12 of the scale as 0."""
    if isinstance(x, Fraction):
        return str(x)
    x = float(x)
    if abs(x) <= 1e-12 * max(1.0, scale):
        return "0"
    return f"{x:.{digits}g}"


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


def fmt_dq(h, digits: int = 6) -> str:
    """A dual quaternion in the expression language: '1 + 2j + eps(3i + k)', '-1/3 i + eps(14/9 i)'."""
    exact = any(isinstance(x, Fraction) for x in h)
    scale = 1.0 if exact else max(1.0, max(abs(float(x)) for x in h))
    units = ("", "i", "j", "k")

    def part(vals):
        terms = []
        for v, u in zip(vals, units):
            c = fmt_num(v, scale, digits)
            if c != "0":
                terms.append(_coef_unit(c, u))
        return terms

    p, q = part(h[:4]), part(h[4:])
    terms = list(p)
    if len(q) == 1 and q[0].lstrip("-") in ("i", "j", "k"):  # eps i, -eps k
        terms.append(q[0].replace(q[0].lstrip("-"), "eps " + q[0].lstrip("-")))
    elif len(q) == 1 and fmt_num(h[4], scale, digits) != "0":  # a scalar dual part: -5 eps
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


def fmt_vec(v) -> str:
    """'(1, 0, -2.5)'."""
    return "(" + ", ".join(fmt_num(x, 1.0) for x in v) + ")"


def fmt_t_minus(a) -> str:
    """'t - 2', 't + 1/3', 't'."""
    s = fmt_num(a)
    if s == "0":
        return "t"
    return f"t + {s[1:]}" if s.startswith("-") else f"t - {s}"


def poly_text(c, var: str = "t", digits: int = 6) -> str:
    """Human text of a real polynomial (ascending Fractions or floats), highest power first:
    't^2 + 1', '3/4*t - 2', '0.5 t'. Float coefficients below 1e-12 of the largest are left out."""
    terms = []
    big = max((abs(float(a)) for a in c), default=0.0)
    for k in range(len(c) - 1, -1, -1):
        a = c[k]
        if a == 0 or (not isinstance(a, Fraction) and abs(float(a)) <= 1e-12 * big):
            continue
        if isinstance(a, Fraction):
            mag = abs(a)
            s = str(mag)
        else:
            mag = abs(float(a))
            s = f"{mag:.{digits}g}"
        sign = "-" if a < 0 else "+"
        mon = "" if k == 0 else (var if k == 1 else f"{var}^{k}")
        if k > 0 and mag == 1:
            body = mon
        elif k > 0:
            body = f"{s}*{mon}" if "/" in s else f"{s} {mon}"
        else:
            body = s
        terms.append((sign, body))
    if not terms:
        return "0"
    out = ("-" if terms[0][0] == "-" else "") + terms[0][1]
    for sign, body in terms[1:]:
        out += f" {sign} {body}"
    return out
