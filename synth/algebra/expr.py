"""A small, whitelisted parser for polynomials in ``t`` with dual-quaternion coefficients.

Language (everything else is an error)::

    expr    := term (('+' | '-') term)*
    term    := unary (('*' | '/') unary | power)*      # juxtaposition before a name or '(' multiplies
    unary   := ('+' | '-') unary | power
    power   := primary (('^' | '**') INTEGER)?         # one exponent; chain with parentheses
    primary := NUMBER | 't' | 'i' | 'j' | 'k' | 'eps' | 'ε' | '(' expr ')'

* Numbers: ``2``, ``0.1``, ``.5``, ``1e-3``, ``2.5E+2``; converted exactly to Fractions (``0.1`` is
  1/10). Fractions are written with division: ``3/4``.
* ``t`` is the real, central polynomial variable; ``i, j, k`` are Hamilton's units (``ij = k``,
  ``ji = -k``, ``i^2 = j^2 = k^2 = -1``); ``eps`` (or ``ε``) is the dual unit (``eps^2 = 0``, central).
  ``e`` is *not* accepted for eps (``1e3`` is a number).
* Implicit multiplication: a factor directly followed by a name or ``(`` multiplies it, so ``2t``,
  ``3 eps k``, ``(t-1)(t-j)`` work. ``2 3`` is an error, and ``1/2t`` means ``(1/2)*t`` (the same
  precedence as ``*``; division by ``t`` is never allowed anyway).
* ``/`` divides only by a nonzero real constant (a number expression without t, i, j, k, eps).
* Exponents are non-negative integer literals (``t^2``, ``(t-i)**3``); the degree they produce is
  checked before anything is expanded.
* Unary minus binds weaker than ``^``: ``-t^2 = -(t^2)``.
* Limits (each refused with an InputError before the work is done): text longer than 10,000
  characters, degree above ``max_degree`` (default 200), a constant raised to more than 1000,
  literals with more than 400 digits or an exponent beyond 1e±400, exact numerators/denominators
  beyond 50,000 bits, and more than 100,000 coefficient-pair products in total (a degree-200 power
  costs about 16,000). Coefficients too large for a float are an error unless ``exact=True``.

Arithmetic is exact: polynomials are kept as integer rows over a common denominator.

Error messages are one line: ``expression: unexpected character '_' at column 1``; columns are
1-based character offsets into the text. The tokenizer and parser are hand-written; no
``eval``/``exec``/``compile``/sympy is ever applied to the text.
"""
from __future__ import annotations

import difflib
from fractions import Fraction
from math import gcd

import numpy as np

from synth.algebra.dq import structure_constants
from synth.errors import InputError

__all__ = ["parse_polynomial", "MAX_TEXT"]

MAX_TEXT = 10_000
MAX_CONSTANT_EXPONENT = 1000  # for powers of constants (no t)
MAX_LITERAL_DIGITS = 400
MAX_LITERAL_EXPONENT = 400  # |e| in 1e400
MAX_BITS = 50_000  # size of any exact numerator/denominator
MAX_WORK = 100_000  # total coefficient-pair products while expanding (a degree-200 power: ~16k)

_NAMES = {"t": None, "i": 1, "j": 2, "k": 3, "eps": 4, "ε": 4}
_ALLOWED_NAMES = "t, i, j, k, eps (or ε)"

# Basis 0..7 = 1, i, j, k, eps, eps i, eps j, eps k. _MUL[a][b] = (sign, c): e_a e_b = sign e_c, or None
# (eps^2 = 0); read off the structure constants of synth.algebra.dq.
_MUL = [[None] * 8 for _ in range(8)]
_D = structure_constants()
for _a, _b, _c in zip(*np.nonzero(_D)):
    _MUL[_a][_b] = (int(_D[_a, _b, _c]), int(_c))

