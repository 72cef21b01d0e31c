"""A/B of the collision-free design search and of one output job against a baseline checkout, in one run
(issue 36: "a Bennett design costs tens of milliseconds").

    .venv/bin/python bench/bench_design_ab.py BASELINE [--rounds 3] [--bennett 24] [--sixbar 4] [--jobs 8]

BASELINE is another checkout of mpsynth (e.g. ``git worktree add /tmp/base <rev>``, or ``git archive REV |
tar -x -C /tmp/base``). Both trees run with this interpreter, one child process per tree and round, the
trees interleaved (A B A B ...), so that a change of the machine's load hits both. Per tree and round:

- ``design_linkage`` with the default sizes (bench_design's) on the first ``--bennett`` solvable random
  Bennett sets and ``--sixbar`` 6R sets (seeds from 0): CPU ms per design (process time, summed over the
  sets), and the gap evaluations counted (`synth.design.work`);
- ``--jobs`` README output jobs (`synth.tools.batchjobs.run_job` with ``out``): CPU ms per job, and the part
  of it spent in the design search, the meshes, the STEP file and the print section.

Printed: each figure per tree (median over rounds) and the ratio B/A (baseline over this tree: > 1 is
faster here). The designs of both trees are compared: every mount offset, the collision report's range,
freedom and distances, and the counted work must be the same (bit for bit: a change of the search's
arithmetic would change its choices); the verdict is printed and is the exit code (1 when they differ).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHILD = r'''
import collections, hashlib, importlib, json, sys, tempfile, time
from pathlib import Path
sys.path.insert(0, sys.argv[1] + "/bench")
from bench_design import default_sizes, solvable_sets
from synth.design.search import design_linkage
nb, ns, nj = int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
out = {}
for kind, n in (("bennett", nb), ("sixbar", ns)):
    if not n:
        continue
    sets = solvable_sets(kind, n, 0)
    design_linkage(sets[0][1], **default_sizes(sets[0][1]))  # imports, caches
    t = time.process_time()
    res = [design_linkage(lk, **default_sizes(lk)) for _, lk in sets]
    cpu = time.process_time() - t
    key = [[m["offset"] for m in r.design.to_dict()["mounts"]] + [r.collision.range, r.collision.free,
           r.collision.min_distance, r.collision.sampled_min_distance, r.collision.work] for r in res]
    out[kind] = {"ms": cpu / n * 1e3, "work": sum(r.collision.work for r in res) / n,
                 "hash": hashlib.sha256(json.dumps(key).encode()).hexdigest()[:16]}
if nj:
    from bench_batch import readme_jobs
    from synth.tools.batchjobs import run_job
    acc = collections.Counter()
    stages = (("synth.design.search", "design_linkage", "design"), ("synth.io.meshes", "design_solids", "meshes"),
              ("synth.io.step", "step_text", "step"), ("synth.io.printreport", "print_section", "print"))

    def timed(f, label):
        def g(*a, **k):
            t = time.process_time()
            try:
                return f(*a, **k)
            finally:
                acc[label] += time.process_time() - t
        return g

    for mod, name, label in stages:
        f = getattr(importlib.import_module(mod), name)
        g = timed(f, label)
        for m in list(sys.modules.values()):  # every module that imported the function by name
            if getattr(m, name, None) is f and str(getattr(m, "__file__", "")).startswith(sys.argv[1]):
                setattr(m, name, g)
    lines = readme_jobs(nj + 1)
    tmp = Path(tempfile.mkdtemp(prefix="bench_design_ab-"))
    items = [(i + 1, json.dumps({**json.loads(s), "out": f"o{i}"})) for i, s in enumerate(lines)]
    run_job(items[-1], out_dir=tmp)  # imports, kernels
    acc.clear()
    t = time.process_time()
    for it in items[:nj]:
        run_job(it, out_dir=tmp)
    out["job"] = {"ms": (time.process_time() - t) / nj * 1e3, **{k: v / nj * 1e3 for k, v in acc.items()}}
print(json.dumps(out))
'''


def child(tree: Path, args) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-c", CHILD, str(tree), str(args.bennett), str(args.sixbar), str(args.jobs)],
                          capture_output=True, text=True, env=env, cwd=tree)
    if proc.returncode:
        sys.exit(f"{tree}: {proc.stderr.strip().splitlines()[-1:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("baseline", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--bennett", type=int, default=24)
    ap.add_argument("--sixbar", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=8, help="README output jobs (0: none)")
    a = ap.parse_args(argv)
    trees = {"A (this tree)": REPO, "B (baseline)": a.baseline.resolve()}
    runs: dict[str, list[dict]] = {k: [] for k in trees}
    load0 = os.getloadavg()[0]
    for _ in range(a.rounds):
        for name, tree in trees.items():
            runs[name].append(child(tree, a))
    print(f"load {load0:.1f} -> {os.getloadavg()[0]:.1f}; CPU ms (process time), median of {a.rounds} rounds")
    A, B = runs["A (this tree)"], runs["B (baseline)"]
    print(f"{'figure':34s} {'A (this tree)':>14s} {'B (baseline)':>14s} {'B / A':>7s}")
    for kind in ("bennett", "sixbar", "job"):
        if kind not in A[0]:
            continue
        for field in A[0][kind]:
            if field == "hash":
                continue
            fa = statistics.median(r[kind].get(field, 0.0) for r in A)
            fb = statistics.median(r[kind].get(field, 0.0) for r in B)
            label = {"ms": f"{kind}: CPU ms per {'job' if kind == 'job' else 'design'}", "work": f"{kind}: gap evaluations"}.get(
                field, f"  of which {field}")
            print(f"{label:34s} {fa:14,.1f} {fb:14,.1f} {fb / fa if fa else float('nan'):7.2f}")
    same = all(A[0][k]["hash"] == B[0][k]["hash"] for k in ("bennett", "sixbar") if k in A[0])
    print(f"designs of both trees identical (every mount offset, report and work count): {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
