"""Issue #36, second pass: the common Bennett job read for a whole chunk at once
(`synth.tools.jobspec.read_common_bennett`) must accept only what the full reader accepts, with its numbers
bit for bit; chunks of raw lines (`synth.io.docload.read_chunks`) must be `read_lines`' lines; result lines
of a chunk at once (`dumps_lines`) the bytes of `dumps`; a pipe is answered when it is idle, and a signal
while `mpsynth batch` waits on it is acted on at once."""
from __future__ import annotations

import io
import json
import os
import random
import select
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import synth.io.docload as docload
from synth.errors import InputError
from synth.io.poses import parse_pose_document
from synth.tools.batchjobs import ChunkLines, dumps, run_chunk, run_chunk_lines
from synth.tools.jobspec import JobError, check_job, echo_id, parse_job, read_common_bennett
from synth.tools.resultlines import dumps_lines

from conftest import REPO
from test_batch_chunks import mixed_lines, readme_job


def full_reader(text):
    """(id echoed, poses (3, 4, 4)) by the full reader of a job line, or None when it refuses the line."""
    try:
        job = parse_job(text)
        check_job(job)
        doc = {k: job[k] for k in ("poses", "units") if k in job}
        ps = parse_pose_document(doc, source="poses", count=(3, "kind 'bennett'"))
    except (JobError, InputError):
        return None
    return echo_id(job.get("id")), ps.matrices


def assert_as_the_full_reader(lines):
    """Every line the fast reader takes is taken by the full reader, with the same id and the same bits."""
    got = read_common_bennett(lines)
    assert got.poses.shape == (len(got.index), 3, 4, 4)
    for k, n in enumerate(got.index):
        ref = full_reader(lines[n])
        assert ref is not None, lines[n]
        assert ref[0] == got.ids[k] and type(ref[0]) is type(got.ids[k])
        assert ref[1].tobytes() == got.poses[k].tobytes(), lines[n]
    return got


def test_readme_jobs_are_read_fast_with_the_full_readers_bits():
    rnd = random.Random(7)
    lines = [json.dumps(readme_job(rnd, i)) for i in range(300)]
    lines[5] = lines[5].replace('"deg"}', '"rad"}')  # angles beyond 2 pi in radians: allowed with a unit
    lines[6] = json.dumps({**json.loads(lines[6]), "units": {"length": "in"}})  # radians without a unit: > 2 pi
    got = assert_as_the_full_reader(lines)
    assert set(range(300)) - set(got.index) == {6}


# textual changes of a good line: each must leave the line to the full reader or keep its numbers
MUTATIONS = [
    ('"id": 3', '"id": 3, "id": 4'), ('"kind": "bennett"', '"kind": "bennett", "kind": "bennett"'),
    ('"length": "mm"', '"length": "mm", "length": "m"'), ('"rpy": [', '"rpy": [1, 2, 3], "rpy": ['),
    ('"id": 3', '"id": NaN'), ('"id": 3', '"id": 1e400'), ('"id": 3', '"id": true'), ('"id": 3', '"id": "a\\"b"'),
    ('"id": 3', '"id": "x:y"'), ('"id": 3', '"id": ":"'), ('"id": 3', '"id": 3.5'), ('"id": 3', '"id": -0.0'),
    ('"id": 3', '"id": 123456789012345678901234567890'), ('"id": 3', '"id": null'), ('"id": 3, ', ''),
    ('"position": [', '"position": [NaN, 1, '), ('"position": [', '"position": [Infinity, 1, '),
    ('"position": [', '"position": [1e400, 1, '), ('"position": [', '"position": [1e12, 1, '),
    ('"position": [', '"position": [1000000000001, 1, '), ('"position": [', '"position": [true, 1, '),
    ('"position": [', '"position": ["1", 1, '), ('"position": [', '"position": [1, '), ('"rpy": [', '"rpy": [90, 180, '),
    ('"rpy": [', '"rpy": [0, -90, '), ('"deg"', '"DEG"'), ('"deg"', '"rad"'), ('"mm"', '"km"'),
    (', "angle": "deg"', ''), ('"units": {"length": "mm", "angle": "deg"}', '"units": {"angle": "deg"}'),
    ('"poses": [', '"poses": [{"position": [0, 0, 0], "rpy": [0, 0, 0]}, '), ('"rpy"', '"quaternion"'),
    ('"rpy": [', '"name": "a", "rpy": ['), ('"kind": "bennett"', '"kind": "sixbar"'), ('"id": 3', '"out": "o"'),
    ('"id": 3', '"normalize": false'), ('{"id"', ' {"id"'), ('": ', '":'), (', ', ' , '), ('"id": 3', '"id": "\u00e9"'),
]


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 10**6), st.lists(st.sampled_from(MUTATIONS), max_size=3), st.booleans())
def test_mutated_lines_are_refused_or_read_as_the_full_reader_reads_them(seed, mutations, shuffle):
    job = readme_job(random.Random(seed), 3)
    if shuffle:
        job = dict(reversed(list(job.items())))
    text = json.dumps(job)
    for old, new in mutations:
        text = text.replace(old, new, 1)
    assert_as_the_full_reader([text, json.dumps(readme_job(random.Random(seed + 1), 4))])


