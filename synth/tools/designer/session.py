"""The state of one designer session: the task document and its history (undo), the kind and the
picked candidate, the live synthesis and the design behind it; "save task" and "write output".

Every decision the page shows is made here: the page sends edits (a leaf's new value, an item's new
position, a kind, a pick) and draws `Session.state()`. Values are in the task's units.
"""
from __future__ import annotations

import math
import threading
from pathlib import Path

import numpy as np

from synth.errors import InputError
from synth.io.atomic import atomic_write
from synth.io.docload import read_source
from synth.io.names import safe_robot_name
from synth.tools.designer import background, document
from synth.solve import design_solution
from synth.tools.designer.scene import clearances, pose_frames, scene
from synth.tools.designer.synth_view import SOLVERS, Kind, default_kind, kind_problems, task_misses, synthesize

MAX_UNDO = 200
ANGLE_DECIMALS = {"deg": 4, None: 6}  # a turned orientation's angles, rounded (degrees, radians)
UNIT_DECIMALS = 9  # a turned quaternion's or rotation matrix's entries, rounded (unit tests pass at 1e-6)
POSITION_DIGITS = 6  # a dragged position is rounded to this many significant digits of the task's size


class Session:
    """A task file opened in the designer. ``background_design``: run the design search behind each
    change (tests of the live part switch it off); ``kind``: the kind to start with (None: the task's
    default, `synth_view.default_kind`); ``normalize``: accept slightly non-unit quaternions and
    non-orthonormal rotations, as the commands' --normalize."""

    def __init__(self, path, background_design: bool = True, kind: str | None = None, normalize: bool = False):
        self.path = Path(path)
        self.source, text = read_source(str(path), None)
        self.doc = document.parse(text, self.source)
        self.bases = [(text, self.doc)]  # (text, its document) of the file as opened and as saved since
        self.history: list[tuple] = []  # (doc, kind, pick) before each change
        self.kind: Kind | None = _kind(kind)  # None: the task's default
        self.normalize = normalize
        self.pick = 0
        self.revision = 0
        self.background_design = background_design
        self.job: background.Job | None = None
        self.lock = threading.RLock()
        self.synthesis = None
        self._update()

    # ------------------------------------------------------------------ changes
    def edit(self, path, value) -> dict:
        """Set the leaf at ``path`` (a list of keys and indices) to ``value``."""
        with self.lock:
            new = document.with_value(self.doc, tuple(path), value)
            return self._change(new, self.kind, self.pick)

    def move(self, item: int, position) -> dict:
        """Move item ``item`` to ``position`` (three numbers, task units): one undo step."""
        with self.lock:
            where = document.position_path(self.doc, int(item))
            if where is None:
                raise InputError(f"item {item} has no position list of three numbers to move")
            if len(position) != 3:
                raise InputError(f"a position needs three numbers, got {len(position)}")
            ps = self.synthesis.ps
            size = max(_spread(ps), 1e-12) if ps is not None else 1.0
            new = self.doc
            for k, x in enumerate(position):
                new = document.with_value(new, where + (k,), _round(float(x), size))
            return self._change(new, self.kind, self.pick)

    def turn(self, item: int, axis, degrees: float) -> dict:
        """Turn item ``item``'s orientation by ``degrees`` about the direction ``axis`` (three numbers, the
        task's frame; the page's view axis) through its position: one undo step, written in the item's
        own orientation form (`document.orientation_leaves`)."""
        from synth.algebra.geometry import rotation_about_axis

        with self.lock:
            ps = self.synthesis.ps
            if ps is None:
                raise InputError("the task does not read; fix it in the table before turning a pose")
            if not 0 <= int(item) < len(ps) or ps.is_point[int(item)]:
                raise InputError(f"item {item} is not a pose with an orientation to turn")
            u = np.asarray(axis, float)
            if u.shape != (3,) or not np.isfinite(u).all() or not np.linalg.norm(u) > 0 or not math.isfinite(degrees):
                raise InputError(f"a turn needs an axis of three finite numbers (not zero) and a finite angle, got "
                                 f"{axis!r}, {degrees!r}")
            R = rotation_about_axis(u / np.linalg.norm(u), math.radians(float(degrees))) @ ps.matrices[int(item)][:3, :3]
            new = self.doc
            for path, value in document.orientation_leaves(self.doc, int(item), R, ps.angle_unit):
                angle = path[2] == "rpy" or path[-1] == "angle"
                digits = ANGLE_DECIMALS.get(ps.angle_unit, 6) if angle else UNIT_DECIMALS
                new = document.with_value(new, path, round(value, digits) + 0.0)
            return self._change(new, self.kind, self.pick)

    def add_field(self, item, key: str) -> dict:
        """Give item ``item`` (None: the task) the field ``key`` (tolerance, exact, velocity, order) with a
        starting value (`document.default_field`), to edit in the table."""
        with self.lock:
            size = _spread(self.synthesis.ps) if self.synthesis.ps is not None else 1.0
            return self._change(document.with_field(self.doc, _item(item), key, size), self.kind, self.pick)

    def remove_field(self, item, key: str) -> dict:
        with self.lock:
            return self._change(document.without_field(self.doc, _item(item), key), self.kind, self.pick)

    def set_kind(self, kind: str) -> dict:
        with self.lock:
            return self._change(self.doc, _kind(kind), 0)

    def set_pick(self, pick: int) -> dict:
        with self.lock:
            n = len(self.synthesis.linkages)
            if not 0 <= int(pick) < max(n, 1):
                raise InputError(f"candidate {pick} does not exist ({n} candidates)")
            return self._change(self.doc, self.kind, int(pick))

    def undo(self) -> dict:
        with self.lock:
            if self.history:
                self.doc, self.kind, self.pick = self.history.pop()
                self._update()
            return self.state()

    def _change(self, doc, kind, pick) -> dict:
        self.history.append((self.doc, self.kind, self.pick))
        del self.history[:-MAX_UNDO]
        self.doc, self.kind, self.pick = doc, kind, pick
        self._update()
        return self.state()

    def _update(self) -> None:
        """Re-synthesize the current document and start the design behind it (cancelling the last)."""
        self.revision += 1
        if self.job is not None:  # stop the last design search first: it would slow this synthesis down
            self.job.cancel()
            self.job.wait(background.STOP_SECONDS)
            self.job = None
        self.synthesis = synthesize(self.doc, self.source, self.kind, self.normalize)
        self.kind_problems = kind_problems(self.doc, self.source, self.normalize)
        if self.pick >= len(self.synthesis.linkages):
            self.pick = 0
        s = self.synthesis
        if self.background_design and s.linkages:
            self.job = background.start(self.revision, self._design(), s.linkages[self.pick])

    def _design(self):
        """The design behind the drawing, as a call: the picked candidate's (`synth.solve.design_solution`)
        when the entry point ranks candidates, else the command's own choice (`background.design_result`)."""
        s, pick = self.synthesis, self.pick
        if s.ranked:
            return lambda: design_solution(s.ps, s.linkages[pick])
        return lambda: background.design_result(SOLVERS[s.kind], s.ps)

    def _written(self) -> str:
        """Which candidate "write output" writes, in words."""
        s = self.synthesis
        if s.ranked:
            return f"candidate {self.pick + 1} of {len(s.linkages)} ({s.labels[self.pick]})"
        return f"the linkage mpsynth {s.kind.value} chooses"

    # ------------------------------------------------------------------ files
    def save(self, path=None) -> dict:
        """Write the task back (to ``path``, default the opened file): the original text with the changed
        numbers in place (comments kept) where possible, else the whole document anew."""
        with self.lock:
            target = Path(path) if path else self.path
            for base_text, base_doc in reversed(self.bases):  # the last saved text first, the opened file last
                text, kept = document.write_back(base_text, base_doc, self.doc, self.source)
                if kept:
                    break
            atomic_write(target, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
            if target == self.path:
                self.bases.append((text, self.doc))
            return {"path": str(target), "comments_kept": kept, "bytes": len(text.encode("utf-8"))}

    def write_output(self, out, force: bool = False) -> dict:
        """Write OUT as `mpsynth KIND TASK -o OUT` does (`synth.io.writer.write_output`) for the candidate
        picked (ranked candidates: `synth.solve.design_solution` of the pick, as ``--top`` designs each; else
        the entry point's own choice with a physical design); the design behind of the current revision is
        reused when done. ``written`` says which one, in words."""
        from synth.io.writer import check_output_target, write_output

        with self.lock:
            s, job, design, written = self.synthesis, self.job, self._design(), self._written()
            if s.problem:
                raise InputError(f"nothing to write: {s.problem}")
            check_output_target(str(out), force)
        if job is not None and job.wait() and job.stage is background.Stage.DONE:
            result = job.result
        else:
            result = design()
        files = write_output(result.linkage, str(out), robot_name=safe_robot_name(Path(self.source).stem or "linkage"),
                             force=force, result=result.design)
        return {"out": str(out), "files": len(files), "design": result.sentence() if result.design else None,
                "choice": result.linkage.info.design_choice, "written": written}

    # ------------------------------------------------------------------ what the page shows
    def state(self) -> dict:
        """The page's whole state as plain JSON types."""
        with self.lock:
            s = self.synthesis
            ps = s.ps
            scale = ps.length_scale if ps is not None else 1.0
            out = {
                "revision": self.revision, "source": self.source, "kind": s.kind.value,
                "default_kind": default_kind(ps).value if ps is not None else None,
                "kinds": [{"kind": k.value, "problem": self.kind_problems.get(k)} for k in Kind], "problem": s.problem, "ms": round(1e3 * s.seconds, 2),
                "unit": ps.length_unit if ps is not None else None,
                "angle_unit": ps.angle_unit if ps is not None else None,
                "items": self._items(), "undo": len(self.history),
                "candidates": s.labels, "pick": self.pick, "written": None if s.problem else self._written(), "scene": None, "errors": [], "linkage": None,
            }
            if ps is not None:
                out["poses"] = pose_frames(ps.matrices, scale)
                out["points"] = ps.is_point.tolist()
            if s.linkages:
                lk = s.linkages[self.pick]
                out["scene"] = scene(lk, scale)
                out["errors"] = [e.to_json() for e in task_misses(lk, scale)]
                out["linkage"] = {"kind": lk.kind, "joints": len(lk.joints), "loops": len(lk.closures)}
            out["background"] = self._background(scale)
            return out

    def _items(self) -> list[dict]:
        key = document.items_key(self.doc)
        rows: dict = {}
        settings = []
        for leaf in document.leaves(self.doc):
            cell = {"path": list(leaf.path), "value": leaf.value,
                    "label": document.label(leaf.path[2:] if leaf.item is not None else leaf.path)}
            if leaf.item is None:
                if leaf.path[:1] != ("units",):
                    settings.append(cell)
            else:
                rows.setdefault(leaf.item, []).append(cell)
        items = [{"index": i, "cells": cells, "movable": document.position_path(self.doc, i) is not None,
                  "addable": document.addable(self.doc, i), "removable": _removable(self.doc, key, i)}
                 for i, cells in sorted(rows.items())]
        return [{"key": key, "rows": items, "settings": settings, "addable": document.addable(self.doc, None),
                 "removable": _removable(self.doc, None, None)}]

    def _background(self, scale: float) -> dict | None:
        job = self.job
        if job is None:
            return None
        out = {"revision": job.revision, "stage": job.stage.value, "drive": job.drive, "problem": job.problem}
        r = job.result
        if job.stage is background.Stage.DONE and r is not None:
            out["design"] = r.sentence() if r.design is not None else None
            out["free"] = bool(r.design.collision.free) if r.design is not None else None
            out["choice"] = r.linkage.info.design_choice
            out["scene"] = scene(r.linkage, scale)
            out["clearance"] = clearances(r.linkage, r.design.collision, scale) if r.design is not None else None
        return out

    def close(self) -> None:
        """Cancel the design behind (the server is stopping) and wait up to `background.STOP_SECONDS` for
        it to stop (one move of the search), so that the interpreter does not finalise under a daemon thread
        still inside a C++ library (manifold3d, OpenCASCADE): a suspected cause of the rare SIGABRT at ^C."""
        if self.job is not None:
            self.job.cancel()
            self.job.wait(background.STOP_SECONDS)


def _kind(kind) -> Kind | None:
    if kind is None:
        return None
    try:
        return Kind(kind)
    except ValueError:
        raise InputError(f"unknown kind {kind!r}; one of {', '.join(k.value for k in Kind)}") from None


def _item(item) -> int | None:
    return None if item is None else int(item)


def _removable(doc, key, item) -> list[str]:
    node = doc if item is None else doc[key][item]
    fields = document.TOP_FIELDS if item is None else document.ITEM_FIELDS
    return [k for k in fields if isinstance(node, dict) and k in node]


def _spread(ps) -> float:
    p = ps.positions / ps.length_scale
    return float((p.max(0) - p.min(0)).max()) if len(p) else 1.0


def _round(x: float, size: float) -> float:
    """``x`` rounded to 10^-POSITION_DIGITS of ``size`` (a round step: 1, 2 or 5 x 10^k)."""
    import math

    step = 10.0 ** math.floor(math.log10(size * 10.0 ** -POSITION_DIGITS))
    return round(round(x / step) * step, 12)
