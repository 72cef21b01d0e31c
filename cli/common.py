"""Helpers shared by the CLI commands: error reporting with exit codes, options, summaries."""
from __future__ import annotations

import errno
import functools
import json
import sys
import traceback

import click

from synth.io.names import check_package, check_robot_name, safe_robot_name
from .streams import environment_error, silence_stderr, silence_stdout


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


def synthesis_options(func):
    """Options shared by the synthesis commands (bennett, sixbar, curve)."""
    opts = [
        click.option("-o", "--out", "out", type=click.Path(file_okay=False),
                     help="Output directory (linkage.urdf, linkage.json, meshes/). Without it nothing is written."),
        click.option("--name", callback=_checked(check_robot_name),
                     help="Robot name in the URDF (default: the pose file's stem)."),
        click.option("--force", is_flag=True, help="Replace OUT even if it holds files not written by mpsynth."),
        *design_option_list("the input's length unit"),
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
        click.option("--require-collision-free", is_flag=True,
                     help="Exit 1 (nothing written) unless the design is collision-free."),
    ]


def mesh_sizes(kwargs, length_scale: float) -> dict:
    """Mesh size and clearance options converted from the input's length unit to metres (sizes validated
    positive, clearances non-negative)."""
    from synth.errors import InputError

    out = {}
    for key in ("pin_radius", "link_radius", "pin_length", "clearance", "hole_clearance"):
        v = kwargs.get(key)
        if v is not None:
            zero_ok = key in ("clearance", "hole_clearance")
            if not ((v > 0 or (zero_ok and v == 0)) and v < 1e9):
                raise InputError(f"--{key.replace('_', '-')} must be a {'non-negative' if zero_ok else 'positive'} "
                                 f"length, got {v}")
            out[key] = v * length_scale
    return out


MESH_SIZE_RANGE = (1e-6, 10.0)  # explicit mesh sizes, relative to the linkage's size (extent): a part
# ten times the mechanism's size is a typo, not a design (e.g. --pin-length 100000 gave a 132 m mesh)


def check_mesh_sizes(sizes: dict, extent: float, scale: float, unit: str) -> None:
    """Refuse explicit mesh sizes (metres) that are absurd for a linkage of size ``extent`` (metres):
    outside MESH_SIZE_RANGE times the extent the meshes cannot be built. Messages use the input unit."""
    from synth.errors import InputError

    lo, hi = MESH_SIZE_RANGE
    for key, v in sizes.items():
        if key in ("clearance", "hole_clearance"):
            if v > hi * extent:
                raise InputError(f"--{key.replace('_', '-')} {v / scale:.6g} {unit} is out of range for a linkage "
                                 f"of size {extent / scale:.3g} {unit}")
            continue
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
    for w in linkage.info.get("warnings", []):
        echo(f"  warning: {w}")


def collision_sentence(report, scale: float, unit: str) -> str:
    """What the design achieves, in words (lengths in the input unit, driver angles in degrees)."""
    import math

    def length(x):
        return f"{x / scale:.3g} {unit}"

    lo, hi = (math.degrees(v) for v in report.driver_range)
    if report.free:
        where = ("over the full cycle" if report.range == "full" else
                 f"over the task range ({report.driver} from {lo:.1f} to {hi:.1f} deg)")
        thin = report.thinned
        if thin:
            clear = " / ".join(" and ".join(p) for p in thin["default_pairs"][:2]) or "colliding bodies"
            where += (f" (bars thinned to radius {length(thin['bar_radius'])}, pins to {length(thin['pin_radius'])}: "
                      f"{thin['scale']:g} x the defaults {length(thin['default_bar_radius'])}, "
                      f"{length(thin['default_pin_radius'])}, to clear {clear})")
        return f"collision-free {where}, clearance {length(report.clearance)}, min gap {length(report.min_distance)}"
    if report.pairs:
        p = report.pairs[0]
        a, b = p["bodies"]
        d = float(p["min_distance"])
        what = "collide" if d < 0 else f"come within {length(d)} (clearance {length(report.clearance)})"
        at = ""
        if p.get("driver_angles"):
            at = (f" at {report.driver} from {math.degrees(p['driver_angles'][0]):.1f} to "
                  f"{math.degrees(p['driver_angles'][1]):.1f} deg")
        more = f" (and {len(report.pairs) - 1} more pair(s))" if len(report.pairs) > 1 else ""
        return f"NOT collision-free: {a} and {b} {what}{at}{more}" + (f"; {report.message}" if report.message else "")
    return f"NOT collision-free: {report.message or 'no collision-free design was found'}"


def design_result(linkage, sizes: dict, *, scale: float, unit: str, source: str, require_free: bool, **search):
    """The physical design of ``linkage`` (`synth.design.choose.design_for`) with the sizes in metres;
    SynthesisError (exit 1) with the sentence when ``require_free`` and it is not collision-free;
    ``search``: further arguments of the design search (ranges, full_work, work)."""
    from synth.design.choose import design_for

    check_mesh_sizes(sizes, linkage.extent(), scale, unit)
    result = design_for(linkage, **sizes, **search)
    if require_free:
        require_collision_free(result, source=source, scale=scale, unit=unit)
    return result