def test_duplicate_keys_anywhere_leave_the_line_to_the_full_reader():
    good = json.dumps(readme_job(random.Random(1), 3))
    for old, new in MUTATIONS[:4]:
        bad = good.replace(old, new, 1)
        assert bad != good and full_reader(bad) is None
        assert read_common_bennett([bad]).index == []


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=120).map(lambda b: b.replace(b"\r", b"a")), st.integers(1, 7), st.integers(1, 6),
       st.integers(1, 60), st.integers(1, 30))
def test_chunks_are_read_lines(data, block, size, max_bytes, limit):
    reference = list(docload.read_lines(io.BytesIO(data), limit=limit))
    saved = docload._CHUNK
    docload._CHUNK = block  # lines across reads
    try:
        chunks = list(docload.read_chunks(io.BytesIO(data), size, max_bytes=max_bytes, limit=limit))
    finally:
        docload._CHUNK = saved
    got = [(first + i, None if b is None else b.decode("utf-8", "replace")) for first, raw in chunks
           for i, b in enumerate(raw)]
    assert got == reference
    assert all(0 < len(raw) <= size for _, raw in chunks)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.fixed_dictionaries({"id": st.one_of(st.none(), st.integers(-2**70, 2**70), st.text(max_size=5)),
                                       "line": st.integers(1, 99),
                                       "x": st.floats(allow_nan=True, allow_infinity=True),
                                       "checks": st.dictionaries(st.sampled_from("abc"), st.floats(-1e30, 1e30))}),
                max_size=6))
def test_chunk_text_is_the_result_lines(results):
    assert dumps_lines(results) == "".join(dumps(r) + "\n" for r in results)


def test_raw_chunks_give_the_lines_of_run_chunk():
    lines = mixed_lines(60, seed=8)
    items = list(enumerate(lines, 1))
    expected = run_chunk(items, False, None)
    raw = run_chunk_lines((1, [s.encode() for s in lines]), False, None, keep=True)
    assert isinstance(raw, ChunkLines) and raw.results == expected
    assert raw.text == "".join(dumps(r) + "\n" for r in expected)
    assert raw.codes == [None if r.get("skipped") else 0 if r["ok"] else r["exit_code"] for r in expected]
    assert {0, 2, None} <= set(raw.codes)


