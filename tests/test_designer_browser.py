"""mpsynth design in a real browser: Debian's chromium driven by playwright (no browser download). The
tests start the server on a free port, load the page, move a pose through the client (a mouse drag
and a table edit), check that the linkage and the errors were updated, save the task and compare it
with the expected YAML. They skip when chromium, playwright or the extra mpsynth[design] is absent."""
from __future__ import annotations

import difflib
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("uvicorn")
pytest.importorskip("starlette")
sync_api = pytest.importorskip("playwright.sync_api")

CHROMIUM = os.environ.get("MPSYNTH_CHROMIUM", "/usr/bin/chromium")
if not Path(CHROMIUM).exists():
    pytest.skip(f"no chromium at {CHROMIUM} (apt-get install chromium)", allow_module_level=True)

from synth.tools.designer.server import Server  # noqa: E402
from synth.tools.designer.session import Session  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--disable-sync"]


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


@pytest.fixture
def open_task(browser, tmp_path):
    servers, pages = [], []

    def open_(fixture: str, background_design: bool = False):
        task = tmp_path / Path(fixture).name
        shutil.copy(ROOT / "fixtures" / fixture, task)
        srv = Server(Session(task, background_design=background_design), port=0, out=str(tmp_path / "out"))
        url = srv.start()
        page = browser.new_page(viewport={"width": 1200, "height": 760})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(url)
        page.wait_for_function("document.body.dataset.revision === '1'")
        servers.append(srv)
        pages.append(page)
        return task, page, errors

    yield open_
    for p in pages:
        p.close()
    for s in servers:
        s.stop()


def settled(page, after: int) -> dict:
    """The page's state once a revision later than ``after`` is shown and no request is waiting."""
    page.wait_for_function(f"window.mpsynthDesigner.idle() && +document.body.dataset.revision > {after}")
    return page.evaluate("window.mpsynthDesigner.state()")


def test_dragging_a_pose_resynthesizes_and_saves_the_moved_numbers(open_task):
    task, page, errors = open_task("bennett_mm_deg.yaml")
    original = task.read_text()
    before = page.evaluate("window.mpsynthDesigner.state()")
    x, y = page.evaluate("window.mpsynthDesigner.handleXY(1)")
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + 40, y + 15, steps=4)
    page.mouse.up()
    after = settled(page, before["revision"])
    moved = [c["value"] for c in after["items"][0]["rows"][1]["cells"] if c["label"].startswith("position")]
    assert moved != [90, 180, 180]
    assert after["scene"]["links"][0]["points"] != before["scene"]["links"][0]["points"]  # the linkage was redrawn
    assert page.locator("#errors tbody tr.hit").count() == 3  # exact through all three poses
    assert "bennett linkage: 4 joints" in page.text_content("#status")
    page.click("#save")
    page.wait_for_function("document.getElementById('message').textContent.startsWith('saved')")
    from synth.tools.designer.document import format_number

    expected = original.replace("position: [90, 180, 180]",
                                "position: [" + ", ".join(format_number(v) for v in moved) + "]")
    assert task.read_text() == expected, "".join(difflib.unified_diff(expected.splitlines(True),
                                                                      task.read_text().splitlines(True)))
    assert errors == []


def test_a_table_edit_saves_the_expected_yaml(open_task):
    task, page, errors = open_task("bennett_mm_deg.yaml")
    original = task.read_text()
    field = page.locator("""input[data-path='["poses",2,"position",0]']""")
    field.fill("-181.5")
    field.press("Enter")
    field.blur()
    st = settled(page, 1)
    assert st["poses"][2][0][3] == pytest.approx(-181.5)
    page.click("#save")
    page.wait_for_function("document.getElementById('message').textContent.startsWith('saved')")
    assert task.read_text() == original.replace("position: [-180, -160, -40]", "position: [-181.5, -160, -40]")
    page.click("button[data-field='add:task:tolerance']")  # a task tolerance: the table gains its numbers
    st = settled(page, st["revision"])
    assert page.locator("""input[data-path='["tolerance","position"]']""").count() == 1
    assert st["problem"] is None and page.locator("#errors tbody tr.hit").count() == 3
    assert errors == []


def test_a_bad_position_is_shown_in_words_and_undo_recovers(open_task):
    task, page, errors = open_task("bennett_mm_deg.yaml")
    rev = 1
    for key, vals in (("position", [0, 0, 200]), ("rpy", [0, 0, 0])):  # pose 1 onto pose 0
        for k, v in enumerate(vals):
            field = page.locator(f"""input[data-path='["poses",1,"{key}",{k}]']""")
            field.fill(str(v))
            field.press("Enter")
            field.blur()
            rev = settled(page, rev)["revision"]
    assert page.get_attribute("#status", "class") == "bad"
    assert page.text_content("#status").startswith("No linkage: ")
    for _ in range(6):
        page.click("#undo")
        rev = settled(page, rev)["revision"]
    assert page.get_attribute("#status", "class") == "ok"
    assert errors == []


def test_sixbar_candidates_and_the_design_behind(open_task):
    task, page, errors = open_task("sixbar_example.yaml", background_design=True)
    assert page.locator("#pick option").count() == 5
    page.select_option("#pick", "2")
    st = settled(page, 1)
    assert st["pick"] == 2 and "6 joints" in page.text_content("#status")
    page.wait_for_function("document.getElementById('design').dataset.stage === 'done'", timeout=120_000)
    assert page.text_content("#design").count("design: ") == 1
    assert errors == []


