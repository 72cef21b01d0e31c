"""Design-space sweeps: a batched synthesis function mapped over chunks of an array of pose sets, in
this process or on a Dask cluster (`synth.sweep`).

    import numpy as np, synth
    P = ...                                   # (N, 3, 4, 4) pose sets in metres (an np.memmap works)
    S = synth.sweep(P)                        # here, chunk by chunk: no Dask needed
    S = synth.sweep(P, client="tcp://host:8786")    # or a distributed.Client, or "local"
    S.ok, S.status, S["bennett_a"], S["lines"]      # arrays over N, in input order
    L = S.linkage(17)                          # the full Linkage of set 17 (recomputed here)

A chunk is a slice of ``chunksize`` sets; each is one call of ``func`` (one Dask task), which returns a
dict of arrays whose axis 0 runs over the chunk's sets; the chunks' arrays are concatenated in order.
The default ``func``, `bennett_chunk`, is `synth.synthesis.bennett_batch.bennett_batch` (the
vectorized Bennett pipeline; conventions there and in docs/conventions.md) reduced to plain arrays;
`sixbar_chunk` runs `synth.sixbar` set by set (6R synthesis is not vectorized over sets). Any
importable function with the same contract works (it must be importable on the workers). At most
``window`` chunks are in flight, so a memory-mapped input is read a few chunks at a time; the results
(about 1 kB per Bennett set) are held in memory.

A worker that dies loses nothing: Dask runs its chunks again elsewhere (the functions are pure). Dask
(``mpsynth[cluster]``) is imported only when a client is used.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass, field

import numpy as np

from synth.checks import BOUND_CHECK_SAMPLES
from synth.errors import InputError, MpsynthError, SynthesisError
from synth.synthesis.bennett import bennett
from synth.synthesis.bennett_batch import bennett_batch
from synth.tools.cluster import ClusterError, close, connect, import_distributed, worker_threads

DEFAULT_CHUNK = 4096


def bennett_chunk(poses, check_samples: int = BOUND_CHECK_SAMPLES) -> dict:
    """`bennett_batch` of ``poses`` (n, 3, 4, 4), metres, as a dict of arrays over n: ``ok``, ``status``
    (str, "" when ok), ``general`` (solved by the per-set path), ``lines`` (n, 4, 2, 3), ``laws`` (n, 4, 2),
    ``pose_angles`` (n, 3, 4), ``motion`` (n, 3, 8), ``study_form`` (n, 3), ``residual``,
    ``relative_error``, ``bennett_<a|alpha|b|beta|opposite_length_mismatch|opposite_twist_mismatch>``
    and ``error_<pose_translation|pose_rotation|closure_translation|closure_rotation|motion>`` (n,)."""
    R = bennett_batch(np.asarray(poses, float), check_samples=check_samples)
    out = {"ok": R.ok, "status": np.array(R.status, dtype=str), "general": R.general, "lines": R.lines,
           "laws": R.laws, "pose_angles": R.pose_angles, "motion": R.motion, "study_form": R.study_form,
           "residual": R.residual, "relative_error": R.relative_error}
    out.update({f"bennett_{k}": v for k, v in R.bennett.items()})
    out.update({f"error_{k}": v for k, v in R.errors.items()})
    return out


def sixbar_chunk(poses, **options) -> dict:
    """`synth.sixbar` on each of ``poses`` (n, 4, 4, 4), metres: ``ok``, ``status``, ``extent`` (m),
    ``max_pose_error``, ``max_closure_error`` (n,) and ``lines`` (n, 6, 2, 3), the joints (direction,
    moment) at the first pose. ``options`` go to `synth.sixbar` (family, member, pair, ...)."""
    from synth.synthesis.sixbar import sixbar  # optional in an installation, and heavy

    P = np.asarray(poses, float)
    n = len(P)
    ok = np.zeros(n, bool)
    status = [""] * n
    extent, pose_err, closure_err = (np.full(n, np.nan) for _ in range(3))
    lines = np.full((n, 6, 2, 3), np.nan)
    for i in range(n):
        try:
            L = sixbar(P[i], **options)
        except MpsynthError as e:
            status[i] = str(e)
            continue
        except Exception as e:  # one set never breaks the sweep
            status[i] = f"internal error: {type(e).__name__}: {e}"
            continue
        ok[i] = True
        extent[i] = L.extent()
        pose_err[i] = L.checks["max_pose_error"]
        closure_err[i] = L.checks["max_closure_error"]
        for k, j in enumerate(L.joints[:6]):
            lines[i, k] = (j.direction, j.moment)
    return {"ok": ok, "status": np.array(status, dtype=str), "extent": extent, "max_pose_error": pose_err,
            "max_closure_error": closure_err, "lines": lines}


@dataclass
class SweepResult:
    """Arrays over the N swept sets, in input order (see `bennett_chunk` / `sixbar_chunk` for the
    fields); ``result["name"]`` is one array, ``ok`` and ``status`` the per-set outcome."""

    poses: object  # the input (N, ...) array, as given
    arrays: dict = field(default_factory=dict)
    chunks: int = 0  # number of chunks (tasks) it took

    def __len__(self) -> int:
        return len(self.arrays["ok"])

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays[name]

    @property
    def ok(self) -> np.ndarray:
        return self.arrays["ok"]

    @property
    def status(self) -> np.ndarray:
        return self.arrays["status"]

    def linkage(self, i: int, names=None):
        """The full Bennett `Linkage` of set ``i``, recomputed here by `synth.bennett` (a Bennett sweep's
        sets only); raises the set's SynthesisError when it failed."""
        i = int(i)
        if not self.ok[i]:
            raise SynthesisError(str(self.status[i]))
        return bennett(np.asarray(self.poses[i], float), names)


