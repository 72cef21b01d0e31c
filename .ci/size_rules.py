#!/usr/bin/env python3
"""The size and naming rules of docs/architecture.md, measured on synth/ and cli/ (standard library only):

- public top-level functions whose name is defined in more than one synth module (but the PROTOCOL names,
  implemented once per linkage type);
- modules over MAX_MODULE_LINES lines;
- functions (and methods) over MAX_FUNCTION_LINES lines.

Prints one line per finding; ``--layers synth/algebra synth/synthesis ...`` restricts the findings to those
paths; exit status 1 when any is found and ``--check`` is given. tests/test_size_rules.py runs it on the
lower layers.
"""
from __future__ import annotations

import argparse
import ast
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80
# one protocol implemented per linkage type (planar four-bar, planar six-bar, 6R, point tasks): the same
# name in each type's module is intended
PROTOCOL = {"build", "candidates", "grid_members", "ranked", "scan"}


def modules(root: Path, top: str):
    return sorted(p for p in (root / top).rglob("*.py") if ".venv" not in p.parts)


def public_functions(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    return [n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
            and not n.name.startswith("_")]


def long_functions(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            n = node.end_lineno - first + 1
            if n > MAX_FUNCTION_LINES:
                yield node.name, node.lineno, n


def findings(root: Path = ROOT) -> list[tuple[str, str]]:
    """(path, message) for every broken rule in synth/ (names, sizes) and cli/ (sizes)."""
    out = []
    where = defaultdict(list)
    for p in modules(root, "synth"):
        for name in public_functions(p):
            where[name].append(p.relative_to(root).as_posix())
    for name, paths in sorted(where.items()):
        if len(paths) > 1 and name not in PROTOCOL:
            out += [(p, f"public function {name!r} also defined in {', '.join(q for q in paths if q != p)}")
                    for p in paths]
    for p in modules(root, "synth") + modules(root, "cli"):
        rel = p.relative_to(root).as_posix()
        lines = len(p.read_text().splitlines())
        if lines > MAX_MODULE_LINES:
            out.append((rel, f"module of {lines} lines"))
        for name, line, n in long_functions(p):
            out.append((rel, f"function {name} (line {line}) of {n} lines"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--layers", nargs="*", default=None, help="only findings under these paths")
    ap.add_argument("--check", action="store_true", help="exit 1 when anything is found")
    args = ap.parse_args(argv)
    found = [(p, m) for p, m in findings() if args.layers is None or any(p == x or p.startswith(x.rstrip("/") + "/")
                                                                          for x in args.layers)]
    for p, m in found:
        print(f"{p}: {m}")
    return 1 if found and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
