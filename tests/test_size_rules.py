"""The size and naming rules (.ci/size_rules.py) hold in the lower layers: algebra, synthesis, linkage, checks."""
from __future__ import annotations

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / ".ci" / "size_rules.py"
LOWER = ("synth/algebra", "synth/synthesis", "synth/linkage.py", "synth/checks.py")


def _rules():
    spec = importlib.util.spec_from_file_location("size_rules", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _lower(findings):
    return [(p, m) for p, m in findings if any(p == x or p.startswith(x + "/") for x in LOWER)]


def test_lower_layers_keep_the_size_and_naming_rules():
    assert _lower(_rules().findings()) == []


def test_the_rules_find_a_duplicate_a_long_function_and_a_long_module(tmp_path):
    rules = _rules()
    (tmp_path / "synth" / "algebra").mkdir(parents=True)
    (tmp_path / "cli").mkdir()
    body = "\n".join(f"    x{i} = {i}" for i in range(rules.MAX_FUNCTION_LINES))
    (tmp_path / "synth" / "algebra" / "a.py").write_text(f"def twice():\n    pass\n\n\ndef long():\n{body}\n")
    (tmp_path / "synth" / "algebra" / "b.py").write_text("def twice():\n    pass\n\n\ndef scan():\n    pass\n"
                                                        + "\n" * rules.MAX_MODULE_LINES)
    (tmp_path / "synth" / "algebra" / "c.py").write_text("def scan():\n    pass\n")
    found = _lower(rules.findings(tmp_path))
    messages = sorted(m.split(" (")[0].split(" also")[0] for _, m in found)
    assert messages == ["function long", "module of 506 lines", "public function 'twice'", "public function 'twice'"]
