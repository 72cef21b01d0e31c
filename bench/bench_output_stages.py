"""CPU time per output job by stage (issue 36: writing outputs with the design search at >= 10 jobs/s).

    python bench/bench_output_stages.py [--jobs 20] [--no-step] [--worker]

The first N README batch jobs (bench_batch.readme_jobs: three poses in mm and degrees), each with ``"out"``,
are run in this process through `synth.tools.batchjobs.run_job` (what a worker of ``mpsynth batch --out-dir``
runs), one BLAS thread as the CLI sets it. Printed: the CPU ms per job without a profiler, then the same jobs
under cProfile (process time, so another process on a shared machine does not count; the profiler adds
its own overhead to Python-heavy stages) by stage: each row is the cumulative CPU of one function, indented
rows are part of the row above. 10 jobs/s on 2 cores is at most 200 ms of CPU per job all in.
"""
from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as cli/__init__.py: before numpy loads its BLAS
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import cProfile  # noqa: E402
import json  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_batch import children_cpu, readme_jobs  # noqa: E402

# (indent, label, module path suffix, function name): cumulative CPU of that function
STAGES = [
    (0, "job in all (run_job)", "synth/tools/batchjobs.py", "run_job"),
    (1, "synthesis and design (solve_bennett)", "synth/solve/tasks.py", "solve_bennett"),
    (2, "design search (design_for)", "synth/design/choose.py", "design_for"),
    (3, "sizing rounds (choose._sturdy)", "synth/design/choose.py", "_sturdy"),
    (3, "search (design_linkage, every call)", "synth/design/search.py", "design_linkage"),
    (3, "mounting plate (place_mounting)", "synth/design/mounting.py", "place_mounting"),
    (1, "writing OUT (write_output)", "synth/io/writer.py", "write_output"),
    (2, "meshes (design_solids)", "synth/io/meshes.py", "design_solids"),
    (3, "manifold3d booleans (solid.boolean)", "synth/io/solid.py", "boolean"),
    (2, "linkage.step (built_step, within the json row; the child's CPU: above)",
     "synth/io/step.py", "built_step"),
    (3, "gmsh fuse", "gmsh.py", "fuse"),
    (3, "gmsh cut", "gmsh.py", "cut"),
    (3, "gmsh revolve", "gmsh.py", "revolve"),
    (3, "gmsh write", "gmsh.py", "write"),
    (3, "placements (place_products)", "synth/io/step.py", "place_products"),
    (2, "linkage.json (write_linkage_json)", "synth/io/jsonout.py", "write_linkage_json"),
    (3, "print section (print_section)", "synth/io/printreport.py", "print_section"),
    (3, "drive report (drive_report)", "synth/drive.py", "drive_report"),
    (2, "STL files (write_stl)", "synth/io/meshes.py", "write_stl"),
    (2, "URDF (write_urdf; builds the meshes, row above)", "synth/io/urdf.py", "write_urdf"),
]


def job_items(n: int, tag: str) -> list[tuple[int, str]]:
    return [(i + 1, json.dumps({**json.loads(s), "out": f"{tag}{i}"})) for i, s in enumerate(readme_jobs(n))]


def stage_table(stats: pstats.Stats, n: int) -> list[tuple[int, str, float, int]]:
    """(indent, label, CPU ms per job, calls) of every `STAGES` row found in ``stats``."""
    rows = []
    for indent, label, path, func in STAGES:
        hits = [(v[1], v[3]) for (f, _, name), v in stats.stats.items() if name == func and f.endswith(path)]
        if hits:
            rows.append((indent, label, sum(c for _, c in hits) / n * 1e3, sum(k for k, _ in hits)))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=20)
    ap.add_argument("--no-step", action="store_true", help="the jobs as `mpsynth batch --no-step` runs them")
    ap.add_argument("--worker", action="store_true",
                    help="this process set up as a worker of `mpsynth batch -j N` (`workerpool.prepare_worker`: "
                         "on this branch, manifold3d's booleans on one thread)")
    a = ap.parse_args()
    if a.worker:
        from synth.tools.workerpool import prepare_worker

        prepare_worker()
    from synth.io.outputs import Outputs
    from synth.tools.batchjobs import run_job

    outputs = Outputs.chosen(step=not a.no_step)
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="bench_stages-") as tmp:
        tmp = Path(tmp)
        run_job((0, json.dumps({**json.loads(readme_jobs(1)[0]), "out": "warm"})), out_dir=tmp, outputs=outputs)
        t, c = time.process_time(), children_cpu()
        results = [run_job(it, out_dir=tmp, outputs=outputs) for it in job_items(a.jobs, "plain")]
        plain = (time.process_time() - t) / a.jobs * 1e3
        child = (children_cpu() - c) / a.jobs * 1e3
        prof = cProfile.Profile(time.process_time)
        prof.enable()
        for it in job_items(a.jobs, "prof"):
            run_job(it, out_dir=tmp, outputs=outputs)
        prof.disable()
        steps = sum((tmp / f"plain{i}" / "linkage.step").exists() for i in range(a.jobs))
    ok = sum(r.get("ok", False) for r in results)
    print(f"{a.jobs} README output jobs with the design search, in process; load {load0:.1f} -> "
          f"{os.getloadavg()[0]:.1f}; ok {ok}, with linkage.step {steps}")
    print(f"CPU per job without the profiler: {plain + child:,.1f} ms (10 jobs/s on 2 cores: <= 200 ms), of which "
          f"{child:,.1f} in linkage.step's child processes (not in the profile below)")
    print(f"{'stage (cProfile, process time)':52s} {'ms/job':>8s} {'calls':>6s}")
    for indent, label, ms, calls in stage_table(pstats.Stats(prof), a.jobs):
        print(f"{'  ' * indent + label:52s} {ms:8.1f} {calls:6d}")


if __name__ == "__main__":
    main()
