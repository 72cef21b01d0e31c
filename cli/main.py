"""The `mpsynth` command: a click group whose subcommands are imported only when run (fast --help)."""
from __future__ import annotations

import gc
import importlib
import importlib.util
import sys
import warnings

import click  # the ^C hooks are installed by the package (cli/__init__.py) before this import

# name -> (module:function, one-line help). Keep the help here so `mpsynth --help` imports nothing.
COMMANDS = {
    "bennett": ("cli.bennett:bennett", "Three poses -> a Bennett 4R (planar/spherical: a four-bar), URDF + STL + JSON."),
    "sixbar": ("cli.sixbar:sixbar", "Four poses -> ranked spatial 6R linkages, or a planar/spherical Watt six-bar."),
    "fourbar": ("cli.fourbar:fourbar", "3-5 coplanar poses (or more, fitted) -> a ranked planar four-bar (Burmester), URDF + STL + JSON."),
    "factor": ("cli.factor:factor", "Factorize a motion polynomial into linear factors (joints)."),
    "flip": ("cli.flip:flip", "Bennett flip: (t-m)(t-h) = (t-k)(t-n)."),
    "curve": ("cli.curve:curve", "A multi-loop linkage that performs a rational motion or draws a rational curve."),
    "check": ("cli.check:check", "Verify an output directory (structure, meshes, poses, closure, mobility)."),
    "simulate": ("cli.simulate:simulate", "Drive the linkage in PyBullet or MuJoCo and compare with the exact motion."),
    "render": ("cli.render:render", "Headless PNG / animated GIF of a linkage."),
    "view": ("cli.view:view", "Self-contained offline HTML viewer of a linkage."),
    "collide": ("cli.collide:collide", "Self-collision check of the links along the motion."),
    "trajectory": ("cli.trajectory:trajectory", "Joint angles, velocities and tool pose over time (CSV/JSON) for a controller."),
    "design": ("cli.design:design", "Interactive designer in the browser: drag poses, see the linkage re-synthesized live."),
    "batch": ("cli.batch:batch", "Run many synthesis jobs from JSON lines."),
    "parts": ("cli.parts:parts", "Print plates (STL) and an assembly sheet (HTML) for a written linkage."),
    "export": ("cli.export:export", "Add linkage.step (B-rep solids for CAD, mpsynth[cad]) to an existing output."),
}


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("mpsynth")
    except Exception:  # pragma: no cover - not installed
        return "unknown"


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return [n for n, (target, _) in COMMANDS.items() if _available(target)]

    def get_command(self, ctx, name):
        if name not in COMMANDS or not _available(COMMANDS[name][0]):
            return None
        module, func = COMMANDS[name][0].split(":")
        command = getattr(importlib.import_module(module), func)
        if not gc.isenabled():  # (cli/__init__.py: off while the modules loaded)
            gc.freeze()
            gc.enable()
        return command

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """click's main, but usage errors (bad option values, missing arguments, unknown commands) are
        one line ``mpsynth: ...`` on stderr with exit code 2, like every other input error."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.exceptions.NoArgsIsHelpError as e:  # plain `mpsynth`: the help text
            e.show()
            sys.exit(e.exit_code)
        except click.ClickException as e:
            sys.exit(_report_click_error(e))
        except click.exceptions.Abort as e:  # Ctrl-C outside a command's own handling, or EOF
            interrupted = isinstance(e.__cause__ or e.__context__, KeyboardInterrupt)
            _report("mpsynth: interrupted" if interrupted else "mpsynth: aborted")
            sys.exit(130 if interrupted else 1)
        sys.exit(rv if isinstance(rv, int) else 0)  # an int here is the code of a click Exit (--help)

    def invoke(self, ctx):
        """click's invoke; a ^C while a command module is imported or run outside `run_guarded` is an
        Abort caused by KeyboardInterrupt (click itself would first print a blank line)."""
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as e:
            raise click.exceptions.Abort() from e

    def resolve_command(self, ctx, args):
        try:
            return super().resolve_command(ctx, args)
        except click.UsageError as e:
            import difflib

            name = args[0] if args else ""
            close = difflib.get_close_matches(name, list(COMMANDS), n=1, cutoff=0.6)
            if close and name not in COMMANDS and "Did you mean" not in e.message:
                e.message = f"{e.message.rstrip('.')}; did you mean '{close[0]}'?"
            raise

    def format_commands(self, ctx, formatter):
        rows = [(n, COMMANDS[n][1]) for n in self.list_commands(ctx)]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


def _report_click_error(e: click.ClickException) -> int:
    """One stderr line for a click error; returns its exit code."""
    msg = " ".join(e.format_message().split()).rstrip(".")
    ctx = getattr(e, "ctx", None)
    if isinstance(e, click.UsageError) and ctx is not None:
        msg += f" (see '{ctx.command_path} --help')"
    _report(f"mpsynth: {msg}")
    return e.exit_code


def _report(msg: str) -> None:
    """One error line on stderr, nothing when stderr cannot be written (`cli.common.report`; imported
    here, on an error path, to keep `mpsynth --help` light)."""
    from .common import report

    report(msg)


def _available(target: str) -> bool:
    module = target.split(":")[0]
    return importlib.util.find_spec(module) is not None


def _print_version(ctx, param, value):
    """--version, resolved only when asked (importlib.metadata costs ~25 ms of every start-up)."""
    if value and not ctx.resilient_parsing:
        click.echo(f"mpsynth, version {_version()}")
        ctx.exit()


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_print_version,
              help="Show the version and exit.")
def mpsynth():
    """Design closed-loop linkages whose coupler visits given poses, by factorizing motion polynomials.

    \b
    Examples:
      mpsynth bennett fixtures/bennett_mm_deg.yaml -o out_bennett
      mpsynth sixbar fixtures/sixbar_example.yaml -o out_sixbar
      mpsynth factor --expr "(t-1)*(t-j) - eps*((i+k)*t - 2*k)"

    Exit codes: 0 success, 1 no real linkage (the message says why), 2 bad input or usage.
    """


def main(argv=None):
    # numpy's floating-point warnings (overflow in an intermediate of extreme input) are not messages for
    # a user: every result is checked, and a failure is reported as one line with its reason
    warnings.simplefilter("ignore", RuntimeWarning)
    try:
        return mpsynth.main(args=argv, prog_name="mpsynth", standalone_mode=True)
    except KeyboardInterrupt:  # pragma: no cover
        _report("mpsynth: interrupted")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
