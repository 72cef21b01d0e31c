"""Seeded hostile sweep of the real `mpsynth` process (issue 20): odd and malformed inputs, odd output
paths, closed and full standard streams (/dev/full), signals at random moments, and (as root, on a small
tmpfs) a full disk. After every run: no traceback from our code, no exit 3 ("internal error"), the
user's files (beside and inside OUT) untouched, no temporary directory left. A small sample runs by
default; the long sweep is marked slow.

Also: a SIGINT as soon as our package starts (cli/__init__.py installs the hook before anything else)
is one line and exit 130; the interpreter's own start-up (before any of our code runs) is not ours."""
from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import REPO

FIXTURE = REPO / "fixtures" / "bennett_quat.yaml"
SIXBAR = REPO / "fixtures" / "sixbar_example.yaml"
OUR_CODE = (f"{os.sep}cli{os.sep}", f"{os.sep}synth{os.sep}")
GOOD_LINE = ('{"id": "j", "kind": "bennett", "poses": [{"position": [0, 0, 0], "quaternion": {"w": 1, "x": 0, "y": 0, "z": 0}}, '
             '{"position": [1, 0, 0.5], "quaternion": {"w": 0.6, "x": 0, "y": 0, "z": 0.8}}, '
             '{"position": [0.25, 1, 0.2], "quaternion": {"w": 0.6, "x": 0.8, "y": 0, "z": 0}}]}')


def _tmpfs(path: Path, size: str) -> bool:
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    path.mkdir()
    return subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                          capture_output=True).returncode == 0


def scenario(rng: random.Random, work: Path) -> dict:
    """One hostile run: argv, stdin (bytes | "closed" | "dev:PATH"), stdout ("pipe" | "closed" | "full"),
    stderr ("pipe" | "full"), signal (None | (signal, delay s)), tmpfs (bool: OUT on a 16 kB tmpfs)."""
    odd_out = ["out", "out dir/ü", "a/b/c", ".", "notes.txt", "user_dir", "-", "x" * 200, "out/../out2",
               "/dev/null", "/proc/version", "disk/out"]
    odd_in = [str(FIXTURE), "missing.yaml", ".", "/dev/null", "/dev/zero", "garbage.yaml", "bad.json", "-",
              "empty.yaml", str(SIXBAR)]
    kind = rng.choice(["bennett", "bennett", "batch", "factor", "check", "sixbar"])
    out = rng.choice(odd_out)
    if kind == "bennett":
        argv = ["bennett", rng.choice(odd_in), "-o", out, *rng.choice([[], ["--force"], ["--json"], ["-q"]])]
    elif kind == "sixbar":
        argv = ["sixbar", rng.choice([str(SIXBAR), str(FIXTURE), "garbage.yaml"]), "-o", out, "-q",
                "--member", "0.7", "--family", "1", "--pair", "1"]
    elif kind == "batch":
        argv = ["batch", rng.choice(["jobs.jsonl", "-", "/dev/full", "missing.jsonl"]), "-q",
                *rng.choice([[], ["--out-dir", "user_dir"], ["-j", "2"]])]
    elif kind == "factor":
        argv = ["factor", "--expr", rng.choice(["(t-i)*(t-j)", "(t-", "t^99999", "(t+10^100)^3", "x" * 5000])]
    else:
        argv = ["check", rng.choice(["out", "user_dir", "/dev/null", "missing"])]
    stdin = rng.choice([FIXTURE.read_bytes(), b"", b"\xff\xfe\x00", "closed", "dev:/dev/zero", "dev:/dev/full",
                        (GOOD_LINE + "\n{broken\n").encode()])
    return {"argv": argv, "stdin": stdin, "stdout": rng.choice(["pipe", "pipe", "closed", "full"]),
            "stderr": rng.choice(["pipe", "pipe", "pipe", "full"]),
            "signal": rng.choice([None, None, (signal.SIGINT, rng.uniform(0.3, 3.0)),
                                  (signal.SIGTERM, rng.uniform(0.3, 3.0))]),
            "tmpfs": "disk/out" in argv}


def prepare(work: Path) -> dict[Path, bytes]:
    """The user's files in the working directory; returns their contents."""
    (work / "user_dir").mkdir()
    files = {work / "notes.txt": b"mine", work / "user_dir" / "thesis.tex": b"years of work",
             work / "garbage.yaml": b"poses: [[[", work / "bad.json": b'{"poses": 1e999}',
             work / "empty.yaml": b"", work / "jobs.jsonl": (GOOD_LINE + "\n\x00\xff\n{\"out\": \"..\"}\n").encode()}
    for p, data in files.items():
        p.write_bytes(data)
    return files


