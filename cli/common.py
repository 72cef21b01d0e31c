"""Helpers shared by the CLI commands: error reporting with exit codes, options, summaries."""
from __future__ import annotations

import errno
import functools
import json
import sys
import traceback
from dataclasses import dataclass

import click

from synth.io.names import check_package, check_robot_name, safe_robot_name
from .streams import environment_error, silence_stderr, silence_stdout

from . import signals

signals.install()  # the CLI owns the process's signals: outputs being written are removed on ^C / SIGTERM


def echo(msg: str = "") -> None:
    """Human-readable output goes to stderr (stdout is reserved for --json)."""
    click.echo(msg, err=True)


def report(msg: str) -> None:
    """One error line on stderr; when stderr itself cannot be written (a full device, a closed pipe)
    nothing is said and the exit code alone tells."""
    try:
        click.echo(msg, err=True)
    except (OSError, ValueError):
        silence_stderr()


def run_guarded(func):
    """Turn library exceptions into one stderr line and the contract's exit codes (1: no real linkage,
    2: bad input). ``--debug`` (a parameter named debug) shows the traceback too."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from synth.errors import MpsynthError

        debug = kwargs.get("debug", False)
        try:
            return func(*args, **kwargs)
        except MpsynthError as e:
            if debug:
                traceback.print_exc()
            report(f"mpsynth: {e}")
            sys.exit(e.exit_code)
        except click.exceptions.Exit:
            raise
        except click.ClickException:
            raise
        except KeyboardInterrupt:
            report("mpsynth: interrupted")
            sys.exit(130)
        except Exception as e:  # an internal error: still one line unless --debug
            if environment_error(e) is not None:  # a full disk, a closed stdout or stderr...: not a bug
                silence_stdout()
                report(f"mpsynth: cannot write: {environment_error(e)}")
                sys.exit(2)
            if debug:
                traceback.print_exc()
            report(f"mpsynth: internal error: {type(e).__name__}: {e} (rerun with --debug for a traceback)")
            sys.exit(3)

    return wrapper


def progress(items, label: str, quiet: bool = False):
    """Yield ``items``, showing "label i/n" on stderr while they are worked on, only when stderr is a
    terminal (never in pipes, logs or tests); the line is erased at the end."""
    items = list(items)
    show = not quiet and len(items) > 1 and getattr(sys.stderr, "isatty", lambda: False)()
    for i, x in enumerate(items):
        if show:
            sys.stderr.write(f"\r{label} {i + 1}/{len(items)}...")
            sys.stderr.flush()
        yield x
    if show:
        sys.stderr.write("\r\033[K")
        sys.stderr.flush()


debug_option = click.option("--debug", is_flag=True, help="Show a Python traceback on errors.")
json_option = click.option("--json", "as_json", is_flag=True,
                           help="Print the result as one JSON document on stdout.")


def print_json(doc) -> None:
    if sys.stdout is None:  # closed (>&-): --json asked for output that cannot go anywhere
        raise OSError(errno.EBADF, "standard output is closed")
    click.echo(json.dumps(doc, indent=None, separators=(",", ":"), allow_nan=False))


def _checked(check):
    """A click callback running ``check`` (synth.io.names) on a given value: a usage error, exit 2."""
    def callback(ctx, param, value):
        if value is None:
            return None
        try:
            return check(value, f"--{param.name}")
        except ValueError as e:
            raise click.BadParameter(str(e).split(": ", 1)[-1]) from None
    return callback


def nonempty_path(ctx, param, value):
    """Click callback: an empty path (``-o ''``) is a usage error, never the working directory."""
    if value is not None and not str(value).strip():
        raise click.BadParameter("an empty path; name a directory")
    return value


def synthesis_options(func):
    """Options shared by the synthesis commands (bennett, sixbar, curve)."""
    opts = [
        click.option("-o", "--out", "out", type=click.Path(file_okay=False), callback=nonempty_path,
                     help="Output directory (linkage.urdf, linkage.json, meshes/). Without it nothing is written."),
        click.option("--name", callback=_checked(check_robot_name),
                     help="Robot name in the URDF (default: the pose file's stem)."),
        click.option("--force", is_flag=True, help="Replace OUT even if it holds files not written by mpsynth."),
        click.option("--no-step", is_flag=True,
                     help="Write no linkage.step (it costs more CPU than the rest of the output; "
                          "`mpsynth export OUT --step` adds it later)."),
        *design_option_list("the input's length unit"),
        *drive_option_list(),
        click.option("--package", callback=_checked(check_package),
                     help="Write mesh paths as package://PACKAGE/meshes/... (ROS package name: a-z, 0-9, _)."),
        click.option("--normalize", is_flag=True,
                     help="Accept slightly non-unit quaternions / non-orthonormal rotations and normalize them."),
        click.option("-q", "--quiet", is_flag=True, help="No summary on stderr."),
        json_option,
        debug_option,
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


def design_option_list(unit: str) -> list:
    """The physical-design options (sizes, clearances) of the synthesis commands; lengths in ``unit``."""
    return [
        click.option("--pin-radius", type=float, help=f"Pin (joint) radius in {unit} (default 0.02 x the linkage's size)."),
        click.option("--link-radius", type=float, help=f"Bar (link) radius in {unit} (default 0.015 x the linkage's size)."),
        click.option("--pin-length", type=float,
                     help=f"Hub length along each joint axis in {unit} (default 0.06 x the linkage's size); a joint's "
                          "pin spans the hubs of its two links, so it is at least this long (its length is in "
                          "linkage.json's design.pins)."),
        click.option("--clearance", type=float,
                     help=f"Required gap in {unit} between bodies that share no joint (default: a quarter of the "
                          "bar radius)."),
        click.option("--hole-clearance", type=float,
                     help=f"Radial clearance in {unit} of each bore around its pin (default 0.2 mm, at most a tenth "
                          "of the pin radius)."),
        click.option("--slenderness", type=float,
                     help="Longest bar length (as written: mount to mount through its cranks) over bar "
                          "diameter, at most (default 25): default bars are made thick enough for this."),
        click.option("--pin-fit", type=click.Choice(["press", "clip", "plain"]), default=None,
                     help="Pins with a head sunk into a counterbore: 'press' (default; pressed into the carrier's "
                          "bore), 'clip' (a groove for a retaining clip); 'plain': bare cylinders."),
        click.option("--require-collision-free", is_flag=True,
                     help="Exit 1 (nothing written) unless the design is collision-free."),
    ]


@dataclass(frozen=True)
class Output:
    """Where and how a command reports: OUT directory (None: nothing written), robot name, --force,
    --package, --quiet, --json, --no-step (``step`` False)."""

    dir: str | None = None
    name: str | None = None
    force: bool = False
    package: str | None = None
    quiet: bool = False
    as_json: bool = False
    step: bool = True

    @classmethod
    def of(cls, params: dict) -> "Output":
        return cls(params.get("out"), params.get("name"), params.get("force", False), params.get("package"),
                   params.get("quiet", False), params.get("as_json", False), not params.get("no_step", False))

    @property
    def formats(self) -> tuple:
        """The formats OUT gets (`synth.io.outputs.Outputs.formats`)."""
        from synth.io.outputs import Outputs

        return Outputs.chosen(step=self.step).formats

    @property
    def physical(self) -> bool:
        """Whether the physical design is needed: files are written or linkage.json printed."""
        return bool(self.dir or self.as_json)


def drive_option_list() -> list:
    """--driver and --max-extent (docs/drive.md)."""
    return [
        click.option("--driver", metavar="JOINT",
                     help="The joint the motor turns (a joint on the base, default the first joint of the first "
                          "branch, h1): it sets the task range, the drive report and the URDF limits."),
        click.option("--max-extent", type=float,
                     help="Refuse (exit 1) a linkage whose extent (RMS distance of its joint sites and tool "
                          "positions from their centroid) exceeds this, in the input's length unit (default 100 x "
                          "the spread of the task's positions; 'inf': no limit)."),
    ]


def drive_options(params: dict) -> dict:
    """`synth.solve.SynthesisOptions`' driver and max_extent among click's ``params``."""
    return dict(driver=params.get("driver"), max_extent=params.get("max_extent"))


def design_options(params: dict):
    """The `synth.solve.DesignOptions` of the design options among click's ``params``."""
    from synth.solve import DesignOptions

    return DesignOptions(params.get("pin_radius"), params.get("link_radius"), params.get("pin_length"),
                         params.get("clearance"), params.get("hole_clearance"),
                         params.get("require_collision_free", False), params.get("slenderness"),
                         params.get("pin_fit"))


