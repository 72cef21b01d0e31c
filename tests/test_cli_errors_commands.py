"""Issue 8 beyond `bennett`: bad input to every other command ends in exactly one `mpsynth: ` line on
stderr, the contract's exit code (2 input/usage, 1 no real linkage), nothing on stdout and nothing
written. (The 66-row table for `bennett` and the injection tests are in test_cli_errors.py.)"""
from __future__ import annotations

import os

import pytest

from conftest import REPO
from test_cli_errors import assert_one_line_error, doc, invoke, leftovers

FIX = REPO / "fixtures"
Q = "quaternion: {w: 1, x: 0, y: 0, z: 0}"
TRANSLATIONS_4 = doc(*(f"{{position: {p}, {Q}}}" for p in ("[0, 0, 0]", "[1, 0, 0]", "[0, 1, 0]", "[0, 0, 1]")))
# rotations about one fixed axis (the z axis): a single revolute joint, no six-bar (docs/planar.md)
ONE_AXIS_4 = doc("{position: [1, 0, 0], rpy: [0, 0, 0]}", "{position: [0, 1, 0], rpy: [0, 0, 1.5707963267948966]}",
                 "{position: [-1, 0, 0], rpy: [0, 0, 3.141592653589793]}",
                 "{position: [0, -1, 0], rpy: [0, 0, -1.5707963267948966]}")

# id -> (argument list, {file name: text}, exit code, substrings of the message)
ROWS = {
    "sixbar-3-poses": (["sixbar", FIX / "bennett_quat.yaml", "-o", "out"], {}, 2, ["needs 4 poses", "got 3"]),
    "sixbar-translations": (["sixbar", "p.yaml", "-o", "out"], {"p.yaml": TRANSLATIONS_4}, 1, ["pure translations"]),
    "sixbar-one-axis": (["sixbar", "p.yaml", "-o", "out"], {"p.yaml": ONE_AXIS_4}, 1, ["lower degree"]),
    "sixbar-family-3": (["sixbar", FIX / "sixbar_example.yaml", "--family", "3", "-o", "out"], {}, 2, ["--family"]),
    "sixbar-pair-0": (["sixbar", FIX / "sixbar_example.yaml", "--pair", "0", "-o", "out"], {}, 2, ["--pair"]),
    "sixbar-top-0": (["sixbar", FIX / "sixbar_example.yaml", "--top", "0", "-o", "out"], {}, 2, ["--top"]),
    "sixbar-member-nan": (["sixbar", FIX / "sixbar_example.yaml", "--member", "nan", "-o", "out"], {}, 2,
                          ["--member", "finite"]),
    "sixbar-member-0": (["sixbar", FIX / "sixbar_example.yaml", "--member", "0", "-o", "out"], {}, 1,
                        ["lambda1 = 0", "no valid 6R"]),
    "sixbar-pin-radius": (["sixbar", FIX / "sixbar_example.yaml", "--pin-radius", "-1", "-o", "out"], {}, 2,
                          ["--pin-radius"]),
    "curve-missing": (["curve", "nofile.yaml", "-o", "out"], {}, 2, ["nofile.yaml", "no such file"]),
    "curve-pose-file": (["curve", FIX / "sixbar_example.yaml", "-o", "out"], {}, 2, ["unknown key 'units'"]),
    "curve-bad-expression": (["curve", "c.yaml", "-o", "out"],
                             {"c.yaml": 'curve: {x: "1 - t^", y: "t", z: "0", w: "1 + t^2"}\n'}, 2, ["c.yaml"]),
    "curve-unbounded": (["curve", "c.yaml", "-o", "out"],
                        {"c.yaml": 'curve: {x: "1", y: "t", z: "0", w: "t"}\n'}, 1, ["unbounded"]),
    "curve-both-keys": (["curve", "c.yaml", "-o", "out"],
                        {"c.yaml": 'curve: {x: "1", y: "t", z: "0", w: "1 + t^2"}\nmotion: {expression: "t - i"}\n'},
                        2, ["c.yaml"]),
    "factor-unfinished": (["factor", "--expr", "t^2+"], {}, 2, ["--expr", "column 5"]),
    "factor-not-monic": (["factor", "--expr", "eps*t^2 + 1"], {}, 2, ["not invertible"]),
    "factor-not-motion": (["factor", "--expr", "t^2 + eps"], {}, 2, ["not a motion polynomial"]),
    "factor-not-generic": (["factor", "--expr", "t^2+1+eps*(i+2*j*t)"], {}, 1, ["not generic", "--cofactor"]),
    "factor-row-length": (["factor", "c.yaml"], {"c.yaml": "coefficients: [[1, 2, 3], [1, 0, 0, 0, 0, 0, 0, 0]]\n"},
                          2, ["c.yaml"]),
    "factor-pose-file": (["factor", FIX / "sixbar_example.yaml"], {}, 2, ["unknown key 'units'"]),
    "flip-not-rotation": (["flip", "1 + eps*i", "k"], {}, 2, ["M: t - m is not a rotation"]),
    "check-missing": (["check", "nowhere"], {}, 2, ["nowhere"]),
    "render-missing": (["render", "nowhere", "--png", "x.png"], {}, 2, ["nowhere"]),
    "view-missing": (["view", "nowhere", "-o", "x.html"], {}, 2, ["nowhere"]),
    "collide-missing": (["collide", "nowhere"], {}, 2, ["nowhere"]),
    "simulate-missing": (["simulate", "nowhere", "--engine", "mujoco"], {}, 2, ["nowhere"]),
    "simulate-engine": (["simulate", "nowhere", "--engine", "gazebo"], {}, 2, ["--engine"]),
    "batch-missing": (["batch", "nofile.jsonl"], {}, 2, ["nofile.jsonl", "no such file"]),
}


@pytest.mark.parametrize("row", list(ROWS))
def test_bad_input_to_every_command(row, tmp_path):
    args, files, expected, needles = ROWS[row]
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    before = set(os.listdir(tmp_path))
    code, out, err = invoke(args, tmp_path)
    assert_one_line_error(code, out, err, expected, needles)
    assert set(os.listdir(tmp_path)) == before
    assert leftovers(tmp_path) == []
