"""Curve and motion spec files of `mpsynth curve` (YAML or JSON): the file -> `CurveSpec` / `MotionSpec`.

A spec has exactly one of ``curve: {x, y, z, w}`` (real polynomials in t, as texts or numbers) or
``motion: {coefficients: [[8 numbers], ...]}`` / ``motion: {expression: "..."}`` (a dual-quaternion
polynomial, ascending in t). Coefficients are kept exact (Fractions). Every problem is a one-line
InputError naming the file and the key. The synthesis from a spec is `synth.synthesis.curve.spec_linkage`.
"""
from __future__ import annotations

import difflib
import os
from fractions import Fraction

import numpy as np

from synth.algebra.expr import parse_polynomial
from synth.errors import InputError
from synth.io.docload import load_document, read_source
from synth.task import MAX_DEGREE, CurveSpec, MotionSpec

SPEC_KEYS = ("curve", "motion")


def _did_you_mean(key, allowed):
    close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else f" (allowed: {', '.join(allowed)})"


def _number_fraction(v, where):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{where}: expected a number, got {type(v).__name__}")
    if isinstance(v, float):
        if not np.isfinite(v):
            raise InputError(f"{where}: number is not finite")
        return Fraction(repr(v))
    return Fraction(v)


def parse_real_polynomial(text, where: str, max_degree: int = MAX_DEGREE) -> list:
    """A real polynomial in t (ascending Fractions) from a number or an expression text."""
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise InputError(f"{where}: expected a polynomial in t (text or number), got {type(text).__name__}")
    if isinstance(text, (int, float)):
        return [_number_fraction(text, where)]
    rows = parse_polynomial(text, exact=True, max_degree=max_degree, source=where)
    for k, r in enumerate(rows):
        bad = [n for n, v in zip(("i", "j", "k", "eps", "eps i", "eps j", "eps k"), r[1:]) if v != 0]
        if bad:
            raise InputError(f"{where}: must be a real polynomial in t, but the coefficient of t^{k} has "
                             f"a {bad[0]} part")
    c = [r[0] for r in rows]
    while len(c) > 1 and c[-1] == 0:
        c.pop()
    return c


def parse_spec(doc, source: str = "spec"):
    """CurveSpec or MotionSpec from a parsed YAML/JSON document (one-line InputError otherwise)."""
    if not isinstance(doc, dict):
        raise InputError(f"{source}: the top level must be a mapping with 'curve' or 'motion'")
    for key in doc:
        if key not in SPEC_KEYS:
            raise InputError(f"{source}: unknown key {str(key)!r} at top level{_did_you_mean(key, SPEC_KEYS)}")
    present = [k for k in SPEC_KEYS if k in doc]
    if len(present) != 1:
        raise InputError(f"{source}: give exactly one of 'curve' or 'motion'")
    if present[0] == "curve":
        spec = doc["curve"]
        if not isinstance(spec, dict):
            raise InputError(f"{source}: curve must be a mapping with x, y, z, w (polynomials in t)")
        for key in spec:
            if key not in ("x", "y", "z", "w"):
                raise InputError(f"{source}: unknown key {str(key)!r} in curve{_did_you_mean(key, 'xyzw')}")
        polys, texts = [], []
        for key in "xyzw":
            if key not in spec:
                raise InputError(f"{source}: curve is missing {key!r} (x, y, z, w are all required)")
            polys.append(parse_real_polynomial(spec[key], f"{source}: curve.{key}"))
            texts.append(str(spec[key]))
        return CurveSpec(polys=polys, texts=texts)
    spec = doc["motion"]
    if not isinstance(spec, dict):
        raise InputError(f"{source}: motion must be a mapping with 'coefficients' or 'expression'")
    for key in spec:
        if key not in ("coefficients", "expression"):
            raise InputError(f"{source}: unknown key {str(key)!r} in motion"
                             f"{_did_you_mean(key, ('coefficients', 'expression'))}")
    if ("coefficients" in spec) == ("expression" in spec):
        raise InputError(f"{source}: motion needs exactly one of 'coefficients' or 'expression'")
    if "expression" in spec:
        text = spec["expression"]
        if not isinstance(text, str):
            raise InputError(f"{source}: motion.expression must be a text, got {type(text).__name__}")
        rows = parse_polynomial(text, exact=True, max_degree=MAX_DEGREE, source=f"{source}: motion.expression")
        return MotionSpec(C=rows, text=text)
    coeffs = spec["coefficients"]
    if not isinstance(coeffs, list) or not coeffs:
        raise InputError(f"{source}: motion.coefficients must be a non-empty list of rows of 8 numbers")
    if len(coeffs) > MAX_DEGREE + 1:
        raise InputError(f"{source}: motion.coefficients has degree {len(coeffs) - 1}, above {MAX_DEGREE}")
    rows = []
    for i, row in enumerate(coeffs):
        if not isinstance(row, list) or len(row) != 8:
            raise InputError(f"{source}: motion.coefficients[{i}] must be a list of 8 numbers")
        rows.append([_number_fraction(v, f"{source}: motion.coefficients[{i}][{k}]") for k, v in enumerate(row)])
    return MotionSpec(C=rows)


def load_spec(path):
    """Read a curve/motion spec file (YAML or JSON; '-' for stdin)."""
    name, text = read_source(path, None)
    doc = load_document(text, name, os.fspath(path).lower().endswith(".json"))
    return parse_spec(doc, name)
