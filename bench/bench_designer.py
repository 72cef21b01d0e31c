"""Update latency of `mpsynth design` (issue 34): a pose moved -> the new linkage drawn.

    .venv/bin/python bench/bench_designer.py [--moves N] [--no-browser]

Server side: `Session.move` (synthesis through `synth.solve`, per-pose errors, the stick figure, the whole
state) plus its JSON encoding, for fixtures/bennett_mm_deg.yaml (Bennett) and fixtures/sixbar_example.yaml
(6R, the five ranked candidates), N small moves of one pose; with the design search running behind
(cancelled by each move, as in use) and without it. In the browser (Debian's chromium through playwright,
when present): the page's own figure, from the change sent to its state drawn on the canvas, for N mouse
drag steps of a pose handle; server side also N small turns of the pose (alt-drag). Targets: Bennett <= 100 ms, 6R <= 300 ms (median and 90th percentile shown).

Baseline, timed in the same run: the route before the designer, one cold `mpsynth bennett|sixbar TASK`
process per change (without -o; no rendering); the ratio baseline / designer says what the live page buys.
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from synth.tools.designer.session import Session  # noqa: E402

CASES = [("Bennett", "bennett_mm_deg.yaml", "bennett", 1, 100.0), ("6R", "sixbar_example.yaml", "sixbar", 2, 300.0)]
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--disable-sync"]


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


def server_side(task: Path, item: int, moves: int, design: bool, turn: bool = False) -> list[float]:
    """Milliseconds per change: ``moves`` small moves of item ``item`` (``turn``: turns by +-0.5 degree
    about a fixed axis, as an alt-drag of its handle sends)."""
    s = Session(task, background_design=design)
    p0 = [row[3] for row in s.state()["poses"][item][:3]]
    size = s.state()["scene"]["size"]
    out = []
    for k in range(moves):
        pos = [p0[0] + 0.002 * size * (k % 7), p0[1] - 0.001 * size * (k % 5), p0[2]]
        t = time.perf_counter()
        st = s.turn(item, [0.3, -0.5, 0.8], 0.5 if k % 4 < 2 else -0.5) if turn else s.move(item, pos)
        json.dumps(st)
        out.append((time.perf_counter() - t) * 1e3)
        assert st["problem"] is None, st["problem"]
    s.close()
    return out


def browser_side(task: Path, item: int, moves: int) -> list[float] | None:
    try:
        from playwright.sync_api import sync_playwright
        from synth.tools.designer.server import Server
    except ImportError:
        return None
    if not Path("/usr/bin/chromium").exists():
        return None
    srv = Server(Session(task), port=0)
    url = srv.start()
    try:
        with sync_playwright() as p:
            b = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS)
            page = b.new_page(viewport={"width": 1200, "height": 760})
            page.goto(url)
            page.wait_for_function("document.body.dataset.revision === '1'")
            for k in range(moves):
                x, y = page.evaluate(f"window.mpsynthDesigner.handleXY({item})")
                rev = int(page.evaluate("document.body.dataset.revision"))
                page.mouse.move(x, y)
                page.mouse.down()
                page.mouse.move(x + 2 + k % 3, y + 1)
                page.mouse.up()
                page.wait_for_function(f"window.mpsynthDesigner.idle() && +document.body.dataset.revision > {rev}")
            out = page.evaluate("window.mpsynthDesigner.timings()")
            b.close()
    finally:
        srv.stop()
    return out


def cold_cli(task: Path, command: str, runs: int) -> float:
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        r = subprocess.run([str(Path(sys.executable).parent / "mpsynth"), command, str(task), "-q"], capture_output=True)
        times.append((time.perf_counter() - t) * 1e3)
        assert r.returncode == 0, r.stderr
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=30)
    ap.add_argument("--no-browser", action="store_true")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    print("| task | where | median ms | p90 ms | max ms | target ms | target / p90 | cold CLI ms | CLI / median |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, fixture, command, item, target in CASES:
        task = tmp / fixture
        shutil.copy(ROOT / "fixtures" / fixture, task)
        cli = cold_cli(task, command, 3)
        rows = [("server, design search behind", server_side(task, item, a.moves, True)),
                ("server, no design search", server_side(task, item, a.moves, False)),
                ("server, pose turned, no design search", server_side(task, item, a.moves, False, turn=True))]
        if not a.no_browser:
            br = browser_side(task, item, a.moves)
            rows.append(("browser (drag -> drawn)", br) if br else ("browser: chromium/playwright absent", None))
        for where, xs in rows:
            if not xs:
                print(f"| {label} | {where} | - | - | - | {target:.0f} | - | {cli:.0f} | - |")
                continue
            med, p90 = statistics.median(xs), pct(xs, 0.9)
            print(f"| {label} | {where} | {med:.1f} | {p90:.1f} | {max(xs):.1f} | {target:.0f} | {target / p90:.2f} "
                  f"| {cli:.0f} | {cli / med:.0f} |")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