def default_robot_name(source: str) -> str:
    from pathlib import Path

    stem = Path(source).stem if source not in ("-", "<stdin>") else "linkage"
    return safe_robot_name(stem)


def fmt_len(x: float, scale: float, unit: str) -> str:
    return f"{x / scale:.6g} {unit}"


def print_linkage_summary(linkage, scale: float, unit: str) -> None:
    """Short human summary of a linkage on stderr, lengths in the input unit."""
    import numpy as np

    echo(f"{linkage.kind} linkage: {len(linkage.joints)} revolute joints, {len(linkage.closures)} loop(s)")
    echo(f"  {'joint':6} {'point on axis':>40}  {'direction':>28}  angle law a, b")
    for j in linkage.joints:
        p = j.point / scale + 0.0  # + 0.0: no "-0" in the table
        d = j.direction + 0.0
        echo(f"  {j.name:6} ({p[0]:11.5g} {p[1]:11.5g} {p[2]:11.5g}) {unit:>3}  "
             f"({d[0]:8.5f} {d[1]:8.5f} {d[2]:8.5f})  {j.a + 0.0:.6g}, {j.b:.6g}"
             + (f"  (rate {j.rate}: {j.rate} theta)" if j.rate != 1 else ""))
    echo("  (angle law a, b: the joint angle is theta(t) = 2 atan2(b, t - a) along the motion parameter t;"
         " theta = 0 at the first pose, t = inf)")
    for rec in linkage.poses:
        t = "inf" if np.isinf(rec.t) else f"{rec.t:.6g}"
        angles = " ".join(f"{k}={np.degrees(v):.3f}" for k, v in rec.joint_angles.items())
        echo(f"  pose {rec.name!s:10} t={t:>8}  deg: {angles}")
    c = linkage.checks
    if c:
        echo(f"  self-check: pose error {c['max_pose_translation_error'] / scale:.2e} {unit} + "
             f"{np.degrees(c['max_pose_rotation_error']):.2e} deg, closure error "
             f"{c['max_closure_translation_error'] / scale:.2e} {unit} + "
             f"{np.degrees(c['max_closure_rotation_error']):.2e} deg over {c.get('samples', 0)} samples")
    for w in linkage.info.warnings or ():
        echo(f"  warning: {w}")


