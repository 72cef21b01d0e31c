"""`mpsynth design TASK [-o OUT]`: the interactive designer, a local web page (the extra mpsynth[design])."""
from __future__ import annotations

import click

from .common import debug_option, echo, nonempty_path, run_guarded


@click.command(epilog="""\b
Example:
  mpsynth design fixtures/bennett_mm_deg.yaml -o out_bennett    # opens the page in the browser""")
@click.argument("task", metavar="TASK", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out", type=click.Path(file_okay=False), callback=nonempty_path,
              help="Output directory of the page's \"write output\" (as mpsynth bennett|sixbar|fourbar -o OUT).")
@click.option("--force", is_flag=True, help="Let \"write output\" replace OUT even if it holds other files.")
@click.option("--port", type=click.IntRange(0, 65535), default=8765, show_default=True,
              help="TCP port of the page (0: a free one).")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Interface to listen on; anything but 127.0.0.1 lets other machines edit your files.")
@click.option("--kind", type=click.Choice(["bennett", "sixbar", "fourbar"]),
              help="The linkage to start with (default: by the task: 4 poses or 7 points a 6R, coplanar poses a "
                   "four-bar, else Bennett); the page switches it.")
@click.option("--normalize", is_flag=True,
              help="Accept slightly non-unit quaternions / non-orthonormal rotations and normalize them.")
@click.option("--no-browser", is_flag=True, help="Do not open the page in a browser; print its URL only.")
@debug_option
@run_guarded
def design(task, out, force, port, host, kind, normalize, no_browser, debug):
    """Open TASK (a pose or point file) in an interactive designer in the browser: drag the poses or edit
    their numbers, and the linkage is re-synthesized and drawn at once with its motion, per-pose errors,
    drive report and collision-free design; undo, save the task, write OUT. Needs the extra
    mpsynth[design] (starlette, uvicorn)."""
    from synth.errors import InputError

    try:
        from synth.tools.designer.server import Server
        import uvicorn  # noqa: F401  (the extra)
    except ImportError as e:
        raise InputError(f"mpsynth design needs the extra: pip install 'mpsynth[design]' ({e.name} is missing)") from None
    from synth.tools.designer.session import Session

    def ready(url):
        echo(f"mpsynth design: {url} (^C to stop)")
        if not no_browser:
            import webbrowser

            webbrowser.open(url)

    Server(Session(task, kind=kind, normalize=normalize), host=host, port=port, out=out, force=force).serve(ready)
