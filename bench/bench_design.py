"""Collision-free design (synth.design.search.design_linkage) on seeded random solvable pose sets, and the
same Bennett linkages through rational-linkages' collision-free optimization, in one run.

    .venv/bin/python bench/bench_design.py [--bennett N] [--sixbar N] [--rl N] [--rl-python PATH] [--seed S]
    .venv/bin/python bench/bench_design.py --cli sixbar --sets N [--verify]   # the CLI end to end

For every set: the synthesis (bennett: 3 random poses; sixbar: 4), then the default design (sizes as
the mesh writer's defaults: pin radius 0.02 E, bar radius 0.015 E, hub length 0.06 E, hole clearance
0.2 mm capped at 0.1 pin radius; clearance 0.25 bar radius). Reported: how many designs are certified
free over the full cycle / over the task range only / neither, and CPU seconds per design (median, max).

--rl N: the first N Bennett linkages are handed (their four joint axes as Plücker lines, the motion
polynomial's factors) to rational-linkages in a subprocess of ``--rl-python`` (default
/tmp/rlvenv/bin/python); its collision-free search is timed there (CPU seconds of that process) and
its success (a design returned) counted. Both columns are printed side by side for those sets.

--cli bennett|sixbar: the default command itself (``mpsynth bennett|sixbar POSES -o OUT -q``, one
process per set, its CPU seconds and peak RSS), on the same seeded sets written as pose files; with
--verify each output's claim (linkage.json ``collision``) is checked by the independent verifier
(``verify_output.py POSES OUT --collisions CLEARANCE --collision-range RANGE``): a claimed design must
pass. The full-cycle / task-range / neither counts are those of what the command writes.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from synth.algebra.dq import quat_to_matrix  # noqa: E402
from synth.design.search import design_linkage  # noqa: E402
from synth.errors import SynthesisError  # noqa: E402

RL_PYTHON = "/tmp/rlvenv/bin/python"
REPO = Path(__file__).resolve().parents[1]
VERIFIER = REPO.parent / "shared" / "tools" / "verify_output.py"


def random_poses(rng, n: int) -> np.ndarray:
    T = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        q = rng.normal(size=4)
        T[i, :3, :3] = quat_to_matrix(q / np.linalg.norm(q))
        T[i, :3, 3] = rng.normal(size=3)
    return T


def default_sizes(linkage) -> dict:
    e = linkage.extent()
    pin = 0.02 * e
    return dict(pin_radius=pin, bar_radius=0.015 * e, hub_length=0.06 * e, hole_clearance=min(2e-4, 0.1 * pin))


def solvable_sets(kind: str, count: int, seed: int):
    """(seed, linkage) for the first ``count`` seeds from ``seed`` on whose random poses synthesize."""
    if kind == "bennett":
        from synth.synthesis.bennett import bennett as synth
        n = 3
    else:
        from synth.synthesis.sixbar import sixbar as synth
        n = 4
    out, s = [], seed
    while len(out) < count:
        try:
            out.append((s, synth(random_poses(np.random.default_rng(s), n))))
        except SynthesisError:
            pass
        s += 1
    return out


def run_ours(kind: str, sets, effort: float = 1.0) -> list[dict]:
    rows = []
    for s, lk in sets:
        t = time.process_time()
        r = design_linkage(lk, **default_sizes(lk), effort=effort).collision
        rows.append({"seed": s, "seconds": time.process_time() - t,
                     "result": ("full" if r.range == "full" else "task") if r.free else "none",
                     "min_distance": r.min_distance})
    return rows


def run_sixbar_default(sets, effort: float = 1.0) -> list[dict]:
    """What `mpsynth sixbar -o OUT` writes: the best-scored candidates designed in turn, collision-free
    first (`synth.design.ranking.rank_buildable`, the CLI's limit and work budget)."""
    from synth.design.ranking import rank_buildable
    from synth.solve.tasks import SIXBAR_CHOICE
    from synth.synthesis.sixbar import sixbar_candidates

    rows = []
    for s, _ in sets:
        t = time.process_time()
        cands = sixbar_candidates(random_poses(np.random.default_rng(s), 4), top=SIXBAR_CHOICE["limit"], build=True)
        ranked = rank_buildable(cands, lambda lk, ranges, full_work, work, eff: design_linkage(
            lk, **default_sizes(lk), effort=effort * eff, ranges=ranges, full_work=full_work, work=work),
            **SIXBAR_CHOICE)
        r = ranked[0][1].collision
        rows.append({"seed": s, "seconds": time.process_time() - t, "designed": len(ranked),
                     "result": ("full" if r.range == "full" else "task") if r.free else "none",
                     "min_distance": r.min_distance})
    return rows


def write_pose_file(path: Path, T) -> Path:
    """A pose file with 4x4 matrices in metres (exact repr of every float)."""
    lines = ["poses:"]
    for i, M in enumerate(T):
        rows = ", ".join("[" + ", ".join(repr(float(x)) for x in row) + "]" for row in M)
        lines.append(f"  - name: p{i}\n    matrix: [{rows}]")
    path.write_text("\n".join(lines) + "\n")
    return path


def run_cli(kind: str, sets, verify: bool, workdir: Path) -> list[dict]:
    """The default command end to end on every set (one process each; CPU seconds and peak RSS of the
    child), and the independent verifier on each claimed design (``verified``: True/False; None when not
    claimed free or not run)."""
    n = 3 if kind == "bennett" else 4
    rows = []
    for s, _ in sets:
        poses = write_pose_file(workdir / f"{kind}_{s}.yaml", random_poses(np.random.default_rng(s), n))
        out = workdir / f"{kind}_{s}"
        with open(workdir / "stderr.txt", "w+") as err:
            cmd = [sys.executable, "-m", "cli.main", kind, str(poses), "-o", str(out), "-q", "--force"]
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, cwd=REPO,
                                    env={**os.environ, "PYTHONPATH": str(REPO)})
            _, status, usage = os.wait4(proc.pid, 0)  # this child's own CPU time and peak RSS
            proc.returncode = os.waitstatus_to_exitcode(status)
            err.seek(0)
            stderr = err.read()
        cpu = usage.ru_utime + usage.ru_stime
        row = {"seed": s, "seconds": cpu, "exit": proc.returncode, "max_rss_mb": usage.ru_maxrss / 1024,
               "result": "error", "verified": None}
        if proc.returncode == 0:
            c = json.loads((out / "linkage.json").read_text())["collision"]
            row.update(result=(c["range"] if c["free"] else "none"), min_distance=c["min_distance"],
                       clearance=c["clearance"])
            if verify and c["free"]:
                v = subprocess.run([sys.executable, str(VERIFIER), str(poses), str(out), "--collisions",
                                    repr(c["clearance"]), "--collision-range", c["range"]],
                                   capture_output=True, text=True)
                row["verified"] = v.returncode == 0
                if v.returncode:
                    row["verifier"] = (v.stdout + v.stderr).strip().splitlines()[-3:]
        else:
            row["stderr"] = stderr.strip().splitlines()[-1:]
        rows.append(row)
        print(f"  seed {s}: {row['result']:5s} {cpu:5.2f} s CPU"
              + ("" if row["verified"] is None else f", verifier {'agrees' if row['verified'] else 'DISAGREES'}"),
              flush=True)
    return rows