# ============================================================== polynomials (exact)
class _Poly:
    """Exact polynomial: ``rows[d]`` = 8 integers, the coefficient of t^d times ``den`` (> 0).
    Kept reduced (gcd of all entries and den is 1) and trimmed (no trailing zero rows; the zero
    polynomial has no rows). Integer arithmetic is much faster than Fractions."""

    __slots__ = ("rows", "den")

    def __init__(self, rows, den=1):
        while rows and not any(rows[-1]):
            rows.pop()
        if not rows:
            den = 1
        elif den != 1:
            g = den
            for r in rows:
                for v in r:
                    if v:
                        g = gcd(g, v)
                        if g == 1:
                            break
                if g == 1:
                    break
            if g > 1:
                rows = [[v // g for v in r] for r in rows]
                den //= g
        self.rows = rows
        self.den = den

    def bits(self) -> int:
        """Bit length of the largest integer stored (numerators and the denominator)."""
        return max([self.den.bit_length()] + [abs(v).bit_length() for r in self.rows for v in r])

    @property
    def degree(self) -> int:
        return len(self.rows) - 1  # -1 for the zero polynomial

    def fractions(self):
        return [[Fraction(v, self.den) for v in r] for r in self.rows]


def _add(a: _Poly, b: _Poly, sign: int = 1) -> _Poly:
    den = a.den * b.den // gcd(a.den, b.den)
    fa, fb = den // a.den, sign * (den // b.den)
    n = max(len(a.rows), len(b.rows))
    zero = [0] * 8
    rows = []
    for d in range(n):
        ra = a.rows[d] if d < len(a.rows) else zero
        rb = b.rows[d] if d < len(b.rows) else zero
        rows.append([x * fa + y * fb for x, y in zip(ra, rb)])
    return _Poly(rows, den)


def _mul(a: _Poly, b: _Poly) -> _Poly:
    if not a.rows or not b.rows:
        return _Poly([])
    out = [[0] * 8 for _ in range(len(a.rows) + len(b.rows) - 1)]
    bnz = [[(ib, v) for ib, v in enumerate(r) if v] for r in b.rows]
    for da, ra in enumerate(a.rows):
        anz = [(ia, v) for ia, v in enumerate(ra) if v]
        if not anz:
            continue
        for db, bl in enumerate(bnz):
            if not bl:
                continue
            tgt = out[da + db]
            for ia, va in anz:
                table = _MUL[ia]
                for ib, vb in bl:
                    m = table[ib]
                    if m is None:
                        continue
                    if m[0] > 0:
                        tgt[m[1]] += va * vb
                    else:
                        tgt[m[1]] -= va * vb
    return _Poly(out, a.den * b.den)


def _scale(a: _Poly, f: Fraction) -> _Poly:
    if not f:
        return _Poly([])
    return _Poly([[v * f.numerator for v in r] for r in a.rows], a.den * f.denominator)


def _const(value: Fraction, idx: int = 0) -> _Poly:
    row = [0] * 8
    row[idx] = value.numerator
    return _Poly([row], value.denominator)


_T = _Poly([[0] * 8, [1, 0, 0, 0, 0, 0, 0, 0]])


# ============================================================== tokens
class _Tok:
    __slots__ = ("kind", "text", "col", "value")

    def __init__(self, kind, text, col, value=None):
        self.kind = kind  # NUM NAME OP LPAR RPAR END
        self.text = text
        self.col = col  # 1-based
        self.value = value

    def show(self) -> str:
        return "end of expression" if self.kind == "END" else repr(self.text)


def _err(source: str, msg: str):
    return InputError(f"{source}: {msg}")


def _parse_number(text: str, pos: int, source: str):
    """Scan a decimal literal at pos; returns (Fraction, end, integer_literal?)."""
    n = len(text)
    p = pos
    while p < n and text[p].isdigit() and text[p].isascii():
        p += 1
    int_digits = text[pos:p]
    frac_digits = ""
    is_int = True
    if p < n and text[p] == ".":
        q = p + 1
        while q < n and text[q].isdigit() and text[q].isascii():
            q += 1
        frac_digits = text[p + 1 : q]
        if not int_digits and not frac_digits:
            raise _err(source, f"unexpected character '.' at column {pos + 1}")
        p = q
        is_int = False
    exp = 0
    if p < n and text[p] in "eE":
        q = p + 1
        if q < n and text[q] in "+-":
            q += 1
        r = q
        while r < n and text[r].isdigit() and text[r].isascii():
            r += 1
        if r > q:  # a real exponent; otherwise 'e' starts a name (e.g. 2eps)
            digits = text[q:r]
            if len(digits) > 6 or int(digits) > MAX_LITERAL_EXPONENT:
                raise _err(
                    source,
                    f"number {text[pos:r]!r} at column {pos + 1} is out of range "
                    f"(exponents up to {MAX_LITERAL_EXPONENT})",
                )
            exp = int(digits) * (-1 if text[p + 1] == "-" else 1)
            p = r
            is_int = False
    mantissa = (int_digits + frac_digits).lstrip("0") or "0"
    if len(mantissa) > MAX_LITERAL_DIGITS:
        raise _err(source, f"number at column {pos + 1} has more than {MAX_LITERAL_DIGITS} digits")
    exp -= len(frac_digits)
    m = int(mantissa)
    value = Fraction(m * 10**exp) if exp >= 0 else Fraction(m, 10**-exp)
    return value, p, is_int


def _tokenize(text: str, source: str) -> list[_Tok]:
    toks = []
    n = len(text)
    p = 0
    while p < n:
        ch = text[p]
        if ch in " \t\r\n":
            p += 1
            continue
        col = p + 1
        if (ch.isdigit() and ch.isascii()) or (ch == "." and p + 1 < n and text[p + 1].isdigit()):
            value, end, is_int = _parse_number(text, p, source)
            toks.append(_Tok("NUM", text[p:end], col, (value, is_int)))
            p = end
        elif ch.isascii() and ch.isalpha():
            q = p
            while q < n and text[q].isascii() and text[q].isalpha():
                q += 1
            word = text[p:q]
            if word not in _NAMES:
                if word == "e" or word == "E":
                    hint = " (the dual unit is written 'eps' or 'ε')"
                elif word.lower() in _NAMES:
                    hint = f" (names are lower-case: {word.lower()!r})"
                else:
                    close = difflib.get_close_matches(word, list(_NAMES), n=1, cutoff=0.6)
                    hint = f" (did you mean {close[0]!r}?)" if close else f" (allowed: {_ALLOWED_NAMES})"
                shown = word if len(word) <= 30 else word[:30] + "..."
                raise _err(source, f"unknown name {shown!r} at column {col}{hint}")
            toks.append(_Tok("NAME", word, col))
            p = q
        elif ch == "ε":
            toks.append(_Tok("NAME", ch, col))
            p += 1
        elif ch == "*" and p + 1 < n and text[p + 1] == "*":
            toks.append(_Tok("OP", "**", col))
            p += 2
        elif ch in "+-*/^":
            toks.append(_Tok("OP", ch, col))
            p += 1
        elif ch == "(":
            toks.append(_Tok("LPAR", ch, col))
            p += 1
        elif ch == ")":
            toks.append(_Tok("RPAR", ch, col))
            p += 1
        else:
            raise _err(source, f"unexpected character {ch!r} at column {col}")
    toks.append(_Tok("END", "", n + 1))
    return toks


# ============================================================== parser
class _Parser:
    def __init__(self, toks, source, max_degree):
        self.toks = toks
        self.i = 0
        self.source = source
        self.max_degree = max_degree
        self.work = 0

    @property
    def tok(self) -> _Tok:
        return self.toks[self.i]

    def advance(self) -> _Tok:
        t = self.toks[self.i]
        self.i += 1
        return t

    def is_op(self, *ops) -> bool:
        t = self.tok
        return t.kind == "OP" and (t.text in ops or (t.text == "**" and "^" in ops))

    def fail(self, msg):
        return _err(self.source, msg)

    def unexpected(self, expected: str):
        t = self.tok
        if t.kind == "END":
            return self.fail(f"unexpected end of expression at column {t.col} (expected {expected})")
        return self.fail(f"unexpected {t.show()} at column {t.col} (expected {expected})")

    def check_degree(self, deg: int, col: int):
        if deg > self.max_degree:
            raise self.fail(f"degree {deg} at column {col} exceeds the maximum of {self.max_degree}")

    # expr := term (('+'|'-') term)*
    def expr(self):
        value = self.term()
        while self.is_op("+", "-"):
            op = self.advance()
            rhs = self.term()
            value = _add(value, rhs, 1 if op.text == "+" else -1)
            if value.den.bit_length() > MAX_BITS:
                raise self.fail(f"the sum at column {op.col} makes numbers too large to handle exactly")
        return value

    # term := unary (('*'|'/') unary | <implicit> power)*
    def term(self):
        value = self.unary()
        while True:
            t = self.tok
            if self.is_op("*"):
                self.advance()
                rhs = self.unary()
                value = self.mul(value, rhs, t.col)
            elif self.is_op("/"):
                self.advance()
                rhs = self.unary()
                value = _scale(value, 1 / self.real_constant(rhs, t.col))
            elif t.kind in ("NAME", "LPAR"):
                rhs = self.power()
                value = self.mul(value, rhs, t.col)
            else:
                return value

    def real_constant(self, p: _Poly, col) -> Fraction:
        if not p.rows:
            raise self.fail(f"division by zero at column {col}")
        if len(p.rows) > 1:
            raise self.fail(f"division by an expression containing t at column {col} (only numbers may divide)")
        if any(p.rows[0][1:]):
            raise self.fail(
                f"division by a quaternion or dual quaternion at column {col} (only numbers may divide)"
            )
        return Fraction(p.rows[0][0], p.den)

    # unary := ('+'|'-') unary | power
    def unary(self):
        if self.is_op("+", "-"):
            op = self.advance()
            v = self.unary()
            return v if op.text == "+" else _scale(v, Fraction(-1))
        return self.power()

    # power := primary (('^'|'**') INTEGER)?
    def power(self):
        base = self.primary()
        if self.is_op("^"):
            op = self.advance()
            t = self.tok
            if t.kind != "NUM" or not t.value[1]:
                if t.kind == "NUM":
                    raise self.fail(
                        f"exponent {t.show()} at column {t.col} must be a non-negative integer literal"
                    )
                raise self.unexpected(f"a non-negative integer literal after {op.text!r}")
            self.advance()
            digits = t.text.lstrip("0") or "0"
            if len(digits) > 7:
                raise self.fail(f"exponent {t.show()} at column {t.col} is too large")
            n = int(digits)
            deg = base.degree
            if deg > 0:
                self.check_degree(deg * n, op.col)
            elif n > MAX_CONSTANT_EXPONENT:
                raise self.fail(
                    f"exponent {n} at column {t.col} is too large (at most {MAX_CONSTANT_EXPONENT} for constants)"
                )
            if self.is_op("^"):
                raise self.fail(
                    f"chained exponent {self.tok.show()} at column {self.tok.col}; use parentheses"
                )
            if base.bits() * n > MAX_BITS:
                raise self.fail(f"the power at column {op.col} makes numbers too large to handle exactly")
            return self.pow(base, n, op.col)
        return base

    def mul(self, a: _Poly, b: _Poly, col: int) -> _Poly:
        """Product with the guards: degree, size of the exact numbers, total work."""
        self.check_degree(a.degree + b.degree, col)
        if a.bits() + b.bits() > MAX_BITS:
            raise self.fail(f"the product at column {col} makes numbers too large to handle exactly")
        self.work += len(a.rows) * len(b.rows)
        if self.work > MAX_WORK:
            raise self.fail(f"expression is too expensive to expand (at column {col})")
        return _mul(a, b)

    def pow(self, base: _Poly, n: int, col: int) -> _Poly:
        result = _const(Fraction(1))
        sq = base
        while n:
            if n & 1:
                result = self.mul(result, sq, col)
            n >>= 1
            if n:
                sq = self.mul(sq, sq, col)
        return result

    def primary(self):
        t = self.tok
        if t.kind == "NUM":
            self.advance()
            return _const(t.value[0])
        if t.kind == "NAME":
            self.advance()
            idx = _NAMES[t.text]
            return _T if idx is None else _const(Fraction(1), idx)
        if t.kind == "LPAR":
            self.advance()
            v = self.expr()
            if self.tok.kind != "RPAR":
                if self.tok.kind == "END":
                    raise self.fail(f"missing ')' for the '(' at column {t.col}")
                raise self.unexpected("an operator or ')'")
            self.advance()
            return v
        if t.kind == "RPAR":
            raise self.fail(f"unexpected ')' at column {t.col} (no matching '(')")
        raise self.unexpected("a number, t, i, j, k, eps or '('")


def parse_polynomial(
    text: str, *, exact: bool = False, max_degree: int = 200, source: str = "expression"
):
    """Parse a polynomial in t with dual-quaternion coefficients.

    Returns an (n+1, 8) float array (row k = coefficient of t^k, layout [p0..p3, q0..q3] as in
    ``synth.algebra.dq``; trailing zero rows trimmed, at least one row), or with ``exact=True`` a list of
    rows of 8 Fractions. ``source`` prefixes error messages. Raises InputError (one line)."""
    if not isinstance(text, str):
        raise _err(source, f"expected text, got {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise _err(source, f"expression is {len(text)} characters long; the limit is {MAX_TEXT}")
    toks = _tokenize(text, source)
    if toks[0].kind == "END":
        raise _err(source, "empty expression")
    parser = _Parser(toks, source, max_degree)
    try:
        poly = parser.expr()
    except RecursionError:
        raise _err(source, "expression is nested too deeply") from None
    if parser.tok.kind != "END":
        t = parser.tok
        if t.kind == "RPAR":
            raise _err(source, f"unexpected ')' at column {t.col} (no matching '(')")
        raise parser.unexpected("an operator or the end of the expression")
    rows = poly.fractions() or [[Fraction(0)] * 8]
    if exact:
        return rows
    return exact_floats(rows, source)


def exact_floats(values, source: str = "") -> np.ndarray:
    """The exact numbers ``values`` (a list, or a list of rows, of Fractions / ints) as a float array;
    InputError (``<source>: ...``) when one lies beyond the floating-point range (``1e400``)."""
    shape = np.shape(values) if len(values) and not isinstance(values[0], (list, tuple)) else None
    rows = [values] if shape is not None else values
    try:
        out = np.array([[float(v) for v in row] for row in rows], dtype=float)
    except OverflowError:
        out = None
    if out is None or not np.all(np.isfinite(out)):
        raise _err(source, "a coefficient is too large to represent as a floating-point number") from None
    return out[0] if shape is not None else out
