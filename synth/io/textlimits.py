"""The size limit of input lists and user text in messages, shared by the input readers (`synth.io.docload`,
`synth.io.yamlload`, `synth.io.posespec`): ``clean_text`` renders arbitrary text on one bounded line."""
from __future__ import annotations

MAX_POSES = 10_000  # items of one list (at most this many poses are accepted)


def clean_text(text: str, limit: int = 200) -> str:
    """One-line, bounded rendering of arbitrary user text (escapes control characters)."""
    out = []
    for ch in str(text)[: limit + 1]:
        if ch.isprintable() or ch == " ":
            out.append(ch)
        else:
            out.append(ch.encode("unicode_escape").decode("ascii"))
    s = "".join(out)
    if len(s) > limit:
        s = s[:limit] + "..."
    return s


def quote_text(text: str, limit: int = 60) -> str:
    return '"' + clean_text(text, limit).replace('"', '\\"') + '"'