def choose_buildable(candidates, ps, sizes: dict, *, limit: int, work: float, what: str):
    """Design the best-scored ``candidates`` (best first) and keep the collision-free one first (full cycle,
    then task range; `synth.design.search.rank_buildable`), then the score. Returns (linkage, DesignResult);
    ``linkage.info["design_choice"]`` says which candidate won; ``what``: the candidates' name in it."""
    from synth.design.search import rank_buildable

    candidates = list(candidates)
    ranked = rank_buildable(candidates, lambda lk, ranges, full_work, spent: design_result(
        lk, sizes, scale=ps.length_scale, unit=ps.length_unit, source=ps.source, require_free=False,
        ranges=ranges, full_work=full_work, work=spent), limit=limit, work=work)
    linkage, result = ranked[0]
    k = next(i for i, c in enumerate(candidates) if c is linkage)
    linkage.info["design_choice"] = (f"candidate {k + 1} of the {min(len(candidates), limit)} best-scored {what}: "
                                     "collision-free first (full cycle, then task range), then the score")
    return linkage, result


def design_solutions(linkages, ps, sizes: dict, *, quiet: bool, require_free: bool, what: str):
    """The physical design of every ranked solution (`--top`): designed in turn (progress on a terminal),
    reordered collision-free first (full cycle, then task range), then the given order; with
    ``require_free`` only the collision-free ones (SynthesisError naming the best when there is none;
    ``what`` names the designs in it). Returns (linkages, DesignResults)."""
    from synth.design.search import collision_rank
    from synth.errors import SynthesisError

    results = [design_result(lk, sizes, scale=ps.length_scale, unit=ps.length_unit, source=ps.source,
                             require_free=False)
               for lk in progress(linkages, "collision-free design search: design", quiet)]
    order = sorted(range(len(linkages)), key=lambda i: (collision_rank(results[i].collision), i))
    pairs = [(linkages[i], results[i]) for i in order]
    if require_free:
        free = [(lk, r) for lk, r in pairs if r.collision.free]
        if not free:
            raise SynthesisError(f"{ps.source}: none of the {len(pairs)} best {what} is collision-free; the best: "
                                 f"{collision_sentence(pairs[0][1].collision, ps.length_scale, ps.length_unit)}")
        pairs = free
    return [lk for lk, _ in pairs], [r for _, r in pairs]


def add_collisions(solutions: list, results, ps) -> None:
    """index.json: each solution's collision report and its sentence in the input's length unit."""
    for sol, r in zip(solutions, results):
        sol["collision"] = r.collision.to_dict()
        sol["design_summary"] = collision_sentence(r.collision, ps.length_scale, ps.length_unit)


def require_collision_free(result, *, source: str, scale: float, unit: str) -> None:
    """SynthesisError (exit 1) with the collision sentence unless the design is collision-free."""
    from synth.errors import SynthesisError

    if not result.collision.free:
        raise SynthesisError(f"{source}: {collision_sentence(result.collision, scale, unit)}")


def emit_linkage(linkage, *, source, scale, unit, out, name, force, package, sizes, quiet, as_json,
                 details=None, require_free=False, result=None):
    """The common ending of a synthesis command: design the physical linkage (when files are written,
    JSON printed or a collision-free design required) and write OUT (when given) first, so that a
    failure is the only line on stderr; then the summary on stderr (plus ``details()``, a callable that
    echoes command-specific lines, and the collision sentence), then linkage.json on stdout with --json.
    ``result``: a design already made (`synth.design.search.DesignResult`), else one is made here."""
    from synth.io.jsonout import linkage_document
    from synth.io.writer import write_output

    files = None
    if result is None and (out or as_json or require_free):
        result = design_result(linkage, sizes, scale=scale, unit=unit, source=source, require_free=require_free)
    elif result is not None and require_free:
        require_collision_free(result, source=source, scale=scale, unit=unit)
    if out:
        files = write_output(linkage, out, robot_name=name or default_robot_name(source), force=force,
                             package=package, result=result)
    if not quiet:
        print_linkage_summary(linkage, scale, unit)
        if details is not None:
            details()
        if result is not None:
            echo(f"  design: {collision_sentence(result.collision, scale, unit)}")
        if files is not None:
            n_pin = sum(1 for f in files if f.name.startswith("pin_") and str(f).endswith(".stl"))
            n_mesh = sum(1 for f in files if str(f).endswith(".stl")) - n_pin
            echo(f"  wrote {out}/: linkage.urdf, linkage.json, {n_mesh} link meshes and {n_pin} pins in meshes/")
        elif not as_json:
            echo("  no files written (give -o OUT to write URDF, STL and JSON)")
    if as_json:
        print_json(linkage_document(linkage, *((result.design, result.collision) if result else ())))
