"""mpsynth speed benchmarks (issue 7), all in one run; prints a table of every figure with its target.

    .venv/bin/python bench/run.py [--rl-python /tmp/rlvenv/bin/python] [--markdown bench/RESULTS.md]
                                  [--quick]

In-process figures are per call: the median (the target's statistic) and the minimum of the wall clock
over many calls on several pose sets, and the CPU time of the process per call (process_time: it does not
count waiting for a core, so it is the steadier figure when other processes compete for the CPU). Cold
figures start a new process each run (median of several runs, file cache warm). Peak memory is the
maximum resident set size of the `mpsynth bennett ... -o OUT` process (/usr/bin/time, else getrusage).

With ``--rl-python PATH`` (a Python in which the `rational-linkages` package is importable, kept in a
separate environment: it is not a dependency of mpsynth), the same Bennett (3 poses) and 6R (4 poses)
syntheses are timed with it on the same pose sets (small-integer dual quaternions, which its symbolic
pipeline needs; first pose the identity) and compared with mpsynth on the identical 4x4 matrices.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the figures are for one core (set before numpy loads)

import numpy as np  # noqa: E402

TARGETS = {  # name: (target, unit, kind) -- kind "max": measured <= target; "min": measured >= target
    "bennett": (570e-6, "s", "max"),  # ~ rational-linkages' Bennett (~170 ms here) / 300: see RL_SPEEDUP
    "sixbar": (4e-3, "s", "max"),  # ~ rational-linkages' 6R (~480 ms here) / 100: see RL_SPEEDUP
    "sixbar_member_prepared": (1e-3, "s", "max"),
    "factor_cubic": (200e-6, "s", "max"),
    "batch": (100_000, "1/s", "min"),
    "cold_help": (0.150, "s", "max"),
    "cold_bennett": (0.8, "s", "max"),
    "peak_memory": (200e6, "B", "max"),
}


# ============================================================================ helpers
def calibration() -> float:
    """A plain-Python reference to compare machines (and to catch a VM slowed by its neighbours):
    ``sum(range(10**6))``, best of 5, in ms."""
    import timeit

    return min(timeit.repeat("sum(range(10**6))", number=1, repeat=5)) * 1e3


def machine() -> dict:
    info = {"nproc": os.cpu_count(), "python": platform.python_version(), "numpy": np.__version__,
            "platform": platform.platform()}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                info["cpu"] = line.split(":", 1)[1].strip()
                break
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                info["ram_gb"] = round(int(line.split()[1]) / 1024 ** 2, 1)
    except OSError:
        pass
    info["load"] = os.getloadavg()
    info["calibration_ms"] = calibration()
    info["openblas_threads"] = os.environ.get("OPENBLAS_NUM_THREADS", "unset")
    return info


def per_call(fn, args_list, repeat):
    """(median wall, min wall, CPU per call) in seconds over ``repeat`` calls on each argument."""
    for a in args_list[:2]:
        fn(a)  # warm up (imports, caches)
    walls = []
    c0 = time.process_time()
    for _ in range(repeat):
        for a in args_list:
            t = time.perf_counter()
            fn(a)
            walls.append(time.perf_counter() - t)
    cpu = (time.process_time() - c0) / (repeat * len(args_list))
    return statistics.median(walls), min(walls), cpu


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def random_poses(rng, n):
    T = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        T[i, :3, :3] = random_rotation(rng)
        T[i, :3, 3] = rng.normal(size=3)
    return T


def random_cubic(rng):
    from synth.algebra.polynomial import product_of_linear

    h = rng.normal(size=(3, 8))
    h[:, 4] = 0.0
    for i in range(3):  # rotation factors: dual scalar 0, v.w = 0
        v, w = h[i, 1:4], h[i, 5:8]
        h[i, 5:8] = w - v * (v @ w) / (v @ v)
    return product_of_linear(h)


def sixbar_sets(rng, count):
    """Random 4-pose sets with a ruled quadric (a real 6R exists), checked with synth.synthesis.sixbar."""
    import synth
    from synth.errors import SynthesisError

    out = []
    while len(out) < count:
        T = random_poses(rng, 4)
        try:
            L = synth.sixbar(T)
        except SynthesisError:
            continue
        out.append((T, L.info.synthesis.family, L.info.synthesis.member))
    return out


def cold(cmd, runs, cwd=REPO):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        r = subprocess.run(cmd, cwd=cwd, capture_output=True)
        times.append(time.perf_counter() - t)
        if r.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, cmd))} failed: {r.stderr.decode()[-500:]}")
    return statistics.median(times), min(times)


def peak_memory(cmd, cwd=REPO) -> float:
    """Max RSS (bytes) of one run of cmd."""
    gnu_time = shutil.which("time") or ("/usr/bin/time" if os.path.exists("/usr/bin/time") else None)
    if gnu_time:
        with tempfile.NamedTemporaryFile("r", suffix=".mem") as f:
            r = subprocess.run([gnu_time, "-f", "%M", "-o", f.name, *map(str, cmd)], cwd=cwd, capture_output=True)
            if r.returncode == 0:
                return float(Path(f.name).read_text().split()[-1]) * 1024
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    subprocess.run(cmd, cwd=cwd, capture_output=True, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return float(max(before, after)) * 1024  # an upper bound if an earlier child was larger


def imported_modules(cmd_args) -> set:
    """Top-level modules imported by `mpsynth <cmd_args>` (python -X importtime)."""
    code = ("import sys; sys.argv = ['mpsynth'] + %r\nfrom cli.main import main\ntry:\n    main()\n"
            "except SystemExit:\n    pass\n") % (list(map(str, cmd_args)),)
    r = subprocess.run([sys.executable, "-X", "importtime", "-c", code], cwd=REPO, capture_output=True, text=True)
    mods = set()
    for line in r.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            mods.add(line.rsplit("|", 1)[1].strip().split(".")[0])
    return mods


# ============================================================================ rational-linkages
RL_HELPER = r'''
import json, signal, statistics, sys, time, warnings
warnings.simplefilter("ignore")
t0 = time.perf_counter()
from rational_linkages import DualQuaternion, MotionInterpolation, RationalMechanism, TransfMatrix
t_import = time.perf_counter() - t0
import importlib.metadata
spec = json.loads(sys.argv[1])
out = {"version": importlib.metadata.version("rational-linkages"), "import_in_process": t_import,
       "bennett": [], "sixbar": [], "failed": {"bennett": 0, "sixbar": 0}}
answers, sys.stdout = sys.stdout, sys.stderr  # whatever the package prints goes to stderr

class Timeout(Exception):
    pass

def on_alarm(*_):
    raise Timeout()

signal.signal(signal.SIGALRM, on_alarm)

def run(dqs):
    poses = [DualQuaternion(list(map(float, d))) for d in dqs]
    t = time.perf_counter()
    c = MotionInterpolation.interpolate(poses)
    f = c.factorize()
    RationalMechanism(f)
    return time.perf_counter() - t

# one set per line on stdin ({"key", "dqs"}), one answer per line on stdout: the caller times mpsynth on the
# same set right after, so that both figures come from the same minute of a shared machine
print(json.dumps(out), file=answers, flush=True)
for line in sys.stdin:
    job = json.loads(line)
    dqs = job["dqs"]
    try:
        signal.alarm(spec["limit"][job["key"]])
        ts = [run(dqs) for _ in range(spec["repeat"])]
        signal.alarm(0)
    except Exception:  # its factorization fails on some inputs, or takes longer than the limit
        signal.alarm(0)
        print(json.dumps({"ok": False}), file=answers, flush=True)
        continue
    mats = [TransfMatrix(DualQuaternion(list(map(float, d))).dq2matrix()).to_standard().tolist() for d in dqs]
    print(json.dumps({"ok": True, "time": min(ts), "matrices": mats}), file=answers, flush=True)
'''


RL_EXAMPLE_6R = [[1, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 1, 1, 0, 1, 0], [1, 2, 0, 0, -2, 1, 0, 0], [3, 0, 1, 0, 1, 0, -3, 0]]
RL_LIMIT = {"bennett": 120, "sixbar": 30}  # seconds per set before rational-linkages is given up on
RL_SPEEDUP = {"bennett": 300, "sixbar": 100}  # targets: this many times faster than rational-linkages
OURS_REPEAT = 100  # mpsynth calls per set (its minimum; about 60 ms per Bennett set, 0.3 s per 6R set)


def integer_dq(rng, k=3):
    """A small-integer dual quaternion on the Study quadric (p . q = 0), p != 0."""
    while True:
        p = rng.integers(-k, k + 1, size=4)
        if p @ p:
            break
    q = rng.integers(-k, k + 1, size=4)
    q = (p @ p) * q - (p @ q) * p  # integer, orthogonal to p
    g = np.gcd.reduce(np.concatenate([p, q]))
    return [int(x) for x in np.concatenate([p, q]) // max(int(g), 1)]


def rl_sets(rng, count, n):
    one = [1, 0, 0, 0, 0, 0, 0, 0]
    return [[one] + [integer_dq(rng) for _ in range(n - 1)] for _ in range(count)]


def run_rl(python, rng, sets3, sets4, repeat, timeout):
    """rational-linkages and mpsynth set by set: each candidate set goes to rational-linkages (a helper
    process in its own environment, ``repeat`` runs, its minimum), and mpsynth is timed on the same 4x4
    matrices right after (minimum of OURS_REPEAT calls), so that a shared machine's changes of speed
    affect both sides alike; the first ``sets3`` / ``sets4`` sets that rational-linkages synthesizes count."""
    import synth
    from synth.errors import SynthesisError
    from synth.synthesis.sixbar_member import one_member_loops

    # candidates: more than needed. 6R: the example of its documentation (MotionInterpolation), then random
    # sets (on which it rarely succeeds)
    cand = {"bennett": rl_sets(rng, 4 * sets3, 3), "sixbar": [RL_EXAMPLE_6R] + rl_sets(rng, 2 * sets4, 4)}
    spec = {"repeat": repeat, "limit": RL_LIMIT}
    # cold import of the package (new process each)
    imports = []
    for _ in range(3):
        t = time.perf_counter()
        subprocess.run([python, "-c", "import rational_linkages"], capture_output=True, check=True, timeout=timeout)
        imports.append(time.perf_counter() - t)
    err = tempfile.TemporaryFile(mode="w+")
    proc = subprocess.Popen([python, "-c", RL_HELPER, json.dumps(spec)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=err, text=True)

    def answer():
        line = proc.stdout.readline()
        if not line:
            err.seek(0)
            raise RuntimeError("rational-linkages helper failed: " + err.read()[-2000:])
        return json.loads(line)

    try:
        rl = answer()
        rl["import_cold"] = statistics.median(imports)
        rl["repeat"] = repeat
        ours_b, ours_s, ours_m, skipped = [], [], [], 0
        for key, count in (("bennett", sets3), ("sixbar", sets4)):
            for dqs in cand[key]:
                if len(rl[key]) >= count:
                    break
                proc.stdin.write(json.dumps({"key": key, "dqs": dqs}) + "\n")
                proc.stdin.flush()
                got = answer()
                if not got["ok"]:
                    rl["failed"][key] += 1
                    continue
                rl[key].append(got["time"])
                T = np.array(got["matrices"])
                if key == "bennett":  # min of the repeats, as for rational-linkages
                    ours_b.append(per_call(synth.bennett, [T], OURS_REPEAT)[1])
                    continue
                try:
                    L = synth.sixbar(T)
                except SynthesisError:  # e.g. an oval quadric: no real 6R of this kind (rational-linkages
                    skipped += 1        # still returns a complex/approximate result); not compared
                    continue
                ours_s.append(per_call(synth.sixbar, [T], max(OURS_REPEAT // 20, 5))[1])
                fam, mem = L.info.synthesis.family, L.info.synthesis.member
                ours_m.append(per_call(lambda x: one_member_loops(x, fam, mem), [T], max(OURS_REPEAT // 20, 5))[1])
    finally:
        proc.stdin.close()
        proc.wait(timeout=60)
        err.close()
    ours_import = cold([sys.executable, "-c", "import synth.synthesis.bennett"], 5)[0]
    return rl, {"bennett": ours_b, "sixbar": ours_s, "member": ours_m, "sixbar_skipped": skipped,
                "import_cold": ours_import}


def _rl_note(r) -> str:
    f = r.get("failed", {})
    if not any(f.values()):
        return ""
    return (f"\nrational-linkages failed (an error, or no result within {RL_LIMIT['bennett']} s / "
            f"{RL_LIMIT['sixbar']} s) on {f.get('bennett', 0)} Bennett and {f.get('sixbar', 0)} 6R candidate sets; "
            "the figures above are over the sets it did synthesize (mpsynth synthesized all of them).")


# ============================================================================ main
def fmt_time(s):
    if s < 1e-3:
        return f"{s * 1e6:.0f} µs"
    if s < 1:
        return f"{s * 1e3:.1f} ms"
    return f"{s:.2f} s"


def batch_row(rng, q: bool) -> tuple:
    """The bennett_batch row: N = 10,000 random sets, (name, label, per second median, best, per CPU s)."""
    import synth

    N = 10_000
    P = np.array([random_poses(rng, 3) for _ in range(N)])
    batch_times, batch_cpu = [], []
    for _ in range(2 if q else 5):
        c0, t0 = time.process_time(), time.perf_counter()
        R = synth.bennett_batch(P)
        batch_times.append(time.perf_counter() - t0)
        batch_cpu.append(time.process_time() - c0)
    bt = statistics.median(batch_times)
    return ("batch", f"bennett_batch, N = {N:,} (ok: {int(R.ok.sum()):,})", N / bt, N / min(batch_times),
            N / statistics.median(batch_cpu))


def cli_rows(fixture: Path, q: bool) -> list[tuple]:
    """The command-line rows: cold --help, a cold `mpsynth bennett` writing files, its peak memory, --json."""
    mpsynth = Path(sys.executable).parent / "mpsynth"
    rows = [("cold_help", "cold `mpsynth --help`", *cold([mpsynth, "--help"], 5 if q else 15), None)]
    with tempfile.TemporaryDirectory() as tmp:
        runs = 3 if q else 9
        outs = iter(range(1000))
        cmd = lambda *more: [mpsynth, "bennett", fixture, "-o", Path(tmp) / f"out{next(outs)}", "-q", *more]  # noqa: E731
        # the target of issue 7 was set for URDF + STL (+ linkage.json): today's `--no-step`; the default also
        # writes linkage.step with the cad extra (issue 33), timed in its own row
        for name, label, more in (("cold_bennett", "cold `mpsynth bennett fixture -o OUT --no-step` (URDF+STL+json)",
                                   ("--no-step",)),
                                  ("cold_bennett_step", "cold `mpsynth bennett fixture -o OUT` (and linkage.step)", ())):
            times = [cold(cmd(*more), 1)[0] for _ in range(runs)]
            rows.append((name, label, statistics.median(times), min(times), None))
        rows.append(("peak_memory", "peak memory of the run with linkage.step (max RSS)", peak_memory(cmd()), None, None))
        rows.append(("cold_json", "cold `mpsynth bennett fixture --json` (no files)",
                     *cold([mpsynth, "bennett", fixture, "--json", "-q"], 3 if q else 9), None))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rl-python", help="a Python interpreter in which rational_linkages is importable")
    ap.add_argument("--markdown", help="also write the results as Markdown to this file")
    ap.add_argument("--quick", action="store_true", help="fewer repeats (a rough figure in ~30 s)")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    q = args.quick
    rng = np.random.default_rng(args.seed)
    info = machine()
    print(f"machine: {info.get('cpu')} x {info['nproc']}, {info.get('ram_gb')} GB, Python {info['python']}, "
          f"numpy {info['numpy']}, load {info['load'][0]:.2f}", flush=True)

    import synth
    from synth.algebra.factorize import factorize

    rows = []  # (name, label, measured, min, cpu)

    sets3 = [random_poses(rng, 3) for _ in range(20)]
    rows.append(("bennett", "synth.bennett(poses) (default checks)", *per_call(synth.bennett, sets3, 10 if q else 50)))
    from synth.synthesis.bennett import verify

    rows.append(("bennett_full", "synth.bennett(poses) + verify (the CLI's explicit 200-sample verification)",
                 *per_call(lambda T: verify(synth.bennett(T)), sets3, 3 if q else 10)))
    cubics = [random_cubic(rng) for _ in range(20)]
    rows.append(("factor_cubic", "synth.factorize(random cubic), all 6", *per_call(factorize, cubics, 10 if q else 50)))
    try:
        from synth.synthesis.sixbar_member import one_member_loops

        six = sixbar_sets(rng, 5 if q else 10)
        rows.append(("sixbar", "synth.sixbar(poses) (default: scan, best candidate built and self-checked)", *per_call(synth.sixbar, [s[0] for s in six], 2 if q else 5)))
        from synth.synthesis.sixbar import prepare

        prepared = [(prepare(s[0]),) + s for s in six]
        rows.append(("sixbar_member_prepared", "one member's 9 loops, scored, poses prepared "
                     "(one_member_loops(..., problem=prepare(poses)))",
                     *per_call(lambda s: one_member_loops(s[1], s[2], s[3], problem=s[0]), prepared, 2 if q else 5)))
        rows.append(("sixbar_member", "one member's 9 loops, scored, from raw poses (+ prepare: quadric and both families, once per pose set)",
                     *per_call(lambda s: one_member_loops(s[0], s[1], s[2]), six, 2 if q else 5)))
    except ImportError:
        print("synth.sixbar not available: skipped", flush=True)

    rows.append(batch_row(rng, q))
    fixture = REPO / "fixtures" / "bennett_mm_deg.yaml"
    rows += cli_rows(fixture, q)
    heavy = sorted(imported_modules(["bennett", str(fixture), "--json", "-q"])
                   & {"trimesh", "scipy", "sympy", "matplotlib", "yourdfpy", "networkx"})

    rl = None
    if args.rl_python:
        print("rational-linkages: timing its Bennett and 6R pipelines (symbolic; takes a minute) ...", flush=True)
        rl = run_rl(args.rl_python, rng, 3 if q else 5, 1 if q else 2, 1 if q else 2, timeout=1800)

    info["load_end"] = os.getloadavg()
    info["calibration_end_ms"] = calibration()
    text = report(info, rows, heavy, rl)
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(text + "\n", encoding="utf-8")


def report(info, rows, heavy, rl) -> str:
    L = []
    L.append("# mpsynth benchmark results (bench/run.py)\n")
    L.append(f"- Machine: {info.get('cpu')}, {info['nproc']} CPUs (nproc), {info.get('ram_gb')} GB RAM; "
             f"{info['platform']}")
    L.append(f"- Python {info['python']}, numpy {info['numpy']}, OPENBLAS_NUM_THREADS={info['openblas_threads']}")
    L.append(f"- Calibration: `sum(range(10**6))` takes {info['calibration_ms']:.1f} ms here at the start and "
             f"{info['calibration_end_ms']:.1f} ms at the end (best of 5; a recent desktop CPU with CPython 3.11 "
             "takes roughly 10-15 ms): scale the in-process figures accordingly" + (
                 "; the two differ by more than 20%: the machine's speed changed during the run (a shared VM), "
                 "so repeat it" if abs(info['calibration_end_ms'] / info['calibration_ms'] - 1) > 0.2 else ""))
    L.append(f"- Load average (1/5/15 min) at start {', '.join(f'{x:.2f}' for x in info['load'])}, at end "
             f"{', '.join(f'{x:.2f}' for x in info['load_end'])}" + (
                 " -- other processes were competing for the CPUs, so wall-clock figures are inflated; the CPU "
                 "column (process time per call) is the steadier one" if max(info["load"]) > 0.5 * info["nproc"] else ""))
    L.append("")
    L.append("| figure | median | min | CPU/call (mean) | target | ratio (>= 1: met) |")
    L.append("|---|---|---|---|---|---|")
    for name, label, med, mn, cpu in rows:
        tgt = TARGETS.get(name)
        if name == "batch":
            val = lambda x: "-" if x is None else f"{x:,.0f} /s"  # noqa: E731
        elif name == "peak_memory":
            val = lambda x: "-" if x is None else f"{x / 1e6:.0f} MB"  # noqa: E731
        else:
            val = lambda x: "-" if x is None else fmt_time(x)  # noqa: E731
        if tgt:
            t, _, kind = tgt
            ratio = (t / med) if kind == "max" else (med / t)
            tcell = ("≤ " if kind == "max" else "≥ ") + val(t)
            rcell = f"{ratio:.2f} ({'met' if ratio >= 1 else 'NOT met'})"
        else:
            tcell, rcell = "-", "-"
        L.append(f"| {label} | {val(med)} | {val(mn)} | {val(cpu)} | {tcell} | {rcell} |")
    L.append("")
    L.append(f"Heavy modules imported by `mpsynth bennett --json` (no -o): {', '.join(heavy) or 'none'}.")
    if rl:
        r, ours = rl
        L.append("")
        L.append(f"## rational-linkages {r.get('version') or ''} on the same pose sets\n")
        L.append("Pose sets: small-integer dual quaternions on the Study quadric, first pose the identity (its "
                 "symbolic pipeline needs exact, small rationals: on random floating-point poses its 6R "
                 "interpolation did not finish within 10 minutes); for 6R the example of its documentation "
                 "first, then random ones. rational-linkages: "
                 "`MotionInterpolation.interpolate(poses)`, `.factorize()`, `RationalMechanism(...)`, minimum of "
                 f"its {r.get('repeat', '?')} runs per set, median over sets. mpsynth: `synth.bennett` / `synth.sixbar` "
                 "(default: scan of both families, best candidate, self-checks) on the identical 4x4 matrices, timed "
                 f"right after rational-linkages on each set (a shared machine's changes of speed hit both alike), "
                 f"the same statistic: minimum of its {OURS_REPEAT} (Bennett) / {max(OURS_REPEAT // 20, 5)} (6R) "
                 "calls per set, median over sets.\n")
        L.append("| figure | rational-linkages | mpsynth | speed-up | target |")
        L.append("|---|---|---|---|---|")
        ours_imp = ours.get("import_cold")
        L.append(f"| cold `import` (new process) | {fmt_time(r['import_cold'])} | {fmt_time(ours_imp)} "
                 f"(`import synth.synthesis.bennett`, numpy included) | {r['import_cold'] / ours_imp:,.1f}x | - |")
        rb, ob = statistics.median(r["bennett"]), statistics.median(ours["bennett"])
        met = "met" if rb / ob >= RL_SPEEDUP["bennett"] else "NOT met"
        L.append(f"| Bennett from 3 poses ({len(r['bennett'])} sets) | {fmt_time(rb)} | {fmt_time(ob)} | {rb / ob:,.0f}x "
                 f"| ≥ {RL_SPEEDUP['bennett']}x ({met}) |")
        if ours["sixbar"]:
            rs, os_, om = (statistics.median(r["sixbar"]), statistics.median(ours["sixbar"]),
                           statistics.median(ours["member"]))
            k = f"{len(ours['sixbar'])} set{'s' if len(ours['sixbar']) != 1 else ''}"
            met6 = "met" if rs / os_ >= RL_SPEEDUP["sixbar"] else "NOT met"
            L.append(f"| 6R from 4 poses, default ({k}) | {fmt_time(rs)} | {fmt_time(os_)} | {rs / os_:,.0f}x "
                     f"| ≥ {RL_SPEEDUP['sixbar']}x ({met6}) |")
            L.append(f"| 6R, one member's loops ({k}) | {fmt_time(rs)} | {fmt_time(om)} | {rs / om:,.0f}x | - |")
        L.append(_rl_note(r))
        if ours["sixbar_skipped"]:
            L.append(f"\n{ours['sixbar_skipped']} of the 4-pose sets have no real 6R of this kind for mpsynth "
                     "(oval quadric) and were not compared.")
    return "\n".join(L)


if __name__ == "__main__":
    main()
