"""Everything `mpsynth flip M H` prints (the CLI only parses its options, calls, prints): the Bennett
flip (t - m)(t - h) = (t - k)(t - n) of two rotation factors given as text (docs/exceptional.md), its
``--json`` document (format ``mpsynth.flip/1``) and its text."""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from synth.algebra.dq import plucker
from synth.algebra.expr import parse_polynomial
from synth.algebra.flip import FlipError, bennett_flip, flip_residual, is_exact, is_rotation, parallelogram_flip
from synth.algebra.text import fmt_dq, fmt_num
from synth.errors import InputError

FORMAT = "mpsynth.flip/1"
DIGITS = 12  # significant digits of floats in the text

_LIST = re.compile(r"^\s*\[?\s*([^\[\]]*?)\s*\]?\s*$")


def parse_factor(text: str, what: str):
    """The dual quaternion m of the rotation factor t - m from TEXT (8 numbers or an expression).
    Returns 8 Fractions (exact) or 8 floats. Raises InputError."""
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


def check_rotation(h, what: str) -> None:
    """InputError naming ``what`` and the reason when t - h is not a rotation."""
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


def axis(h) -> dict:
    """Axis of the rotation t - h: Plücker direction and moment, the point nearest the origin, and the
    angle law's (a, b)."""
    u, m = plucker(np.array([float(x) for x in h]))
    p = np.cross(u, m)
    a = float(h[0])
    b = float(np.linalg.norm([float(x) for x in h[1:4]]))
    return {"direction": [float(x) + 0.0 for x in u], "moment": [float(x) + 0.0 for x in m],
            "point": [float(x) + 0.0 for x in p], "a": a, "b": b}


@dataclass
class FlipReport:
    m: list  # 8 numbers each: Fractions when exact, else floats
    h: list
    k: list
    n: list
    exact: bool
    residual: float  # multiply-back relative error (0 when exact)
    shift: list | None = None  # parallelogram flip: the member's s (k = m - eps s, n = h + eps s)


def _floats(v) -> list | None:
    """``v`` as finite floats, or None when an entry overflows."""
    try:
        out = [float(x) for x in v]
    except OverflowError:
        return None
    return out if all(math.isfinite(x) for x in out) else None


def flip_report(m_text: str, h_text: str) -> FlipReport:
    """Parse M and H, check that both are rotations (InputError), flip (FlipError when the flip does not
    exist) and check the product."""
    M = parse_factor(m_text, "M")
    H = parse_factor(h_text, "H")
    # decimals are read as exact rationals; digits printed from floating point satisfy the rotation
    # conditions only to rounding (v . w ~ 1e-17), so such input is taken as floats (tolerance 1e-9
    # relative, `is_rotation`), like `mpsynth factor` without --exact
    if not (is_rotation(M) and is_rotation(H)):
        fm, fh = _floats(M), _floats(H)
        if fm is not None and fh is not None and is_rotation(fm) and is_rotation(fh):
            M, H = fm, fh
    check_rotation(M, "M")
    check_rotation(H, "H")
    shift = None
    try:
        K, N = bennett_flip(M, H)
    except FlipError:  # primal(h) = conj(primal(m)): a circular translation, the parallelogram family
        K, N, shift = parallelogram_flip(M, H)
    exact = is_exact(M, H)
    return FlipReport(m=list(M), h=list(H), k=list(K), n=list(N), exact=exact,
                      residual=0.0 if exact else flip_residual(M, H, K, N),
                      shift=None if shift is None else list(shift))


def flip_document(rep: FlipReport) -> dict:
    """The --json document: exact numbers as strings ("2/3"), floats as numbers; the four axes."""
    def vec(v):
        return [str(x) if rep.exact else float(x) + 0.0 for x in v]

    return {"format": FORMAT, "exact": rep.exact, "m": vec(rep.m), "h": vec(rep.h), "k": vec(rep.k),
            "n": vec(rep.n), "k_float": [float(x) + 0.0 for x in rep.k], "n_float": [float(x) + 0.0 for x in rep.n],
            "h_prime": vec(rep.k), "m_prime": vec(rep.n),  # the names of the text: h' = k, m' = n
            "residual": rep.residual,
            "axes": {"m": axis(rep.m), "h": axis(rep.h), "n": axis(rep.n), "k": axis(rep.k)},
            "loop": ["m", "h", "n", "k"],
            **({"parallelogram": {"shift": vec(rep.shift),
                                  "family": "k = m - eps s, n = h + eps s for every s perpendicular to the axes "
                                            "(s != 0); the four axes form a parallelogram"}}
               if rep.shift is not None else {})}


TEXT_NAMES = (("m", "m"), ("h", "h"), ("h'", "k"), ("m'", "n"))  # printed name, FlipReport field


def flip_text(rep: FlipReport) -> str:
    """The default text: the identity, m, h, h', m' as expressions and h', m' as lists. The results are
    printed as h' (= k of docs/exceptional.md: N(t - h') = N(t - h)) and m' (= n: N(t - m') = N(t - m)),
    since k also names the quaternion unit."""
    lines = ["(t - m)(t - h) = (t - h')(t - m')" + (" (exact)" if rep.exact else "")]
    for name, field_ in TEXT_NAMES:
        lines.append(f"  {name} = {fmt_dq(getattr(rep, field_), DIGITS)}")
    for name, field_ in TEXT_NAMES[2:]:
        lines.append(f"  {name} = [{', '.join(fmt_num(x, digits=DIGITS) for x in getattr(rep, field_))}]")
    if rep.shift is not None:
        lines.append("  parallelogram flip: (t - m)(t - h) is a circular translation, so the flip is not unique: "
                     "h' = m - eps s, m' = h + eps s for every s perpendicular to the axes; shown s = ("
                     + ", ".join(fmt_num(x, digits=DIGITS) for x in rep.shift) + ")")
    if not rep.exact:
        lines.append(f"  multiply-back check: relative error {rep.residual:.1e}")
    return "\n".join(lines)
