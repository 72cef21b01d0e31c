"""A kernel call that may not return, run in a forked child bounded in CPU time.

OpenCASCADE's booleans (linkage.step, `synth.io.step`) can fail to return on some near-tangent solids:
measured on fixtures/motion_darboux.yaml's link_k4 with the stacks of issue 33 (a fuse of revolved round
bars and hubs still running after 300 CPU seconds, where the same part built from cylinders and balls
takes 0.36 s). A boolean that never returns cannot be caught in the process, so `bounded_build` runs
the build in a forked child that reports each attempt (a key, e.g. (part, construction)) before it
starts it; when an attempt reaches its CPU limit (RLIMIT_CPU, set anew before each attempt; CPU time, not
wall-clock: a busy machine does not change the outcome) the child ends, that attempt is banned and a new
child starts without it. The limit is far above what an attempt that returns takes (`CPU_SECONDS`), so
only one that hangs meets it.

Where ``os.fork`` is not available the build runs in the process, unbounded.
"""
from __future__ import annotations

import os
import pickle
import signal

CPU_SECONDS = 10  # an attempt's CPU limit (linkage.step: a part's construction, the largest of the fixtures ~0.4 s)
ROUNDS = 8  # children started at most (each bans one attempt that did not return)


class Hung(RuntimeError):
    """Every child reached its CPU limit: the attempts that did not return are in ``banned``."""

    def __init__(self, banned: frozenset):
        super().__init__(f"the B-rep kernel did not return within {CPU_SECONDS} CPU seconds an attempt "
                         f"({', '.join(map(str, sorted(banned, key=str)))})")
        self.banned = banned


def bounded_build(build, *args, cpu_seconds: float = CPU_SECONDS, rounds: int = ROUNDS):
    """``build(*args, banned=frozenset of keys, trying=callable(key))``'s result, computed in a forked
    child whose every attempt is limited to ``cpu_seconds`` of CPU; ``build`` calls ``trying(key)`` before each attempt that may
    not return and skips the keys in ``banned``. An exception raised by ``build`` is raised here again
    (as RuntimeError with its text); `Hung` after ``rounds`` children that each met the limit."""
    if not hasattr(os, "fork"):
        return build(*args, banned=frozenset(), trying=lambda key: None)
    banned: frozenset = frozenset()
    for _ in range(rounds):
        kind, value = _child(build, args, banned, cpu_seconds)
        if kind == "done":
            return value
        if kind == "error":
            raise RuntimeError(value)
        if value is None or value in banned:  # killed before any attempt, or by something else
            raise RuntimeError(f"the B-rep kernel's process ended without a result ({kind})")
        banned = banned | {value}
    raise Hung(banned)


def _child(build, args, banned, cpu_seconds) -> tuple[str, object]:
    """("done", result) | ("error", text) | ("hung", the last key tried or None) of one child."""
    import resource

    rfd, wfd = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns, never runs the parent's exit handlers
        status = 1
        try:
            os.close(rfd)
            for s in (signal.SIGINT, signal.SIGTERM):
                signal.signal(s, signal.SIG_DFL)
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # SIGXCPU's default action dumps core
            hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
            out = os.fdopen(wfd, "wb")

            def send(message):
                pickle.dump(message, out)
                out.flush()

            def limit():  # the CPU used so far plus an attempt's (whole seconds: RLIMIT_CPU's unit)
                use = resource.getrusage(resource.RUSAGE_SELF)
                soft = int(use.ru_utime + use.ru_stime + cpu_seconds) + 1
                resource.setrlimit(resource.RLIMIT_CPU, (soft if hard == resource.RLIM_INFINITY else min(soft, hard),
                                                          hard))

            def trying(key):
                send(("try", key))
                limit()

            limit()
            try:
                result = build(*args, banned=banned, trying=trying)
            except Exception as e:  # noqa: BLE001  (the parent raises it again)
                send(("error", str(e)))
            else:
                send(("done", result))
            status = 0
        finally:
            os._exit(status)
    os.close(wfd)
    last, end = None, None
    try:
        with os.fdopen(rfd, "rb") as inp:
            while True:
                try:
                    kind, value = pickle.load(inp)
                except (EOFError, pickle.UnpicklingError):
                    break
                if kind == "try":
                    last = value
                else:
                    end = (kind, value)
    finally:
        try:
            os.kill(pid, signal.SIGKILL) if end is None else None
        except ProcessLookupError:
            pass
        _, status = os.waitpid(pid, 0)
    if end is not None:
        return end
    return "hung", last
