"""CPU time of the physical design (`synth.design.choose.design_for`) of the README's Bennett batch jobs
(issue 36: "a Bennett design costs tens of milliseconds").

    .venv/bin/python bench/bench_design_jobs.py [--jobs 20] [--repeats 1] [--tree PATH] [--json FILE]

The first N README jobs (bench_batch.readme_jobs: three random poses in mm and degrees) are parsed and
synthesized once (not timed), then each linkage's design is made with the defaults (`design_for`, what
`mpsynth batch --out-dir` runs) in this process, one BLAS thread. Printed per job: CPU ms (process time: a
shared machine's other processes do not count), the counted work (gap evaluations, `synth.design.work`),
the range it is free over, the written slenderness, the certified gap over the clearance; then the median,
mean and max CPU ms over the jobs (with ``--repeats`` R, each job's least CPU of R runs) and a hash of every
design's mount offsets and report (to see whether two trees design the same). ``--tree``: import mpsynth
from that checkout instead (an A/B against a baseline: run both, interleaved).
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as cli/__init__.py: before numpy loads its BLAS
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

HERE = Path(__file__).resolve().parent


def readme_linkages(n: int) -> list:
    """The Bennett linkages of the first ``n`` README jobs (the ones the synthesis accepts)."""
    from bench_batch import readme_jobs
    from synth.errors import SynthesisError
    from synth.io.poses import parse_pose_document
    from synth.synthesis.bennett import bennett_candidates

    out = []
    for line in readme_jobs(n):
        job = json.loads(line)
        ps = parse_pose_document({k: job[k] for k in ("poses", "units")}, count=3)
        try:
            out.append((job["id"], bennett_candidates(ps.matrices, ps.names)[0]))
        except SynthesisError:
            continue
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--tree", help="import mpsynth from this checkout")
    ap.add_argument("--json", help="write every row to this file")
    ap.add_argument("--quiet", action="store_true", help="the summary only")
    a = ap.parse_args(argv)
    if a.tree:
        sys.path.insert(0, str(Path(a.tree).resolve()))
    sys.path.insert(0, str(HERE))
    from synth.design.choose import design_for

    load0 = os.getloadavg()[0]
    linkages = readme_linkages(a.jobs)
    design_for(readme_linkages(1)[0][1])  # imports (another linkage object: nothing kept on the ones timed)
    rows, keys = [], []
    for jid, lk in linkages:
        best = None
        for _ in range(a.repeats):
            fresh = readme_linkages(jid + 1)[-1][1] if a.repeats > 1 else lk  # (no cache kept on the linkage)
            t = time.process_time()
            r = design_for(fresh)
            cpu = time.process_time() - t
            best = cpu if best is None else min(best, cpu)
        c, s = r.collision, r.slenderness
        rows.append({"id": jid, "ms": best * 1e3, "work": c.work, "free": c.free, "range": c.range,
                     "ratio": s.ratio, "radius": r.design.bar_radius, "gap": c.min_distance / c.clearance})
        keys.append([m["offset"] for m in r.design.to_dict()["mounts"]] + [r.design.bar_radius, c.range, c.free,
                                                                            c.min_distance, c.work])
        if not a.quiet:
            print(f"job {jid:3d}: {best * 1e3:8.1f} ms  work {c.work:10.3g}  {'free ' + c.range if c.free else 'NOT free':9s}"
                  f"  1:{s.ratio:5.2f}  gap/clearance {c.min_distance / c.clearance:6.2f}", flush=True)
    ms = [r["ms"] for r in rows]
    digest = hashlib.sha256(json.dumps(keys).encode()).hexdigest()[:16]
    import synth
    print(f"{Path(synth.__file__).parent.parent}: {len(rows)} jobs, design_for CPU ms median {statistics.median(ms):.1f} mean "
          f"{statistics.mean(ms):.1f} max {max(ms):.1f}; work {sum(r['work'] for r in rows):.3g}; free full "
          f"{sum(r['free'] and r['range'] == 'full' for r in rows)}, within 1:25 {sum(r['ratio'] <= 25 + 1e-6 for r in rows)}; "
          f"max 1:{max(r['ratio'] for r in rows):.2f}; designs {digest}; load {load0:.1f} -> {os.getloadavg()[0]:.1f}")
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
