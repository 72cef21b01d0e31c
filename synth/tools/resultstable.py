"""Batch results as a Parquet table: `mpsynth batch JOBS --results FILE.parquet`.

One row per job (blank lines are not jobs) in input order, with the columns of `COLUMNS`: ``line`` (1-based
input line), ``id`` (as text: a string id as given, a numeric id as its JSON text, else null), ``ok``,
``status`` ("ok", "no linkage", "bad input", "internal error"), ``exit_code`` (0 when ok), ``kind``,
``joints``, ``extent`` (m), the self-check figures ``max_pose_error``, ``max_closure_error``,
``max_motion_error`` (metres plus radians, as in linkage.json's checks), the Bennett parameters ``a``,
``alpha``, ``b``, ``beta`` (m, rad; null for 6R), ``out`` and ``error``. Nulls where a figure does not
apply. A million rows filter in pandas / duckdb in well under a second.

`ResultsTable(path)` writes row groups of ``ROW_GROUP`` rows as results arrive (memory stays bounded),
into a temporary file beside ``path`` that replaces ``path`` only on `close` (nothing partial is
written: an interrupted batch leaves no results file). pyarrow is optional (``mpsynth[cluster]``);
without it the constructor raises an InputError saying how to install it.
"""
from __future__ import annotations

import json
import os
import tempfile

from synth.errors import InputError, OutputError
from synth.io.atomic import check_file_target, commit_file

ROW_GROUP = 65536
STATUS = {1: "no linkage", 2: "bad input", 3: "internal error"}
CHECKS = ("max_pose_error", "max_closure_error", "max_motion_error")
BENNETT = ("a", "alpha", "b", "beta")
# column name -> arrow type name
COLUMNS = {"line": "int64", "id": "string", "ok": "bool_", "status": "string", "exit_code": "int8",
           "kind": "string", "joints": "int16", "extent": "float64",
           **{k: "float64" for k in CHECKS}, **{k: "float64" for k in BENNETT},
           "out": "string", "error": "string"}


def row(result: dict) -> dict | None:
    """The table row of one result dictionary (`synth.tools.batchjobs.run_job`); None for a blank line."""
    if result.get("skipped"):
        return None
    jid = result.get("id")
    ok = bool(result.get("ok"))
    code = 0 if ok else int(result.get("exit_code", 3))
    checks = result.get("checks") or {}
    bennett = result.get("bennett") or {}
    r = {"line": result.get("line"), "id": jid if (jid is None or isinstance(jid, str)) else json.dumps(jid),
         "ok": ok, "status": "ok" if ok else STATUS.get(code, "internal error"), "exit_code": code,
         "kind": result.get("kind"), "joints": result.get("joints"), "extent": result.get("extent"),
         "out": result.get("out"), "error": result.get("error")}
    r.update({k: checks.get(k) for k in CHECKS})
    r.update({k: bennett.get(k) for k in BENNETT})
    return r


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError as e:
        raise InputError(f"--results needs pyarrow, which is not installed ({e}); "
                         "pip install 'mpsynth[cluster]'") from None
    return pyarrow, pyarrow.parquet


class ResultsTable:
    """Streaming Parquet writer of batch results (see the module docstring). Use as a context manager:
    a clean exit commits the file, an exception removes the temporary one."""

    def __init__(self, path, avoid=()):
        """``avoid``: paths the table may not replace (the jobs file)."""
        self.pa, self.pq = _pyarrow()
        self.path = os.fspath(check_file_target(path, "--results"))
        parent = os.path.dirname(self.path)
        for other in avoid:
            if other and other != "-" and os.path.exists(other) and os.path.exists(self.path) \
                    and os.path.samefile(other, self.path):
                raise InputError(f"--results {path}: is the jobs file; name another file")
        self.schema = self.pa.schema([(k, getattr(self.pa, t)()) for k, t in COLUMNS.items()])
        try:
            fd, self.tmp = tempfile.mkstemp(prefix=f".{os.path.basename(self.path)}.mpsynth-tmp-", dir=parent)
            os.close(fd)
            self.writer = self.pq.ParquetWriter(self.tmp, self.schema)
        except OSError as e:
            raise InputError(f"--results {path}: cannot write there ({e.strerror or e})") from None
        self.rows: list[dict] = []
        self.count = 0

    def add(self, result: dict) -> None:
        r = row(result)
        if r is not None:
            self.rows.append(r)
            if len(self.rows) >= ROW_GROUP:
                self._flush()

    def _flush(self) -> None:
        if not self.rows:
            return
        cols = {k: [r[k] for r in self.rows] for k in COLUMNS}
        table = self.pa.table(cols, schema=self.schema)
        try:
            self.writer.write_table(table)
        except OSError as e:
            raise OutputError(f"--results {self.path}: cannot write ({e.strerror or e})") from None
        self.count += len(self.rows)
        self.rows = []

    def close(self) -> None:
        """Write the last rows and move the file into place."""
        self._flush()
        try:
            self.writer.close()
            commit_file(self.tmp, self.path)
        except InputError:
            self.abort()
            raise
        except OSError as e:
            self.abort()
            raise OutputError(f"--results {self.path}: cannot write ({e.strerror or e})") from None

    def abort(self) -> None:
        try:
            self.writer.close()
        except Exception:
            pass
        try:
            os.unlink(self.tmp)
        except OSError:
            pass

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        if kind is None:
            self.close()
        else:
            self.abort()
        return False
