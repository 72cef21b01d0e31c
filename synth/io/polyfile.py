"""Reading the input file of `mpsynth factor` (YAML or JSON, '-' for stdin, at most 10 MB): a mapping
with exactly one of ``coefficients`` (rows of 8 numbers, constant term first) or ``expression``
(text). The numbers are checked later (`synth.algebra.polyinput`)."""
from __future__ import annotations

import difflib
import json

import yaml

from synth.algebra.polyinput import MAX_DEGREE, PolynomialInput
from synth.errors import InputError
from synth.io.docload import json_object_pairs, read_source

TOP_KEYS = ("coefficients", "expression")


def _parse_document(name: str, text: str):
    stripped = text.lstrip()
    if name.lower().endswith(".json") or stripped.startswith("{"):
        try:
            return json.loads(text, object_pairs_hook=json_object_pairs)
        except ValueError as e:
            if name.lower().endswith(".json"):
                raise InputError(f"{name}: invalid JSON: {e}") from None
            # not JSON after all: YAML flow mappings also start with '{'
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or "syntax error"
        raise InputError(f"{name}: invalid YAML{where}: {problem}") from None


def _check_rows(name: str, rows) -> list:
    if not isinstance(rows, list):
        raise InputError(f"{name}: 'coefficients' must be a list of rows of 8 numbers "
                           f"(constant term first), got {type(rows).__name__}")
    if len(rows) < 2:
        raise InputError(f"{name}: 'coefficients' needs at least 2 rows (degree >= 1), got {len(rows)}")
    if len(rows) > MAX_DEGREE + 1:
        raise InputError(f"{name}: degree {len(rows) - 1} exceeds the maximum of {MAX_DEGREE}")
    for k, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != 8:
            got = f"{len(row)} entries" if isinstance(row, list) else f"a {type(row).__name__}"
            raise InputError(f"{name}: coefficients row {k} (coefficient of t^{k}) must hold 8 numbers "
                               f"[p0, p1, p2, p3, q0, q1, q2, q3], got {got}")
    return rows


def load_input(file: str | None, expr: str | None) -> PolynomialInput:
    """Read FILE ('-' = stdin) or take --expr; check the document's shape (not the numbers yet)."""
    if file is not None and expr is not None:
        raise InputError("give either FILE or --expr, not both")
    if file is None and expr is None:
        raise InputError("give a FILE (YAML or JSON, '-' for stdin) or --expr TEXT; see --help")
    if expr is not None:
        return PolynomialInput(source="--expr", expression=expr)
    name, text = read_source(file, None)
    doc = _parse_document(name, text)
    if not isinstance(doc, dict):
        got = "an empty document" if doc is None else f"a {type(doc).__name__}"
        raise InputError(f"{name}: expected a mapping with 'coefficients' or 'expression', got {got}")
    unknown = [k for k in doc if k not in TOP_KEYS]
    if unknown:
        k = unknown[0]
        close = difflib.get_close_matches(str(k), TOP_KEYS, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else " (allowed: 'coefficients' or 'expression')"
        raise InputError(f"{name}: unknown key {str(k)!r}{hint}")
    present = [k for k in TOP_KEYS if k in doc]
    if len(present) != 1:
        which = "both 'coefficients' and 'expression'" if present else "neither 'coefficients' nor 'expression'"
        raise InputError(f"{name}: the file has {which}; give exactly one")
    if present[0] == "expression":
        text = doc["expression"]
        if not isinstance(text, str):
            raise InputError(f"{name}: 'expression' must be text, got {type(text).__name__}")
        return PolynomialInput(source=name, expression=text)
    return PolynomialInput(source=name, rows=_check_rows(name, doc["coefficients"]))
