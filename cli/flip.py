"""`mpsynth flip M H`: the Bennett flip (t - m)(t - h) = (t - h')(t - m') (docs/exceptional.md, where h'
is k and m' is n). Thin:
`synth.algebra.flip_report` computes and formats, this prints."""
from __future__ import annotations

import click

from synth.algebra.flip_report import flip_document, flip_report, flip_text

from .common import debug_option, json_option, print_json, run_guarded

EPILOG = """\b
M and H are the rotation factors t - m, t - h, each given as
  - 8 numbers p0 p1 p2 p3 q0 q1 q2 q3 (= p + eps q), e.g. "[1, 2, 0, 0, 0, 0, 3, 0]" or "1,2,0,0,0,0,3,0"
    (fractions as "3/4"), or
  - an expression in i, j, k, eps (e.g. "1 + 2i + 3 eps j"), or the factor itself ("t - 1 - 2i - 3eps j").
Rational input gives exact rational output; decimals that satisfy the rotation conditions only to
rounding (digits printed from floating point) are computed in floating point. A negative first
argument needs no "--": mpsynth flip "-1 + 2i" k.

\b
Example:
  mpsynth flip "1 + 2i + 3eps j" "k + eps(i + j)"
    h' = 2/3 i - 2/3 j - 1/3 k + eps(14/9 i + 10/9 j + 8/9 k)
    m' = 1 + 4/3 i + 2/3 j + 4/3 k + eps(-5/9 i + 26/9 j - 8/9 k)

\b
The four axes m, h, m', h' (in this loop order) form a Bennett linkage; N(t-m') = N(t-m), N(t-h') = N(t-h).
(--json also gives h' and m' as "k" and "n", the names of docs/exceptional.md.)
When primal(h) = conj(primal(m)) the product is a circular translation and the flip is a
parallelogram, one member of the family h' = m - eps s, m' = h + eps s (s perpendicular to the axes).
Exit codes: 0 flipped, 1 the flip does not exist (the same axis reversed: the identity),
2 bad input (not 8 numbers / not a rotation)."""


@click.command(epilog=EPILOG, context_settings={"ignore_unknown_options": True})
@click.argument("m", metavar="M")
@click.argument("h", metavar="H")
@json_option
@debug_option
@run_guarded
def flip(m, h, as_json, debug):
    """Bennett flip of two rotation factors: print h' and m' with (t - m)(t - h) = (t - h')(t - m')."""
    rep = flip_report(m, h)
    if as_json:
        print_json(flip_document(rep))
    else:
        click.echo(flip_text(rep))
