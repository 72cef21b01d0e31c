"""The polynomial given to `mpsynth factor` (docs/algorithm1.md): coefficient rows or expression text,
and its conversion to a float (n+1, 8) array or to exact rows of Fractions, with one-line InputErrors
naming the source, row and entry. Reading the file is `synth.io.polyfile`."""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from synth.algebra.dq import exact_array
from synth.algebra.exact import to_fraction
from synth.algebra.expr import parse_polynomial
from synth.algebra.polynomial import make_monic
from synth.errors import InputError

MAX_DEGREE = 200
MAX_ABS = 1e12


@dataclass
class PolynomialInput:
    source: str  # file name, "<stdin>" or "--expr"
    rows: list | None = None  # raw rows of numbers (from `coefficients`)
    expression: str | None = None

    @property
    def expression_source(self) -> str:
        """The prefix of error messages about the expression."""
        return "--expr" if self.source == "--expr" else f"{self.source}: expression"


def float_rows(inp: PolynomialInput) -> np.ndarray:
    """The numeric polynomial (n+1, 8) of the input."""
    if inp.expression is not None:
        return parse_polynomial(inp.expression, max_degree=MAX_DEGREE, source=inp.expression_source)
    out = np.empty((len(inp.rows), 8))
    for k, row in enumerate(inp.rows):
        for d, x in enumerate(row):
            what = f"{inp.source}: coefficients row {k}, entry {d}"
            if isinstance(x, bool) or not isinstance(x, (int, float, str)):
                raise InputError(f"{what}: expected a number, got {type(x).__name__ if x is not None else 'null'}")
            if isinstance(x, str):
                x = to_fraction(x, what)
            try:
                v = float(x)
            except OverflowError:
                v = math.inf
            if not math.isfinite(v):
                raise InputError(f"{what}: {x!r} is not a finite number (NaN and infinity are not allowed)")
            if abs(v) > MAX_ABS:
                raise InputError(f"{what}: {v:g} is too large (|x| <= {MAX_ABS:g})")
            out[k, d] = v
    return out


def exact_rows(inp: PolynomialInput) -> list:
    """The polynomial as rows of 8 Fractions (floats by their shortest decimal: 0.1 is 1/10)."""
    if inp.expression is not None:
        return parse_polynomial(inp.expression, exact=True, max_degree=MAX_DEGREE, source=inp.expression_source)
    rows = []
    for k, row in enumerate(inp.rows):
        out = []
        for d, x in enumerate(row):
            what = f"{inp.source}: coefficients row {k}, entry {d}"
            if x is None:
                raise InputError(f"{what}: expected a number, got null")
            out.append(to_fraction(x, what))
        rows.append(out)
    return rows


def monic_input(C, exact: bool = False):
    """(M, L): C = L M with M monic, for a polynomial C ((n+1, 8) floats, or rows of Fractions when
    ``exact``) whose leading coefficient L is invertible (nonzero primal part): M = L^-1 C
    (`synth.algebra.polynomial.make_monic`), the same motion seen from the base frame moved by L^-1 (a
    real L changes nothing). L is None when C is monic already. InputError when L is not invertible."""
    rows = exact_array(C) if exact else np.asarray(C, float)
    L = rows[-1]
    if all(x == y for x, y in zip(L, (1, 0, 0, 0, 0, 0, 0, 0))):
        return C, None
    if all(x == 0 for x in L[:4]) or (not exact and float(np.linalg.norm(L[:4].astype(float))) <=
                                       1e-12 * float(np.abs(rows.astype(float)).max())):
        raise InputError("not monic, and the leading coefficient has a zero primal part (not invertible): "
                         "the polynomial cannot be made monic")
    M = make_monic(rows)
    if exact:
        M = [list(r) for r in M]
        M[-1] = [Fraction(1)] + [Fraction(0)] * 7
        return M, list(L)
    M[-1] = np.eye(8)[0]
    return M, L


def prefixed(source: str, func, *args):
    """Run a validation step, prefixing its InputError message with the input's name."""
    try:
        return func(*args)
    except InputError as e:
        msg = str(e)
        if msg.startswith(source + ":") or source == "--expr" and msg.startswith("--expr"):
            raise
        raise InputError(f"{source}: {msg}") from None
