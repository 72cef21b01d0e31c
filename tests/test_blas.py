"""BLAS threads in batched kernels (docs/architecture.md, "Threads")."""
import numpy as np
import pytest

threadpoolctl = pytest.importorskip("threadpoolctl")

from synth.blas import one_blas_thread  # noqa: E402
from synth.synthesis import bennett_core  # noqa: E402


def blas_threads():
    return [lib["num_threads"] for lib in threadpoolctl.threadpool_info() if lib["user_api"] == "blas"]


def test_one_blas_thread_limits_and_restores():
    np.ones((4, 4)) @ np.ones((4, 4))  # BLAS loaded
    before = blas_threads()
    if not before:
        pytest.skip("no BLAS library that threadpoolctl can see")
    with one_blas_thread():
        assert blas_threads() == [1] * len(before)
    assert blas_threads() == before


def test_large_batches_run_on_one_blas_thread(monkeypatch):
    seen = []
    solve_chunk = bennett_core._solve

    def spy(T, check_samples, fac=None):
        seen.append((len(T), blas_threads()))
        return solve_chunk(T, check_samples, fac)

    monkeypatch.setattr(bennett_core, "_solve", spy)
    rng = np.random.default_rng(5)
    T = np.tile(np.eye(4), (bennett_core.ONE_THREAD_MIN, 3, 1, 1))
    T[:, :, :3, 3] = rng.normal(size=(bennett_core.ONE_THREAD_MIN, 3, 3))
    T[:, 1, :3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    T[:, 2, :3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]
    out = bennett_core.solve(T, 0)
    assert out.good.shape == (len(T),)
    assert seen and all(n == len(T) and set(threads) <= {1} for n, threads in seen)
    bennett_core.solve(T[:3], 0)
    assert seen[-1][0] == 3  # small batches: BLAS untouched (the limit costs more than it saves there)


def test_the_command_runs_blas_on_one_thread_unless_told_otherwise():
    """cli/__init__.py sets one BLAS thread before numpy loads (docs/architecture.md, "Threads"); an explicit
    OPENBLAS_NUM_THREADS in the environment wins."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    code = ("import cli.main, numpy, threadpoolctl; numpy.ones((4, 4)) @ numpy.ones((4, 4)); "
            "print(sorted({i['num_threads'] for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas'}))")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS")}
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=root, capture_output=True, text=True, check=True)
    if out.stdout.strip() == "[]":
        pytest.skip("no BLAS library that threadpoolctl can see")
    assert out.stdout.strip() == "[1]"
    if (os.cpu_count() or 1) > 1:
        env["OPENBLAS_NUM_THREADS"] = env["MKL_NUM_THREADS"] = "2"
        out = subprocess.run([sys.executable, "-c", code], env=env, cwd=root, capture_output=True, text=True, check=True)
        assert out.stdout.strip() == "[2]"
