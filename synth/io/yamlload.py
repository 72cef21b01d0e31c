"""The strict YAML loader of `synth.io.docload.load_document` (imported with the first YAML document: a
process that reads only JSON, such as `mpsynth batch`, never loads PyYAML): a `yaml.SafeLoader` subclass
that rejects duplicate keys, reads ``1e-3`` as a float (YAML 1.2 style) and refuses documents far larger
than any input while they are still being parsed."""
from __future__ import annotations

import re

import yaml

from synth.io.textlimits import MAX_POSES, clean_text

MAX_YAML_NODES = 30 * MAX_POSES  # values in a YAML document (a pose has at most about 25)
MAX_MERGED_KEYS = 1000  # entries of one mapping after expanding YAML merge keys


class TooLarge(yaml.YAMLError):
    """The document is far larger than any pose file (raised while composing, before construction)."""


class _StrictSafeLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate keys and reads 1e-3 as a float.

    It also refuses, while the document is still being parsed, a list of more than ``MAX_POSES``
    items, more than ``MAX_YAML_NODES`` values in total (aliases included) and merge keys (``<<``)
    that would expand a mapping to more than ``MAX_MERGED_KEYS`` entries ("YAML bombs"): such
    documents otherwise take minutes and gigabytes before the pose limits could even be checked."""

    def compose_node(self, parent, index):
        self._mpsynth_nodes = getattr(self, "_mpsynth_nodes", 0) + 1
        if self._mpsynth_nodes > MAX_YAML_NODES:
            raise TooLarge(f"{self._mark_text()}the document has more than {MAX_YAML_NODES} values; "
                            f"a pose file of {MAX_POSES} poses has far fewer, refusing to read further")
        if isinstance(index, int) and index >= MAX_POSES:  # the (index+1)-th item of a list
            raise TooLarge(f"{self._mark_text()}a list has more than {MAX_POSES} items "
                            f"(at most {MAX_POSES} poses are accepted); refusing to read further")
        return super().compose_node(parent, index)

    def _mark_text(self) -> str:
        try:
            mark = self.peek_event().start_mark
            return f"line {mark.line + 1}: "
        except Exception:  # pragma: no cover - the message stays useful without a line
            return ""

    def flatten_mapping(self, node):
        if _merged_size(node, {}) > MAX_MERGED_KEYS:
            raise TooLarge(f"line {node.start_mark.line + 1}: merge keys ('<<') expand a mapping to more than "
                            f"{MAX_MERGED_KEYS} entries; refusing to expand it")
        return super().flatten_mapping(node)

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    hash(key)
                except TypeError:
                    continue  # the base class reports unhashable keys
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        "while constructing a mapping",
                        node.start_mark,
                        f"found duplicate key {clean_text(repr(key), 40)}",
                        key_node.start_mark,
                    )
                seen[key] = True
        return super().construct_mapping(node, deep=deep)


def _merged_size(node, memo: dict) -> int:
    """Number of entries ``node`` (a MappingNode) has once its merge keys are expanded; stops counting
    early above MAX_MERGED_KEYS. Shared (aliased) mappings are counted once per use, as the expansion
    copies them; ``memo`` keeps that linear in the number of nodes."""
    key = id(node)
    if key in memo:
        return memo[key]
    memo[key] = 0  # a mapping that merges itself is reported by the expansion (nested too deeply)
    n = 0
    for k, v in node.value:
        if k.tag != "tag:yaml.org,2002:merge":
            n += 1
            continue
        for sub in (v.value if isinstance(v, yaml.SequenceNode) else [v]):
            if isinstance(sub, yaml.MappingNode):
                n += _merged_size(sub, memo)
        if n > MAX_MERGED_KEYS:
            break
    memo[key] = n
    return n


MAX_NUMBER_CHARS = 100  # characters of one numeric scalar (a float has at most ~25)
_INT = re.compile(r"^(?:[-+]?0b[0-1_]+|[-+]?0[0-7_]+|[-+]?(?:0|[1-9][0-9_]*)|[-+]?0x[0-9a-fA-F_]+)$")
_FLOAT = re.compile(r"^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?|\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?"
                    r"|[-+]?(?:[0-9][0-9_]*)[eE][-+]?[0-9]+|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$")


def _numbers_without_base_60(resolvers: dict) -> dict:
    """The implicit resolvers of YAML 1.1 without its base-60 numbers (``1:30`` is a string, as in YAML
    1.2: PyYAML converts ``1:0:0:...`` in quadratic time, a 2 MB scalar > 60 s) and with ``1e-3`` a float."""
    out = {}
    for first, entries in resolvers.items():
        out[first] = [(tag, rx) for tag, rx in entries
                      if tag not in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")]
    for tag, rx, firsts in (("tag:yaml.org,2002:int", _INT, "-+0123456789"),
                            ("tag:yaml.org,2002:float", _FLOAT, "-+0123456789.")):
        for ch in firsts:
            out.setdefault(ch, []).append((tag, rx))
    return out


_StrictSafeLoader.yaml_implicit_resolvers = _numbers_without_base_60(yaml.SafeLoader.yaml_implicit_resolvers)


def _bounded(construct):
    """A number constructor that refuses numeric scalars longer than MAX_NUMBER_CHARS (no input needs
    them; Python's int() of a long digit string is quadratic)."""
    def wrapper(loader, node):
        if len(node.value) > MAX_NUMBER_CHARS:
            raise yaml.constructor.ConstructorError(
                None, None, f"a number with {len(node.value)} characters (at most {MAX_NUMBER_CHARS})",
                node.start_mark)
        return construct(loader, node)
    return wrapper


_StrictSafeLoader.add_constructor("tag:yaml.org,2002:int", _bounded(yaml.SafeLoader.construct_yaml_int))
_StrictSafeLoader.add_constructor("tag:yaml.org,2002:float", _bounded(yaml.SafeLoader.construct_yaml_float))


def yaml_error_message(e: Exception) -> str:
    mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
    problem = getattr(e, "problem", None) or getattr(e, "context", None) or str(e)
    problem = " ".join(str(problem).split())
    kind = "YAML syntax error" if isinstance(e, (yaml.scanner.ScannerError, yaml.parser.ParserError)) else "YAML error"
    if mark is not None:
        return f"{kind} at line {mark.line + 1}, column {mark.column + 1}: {clean_text(problem)}"
    return f"YAML error: {clean_text(problem)}"


def load_strict(text: str):
    """The value of the YAML document ``text`` (`_StrictSafeLoader`); yaml.YAMLError (TooLarge: far too large)."""
    return yaml.load(text, Loader=_StrictSafeLoader)  # noqa: S506 - a SafeLoader subclass
