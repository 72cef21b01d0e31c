"""The designer's local web server: the page and the session's JSON API, on 127.0.0.1 unless told.

A small ASGI application (starlette, served by uvicorn: the optional extra ``mpsynth[design]``, imported
only by this module). Every route calls one `Session` method; an InputError or SynthesisError is a 400
answer ``{"error": message}`` that the page shows in words.

    GET  /               the page (`synth.tools.designer.page`)
    GET  /api/state      Session.state()
    POST /api/edit       {"path": [...], "value": v}       POST /api/move  {"item": i, "position": [x, y, z]}
    POST /api/turn       {"item": i, "axis": [x, y, z], "degrees": a}
    POST /api/kind       {"kind": "bennett"|...}           POST /api/pick  {"pick": k}
    POST /api/add        {"item": i or null, "key": k}     POST /api/remove {"item": i or null, "key": k}
    POST /api/undo       {}                                POST /api/save  {} (the task file itself)
    POST /api/write      {} (the command's -o OUT and --force: a page names no path, so a client reached
                         through --host can write nothing else)
"""
from __future__ import annotations

import threading
import time

from synth.errors import InputError, MpsynthError
from synth.tools.designer.page import page_html

LOCALHOST = "127.0.0.1"


def make_app(session, out: str | None = None, force: bool = False):
    """The ASGI application serving ``session``; ``out``: the default OUT of "write output"."""
    from starlette.applications import Starlette
    from starlette.concurrency import run_in_threadpool
    from starlette.responses import HTMLResponse, JSONResponse, Response
    from starlette.routing import Route

    html = page_html()

    async def index(request):
        return HTMLResponse(html, headers={"Cache-Control": "no-store"})

    def write():
        if not out:
            raise InputError("no output directory: start mpsynth design with -o OUT")
        return session.write_output(out, force)

    calls = {
        "state": lambda b: session.state(),
        "edit": lambda b: session.edit(b["path"], b["value"]),
        "move": lambda b: session.move(b["item"], b["position"]),
        "turn": lambda b: session.turn(b["item"], b["axis"], b["degrees"]),
        "kind": lambda b: session.set_kind(b["kind"]),
        "add": lambda b: session.add_field(b.get("item"), b["key"]),
        "remove": lambda b: session.remove_field(b.get("item"), b["key"]),
        "pick": lambda b: session.set_pick(b["pick"]),
        "undo": lambda b: session.undo(),
        "save": lambda b: session.save(),
        "write": lambda b: write(),
    }

    async def api(request):
        name = request.path_params["name"]
        if name not in calls or (request.method == "GET") != (name == "state"):
            return JSONResponse({"error": f"no such call: {request.method} {name}"}, status_code=404)
        try:
            body = await request.json() if request.method == "POST" else {}
        except ValueError:
            return JSONResponse({"error": "the request body is not JSON"}, status_code=400)
        try:
            return JSONResponse(await run_in_threadpool(calls[name], body if isinstance(body, dict) else {}))
        except KeyError as e:
            return JSONResponse({"error": f"the request lacks {e}"}, status_code=400)
        except MpsynthError as e:
            return JSONResponse({"error": str(e)}, status_code=400)

    async def no_icon(request):
        return Response(status_code=204)

    return Starlette(routes=[Route("/", index), Route("/favicon.ico", no_icon),
                             Route("/api/{name}", api, methods=["GET", "POST"])])


class Server:
    """The uvicorn server of a session, run on this thread (`serve`) or on a background one (`start`);
    ``port`` 0: a free one (``url`` tells which, once started)."""

    def __init__(self, session, host: str = LOCALHOST, port: int = 8765, out: str | None = None,
                 force: bool = False):
        import uvicorn

        self.session = session
        config = uvicorn.Config(make_app(session, out, force), host=host, port=port, log_level="warning",
                                access_log=False, lifespan="off")
        self.server = uvicorn.Server(config)
        self.host = host
        self.thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        sock = self.server.servers[0].sockets[0]
        port = sock.getsockname()[1]
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{port}/"

    def serve(self, ready=None) -> None:
        """Serve until interrupted (^C: a normal end) or `stop`; ``ready(url)`` is called (on
        another thread) once the server listens. InputError when it cannot listen."""
        if ready is not None:
            def watch():
                while not self.server.started and not self.server.should_exit:
                    time.sleep(0.02)
                if self.server.started:
                    ready(self.url)

            threading.Thread(target=watch, name="mpsynth-design-ready", daemon=True).start()
        try:
            self.server.run()
        except KeyboardInterrupt:  # ^C, the way to stop the server (uvicorn raises it again once shut down)
            pass
        except SystemExit:  # uvicorn's answer to a port in use or an address it cannot bind
            self.server.should_exit = True
            raise InputError(f"cannot listen on {self.host}:{self.server.config.port} (in use, or not an "
                             "address of this machine); choose another --port or --host") from None
        finally:
            self.session.close()

    def start(self, timeout: float = 30.0) -> str:
        """Serve on a background thread; returns the URL once listening."""
        self.thread = threading.Thread(target=self.serve, name="mpsynth-design-server", daemon=True)
        self.thread.start()
        deadline = time.monotonic() + timeout
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("the designer's server did not start")
            time.sleep(0.01)
        return self.url

    def stop(self) -> None:
        self.server.should_exit = True
        if self.thread is not None:
            self.thread.join(10)