def emit(result, output: Output, details=None) -> None:
    """The common ending of a synthesis command with one linkage (a `synth.solve.Result`): write OUT
    (when given) first, so that a failure is the only line on stderr; then the summary on stderr (plus
    ``details()``, a callable that echoes command-specific lines, and the collision sentence), then
    linkage.json on stdout with --json."""
    from synth.io.jsonout import linkage_document
    from synth.io.printreport import print_notes
    from synth.io.step import STEP_FILE
    from synth.io.step import missing_sentence as step_missing
    from synth.io.writer import write_output

    linkage, design, scale, unit = result.linkage, result.design, result.scale, result.unit
    files = None
    if output.dir:
        files = write_output(linkage, output.dir, robot_name=output.name or default_robot_name(result.source),
                             force=output.force, package=output.package, result=design, formats=output.formats)
    if not output.quiet:
        print_linkage_summary(linkage, scale, unit)
        if details is not None:
            details()
        from synth.drive import drive_report

        drive = result.drive if result.drive is not None else drive_report(linkage)
        echo(f"  drive: {drive.sentence()}")
        if result.constraints_met:
            echo(f"  constraints: {result.constraints_met}")
        for w in drive.warnings:
            echo(f"  warning: {w}")
        if design is not None:
            echo(f"  design: {result.sentence()}")
            if design.design.mounting is not None and design.design.mounting.box_sentence():
                echo(f"  mounting: {design.design.mounting.box_sentence(scale, unit)}")
            if design.slenderness is not None and not design.slenderness.met:
                echo(f"  bars: {design.slenderness.sentence(scale, unit)}")
        if files is not None:
            n_pin = sum(1 for f in files if f.name.startswith("pin_") and str(f).endswith(".stl"))
            n_mesh = sum(1 for f in files if str(f).endswith(".stl")) - n_pin
            step = ", linkage.step" if any(f.name == STEP_FILE for f in files) else ""
            echo(f"  wrote {output.dir}/: linkage.urdf, linkage.json{step}, {n_mesh} link meshes and {n_pin} pins in meshes/")
            if design is not None and output.step and (missing := step_missing(files)):
                echo(f"  warning: {missing}")
            for line in print_notes(output.dir):
                echo(f"  print: {line}")
        elif not output.as_json:
            echo("  no files written (give -o OUT to write URDF, STL and JSON)")
    if output.as_json:
        print_json(linkage_document(linkage, *((design.design, design.collision) if design else (None, None)),
                                    result.drive, design.slenderness if design else None))


def write_ranked(result, output: Output) -> None:
    """Write the ranked solutions of a Result (``--top``) as OUT/<id>/ with OUT/index.json."""
    from synth.io.writer import write_solutions

    base = output.name or default_robot_name(result.source)
    write_solutions(output.dir, [(s.id, s.linkage, f"{base}_{s.id.replace('-', '_')}", s.design)
                                 for s in result.solutions], result.index, force=output.force, package=output.package,
                    formats=output.formats)


def finish_ranked(result, output: Output) -> None:
    """The ending of a ``--top`` run after its ranking table: OUT/<id>/ and OUT/index.json written
    (`write_ranked`) and said, or that nothing was written; the index document on stdout with --json."""
    ids = [s.id for s in result.solutions]
    if output.dir:
        write_ranked(result, output)
        if not output.quiet:
            echo(f"  wrote {output.dir}/: index.json and {len(ids)} solution directories ({', '.join(ids)})")
    elif not output.quiet and not output.as_json:
        echo("  no files written (give -o OUT to write every design's URDF, STL and JSON)")
    if output.as_json:
        from synth.io.jsonout import plain

        print_json(plain(result.index))
