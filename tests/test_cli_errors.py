"""Issue 8 at the command line: every malformed input, unusable OUT or degenerate geometry ends in
exactly one stderr line ``mpsynth: ...`` naming the file, pose and problem, the contract's exit code
(2 input/usage, 1 no real linkage), nothing on stdout, no traceback, and nothing written: no OUT and
no temporary ``.*mpsynth-tmp*`` / ``.*mpsynth-old*`` directory.

The table runs the real click command in-process (fast); `test_subprocess_rows` re-runs a sample in a
real process, where Python would print warnings and tracebacks itself."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import REPO, invoke

EXE = REPO / ".venv" / "bin" / "mpsynth"
CMD = [str(EXE)] if EXE.exists() else [sys.executable, "-c", "from cli.main import main; main()"]

POSE_A = "{name: a, position: [0, 0, 0], quaternion: {w: 1, x: 0, y: 0, z: 0}}"
POSE_B = "{name: b, position: [1, 0, 0.5], quaternion: {w: 0.6, x: 0, y: 0, z: 0.8}}"
POSE_C = "{name: c, position: [0.25, 1, 0.2], quaternion: {w: 0.6, x: 0.8, y: 0, z: 0}}"


def doc(*poses, units=None):
    head = (f"units: {units}\n" if units else "") + "quaternion_order: wxyz\n"
    return head + "poses:\n" + "".join(f"  - {p}\n" for p in poses)


GOOD = doc(POSE_A, POSE_B, POSE_C)
GOOD_JSON = json.dumps({"poses": [
    {"name": "a", "position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
    {"name": "b", "position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}},
    {"name": "c", "position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}}]})


def leftovers(root: Path) -> list[str]:
    """Temporary or moved-away directories the writer might leave behind, anywhere under root."""
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if "mpsynth-tmp" in p.name
                  or "mpsynth-old" in p.name)


def assert_one_line_error(code, out, err, expected_code, needles):
    assert code == expected_code, (code, err)
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("mpsynth: "), err
    assert "Traceback" not in err and "Error:" not in lines[0][:15]
    for n in needles:
        assert n in lines[0], (n, lines[0])
    assert out == ""


# ------------------------------------------------------------------ the table
# Each setup(tmp) writes what it needs under tmp and returns the argument list (after "mpsynth").
# Rows: id -> (setup, exit code, substrings of the message).
def _file(name, text, *extra, mode="w"):
    def setup(tmp):
        p = tmp / name
        if mode == "wb":
            p.write_bytes(text)
        else:
            p.write_text(text)
        return ["bennett", name, "-o", "out", *extra]
    return setup


def _args(*args, files=None):
    def setup(tmp):
        for name, text in (files or {}).items():
            (tmp / name).write_text(text)
        return list(args)
    return setup


def _sparse_50mb(tmp):
    with open(tmp / "huge.yaml", "wb") as f:
        f.truncate(50 * 1024 * 1024)  # sparse: instant, takes no disk
    return ["bennett", "huge.yaml", "-o", "out"]


def _million_json(tmp):
    (tmp / "many.json").write_text('{"poses": [' + ",".join(["{}"] * 10**6) + "]}")
    return ["bennett", "many.json", "-o", "out"]


def _million_yaml(tmp):
    (tmp / "many.yaml").write_text("poses:\n" + "- {}\n" * 10**6)
    return ["bennett", "many.yaml", "-o", "out"]


def _alias_million(tmp):
    (tmp / "alias.yaml").write_text(f"poses: [{', '.join(['*p'] * 10**6)}]\n".replace("*p", f"&p {POSE_A}", 1))
    return ["bennett", "alias.yaml", "-o", "out"]


def _merge_bomb(tmp):
    lines = ["m0: &m0 {" + ", ".join(f"k{i}: 1" for i in range(10)) + "}"]
    for k in range(1, 10):
        lines.append(f"m{k}: &m{k} {{<<: [{', '.join([f'*m{k - 1}'] * 10)}]}}")
    lines.append("poses: [*m9]")
    (tmp / "bomb.yaml").write_text("\n".join(lines) + "\n")
    return ["bennett", "bomb.yaml", "-o", "out"]


def _foreign_out(tmp):
    (tmp / "good.yaml").write_text(GOOD)
    (tmp / "out").mkdir()
    (tmp / "out" / "thesis.tex").write_text("precious")
    return ["bennett", "good.yaml", "-o", "out"]


def _out_is_file(tmp):
    (tmp / "good.yaml").write_text(GOOD)
    (tmp / "out").write_text("a file")
    return ["bennett", "good.yaml", "-o", "out"]


def _out_parent_is_file(tmp):
    (tmp / "good.yaml").write_text(GOOD)
    (tmp / "plain").write_text("")
    return ["bennett", "good.yaml", "-o", "plain/out"]


def _unreadable(tmp):
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        return ["bennett", "/proc/self/mem", "-o", "out"]  # open() works, read() fails (EIO), even for root
    (tmp / "secret.yaml").write_text(GOOD)
    (tmp / "secret.yaml").chmod(0)
    return ["bennett", "secret.yaml", "-o", "out"]


TRANSLATIONS = doc("{position: [0, 0, 0], rpy: [0, 0, 0]}", "{position: [1, 0, 0], rpy: [0, 0, 0]}",
                   "{position: [0, 2, 0], rpy: [0, 0, 0]}")
COINCIDENT = doc(POSE_A, "{name: again, position: [0, 0, 0], rpy: [0, 0, 0]}", POSE_C)
PARALLEL_SCREWS = doc("{position: [0, 0, 0], rpy: [0, 0, 0]}", "{position: [0, 0, 0.3], rpy: [0, 0, 0.7]}",
                      "{position: [1, 1, 0.5], rpy: [0, 0, 1.1]}")

ROWS = {
    # --- reading the file
    "missing-file": (_args("bennett", "nope.yaml", "-o", "out"), 2, ["nope.yaml", "no such file"]),
    "directory-as-file": (_args("bennett", ".", "-o", "out"), 2, [".: ", "directory"]),
    "unreadable-file": (_unreadable, 2, ["cannot read file"]),
    "empty-file": (_file("p.yaml", ""), 2, ["p.yaml", "empty"]),
    "comment-only": (_file("p.yaml", "# nothing here\n"), 2, ["p.yaml", "empty"]),
    "binary-garbage": (_file("p.yaml", bytes(range(256)) * 40, mode="wb"), 2, ["p.yaml", "not UTF-8"]),
    "50MB-file": (_sparse_50mb, 2, ["huge.yaml", "10 MB"]),
    "10^6-poses-json": (_million_json, 2, ["many.json", "1000000 poses", "10000"]),
    "10^6-poses-yaml": (_million_yaml, 2, ["many.yaml", "more than 10000 items"]),
    "10^6-aliases-yaml": (_alias_million, 2, ["alias.yaml", "more than 10000 items"]),
    # PyYAML < 6.0.4 expands merge keys with repeats (refused by our loader: "merge keys ..."); 6.0.4
    # drops repeated keys, so the document is small and the unknown top-level keys are reported
    "yaml-merge-bomb": (_merge_bomb, 2, ["bomb.yaml"]),
    # --- syntax and structure
    "yaml-syntax": (_file("p.yaml", "poses:\n  - {position: [0, 0, 0]\n  - x\n"), 2,
                    ["p.yaml", "YAML syntax error at line"]),
    "yaml-bad-indent": (_file("p.yaml", "poses:\n  - position: [0,0,0]\n quaternion: [1,0,0,0]\n"), 2,
                        ["p.yaml", "YAML syntax error at line 3"]),
    "json-syntax": (_file("p.json", '{"poses": [\n  {"position": [0, 0, 0],}\n]}'), 2,
                    ["p.json", "JSON syntax error at line 2"]),
    "not-a-mapping": (_file("p.yaml", "- position: [0, 0, 0]\n"), 2, ["p.yaml", "top level must be a mapping"]),
    "missing-poses": (_file("p.yaml", "units: {length: mm}\n"), 2, ["p.yaml", "missing 'poses'"]),
    "poses-not-a-list": (_file("p.yaml", "poses: 3\n"), 2, ["p.yaml", "'poses' must be a list"]),
    "too-few-poses": (_file("p.yaml", doc(POSE_A, POSE_B)), 2,
                      ["p.yaml", "needs 3 or more poses, 2 poses with a velocity at one of them, or 3 or more points, got 2 poses"]),
    # four exact poses over-determine a Bennett motion: fitted, and refused when they are not on one
    "four-exact-poses": (_file("p.yaml", doc(POSE_A, POSE_B, POSE_C, "{position: [1, 1, 1], rpy: [1, 0, 0]}")),
                         1, ["p.yaml", "the exact poses and velocities cannot all be met by a Bennett motion"]),
    "pose-not-a-mapping": (_file("p.yaml", doc(POSE_A, "[1, 2, 3]", POSE_C)), 2,
                           ["p.yaml: pose 1: a pose must be a mapping"]),
    "unknown-top-key": (_file("p.yaml", "pose:\n  - " + POSE_A + "\n"), 2,
                        ["p.yaml", 'unknown key "pose"', 'did you mean "poses"?']),
    "unknown-pose-key": (_file("p.yaml", doc(POSE_A, "{name: b, postion: [0, 0, 1], rpy: [0, 0, 0]}", POSE_C)),
                         2, ['p.yaml: pose 1 ("b"): unknown key "postion"', 'did you mean "position"?']),
    "two-orientations": (_file("p.yaml", doc(POSE_A, "{name: b, position: [0, 0, 1], rpy: [0, 0, 0], "
                                                     "quaternion: [1, 0, 0, 0]}", POSE_C)),
                         2, ['pose 1 ("b")', "two orientations"]),
    "matrix-and-position": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [0, 0, 0], matrix: "
                                                "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}")),
                            2, ['pose 2 ("c")', "'matrix' must be alone"]),
    "missing-position": (_file("p.yaml", doc(POSE_A, "{name: b, rpy: [0, 0, 1]}", POSE_C)), 2,
                         ['pose 1 ("b")', "missing 'position'"]),
    "missing-orientation": (_file("p.yaml", doc(POSE_A, POSE_B, "{position: [1, 2, 3]}")), 2,
                            ["pose 2: missing orientation"]),
    "short-vector": (_file("p.yaml", doc(POSE_A, "{name: b, position: [0, 1], rpy: [0, 0, 1]}", POSE_C)), 2,
                     ['pose 1 ("b")', "position must be a list of 3 numbers"]),
    "long-quaternion": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [0, 1, 2], "
                                                            "quaternion: [1, 0, 0, 0, 0]}")),
                        2, ['pose 2 ("c")', "quaternion list must have 4 numbers"]),
    "string-for-number": (_file("p.yaml", doc(POSE_A, "{name: b, position: [0, 'one', 2], rpy: [0, 0, 1]}",
                                              POSE_C)), 2, ['pose 1 ("b")', "position[1] must be a number"]),
    "bool-for-number": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [0, 1, 2], rpy: [yes, 0, 0]}")),
                        2, ['pose 2 ("c")', "rpy[0] must be a number"]),
    "nan": (_file("p.yaml", doc(POSE_A, "{name: b, position: [0, .nan, 2], rpy: [0, 0, 1]}", POSE_C)), 2,
            ['pose 1 ("b")', "not finite"]),
    "inf-json": (_file("p.json", GOOD_JSON.replace("[1, 0, 0.5]", "[1, Infinity, 0.5]")), 2,
                 ['p.json: pose 1 ("b")', "not finite"]),
    "1e300": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [1e300, 0, 0], rpy: [0, 0, 1]}")), 2,
              ['pose 2 ("c")', "too large"]),
    "far-beyond-any-task": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [9e11, 0, 0], rpy: [0, 0, 1]}")),
                            2, ['pose 2 ("c")', "too far from the origin"]),
    "non-unit-quaternion": (_file("p.yaml", doc(POSE_A, "{name: b, position: [1, 0, 0.5], quaternion: "
                                                        "{w: 0.3, x: 0, y: 0, z: 0.4}}", POSE_C)),
                            2, ['p.yaml: pose 1 ("b"): quaternion has length 0.5, expected 1 '
                                '(normalize it or use --normalize)']),
    "zero-quaternion": (_file("p.yaml", doc(POSE_A, "{name: b, position: [0, 0, 0], quaternion: [0, 0, 0, 0]}",
                                            POSE_C)), 2, ['pose 1 ("b")', "quaternion is zero"]),
    "non-orthonormal-rotation": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [0, 0, 0], "
                                                     "rotation: [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]}")),
                                 2, ['pose 2 ("c")', "not orthonormal"]),
    "reflection": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, position: [0, 0, 0], "
                                       "rotation: [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]}")),
                   2, ['pose 2 ("c")', "reflection"]),
    "bad-last-matrix-row": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, matrix: [[1,0,0,0],[0,1,0,0],"
                                                "[0,0,1,0],[0,0,1,1]]}")),
                            2, ['pose 2 ("c")', "last row", "expected [0, 0, 0, 1]"]),
    "matrix-3x4": (_file("p.yaml", doc(POSE_A, POSE_B, "{name: c, matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}")),
                   2, ['pose 2 ("c")', "4x4 matrix"]),
    "unknown-length-unit": (_file("p.yaml", doc(POSE_A, POSE_B, POSE_C, units="{length: furlong}")), 2,
                            ["p.yaml", 'unknown length unit "furlong"', "m, mm, cm, in"]),
    "unknown-angle-unit": (_file("p.yaml", doc(POSE_A, POSE_B, POSE_C, units="{angle: grad}")), 2,
                           ["p.yaml", 'unknown angle unit "grad"']),
    "duplicate-names": (_file("p.yaml", doc(POSE_A, POSE_B, POSE_C.replace("name: c", "name: a"))), 2,
                        ['pose 2 ("a")', 'duplicate pose name "a"', "pose 0 has it"]),
    "duplicate-key": (_file("p.yaml", "poses:\n  - position: [0,0,0]\n    position: [1,0,0]\n    rpy: [0,0,0]\n"),
                      2, ["p.yaml", "duplicate key", "line 3"]),
    "name-not-a-string": (_file("p.yaml", doc(POSE_A, POSE_B.replace("name: b", "name: [b]"), POSE_C)), 2,
                          ["pose 1: name must be a string"]),
    "python-object-tag": (_file("p.yaml", 'poses: !!python/object/apply:os.system ["touch pwned"]\n'), 2,
                          ["p.yaml", "python/object/apply:os.system"]),
    "stdin-garbage": (_args("bennett", "-", "-o", "out"), 2, ["<stdin>", "YAML syntax error"]),  # input below
    # --- options
    "pin-radius-negative": (_file("good.yaml", GOOD, "--pin-radius", "-1"), 2, ["--pin-radius", "positive"]),
    "pin-radius-nan": (_file("good.yaml", GOOD, "--pin-radius", "nan"), 2, ["--pin-radius", "positive"]),
    "pin-radius-inf": (_file("good.yaml", GOOD, "--pin-radius", "inf"), 2, ["--pin-radius", "positive"]),
    "pin-radius-not-a-number": (_file("good.yaml", GOOD, "--pin-radius", "abc"), 2,
                                ["--pin-radius", "'abc' is not a valid float", "mpsynth bennett --help"]),
    "link-radius-absurd": (_file("good.yaml", GOOD, "--link-radius", "1e8"), 2,
                           ["--link-radius", "out of range for a linkage of size"]),
    "pin-length-absurd": (_file("good.yaml", GOOD, "--pin-length", "100000"), 2,
                          ["--pin-length", "out of range for a linkage of size"]),
    "pin-radius-absurdly-small": (_file("good.yaml", GOOD, "--pin-radius", "1e-12"), 2,
                                  ["--pin-radius", "out of range"]),
    "unknown-option": (_file("good.yaml", GOOD, "--bogus"), 2, ["No such option '--bogus'"]),
    "missing-argument": (_args("bennett", "-o", "out"), 2, ["Missing argument 'POSES'"]),
    "unknown-command": (_args("benett", "x.yaml"), 2, ["No such command 'benett'", "did you mean 'bennett'?"]),
    # --- OUT
    "out-parent-missing": (_args("bennett", "good.yaml", "-o", "no/such/out", files={"good.yaml": GOOD}), 2,
                           ["no/such", "output parent directory does not exist"]),
    "out-is-a-file": (_out_is_file, 2, ["'out' is a file"]),
    "out-parent-is-a-file": (_out_parent_is_file, 2, ["plain", "output parent is not a directory"]),
    "out-foreign-directory": (_foreign_out, 2, ["out", "not written by mpsynth", "--force"]),
    "out-under-proc": (_args("bennett", "good.yaml", "-o", "/proc/mpsynth-test-out", files={"good.yaml": GOOD}),
                       2, ["/proc", "cannot create the output directory"]),
    "out-in-read-only-dir": (_args("bennett", "good.yaml", "-o", "/proc/sys/mpsynth-test-out",
                                   files={"good.yaml": GOOD}), 2, ["/proc/sys", "not writable"]),
    # --- geometry (exit 1): the input is valid, no linkage exists
    "coincident-poses": (_file("p.yaml", COINCIDENT), 1, ["p.yaml: poses 0 ('a') and 1 ('again') coincide"]),
    "translation-poses": (_file("p.yaml", TRANSLATIONS), 1, ["p.yaml: ", "pure translations"]),
    "parallel-screws": (_file("p.yaml", PARALLEL_SCREWS), 1, ["p.yaml: ", "prismatic"]),
}
STDIN = {"stdin-garbage": "poses: [\n  - {a: 1\n"}


def test_enough_rows():
    assert len(ROWS) >= 30


@pytest.mark.parametrize("row", list(ROWS))
def test_malformed_input(row, tmp_path):
    setup, expected, needles = ROWS[row]
    args = setup(tmp_path)
    before = set(os.listdir(tmp_path))
    t0 = time.process_time()  # this process's CPU time (in-process CLI): a blow-up guard, steady under load
    code, out, err = invoke(args, tmp_path, input=STDIN.get(row))
    elapsed = time.process_time() - t0
    assert_one_line_error(code, out, err, expected, needles)
    after = set(os.listdir(tmp_path))
    if row.startswith("out-") and "out" in before:
        assert after == before  # the foreign OUT / the file is left as it was
    else:
        assert after == before and "out" not in after, after - before
    assert leftovers(tmp_path) == []
    assert not (tmp_path / "pwned").exists()
    if row in ("50MB-file", "10^6-poses-json", "10^6-poses-yaml", "10^6-aliases-yaml", "yaml-merge-bomb"):
        assert elapsed < 15, f"{row} took {elapsed:.1f} s of CPU: it must be refused early"


def test_foreign_out_is_untouched_then_written_beside_with_force(tmp_path):
    args = _foreign_out(tmp_path)
    code, _, err = invoke(args, tmp_path)
    assert code == 2 and (tmp_path / "out" / "thesis.tex").read_text() == "precious"
    code, out, err = invoke(args + ["--force", "-q"], tmp_path)
    assert code == 0, err
    assert (tmp_path / "out" / "thesis.tex").read_text() == "precious"  # --force never deletes the user's files
    assert json.loads((tmp_path / "out" / "linkage.json").read_text())["format"] == "mpsynth.linkage/1"
    assert sorted(os.listdir(tmp_path)) == ["good.yaml", "out"] and leftovers(tmp_path) == []


def test_normalize_accepts_non_unit_quaternion(tmp_path):
    text = doc(POSE_A, "{name: b, position: [1, 0, 0.5], quaternion: {w: 0.3, x: 0, y: 0, z: 0.4}}", POSE_C)
    (tmp_path / "p.yaml").write_text(text)
    code, _, err = invoke(["bennett", "p.yaml", "-o", "out"], tmp_path)
    assert code == 2 and "--normalize" in err
    code, out, err = invoke(["bennett", "p.yaml", "-o", "out", "--normalize", "--json"], tmp_path)
    assert code == 0, err
    doc_ = json.loads(out)
    assert doc_["checks"]["max_pose_error"] < 1e-12
    # the normalized quaternion (0.6, 0, 0, 0.8) is pose b of the worked example
    assert doc_["poses"][1]["matrix"][0][:3] == pytest.approx([-0.28, -0.96, 0.0], abs=1e-15)
    assert (tmp_path / "out" / "linkage.urdf").is_file()


def test_nothing_written_without_out_even_on_error(tmp_path):
    (tmp_path / "p.yaml").write_text(TRANSLATIONS)
    code, out, err = invoke(["bennett", "p.yaml", "--json"], tmp_path)
    assert_one_line_error(code, out, err, 1, ["pure translations"])
    assert os.listdir(tmp_path) == ["p.yaml"]


# ------------------------------------------------------------------ real processes
SUBPROCESS_ROWS = ["missing-file", "yaml-syntax", "non-unit-quaternion", "nan", "pin-radius-nan",
                   "pin-radius-not-a-number", "out-parent-missing", "out-foreign-directory", "coincident-poses",
                   "translation-poses", "python-object-tag"]


@pytest.mark.parametrize("row", SUBPROCESS_ROWS)
def test_subprocess_rows(row, tmp_path):
    setup, expected, needles = ROWS[row]
    args = setup(tmp_path)
    before = set(os.listdir(tmp_path))
    r = subprocess.run(CMD + args, cwd=tmp_path, capture_output=True, text=True, timeout=120,
                       stdin=subprocess.DEVNULL)
    assert_one_line_error(r.returncode, r.stdout, r.stderr, expected, needles)
    assert set(os.listdir(tmp_path)) == before and leftovers(tmp_path) == []
    assert not (tmp_path / "pwned").exists()


def test_debug_shows_the_traceback(tmp_path):
    (tmp_path / "p.yaml").write_text(doc(POSE_A, POSE_B))
    r = subprocess.run(CMD + ["bennett", "p.yaml", "-o", "out", "--debug"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert r.returncode == 2 and r.stdout == ""
    assert "Traceback (most recent call last)" in r.stderr and "InputError" in r.stderr
    assert r.stderr.splitlines()[-1] == "mpsynth: p.yaml: a Bennett linkage needs 3 or more poses, 2 poses with a velocity at one of them, or 3 or more points, got 2 poses"
    assert not (tmp_path / "out").exists()
    # without --debug: the same line alone
    r = subprocess.run(CMD + ["bennett", "p.yaml", "-o", "out"], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120, stdin=subprocess.DEVNULL)
    assert r.returncode == 2 and r.stderr == "mpsynth: p.yaml: a Bennett linkage needs 3 or more poses, 2 poses with a velocity at one of them, or 3 or more points, got 2 poses\n"


# ------------------------------------------------------------------ code injection
YAML_TAG_PAYLOADS = [
    '!!python/object/apply:os.system ["touch pwned"]',
    '!!python/object/apply:subprocess.call [["touch", "pwned"]]',
    '!!python/object/new:os.system ["touch pwned"]',
    "!!python/name:os.system",
    "!!python/module:os",
    '!!python/object:__main__.X {a: 1}',
    "!!binary aGVsbG8=",
    "!custom {a: 1}",
]
TAG_PLACES = {  # where a tag can sit in a pose file
    "top": "{p}\n",
    "poses": "poses: {p}\n",
    "pose": "poses:\n  - {p}\n  - " + POSE_B + "\n  - " + POSE_C + "\n",
    "position": "poses:\n  - {name: a, position: {p}, rpy: [0, 0, 0]}\n  - " + POSE_B + "\n  - " + POSE_C + "\n",
    "name": "poses:\n  - {name: {p}, position: [0, 0, 0], rpy: [0, 0, 0]}\n  - " + POSE_B + "\n  - " + POSE_C
            + "\n",
    "units": "units: {p}\n" + GOOD,
    "key": "poses:\n  - {? {p} : 1, position: [0, 0, 0], rpy: [0, 0, 0]}\n  - " + POSE_B + "\n  - " + POSE_C
           + "\n",
}


@pytest.mark.parametrize("place", list(TAG_PLACES))
@pytest.mark.parametrize("payload", YAML_TAG_PAYLOADS, ids=[str(i) for i in range(len(YAML_TAG_PAYLOADS))])
def test_yaml_tags_execute_nothing(place, payload, tmp_path):
    (tmp_path / "p.yaml").write_text(TAG_PLACES[place].replace("{p}", payload))
    code, out, err = invoke(["bennett", "p.yaml", "-o", "out"], tmp_path)
    assert_one_line_error(code, out, err, 2, ["p.yaml"])
    assert sorted(os.listdir(tmp_path)) == ["p.yaml"]  # no pwned, no out


EXPR_PAYLOADS = [
    "__import__('os').system('touch pwned')",
    "t.__class__",
    "t.__class__.__mro__[1].__subclasses__()",
    "exec('open(\"pwned\", \"w\")')",
    "eval('1')",
    "open('pwned', 'w')",
    "lambda: 0",
    "(t - i); __import__('os').system('touch pwned')",
    "t - i ; touch pwned",
    "`touch pwned`",
    "$(touch pwned)",
    "t - i && touch pwned",
    "t - i | touch pwned",
    "Symbol('t')",
    "sympify('t')",
    "t**2 if 1 else 0",
    "[t for t in ()]",
    "{'a': t}",
    "t @ i",
    "t - i # comment",
    "t = 1",
    "t - \\x69",
    "t - i\n__import__('os')",
    "t - \u0131",  # dotless i
    "E**t",
    "t - i\x00",
]


@pytest.mark.parametrize("payload", EXPR_PAYLOADS, ids=[str(i) for i in range(len(EXPR_PAYLOADS))])
def test_expression_parser_rejects_code(payload, tmp_path, monkeypatch):
    """The parser behind `factor --expr`, `expression:` and `curve:` never evaluates its text."""
    from synth.errors import InputError
    from synth.algebra.expr import parse_polynomial

    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError) as e:
        parse_polynomial(payload)
    msg = str(e.value)
    assert "\n" not in msg and msg
    assert os.listdir(tmp_path) == []


def test_expression_parser_huge_degree_refused_fast():
    from synth.errors import InputError
    from synth.algebra.expr import parse_polynomial

    for text in ["(t - i)^10000", "t^10000 + 1", "(" * 5000 + "t" + ")" * 5000, "t" + "*t" * 9000]:
        t0 = time.process_time()  # (this process's CPU time: a blow-up guard, steady under load)
        with pytest.raises(InputError):
            parse_polynomial(text)
        assert time.process_time() - t0 < 5, text


CLI_PAYLOADS = ["__import__('os').system('touch pwned')", "t.__class__", "exec('open(\"pwned\", \"w\")')",
                "lambda: 0", "t - i; __import__('os')", "`touch pwned`", "$(touch pwned)"]
EXPRESSION_FIELDS = {  # every command field that takes a polynomial expression: (setup(tmp, payload) -> args)
    "factor --expr": lambda tmp, p: ["factor", "--expr", p],
    "factor file expression:": lambda tmp, p: (_write(tmp / "f.yaml", {"expression": p}), ["factor", "f.yaml"])[1],
    "curve motion: expression": lambda tmp, p: (_write(tmp / "c.yaml", {"motion": {"expression": p}}),
                                                 ["curve", "c.yaml", "-o", "out"])[1],
    "curve curve: x": lambda tmp, p: (_write(tmp / "c.yaml", {"curve": {"x": p, "y": "t", "z": "0", "w": "t^2 + 1"}}),
                                      ["curve", "c.yaml", "-o", "out"])[1],
}
YAML_COMMANDS = {"factor": ["factor", "p.yaml"], "curve": ["curve", "p.yaml", "-o", "out"],
                 "bennett": ["bennett", "p.yaml", "-o", "out"]}


def _write(path, doc):
    path.write_text(json.dumps(doc))  # JSON is YAML: quoting stays exact


@pytest.mark.parametrize("field", list(EXPRESSION_FIELDS))
@pytest.mark.parametrize("payload", CLI_PAYLOADS, ids=[str(i) for i in range(len(CLI_PAYLOADS))])
def test_expression_fields_execute_nothing(field, payload, tmp_path):
    args = EXPRESSION_FIELDS[field](tmp_path, payload)
    before = set(os.listdir(tmp_path))
    code, out, err = invoke(args, tmp_path)
    assert_one_line_error(code, out, err, 2, [])
    assert set(os.listdir(tmp_path)) == before and leftovers(tmp_path) == []  # no pwned, no out


@pytest.mark.parametrize("command", list(YAML_COMMANDS))
@pytest.mark.parametrize("payload", YAML_TAG_PAYLOADS[:5], ids=[str(i) for i in range(5)])
def test_yaml_tags_in_every_yaml_input(command, payload, tmp_path):
    (tmp_path / "p.yaml").write_text(f"x: {payload}\n")
    code, out, err = invoke(YAML_COMMANDS[command], tmp_path)
    assert_one_line_error(code, out, err, 2, ["p.yaml"])
    assert sorted(os.listdir(tmp_path)) == ["p.yaml"]
