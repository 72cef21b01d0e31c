"""Helpers shared by the CLI commands: error reporting with exit codes, options, summaries."""
from __future__ import annotations

import errno
import functools
import json
import sys
import traceback

import click

from synth.io.names import check_package, check_robot_name, safe_robot_name
from synth.io.streams import environment_error, silence_stdout


def echo(msg: str = "") -> None:
    """Human-readable output goes to stderr (stdout is reserved for --json)."""
    click.echo(msg, err=True)


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
            click.echo(f"mpsynth: {e}", err=True)
            sys.exit(e.exit_code)
        except click.exceptions.Exit:
            raise
        except click.ClickException:
            raise
        except KeyboardInterrupt:
            click.echo("mpsynth: interrupted", err=True)
            sys.exit(130)
        except Exception as e:  # an internal error: still one line unless --debug
            if environment_error(e) is not None:  # a full disk, a closed stdout...: not a bug
                silence_stdout()
                click.echo(f"mpsynth: cannot write: {environment_error(e)}", err=True)
                sys.exit(2)
            if debug:
                traceback.print_exc()
            click.echo(f"mpsynth: internal error: {type(e).__name__}: {e} (rerun with --debug for a traceback)",
                       err=True)
            sys.exit(3)

    return wrapper


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


def synthesis_options(func):
    """Options shared by the synthesis commands (bennett, sixbar, curve)."""
    opts = [
        click.option("-o", "--out", "out", type=click.Path(file_okay=False),
                     help="Output directory (linkage.urdf, linkage.json, meshes/). Without it nothing is written."),
        click.option("--name", callback=_checked(check_robot_name),
                     help="Robot name in the URDF (default: the pose file's stem)."),
        click.option("--force", is_flag=True, help="Replace OUT even if it holds files not written by mpsynth."),
        click.option("--pin-radius", type=float, help="Pin (joint) radius in the input's length unit."),
        click.option("--link-radius", type=float, help="Bar (link) radius in the input's length unit."),
        click.option("--pin-length", type=float, help="Pin length in the input's length unit."),
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


def mesh_sizes(kwargs, length_scale: float) -> dict:
    """Mesh size options converted from the input's length unit to metres (validated positive)."""
    from synth.errors import InputError

    out = {}
    for key in ("pin_radius", "link_radius", "pin_length"):
        v = kwargs.get(key)
        if v is not None:
            if not (v > 0 and v < 1e9):
                raise InputError(f"--{key.replace('_', '-')} must be a positive length, got {v}")
            out[key] = v * length_scale
    return out


MESH_SIZE_RANGE = (1e-6, 1e4)  # explicit mesh sizes, relative to the linkage's size (extent)


def check_mesh_sizes(sizes: dict, extent: float, scale: float, unit: str) -> None:
    """Refuse explicit mesh sizes (metres) that are absurd for a linkage of size ``extent`` (metres):
    outside MESH_SIZE_RANGE times the extent the meshes cannot be built. Messages use the input unit."""
    from synth.errors import InputError

    lo, hi = MESH_SIZE_RANGE
    for key, v in sizes.items():
        if not (lo * extent <= v <= hi * extent):
            raise InputError(
                f"--{key.replace('_', '-')} {v / scale:.6g} {unit} is out of range for a linkage of size "
                f"{extent / scale:.3g} {unit}: give a value between {lo * extent / scale:.3g} and "
                f"{hi * extent / scale:.3g} {unit}")


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
        p = j.point / scale
        echo(f"  {j.name:6} ({p[0]:11.5g} {p[1]:11.5g} {p[2]:11.5g}) {unit:>3}  "
             f"({j.direction[0]:8.5f} {j.direction[1]:8.5f} {j.direction[2]:8.5f})  {j.a:.6g}, {j.b:.6g}")
    for rec in linkage.poses:
        t = "inf" if np.isinf(rec.t) else f"{rec.t:.6g}"
        angles = " ".join(f"{k}={np.degrees(v):.3f}" for k, v in rec.joint_angles.items())
        echo(f"  pose {rec.name!s:10} t={t:>8}  deg: {angles}")
    c = linkage.checks
    if c:
        echo(f"  self-check: pose error {c['max_pose_translation_error'] / scale:.2e} {unit} + "
             f"{c['max_pose_rotation_error']:.2e} rad, closure error {c['max_closure_translation_error'] / scale:.2e} "
             f"{unit} + {c['max_closure_rotation_error']:.2e} rad over {c.get('samples', 0)} samples")
    for w in linkage.info.get("warnings", []):
        echo(f"  warning: {w}")


def emit_linkage(linkage, *, source, scale, unit, out, name, force, package, sizes, quiet, as_json,
                 details=None):
    """The common ending of a synthesis command: write OUT (when given) first, so that a failure to
    write is the only line on stderr; then the summary on stderr (plus ``details()``, a callable that
    echoes command-specific lines), then linkage.json on stdout with --json."""
    from synth.io.jsonout import linkage_document
    from synth.io.writer import write_output

    files = None
    if out:
        check_mesh_sizes(sizes, linkage.extent(), scale, unit)
        files = write_output(linkage, out, robot_name=name or default_robot_name(source), force=force,
                             package=package, **sizes)
    if not quiet:
        print_linkage_summary(linkage, scale, unit)
        if details is not None:
            details()
        if files is not None:
            n_mesh = sum(1 for f in files if str(f).endswith(".stl"))
            echo(f"  wrote {out}/: linkage.urdf, linkage.json, {n_mesh} meshes in meshes/")
        elif not as_json:
            echo("  no files written (give -o OUT to write URDF, STL and JSON)")
    if as_json:
        print_json(linkage_document(linkage))
