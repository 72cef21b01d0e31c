"""Issue #35: a signal to `mpsynth batch -j N` is acted on from the pool's loop, never from inside the
pool's bookkeeping (`synth.tools.batchjobs.run_jobs(stop=...)`, `cli.signals.StopOnSignal`)."""
from __future__ import annotations

import json
import os
import signal

import pytest

from synth.tools.batchjobs import Stopped, run_jobs

POSES3 = [{"position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}},
          {"position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}},
          {"position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}}]


def job_lines(n: int) -> list[str]:
    return [json.dumps({"id": i, "kind": "bennett", "poses": POSES3}) for i in range(n)]


def _workers() -> set[int]:
    """Pids of this process's live descendants (Linux /proc, zombies excluded) but multiprocessing's
    long-lived helpers (the fork server, the resource tracker): the pool workers."""
    parent, helpers = {}, set()
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            stat = open(f"/proc/{pid}/stat").read()
            cmd = open(f"/proc/{pid}/cmdline", "rb").read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z":
            parent[int(pid)] = int(fields[1])
        if b"forkserver" in cmd or b"resource_tracker" in cmd:
            helpers.add(int(pid))
    found, todo = set(), [os.getpid()]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        found.update(kids)
        todo.extend(kids)
    return found - helpers


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs /proc")
@pytest.mark.parametrize("after", [0, 3])
def test_a_stopped_pool_raises_stopped_and_leaves_no_worker(after):
    """``stop()`` true after ``after`` results: exactly those results came, then `Stopped`, and the pool's
    workers are gone (terminated and joined by run_jobs, not left to the interpreter's exit)."""
    before = _workers()
    got = []
    with pytest.raises(Stopped):
        for res in run_jobs(job_lines(40), jobs=2, chunksize=1, stop=lambda: len(got) >= after):
            got.append(res)
    assert len(got) == after and [r["line"] for r in got] == list(range(1, after + 1))
    assert all(r["ok"] for r in got)
    assert _workers() <= before


def test_a_serial_run_asks_stop_between_jobs():
    got = []
    with pytest.raises(Stopped):
        for res in run_jobs(job_lines(5), jobs=1, stop=lambda: len(got) >= 2):
            got.append(res)
    assert len(got) == 2


def test_stop_never_asked_true_changes_nothing():
    lines = job_lines(6)
    assert [r["line"] for r in run_jobs(lines, jobs=2, chunksize=1, stop=lambda: False)] == list(range(1, 7))


def test_stop_on_signal_only_records_the_first_signal(monkeypatch):
    """The handler raises nothing (the loop acts later) and starts the bounded clean-up once."""
    from cli import signals, streams

    started = []
    monkeypatch.setattr(streams, "exit_after_cleanup", started.append)
    previous = signal.getsignal(signal.SIGTERM)
    with signals.StopOnSignal() as stopper:
        assert not stopper.requested()
        signal.raise_signal(signal.SIGTERM)  # no exception here
        signal.raise_signal(signal.SIGINT)
        assert stopper.requested() and stopper.signum == signal.SIGTERM and started == [143]
        with pytest.raises(SystemExit) as e:
            stopper.act()
        assert e.value.code == 143
    assert signal.getsignal(signal.SIGTERM) == previous



class _StuckPool:
    """A pool whose terminate waits for good on a worker that never acts on SIGTERM, until it is killed
    (what a loaded machine showed: `terminate_pool`'s docstring)."""

    def __init__(self, workers):
        self.workers, self.joined = workers, False

    def terminate(self):
        for w in self.workers:
            w.gone.wait()

    def join(self):
        self.joined = True


class _Worker:
    def __init__(self, stuck: bool):
        import threading

        self.gone, self.killed = threading.Event(), False
        if not stuck:
            self.gone.set()

    @property
    def exitcode(self):
        return 0 if self.gone.is_set() else None

    def kill(self):
        self.killed = True
        self.gone.set()


def test_a_pool_whose_terminate_hangs_on_a_worker_is_shut_down_by_killing_it(monkeypatch):
    from synth.tools import workerpool as batchjobs

    monkeypatch.setattr(batchjobs, "TERMINATE_SECONDS", 0.2)
    done, stuck = _Worker(stuck=False), _Worker(stuck=True)
    pool = _StuckPool([done, stuck])
    assert batchjobs.terminate_pool(pool, [done, stuck]) and pool.joined
    assert stuck.killed and not done.killed  # only the worker still running


def test_a_pool_that_stays_stuck_is_left_unjoined(monkeypatch):
    from synth.tools import workerpool as batchjobs

    monkeypatch.setattr(batchjobs, "TERMINATE_SECONDS", 0.1)
    pool = _StuckPool([_Worker(stuck=True)])
    assert not batchjobs.terminate_pool(pool, []) and not pool.joined  # (the caller's process ends anyway)
    pool.workers[0].kill()


class _PartialRaw:
    """A raw binary stdout that takes at most ``most`` bytes per write (a pipe interrupted by a signal)."""

    def __init__(self, most: int):
        self.most, self.data, self.calls = most, bytearray(), 0

    def write(self, b):
        self.calls += 1
        n = min(self.most, len(b))
        self.data += bytes(b[:n])
        return n

    def flush(self):
        pass


def test_a_chunks_lines_go_out_whole_when_the_raw_stdout_takes_part_of_a_write():
    from cli.batch import _write_bytes

    text = "".join(f'{{"id":{i},"line":{i + 1},"ok":true}}\n' for i in range(300)).encode()
    raw = _PartialRaw(1000)
    _write_bytes(raw, text)
    assert bytes(raw.data) == text
    assert raw.calls == -(-len(text) // 1000)  # (one write call per piece it takes, not per line)


def test_result_lines_go_out_in_pieces_of_whole_lines_of_at_most_pipe_buf(monkeypatch):
    """cli.batch._write without ``whole``: each write call is whole lines of at most PIPE_BUF bytes (atomic on a
    pipe; a signal's exception between two calls never cuts a line), a longer line alone."""
    import io
    import select

    from cli import batch

    class Recorder(io.StringIO):
        def __init__(self):
            super().__init__()
            self.calls = []

        def write(self, s):
            self.calls.append(s)
            return super().write(s)

    lines = [f'{{"id":{i},"pad":"{"x" * (i * 37 % 900)}"}}\n' for i in range(200)] + ['{"long":"' + "y" * 9000 + '"}\n']
    out = Recorder()
    monkeypatch.setattr(batch.sys, "stdout", out)
    batch._write("".join(lines))
    assert out.getvalue() == "".join(lines)
    assert all(c.endswith("\n") for c in out.calls)
    assert all(len(c) <= select.PIPE_BUF for c in out.calls[:-1]) and out.calls[-1] == lines[-1]
    assert len(out.calls) < len(lines) / 3