def test_the_camera_orbits_zooms_and_resets(open_task):
    task, page, errors = open_task("bennett_mm_deg.yaml")
    cam0 = page.evaluate("window.mpsynthDesigner.camera()")
    box = page.locator("#view").bounding_box()
    x, y = box["x"] + 60, box["y"] + 60  # the background, away from the handles
    page.mouse.move(x, y)
    page.mouse.down(button="right")
    page.mouse.move(x + 80, y + 30, steps=4)
    page.mouse.up(button="right")
    cam1 = page.evaluate("window.mpsynthDesigner.camera()")
    assert cam1["yaw"] == pytest.approx(cam0["yaw"] - 0.8) and cam1["pitch"] == pytest.approx(cam0["pitch"] + 0.3)
    h0 = page.evaluate("window.mpsynthDesigner.handleXY(2)")
    page.mouse.wheel(0, -200)
    assert page.evaluate("window.mpsynthDesigner.camera()")["zoom"] > cam0["zoom"]
    assert page.evaluate("window.mpsynthDesigner.handleXY(2)") != h0
    page.click("#reset")
    cam2 = page.evaluate("window.mpsynthDesigner.camera()")
    assert cam2 == cam0
    assert page.evaluate("window.mpsynthDesigner.state()")["revision"] == 1  # the view moved, the task did not
    assert errors == []


def test_alt_drag_turns_a_pose_and_the_wheel_moves_it_along_the_depth(open_task):
    task, page, errors = open_task("bennett_mm_deg.yaml")
    x, y = page.evaluate("window.mpsynthDesigner.handleXY(0)")
    page.keyboard.down("Alt")
    page.mouse.move(x + 30, y)
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + 30, y, steps=2)
    page.mouse.move(x, y - 30, steps=4)  # a quarter turn counter-clockwise round the handle
    page.mouse.up()
    page.keyboard.up("Alt")
    st = settled(page, 1)
    rpy = [c["value"] for c in st["items"][0]["rows"][0]["cells"] if c["label"].startswith("rpy")]
    assert rpy != [0, 0, 0] and st["undo"] >= 1
    f = page.evaluate("(() => { const c = window.mpsynthDesigner.camera(), cp = Math.cos(c.pitch);"
                      " return [cp * Math.cos(c.yaw), cp * Math.sin(c.yaw), Math.sin(c.pitch)]; })()")
    R = np.array(st["poses"][0])[:3, :3]  # turned about the view axis: that axis is kept
    assert np.allclose(R @ np.array(f), f, atol=1e-4)
    assert np.degrees(np.arccos((np.trace(R) - 1) / 2)) == pytest.approx(90, abs=8)
    rev = st["revision"]
    x, y = page.evaluate("window.mpsynthDesigner.handleXY(2)")
    p0 = np.array(st["poses"][2])[:3, 3]
    page.mouse.move(x, y)
    page.mouse.wheel(0, -100)
    st = settled(page, rev)
    d = np.array(st["poses"][2])[:3, 3] - p0
    assert np.linalg.norm(d) > 0 and np.allclose(np.cross(d, f), 0, atol=1e-3 * np.linalg.norm(d))
    while st["undo"]:
        page.click("#undo")
        st = settled(page, st["revision"])
    assert [c["value"] for c in st["items"][0]["rows"][0]["cells"] if c["label"].startswith("rpy")] == [0, 0, 0]
    assert errors == []


def test_a_kind_that_cannot_apply_is_greyed_out_with_its_reason(open_task):
    task, page, errors = open_task("bennett_mm_deg.yaml")
    four = page.locator("#kind option[value='fourbar']")
    assert four.is_disabled() and "coplanar" in four.get_attribute("title")
    assert not page.locator("#kind option[value='sixbar']").is_disabled()
    assert errors == []


def test_write_output_writes_the_picked_candidate_coloured_by_clearance(open_task):
    task, page, errors = open_task("sixbar_example.yaml", background_design=True)
    page.select_option("#pick", "3")
    settled(page, 1)
    page.wait_for_function("document.getElementById('design').dataset.stage === 'done'", timeout=300_000)
    drawn = page.evaluate("window.mpsynthDesigner.drawn()")
    cl = page.evaluate("window.mpsynthDesigner.state().background.clearance")
    red = {True: "#b71c1c", False: "#e53935"}  # overlapping (a negative gap), closer than the clearance
    # each link's colour follows its smallest gap, whatever the design search found for this candidate
    for link, colour in drawn.items():
        gap = cl["bodies"].get(link)
        assert colour == ("#2e7d32" if gap is None or gap >= cl["clearance"] else red[gap < 0]), (link, gap)
    assert ("red come closer" in page.text_content("#design")) == (not cl["free"])
    page.click("#write")
    page.wait_for_function("document.getElementById('message').textContent.startsWith('wrote')", timeout=120_000)
    assert page.text_content("#message").startswith("wrote candidate 4 of 5 (04-f2-p9) to ")
    assert page.locator("#errors tbody tr.hit").count() == 4
    assert errors == []