def _concat(parts: list[dict]) -> dict:
    if not parts:
        return {"ok": np.zeros(0, bool), "status": np.zeros(0, str)}
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def sweep(poses, func=bennett_chunk, *, client=None, chunksize: int = DEFAULT_CHUNK, window: int | None = None,
          **kwargs) -> SweepResult:
    """``func(poses[a:b], **kwargs)`` over consecutive chunks of ``chunksize`` sets, results concatenated
    in order (module docstring). ``client``: None runs here; a ``distributed.Client``, or an address
    ("tcp://host:8786", or "local" for a LocalCluster, started and closed here) runs the chunks as Dask
    tasks, at most ``window`` in flight (default 2 per worker thread, at least 4)."""
    n = len(poses)
    if chunksize < 1:
        raise InputError(f"sweep: chunksize must be at least 1, got {chunksize}")
    bounds = [(a, min(a + chunksize, n)) for a in range(0, n, chunksize)]
    if client is None:
        parts = [func(np.asarray(poses[a:b]), **kwargs) for a, b in bounds]
        return SweepResult(poses, _concat(parts), len(bounds))
    own = isinstance(client, str)
    if own:
        client = connect(client)
    try:
        parts = list(_map_on(client, func, poses, bounds, window or max(4, 2 * worker_threads(client)), kwargs))
    finally:
        if own:
            close(client)
    return SweepResult(poses, _concat(parts), len(bounds))


def _map_on(client, func, poses, bounds, window, kwargs):
    distributed = import_distributed()
    pending: collections.deque = collections.deque()
    try:
        for a, b in bounds:
            pending.append(client.submit(func, np.asarray(poses[a:b]), pure=False, **kwargs))
            while len(pending) >= window:
                yield _result(distributed, pending.popleft())
        while pending:
            yield _result(distributed, pending.popleft())
    finally:
        if pending:
            try:
                client.cancel(list(pending))
            except Exception:
                pass


def _result(distributed, fut):
    try:
        return fut.result()
    except distributed.KilledWorker as e:
        raise ClusterError(f"sweep: a chunk killed every worker that ran it ({e}); try a smaller chunksize") from None
