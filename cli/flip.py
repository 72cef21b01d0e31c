"""`mpsynth flip M H`: the Bennett flip (t - m)(t - h) = (t - k)(t - n) (docs/exceptional.md)."""
from __future__ import annotations

import re
from fractions import Fraction

import click

from .common import debug_option, json_option, print_json, run_guarded

FORMAT = "mpsynth.flip/1"

EPILOG = """\b
M and H are the rotation factors t - m, t - h, each given as
  - 8 numbers p0 p1 p2 p3 q0 q1 q2 q3 (= p + eps q), e.g. "[1, 2, 0, 0, 0, 0, 3, 0]" or "1,2,0,0,0,0,3,0"
    (fractions as "3/4"), or
  - an expression in i, j, k, eps (e.g. "1 + 2i + 3 eps j"), or the factor itself ("t - 1 - 2i - 3eps j").
Rational input gives exact rational output.

\b
Example:
  mpsynth flip "1 + 2i + 3eps j" "k + eps(i + j)"
    k = 2/3 i - 2/3 j - 1/3 k + eps(14/9 i + 10/9 j + 8/9 k)
    n = 1 + 4/3 i + 2/3 j + 4/3 k + eps(-5/9 i + 26/9 j - 8/9 k)

\b
The four axes m, h, n, k (in this loop order) form a Bennett linkage; N(t-n) = N(t-m), N(t-k) = N(t-h).
Exit codes: 0 flipped, 1 the flip does not exist (primal(h) = conj(primal(m)): a translation),
2 bad input (not 8 numbers / not a rotation)."""

_LIST = re.compile(r"^\s*\[?\s*([^\[\]]*?)\s*\]?\s*$")


def parse_factor(text: str, what: str):
    """The dual quaternion m of the rotation factor t - m from TEXT (8 numbers or an expression).
    Returns 8 Fractions (exact) or 8 floats. Raises InputError."""
    from synth.errors import InputError
    from synth.algebra.expr import parse_polynomial

    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{what}: empty")
    stripped = text.strip()
    if stripped.startswith("[") or "," in stripped:
        body = _LIST.match(stripped)
        items = [x for x in re.split(r"[,\s]+", body.group(1) if body else stripped) if x]
        if len(items) != 8:
            raise InputError(f"{what}: expected 8 numbers p0 p1 p2 p3 q0 q1 q2 q3, got {len(items)}")
        out = []
        for k, item in enumerate(items):
            try:
                v = Fraction(item)
            except (ValueError, ZeroDivisionError):
                try:
                    v = float(item)
                except ValueError:
                    raise InputError(f"{what}: entry {k} ({item!r}) is not a number") from None
                if v != v or v in (float("inf"), float("-inf")):
                    raise InputError(f"{what}: entry {k} is not finite") from None
            out.append(v)
        return out
    rows = parse_polynomial(stripped, exact=True, max_degree=1, source=what)
    if len(rows) == 1:
        return list(rows[0])
    lead = rows[1]
    if lead != [1] + [0] * 7:
        raise InputError(f"{what}: a factor in t must be monic linear, 't - m'")
    return [-x for x in rows[0]]


def _check_rotation(h, what):
    from synth.errors import InputError
    from synth.algebra.flip import is_rotation

    if not is_rotation(h):
        v = [float(x) for x in h[1:4]]
        if all(x == 0 for x in v):
            why = "its primal vector part is zero (t - m would be a translation or a real factor)"
        elif float(h[4]) != 0:
            why = "its dual scalar part is not zero (not a motion polynomial)"
        else:
            vw = sum(float(a) * float(b) for a, b in zip(h[1:4], h[5:8]))
            why = f"the axis condition v . w = 0 fails (v . w = {vw:.6g})"
        raise InputError(f"{what}: t - m is not a rotation: {why}")


def _num(x) -> str:
    if isinstance(x, Fraction):
        return str(x)
    x = float(x)
    return "0" if x == 0 else f"{x:.12g}"


def fmt_dq(h) -> str:
    """'1 + 4/3 i + eps(-5/9 i + 26/9 j)' style text of 8 numbers."""
    def terms(vals, units):
        out = []
        for v, u in zip(vals, units):
            if v == 0:
                continue
            s = _num(v)
            neg = s.startswith("-")
            mag = s[1:] if neg else s
            body = (u if mag == "1" and u else (f"{mag} {u}" if u else mag))
            out.append(("-" if neg else "+", body))
        return out

    def join(ts):
        if not ts:
            return "0"
        s = ("-" if ts[0][0] == "-" else "") + ts[0][1]
        for sign, body in ts[1:]:
            s += f" {sign} {body}"
        return s

    p = terms(h[:4], ("", "i", "j", "k"))
    q = terms(h[4:], ("", "i", "j", "k"))
    text = join(p) if p else ""
    if q:
        dual = f"eps({join(q)})"
        text = f"{text} + {dual}" if text else dual
    return text or "0"


def _axis(h):
    import numpy as np

    from synth.algebra.dq import plucker

    u, m = plucker(np.array([float(x) for x in h]))
    p = np.cross(u, m)
    a = float(h[0])
    b = float(np.linalg.norm([float(x) for x in h[1:4]]))
    return {"direction": [float(x) + 0.0 for x in u], "moment": [float(x) + 0.0 for x in m],
            "point": [float(x) + 0.0 for x in p], "a": a, "b": b}


@click.command(epilog=EPILOG)
@click.argument("m", metavar="M")
@click.argument("h", metavar="H")
@json_option
@debug_option
@run_guarded
def flip(m, h, as_json, debug):
    """Bennett flip of two rotation factors: print K and N with (t - m)(t - h) = (t - k)(t - n)."""
    from synth.algebra.flip import bennett_flip, flip_residual, is_exact

    M = parse_factor(m, "M")
    H = parse_factor(h, "H")
    _check_rotation(M, "M")
    _check_rotation(H, "H")
    K, N = bennett_flip(M, H)
    exact = is_exact(M, H)
    res = 0.0 if exact else flip_residual(M, H, K, N)
    if as_json:
        def vec(v):
            return [str(x) if exact else float(x) + 0.0 for x in v]

        print_json({"format": FORMAT, "exact": exact, "m": vec(M), "h": vec(H), "k": vec(K), "n": vec(N),
                    "k_float": [float(x) + 0.0 for x in K], "n_float": [float(x) + 0.0 for x in N],
                    "residual": res,
                    "axes": {"m": _axis(M), "h": _axis(H), "n": _axis(N), "k": _axis(K)},
                    "loop": ["m", "h", "n", "k"]})
        return
    click.echo("(t - m)(t - h) = (t - k)(t - n)" + (" (exact)" if exact else ""))
    click.echo(f"  m = {fmt_dq(M)}")
    click.echo(f"  h = {fmt_dq(H)}")
    click.echo(f"  k = {fmt_dq(K)}")
    click.echo(f"  n = {fmt_dq(N)}")
    click.echo(f"  k = [{', '.join(_num(x) for x in K)}]")
    click.echo(f"  n = [{', '.join(_num(x) for x in N)}]")
    if not exact:
        click.echo(f"  multiply-back check: relative error {res:.1e}")