def summary(kind: str, rows: list[dict]) -> str:
    n = len(rows)
    count = {k: sum(r["result"] == k for r in rows) for k in ("full", "task", "none")}
    secs = [r["seconds"] for r in rows]
    return (f"{kind:8s} sets={n:3d}  full={count['full']} ({100 * count['full'] / max(n, 1):.0f}%)  "
            f"task-only={count['task']}  none={count['none']}  "
            f"time median={statistics.median(secs):.3f}s max={max(secs):.3f}s (CPU)")


RL_SCRIPT = r"""
import json, sys, time, io, contextlib
import numpy as np
from rational_linkages import RationalMechanism, MotionFactorization, DualQuaternion
data = json.loads(sys.stdin.read())
out = []
for item in data:
    h = [DualQuaternion(np.array(v)) for v in item["h"]]
    k = [DualQuaternion(np.array(v)) for v in item["k"]]
    m = RationalMechanism([MotionFactorization(h), MotionFactorization(k)])
    t = time.process_time()
    ok, err = False, ""
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            res = m.collision_free_optimization(max_iters=item.get("max_iters", 10))
        ok = res is not None and res is not False
    except Exception as e:  # noqa: BLE001
        err = f"{type(e).__name__}: {e}"[:200]
    out.append({"seed": item["seed"], "seconds": time.process_time() - t, "ok": ok, "error": err})
print(json.dumps(out))
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bennett", type=int, default=24)
    ap.add_argument("--sixbar", type=int, default=12)
    ap.add_argument("--rl", type=int, default=0, help="Bennett sets also run through rational-linkages")
    ap.add_argument("--rl-python", default=RL_PYTHON)
    ap.add_argument("--rl-timeout", type=float, default=600.0,
                    help="CPU seconds allowed to rational-linkages per set (a timeout counts as a failure)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", help="write every row to this file")
    ap.add_argument("--effort", type=float, default=1.0, help="design_linkage effort")
    ap.add_argument("--cli", choices=("bennett", "sixbar"), help="run the default command end to end instead")
    ap.add_argument("--sets", type=int, default=12, help="with --cli: how many solvable sets")
    ap.add_argument("--verify", action="store_true", help="with --cli: run the independent verifier on each claim")
    args = ap.parse_args(argv)
    report = {}
    if args.cli:
        with tempfile.TemporaryDirectory() as tmp:
            rows = run_cli(args.cli, solvable_sets(args.cli, args.sets, args.seed), args.verify, Path(tmp))
        report[f"cli_{args.cli}"] = rows
        print(summary(f"mpsynth {args.cli} -o (default)", rows))
        checked = [r for r in rows if r["verified"] is not None]
        if checked:
            print(f"independent verifier: {sum(r['verified'] for r in checked)}/{len(checked)} claims confirmed; "
                  f"peak RSS max {max(r['max_rss_mb'] for r in rows):.0f} MB")
        if args.json:
            Path(args.json).write_text(json.dumps(report, indent=1))
        return 0
    for kind, count in (("bennett", args.bennett), ("sixbar", args.sixbar)):
        if count:
            sets = solvable_sets(kind, count, args.seed)
            rows = run_ours(kind, sets, args.effort)
            report[kind] = rows
            print(summary(kind, rows), flush=True)
            if kind == "sixbar":  # the CLI's default: candidates designed in turn, collision-free first
                rows = run_sixbar_default(sets, args.effort)
                report["sixbar_default"] = rows
                print(summary("sixbar (CLI default, collision-free first)", rows), flush=True)
            if args.rl:
                compare_rl(kind, sets[:args.rl], rows[:args.rl], args.rl_python, report, args.rl_timeout)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))
    return 0


def factor(joint) -> list[float]:
    """The rotation factor h of ``joint`` (the motion is prod (t - h_i)): h = a - b u + eps b m in this
    project's dual-quaternion convention (docs/conventions.md); the 8 numbers are the same algebraic
    object for rational-linkages (same dual-quaternion product)."""
    return [joint.a, *(-joint.b * joint.direction), 0.0, *(joint.b * joint.moment)]


def compare_rl(kind, sets, ours, python, report, timeout) -> None:
    """The same linkages through rational-linkages' collision_free_optimization, one subprocess per set
    (so that a set that runs past ``timeout`` CPU seconds is stopped and counted as a failure)."""

    def limit_cpu():
        resource.setrlimit(resource.RLIMIT_CPU, (int(timeout), int(timeout) + 5))

    rl = []
    t = time.perf_counter()
    for s, lk in sets:
        item = {"seed": s, "h": [factor(lk.joint(n)) for n in lk.branches[0]],
                "k": [factor(lk.joint(n)) for n in lk.branches[1]]}
        try:
            proc = subprocess.run([python, "-c", RL_SCRIPT], input=json.dumps([item]), capture_output=True,
                                  text=True, preexec_fn=limit_cpu, timeout=50 * timeout)
        except subprocess.TimeoutExpired:
            rl.append({"seed": s, "seconds": float("nan"), "ok": False,
                       "error": f"timeout ({50 * timeout:.0f} s wall)"})
            continue
        if proc.returncode in (-signal.SIGXCPU, -signal.SIGKILL):
            rl.append({"seed": s, "seconds": float("nan"), "ok": False, "error": f"timeout ({timeout:.0f} s CPU)"})
            continue
        if proc.returncode:
            rl.append({"seed": s, "seconds": float("nan"), "ok": False,
                       "error": (proc.stderr.strip().splitlines() or ["?"])[-1][:200]})
            continue
        rl.append(json.loads(proc.stdout.strip().splitlines()[-1])[0])
    report[f"rational_linkages_{kind}"] = rl
    ok_rl = sum(r["ok"] for r in rl)
    ok_us = sum(r["result"] != "none" for r in ours)
    finished = [r["seconds"] for r in rl if r["seconds"] == r["seconds"]]
    t_rl = statistics.median(finished) if finished else float("nan")
    t_us = statistics.median(r["seconds"] for r in ours)
    print(f"same {len(rl)} {kind} sets: rational-linkages success={ok_rl}/{len(rl)} median {t_rl:.2f}s CPU "
          f"(of the {len(finished)} that finished); ours success={ok_us}/{len(ours)} "
          f"(full {sum(r['result'] == 'full' for r in ours)}) median {t_us:.3f}s; "
          f"speed-up {t_rl / max(t_us, 1e-9):.0f}x (wall {time.perf_counter() - t:.0f}s)")
    for r in rl:
        if r.get("error"):
            print(f"  rational-linkages seed {r['seed']}: {r['error']}")


if __name__ == "__main__":
    sys.exit(main())
