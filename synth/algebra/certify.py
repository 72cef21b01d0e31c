"""Exact certification of a floating-point co-factor answer (docs/exceptional.md): rationalize the
factors and R, and check C R = (t - h_1)...(t - h_m) in Fractions with the dtype-generic polynomial
routines of `synth.algebra.polynomial`."""
from __future__ import annotations

from fractions import Fraction

import numpy as np

from synth.algebra.dq import exact_array
from synth.algebra.polynomial import poly_mul, product_of_linear


def rationalize(x, max_denominator: int = 10**7, tol: float = 1e-9) -> Fraction:
    """The Fraction nearest to x with a bounded denominator; raises ValueError when it is farther
    than tol * max(1, |x|)."""
    f = Fraction(float(x)).limit_denominator(max_denominator)
    if abs(float(f) - float(x)) > tol * max(1.0, abs(float(x))):
        raise ValueError(f"{x!r} is not close to a rational with denominator <= {max_denominator}")
    return f


def exact_product(hs):
    """prod (t - h_i) in exact arithmetic: rows (lists) of 8 Fractions, ascending; [1] for no factor."""
    if len(hs) == 0:
        return [[Fraction(1)] + [Fraction(0)] * 7]
    return product_of_linear(exact_array(hs)).tolist()


def exact_check(C, R, hs) -> bool:
    """True when C R = prod (t - h_i) exactly (all entries Fractions/ints; R ascending real)."""
    R8 = np.zeros((len(R), 8), dtype=object)
    R8[:, 0] = list(R)
    CR = poly_mul(exact_array(C), exact_array(R8))
    return exact_product(hs) == CR.tolist()


def rationalize_factors(hs, max_denominator: int = 10**7):
    return [[rationalize(x, max_denominator) for x in h] for h in hs]


def exact_result(C, result, max_denominator: int = 10**6):
    """(R, factors) as Fractions when rationalizing the `CofactorResult` ``result`` gives an exact identity
    C R = prod(t - h) for the rational C (rows of ints/Fractions); None otherwise (irrational answer, or
    not certified)."""
    try:
        R = [rationalize(x, max_denominator) for x in result.R]
        hs = [[rationalize(x, max_denominator) for x in h] for h in result.factors]
    except ValueError:
        return None
    return (R, hs) if exact_check(C, R, hs) else None