def _batch_on_a_pipe(args):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.Popen([sys.executable, "-m", "cli.main", "batch", "-", "-q", *args], cwd=REPO, env=env,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _result_lines(p, n: int, timeout: float = 120.0) -> list[dict]:
    """The first n result lines of p (waiting at most ``timeout`` s for them)."""
    out, end = b"", time.monotonic() + timeout
    while out.count(b"\n") < n and select.select([p.stdout], [], [], max(end - time.monotonic(), 0))[0]:
        chunk = os.read(p.stdout.fileno(), 1 << 16)
        if not chunk:
            break
        out += chunk
    return [json.loads(s) for s in out.splitlines()]


@pytest.mark.parametrize("args", [[], ["-j", "2"]])
def test_a_slow_producer_gets_its_answers_before_it_closes_the_pipe(args):
    """Three lines written, the pipe kept open: their results come (the reader answers what it has when the
    input is idle), then a fourth line, then the end."""
    rnd = random.Random(2)
    p = _batch_on_a_pipe(args)
    try:
        p.stdin.write(("".join(json.dumps(readme_job(rnd, i)) + "\n" for i in range(3)) + "\n").encode())
        p.stdin.flush()
        first = _result_lines(p, 4)
        assert [r["line"] for r in first] == [1, 2, 3, 4] and first[3]["skipped"] == "blank line"
        p.stdin.write(b'{"kind": "bennett"}\n')
        p.stdin.close()
        rest = [json.loads(s) for s in p.stdout.read().splitlines()]
        assert p.wait(120) == 1 and [r["line"] for r in rest] == [5] and rest[0]["exit_code"] == 2
    finally:
        p.kill()
        p.wait()


@pytest.mark.parametrize("args", [[], ["-j", "2"]])
@pytest.mark.parametrize("sig,code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_while_waiting_on_stdin_stops_the_batch_at_once(args, sig, code):
    """#35's left-over: a batch waiting on an idle pipe acts on SIGINT/SIGTERM at once (not after the
    10 s clean-up bound), with one result line for every line read."""
    p = _batch_on_a_pipe(args)
    try:
        p.stdin.write((json.dumps(readme_job(random.Random(3), 0)) + "\n").encode())
        p.stdin.flush()
        assert [r["line"] for r in _result_lines(p, 1)] == [1]
        start = time.monotonic()
        p.send_signal(sig)
        rc = p.wait(60)
        waited = time.monotonic() - start
        assert rc == code and p.stdout.read() == b""
        assert waited < 8.0  # (the clean-up bound, CLEANUP_SECONDS = 10 s, is what it was before)
    finally:
        p.kill()
        p.wait()


def test_result_lines_without_dicts_are_the_dict_paths_bytes():
    """Issue #36, fifth pass: `run_chunk_lines` without ``keep`` writes the batched successes from columns
    (`batchjobs._success_lines`), the same bytes and codes as the result dicts through `dumps`; ids of
    every kind a line may carry."""
    lines = mixed_lines(80, seed=11)
    rnd = random.Random(5)
    for k, jid in enumerate(["a\u00e9", "q\"x", 2.5, -0.0, 10**30, "%s{0}", None, 7]):
        job = readme_job(rnd, k)
        job["id"] = jid
        lines.append(json.dumps(job))
    expected = run_chunk(list(enumerate(lines, 1)), False, None)
    got = run_chunk_lines((1, [s.encode() for s in lines]), False, None)
    assert got.results is None
    assert got.text == "".join(dumps(r) + "\n" for r in expected)
    assert got.codes == [None if r.get("skipped") else 0 if r["ok"] else r["exit_code"] for r in expected]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), max_size=12))
def test_float_texts_are_json_dumps_texts(values):
    from synth.tools.resultlines import float_texts

    assert float_texts(values) == [json.dumps(x) for x in values]


NUMBER_FORMS = (repr, lambda x: "%.17g" % x, lambda x: "%.25f" % x, lambda x: "%.3e" % x, lambda x: "%.40g" % x,
                lambda x: "%.1f" % x)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(-179.9, 179.9, allow_subnormal=True), min_size=18, max_size=18),
       st.lists(st.sampled_from(range(len(NUMBER_FORMS))), min_size=18, max_size=18), st.booleans())
def test_numbers_in_any_form_read_as_the_full_reader_reads_them(values, forms, compact):
    """Issue #36, fifth pass: a line is read by orjson only where it is orjson's own text but for spaces
    (`jobspec._canonical`); numbers written any other way go to the json module: the same bits either way,
    and README's lines (json.dumps) take the orjson path."""
    texts = [NUMBER_FORMS[f](v) for f, v in zip(forms, values)]
    poses = ", ".join('{"position": [%s, %s, %s], "rpy": [%s, %s, %s]}' % tuple(texts[6 * k: 6 * k + 6]) for k in range(3))
    line = '{"id": 3, "kind": "bennett", "units": {"length": "mm", "angle": "deg"}, "poses": [%s]}' % poses
    if compact:
        line = line.replace(", ", ",").replace(": ", ":")
    got = assert_as_the_full_reader([line])
    assert got.index == ([0] if full_reader(line) is not None else [])
    from synth.tools import jobspec

    readme = json.dumps(readme_job(random.Random(len(line)), 1))
    assert jobspec._orjson is None or jobspec._canonical(readme) == json.loads(readme)
