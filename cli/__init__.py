"""The `mpsynth` command line (click), a thin layer over `synth` (docs/architecture.md).

The first thing the package does, before any command module or click is imported, is to install the ^C
hooks: a SIGINT that arrives while Python is still importing (before `cli.main.main` can catch it) ends
the run with one line ``mpsynth: interrupted`` and exit 130, not a traceback. Both the console script
(``from cli.main import main``) and ``python -m cli.main`` import this package first. A SIGINT during
CPython's own start-up (before any of this code runs) is the interpreter's to report."""
import gc
import os
import sys

# The command run as a program (the console script, python -m cli.main): no cycle collection while its modules
# load (`cli.main.LazyGroup.get_command` turns it on again, with what was loaded frozen: never visited again,
# nor copied into a forked batch worker); a collection during the imports walks every object loaded so far
# (`mpsynth batch` with one job: 15-20 ms of its ~150 ms of CPU). Imported as a library, nothing changes.
if sys.argv and (sys.argv[0] == "-m" or os.path.basename(sys.argv[0]) == "mpsynth"):
    gc.disable()


def interrupted_hook(kind, value, tb, _previous=sys.excepthook):
    """sys.excepthook: ^C while Python is still importing (before `main` can catch it): one line, exit 130."""
    if issubclass(kind, KeyboardInterrupt):
        try:
            sys.stderr.write("mpsynth: interrupted\n")
            sys.stderr.flush()
        finally:
            os._exit(130)
    _previous(kind, value, tb)


def unraisable_hook(info, _previous=sys.unraisablehook):
    """sys.unraisablehook: a ^C inside an import-lock callback is not reported twice."""
    if not isinstance(info.exc_value, KeyboardInterrupt):
        _previous(info)


sys.excepthook = interrupted_hook
sys.unraisablehook = unraisable_hook

# One BLAS thread for the whole command, set before numpy loads its BLAS (docs/architecture.md, "Threads"):
# a run's few large products (the print orientations' vertices x directions) gain nothing from a second
# thread whose spinning cost 0.2-0.3 s of CPU per `mpsynth bennett` (about 12 %), and a product's last
# bits depend on how many threads split it, so one thread also gives the same digits on every machine.
# An explicit setting in the environment wins.
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
