"""`mpsynth factor FILE | --expr TEXT`: every factorization of a monic motion polynomial into linear
factors (docs/algorithm1.md). Thin: reads the input (`synth.io.polyfile`), computes and formats the
report (`synth.algebra.report`), prints it."""
from __future__ import annotations

import click

from synth.algebra.report import (compute, compute_cofactor, cofactor_document, format_cofactor, format_table,
                                  report_document)
from synth.io.polyfile import load_input

from .common import debug_option, json_option, print_json, run_guarded

EPILOG = """\b
Input file (YAML or JSON; constant term first; a non-monic C is divided by its leading
coefficient when that is invertible, with a note):
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
2 bad input (leading coefficient not invertible, not a motion polynomial, unparsable, ...)."""



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