def run(sc: dict, work: Path) -> tuple[int, str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    pre = []
    if sc["stdin"] == "closed":
        pre.append("os.close(0)")
    if sc["stdout"] == "closed":
        pre.append("os.close(1)")
    code = "import os; " + "; ".join(pre + ["from cli.main import main; main()"])
    stdin = subprocess.PIPE
    files = []
    if isinstance(sc["stdin"], str) and sc["stdin"].startswith("dev:"):
        stdin = open(sc["stdin"][4:], "rb")
        files.append(stdin)
    stdout = subprocess.DEVNULL if sc["stdout"] != "full" else open("/dev/full", "wb")
    stderr = subprocess.PIPE if sc["stderr"] == "pipe" else open("/dev/full", "wb")
    files += [f for f in (stdout, stderr) if hasattr(f, "close")]
    try:
        p = subprocess.Popen([sys.executable, "-c", code, *sc["argv"]], cwd=work, env=env, stdin=stdin,
                             stdout=stdout, stderr=stderr)
        data = sc["stdin"] if isinstance(sc["stdin"], bytes) else b""
        if sc["signal"] is not None:
            sig, delay = sc["signal"]
            if stdin is subprocess.PIPE:
                try:
                    p.stdin.write(data)
                    p.stdin.close()
                except OSError:
                    pass
            t0 = time.monotonic()
            while p.poll() is None and time.monotonic() - t0 < delay:
                time.sleep(0.005)
            if p.poll() is None:
                p.send_signal(sig)
            err = p.stderr.read() if p.stderr else b""
            p.wait(timeout=300)
        else:
            _, err = p.communicate(data if stdin is subprocess.PIPE else None, timeout=300)
    finally:
        for f in files:
            f.close()
    return p.returncode, (err or b"").decode("utf-8", "replace")


def check(sc: dict, code: int, err: str, work: Path, files: dict[Path, bytes]) -> None:
    what = f"{sc} -> {code}: {err[-2000:]}"
    ours = any(part in err for part in OUR_CODE)
    assert not ("Traceback" in err and ours), what
    assert "internal error" not in err and code != 3, what
    if sc["signal"] is None:
        assert code in (0, 1, 2), what
    else:
        assert code in (0, 1, 2, 130, 143, -signal.SIGINT, -signal.SIGTERM), what
    if sc["stderr"] == "pipe" and code in (1, 2) and sc["signal"] is None:
        assert err.count("\n") >= 1 and all(line.startswith(("mpsynth: ", "batch: ", "FAIL ", "check "))
                                           for line in err.splitlines()), what
    for p, data in files.items():
        assert p.read_bytes() == data, (p, what)
    left = [q for q in work.rglob("*") if "mpsynth-tmp" in q.name or "mpsynth-old" in q.name]
    assert not left, (left, what)


def sweep(tmp_path: Path, seed: int, n: int) -> None:
    rng = random.Random(seed)
    for i in range(n):
        work = tmp_path / f"r{i}"
        work.mkdir()
        files = prepare(work)
        sc = scenario(rng, work)
        mounted = sc["tmpfs"] and _tmpfs(work / "disk", "16k")
        try:
            code, err = run(sc, work)
            check(sc, code, err, work, files)
        finally:
            if mounted:
                subprocess.run(["umount", str(work / "disk")], capture_output=True)


def test_hostile_sample(tmp_path):
    sweep(tmp_path, seed=3, n=4)


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_hostile_sweep(tmp_path, seed):
    sweep(tmp_path, seed=100 + seed, n=50)


# ---------------------------------------------------------------- ^C at start-up
def test_interrupt_as_soon_as_the_package_starts_is_one_line():
    """The hook is in place from the first statement of cli/__init__.py on (before click, before
    cli.main), for the console script and for `python -m cli.main` alike."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    p = subprocess.run([sys.executable, "-c", "import cli; raise KeyboardInterrupt"], env=env,
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and p.stderr == "mpsynth: interrupted\n"


def test_interrupt_while_a_command_module_imports_is_one_line():
    """A ^C inside click's invocation (importing a command module) was printed after a blank line."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    code = ("import cli.main, importlib\n"
            "def boom(name, *a, **k):\n    raise KeyboardInterrupt\n"
            "importlib.import_module = boom\n"
            "cli.main.main(['bennett', 'x.yaml'])")
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and p.stderr == "mpsynth: interrupted\n", p.stderr


@pytest.mark.slow
def test_sigint_at_random_start_up_moments():
    """SIGINT at random moments from the start of the process: from the moment our package runs, one
    line and exit 130 (or a finished run); before it, only CPython's own report (a fatal start-up error
    or a KeyboardInterrupt traceback without any frame of our code)."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    rng = random.Random(20)
    for _ in range(40):
        p = subprocess.Popen([sys.executable, "-m", "cli.main", "bennett", str(FIXTURE), "-q"], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(rng.uniform(0.0, 1.5))
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=120)
        if err.startswith("Fatal Python error: init_") or (p.returncode == -signal.SIGINT and err == ""):
            continue  # CPython itself was starting
        if "Traceback" in err:
            assert not any(part in err for part in OUR_CODE), err
            continue
        assert (p.returncode, err) in ((130, "mpsynth: interrupted\n"), (0, "")), (p.returncode, err)
