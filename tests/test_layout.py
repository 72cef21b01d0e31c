"""The shape of the code (docs/architecture.md): imports inside synth/ and cli/ point one way through the
layers (the contracts in pyproject.toml, checked by import-linter), form no cycle (in-function imports
included), never name another module's private ``_name``, and only synth/io and synth/tools touch files.

The import graph is read with ``ast`` from the source, so an import hidden in a function counts too.
Run ``python tests/test_layout.py`` to print the graph's in-function edges and its cycles.
"""
from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("synth", "cli")

# still to be removed by their owners (each entry is one known exception; the tests fail on any other)
KNOWN_CYCLES: list[set[str]] = []
KNOWN_PRIVATE: set[tuple[str, str, str]] = set()
FILE_METHODS = ("read_text", "write_text", "read_bytes", "write_bytes", "mkdir", "unlink", "rmdir", "touch")
FILE_FUNCTIONS = {"os": ("open", "replace", "rename", "remove", "unlink", "makedirs", "mkdir"),
                  "shutil": ("rmtree", "copytree", "copyfile", "move"), "tempfile": ("mkstemp", "mkdtemp"),
                  "io": ("open",)}


def modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for f in (ROOT / pkg).rglob("*.py"):
            parts = list(f.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = f
    return out


def _resolve(name: str, mods) -> str | None:
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


_CACHE: dict = {}


def imports() -> list[tuple[str, str, str, bool]]:
    """(importer, imported module, imported name or "", inside a function?) for every intra-package
    import; ``from a.b import c`` names module a.b.c when it exists, else a.b. Read once per ROOT."""
    if ROOT not in _CACHE:
        _CACHE[ROOT] = _read_imports(modules())
    return _CACHE[ROOT]


def _read_imports(mods) -> list[tuple[str, str, str, bool]]:
    out = []
    for m, f in mods.items():
        is_pkg = f.name == "__init__.py"

        def visit(node, in_func):
            for ch in ast.iter_child_nodes(node):
                inner = in_func or isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
                if isinstance(ch, ast.Import):
                    for a in ch.names:
                        r = _resolve(a.name, mods)
                        if a.name.split(".")[0] in PACKAGES and r and r != m:
                            out.append((m, r, "", inner))
                elif isinstance(ch, ast.ImportFrom):
                    base = ch.module or ""
                    if ch.level:
                        pkg = m.split(".") if is_pkg else m.split(".")[:-1]
                        pkg = pkg[:len(pkg) - (ch.level - 1)]
                        base = ".".join(pkg + ([base] if base else []))
                    if base.split(".")[0] in PACKAGES:
                        for a in ch.names:
                            r = _resolve(f"{base}.{a.name}", mods)
                            name = "" if r == f"{base}.{a.name}" else a.name
                            if r and r != m:
                                out.append((m, r, name, inner))
                visit(ch, inner)

        visit(ast.parse(f.read_text(encoding="utf-8")), False)
    return out


def cycles(edges) -> list[set[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    graph: dict[str, set[str]] = {}
    for a, b, _, _ in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, stack, on, comps = {}, {}, [], set(), []

    def strong(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(comp)

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph) + 100))
    for v in sorted(graph):
        if v not in index:
            strong(v)
    return comps


def test_no_import_cycles():
    found = cycles(imports())
    assert [c for c in found if c not in KNOWN_CYCLES] == []


def test_imports_point_down_the_layers():
    """`lint-imports` (import-linter, the test extra) keeps the contracts of pyproject.toml, as .ci/run checks."""
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    if exe is None:
        pytest.skip("import-linter is not installed (pip install -e '.[test]')")
    r = subprocess.run([exe, "--no-cache", "--no-logo"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]


def test_architecture_names_every_module():
    """docs/architecture.md names every module of synth/ and cli/ (by its file name, in its layer's
    paragraph): a new module gets its line there."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")

    def named(stem: str) -> bool:
        return re.search(rf"(?<![\w]){re.escape(stem)}(\.py|/)", text) is not None

    missing = [str(f.relative_to(ROOT)) for f in modules().values() if f.name != "__init__.py" and not named(f.stem)]
    assert missing == [], "add these to docs/architecture.md: " + ", ".join(sorted(missing))


def test_no_private_names_across_modules():
    private = {(a, b, n) for a, b, n, _ in imports() if n.startswith("_") and not n.startswith("__")}
    assert private - KNOWN_PRIVATE == set()


def test_only_io_and_tools_touch_files():
    """No file-system call outside synth/io and synth/tools (cli/ included: the CLI calls the library)."""
    offenders = []
    for m, f in modules().items():
        if m.startswith(("synth.io", "synth.tools")):
            continue
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Call):
                continue
            fn = node.func
            if isinstance(fn, ast.Name):
                hit = fn.id == "open"
            elif isinstance(fn, ast.Attribute):
                owner = fn.value.id if isinstance(fn.value, ast.Name) else ""
                hit = fn.attr in FILE_METHODS or fn.attr in FILE_FUNCTIONS.get(owner, ())
                hit = hit and not (m in ("cli.batch", "cli.streams") and owner == "os")  # os.open(os.devnull): std streams
            else:
                hit = False
            if hit:
                offenders.append(f"{m}:{node.lineno}")
    known = {"cli.factor", "cli.sixbar"}  # still to move their file reading / writing into synth.io
    assert [o for o in offenders if o.split(":")[0] not in known] == []


def test_the_graph_sees_hidden_imports(tmp_path, monkeypatch):
    """The reader counts an import inside a function and finds the cycle it closes."""
    pkg = tmp_path / "synth"
    (pkg / "a").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a" / "__init__.py").write_text("")
    (pkg / "a" / "x.py").write_text("from synth.a.y import f\n")
    (pkg / "a" / "y.py").write_text("def f():\n    from synth.a import x\n    return x\n")
    (tmp_path / "cli").mkdir()
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    edges = imports()
    assert ("synth.a.y", "synth.a.x", "", True) in edges and ("synth.a.x", "synth.a.y", "f", False) in edges
    assert cycles(edges) == [{"synth.a.x", "synth.a.y"}]


if __name__ == "__main__":  # the report: in-function edges and cycles
    edges = imports()
    print("in-function imports:")
    for a, b, n, inner in sorted(set(edges)):
        if inner:
            print(f"  {a} -> {b}{'.' + n if n else ''}")
    print("cycles:")
    for comp in cycles(edges):
        print("  " + ", ".join(sorted(comp)))
        for a, b, inner in sorted({(a, b, inner) for a, b, _, inner in edges}):
            if a in comp and b in comp:
                print(f"    {'in-function' if inner else 'top-level  '} {a} -> {b}")
