"""History of nightly runs in an embedded SQLite database.

One ``runs`` row per run (metadata: date, git commit, package and engine versions, machine,
suite, settings, the measurement version) and one ``cells`` row per measured cell: a tidy
table with the scene, method, measure, timestep, status and the measure's headline value,
the rest of the measurement in a JSON column. A cell is converted to and from its row by
``records.cell.Cell`` (``to_db_row`` / ``from_db_row``), nowhere else.

A run is inserted with ``complete = 0`` and marked complete only after its last cell and its
report are written. A task's cells are committed in one transaction with a ``tasks`` row that
says the task is done (``add_task_cells``): a run killed half-way leaves every earlier run
intact, is itself never read as complete, and holds whole tasks only, so that
``harness nightly --resume`` runs exactly the tasks it has no row for (``done_tasks``).
Runs are only compared with runs of the same ``MEASUREMENT_VERSION`` (as asv does with
its benchmark versions).
"""

from __future__ import annotations

import json
import sqlite3
from contextlib import closing
from pathlib import Path

import pandas as pd

from adapters import ENGINES
from records.cell import CELL_COLUMNS as _CELL_COLUMNS, Cell, to_json

#: Bump when a measure's definition changes: results across versions are not comparable.
#: 2: cost on the worker's CPU clock with explicit Euler timed beside it in the same cell;
#: order over half a period; stability searched up to the suite's h*omega maximum.
#: 3: an engine mode's cost is its own loop's (``engine s/step``), no longer the per-step path.
#: 4: cost timed over the steps a run runs before it diverges (a blow-up's replay was timed
#: and divided by N); a compiled loop's repeat at most 0.02 s and an engine's at most 0.1 s (a slow
#: kernel's figure is an average over fewer steps: Kepler's implicit midpoint, whose Newton
#: iterations vary around the orbit, reads a few % apart).
#: 5: the standard suite bisects the largest stable timestep to 1e-4 relative (was the measure's
#: 1e-6: every stability cell moves within 1e-4); an engine's error and order on a model file
#: that another engine's run is the reference of are against its own run at dt/2 (Richardson).
#: 6: a model file's conservative variant keeps armature and gravity (it switches off only what
#: dissipates or injects energy); the cross-engine cell compares at a resolved step over one
#: period of the slowest mode and names every built quantity that differs.
#: 7: an engine's timed repeat is held to ENGINE_RUN_BUDGET_S, now a compiled loop's budget (a slow
#: engine's figure, Drake's or pybullet's, is an average over fewer steps).
MEASUREMENT_VERSION = 7

SCHEMA = """
CREATE TABLE IF NOT EXISTS runs (
    run_id INTEGER PRIMARY KEY AUTOINCREMENT,
    started TEXT NOT NULL,
    finished TEXT,
    complete INTEGER NOT NULL DEFAULT 0,
    suite TEXT NOT NULL,
    measurement_version INTEGER NOT NULL,
    git_commit TEXT,
    versions TEXT NOT NULL,
    machine TEXT NOT NULL,
    settings TEXT NOT NULL,
    wall_s REAL,
    timing TEXT,
    regressions INTEGER
);
CREATE TABLE IF NOT EXISTS cells (
    run_id INTEGER NOT NULL REFERENCES runs(run_id),
    scene TEXT NOT NULL,
    method TEXT NOT NULL,
    family TEXT NOT NULL,
    measure TEXT NOT NULL,
    dt REAL,
    steps INTEGER,
    status TEXT NOT NULL,
    detail TEXT,
    value REAL,
    wall_s REAL,
    data TEXT NOT NULL,
    UNIQUE (run_id, scene, method, measure, dt)
);
CREATE INDEX IF NOT EXISTS cells_run ON cells(run_id);
CREATE TABLE IF NOT EXISTS tasks (
    run_id INTEGER NOT NULL REFERENCES runs(run_id),
    label TEXT NOT NULL,
    wall_s REAL,
    cpu_s REAL,
    PRIMARY KEY (run_id, label)
);
"""

#: The columns this code reads: a database whose tables lack any (an older schema) is refused.
REQUIRED_COLUMNS = {
    "runs": (
        "run_id",
        "started",
        "finished",
        "complete",
        "suite",
        "measurement_version",
        "git_commit",
        "versions",
        "machine",
        "settings",
        "wall_s",
        "timing",
        "regressions",
    ),
    "cells": (
        "run_id",
        "scene",
        "method",
        "family",
        "measure",
        "dt",
        "steps",
        "status",
        "detail",
        "value",
        "wall_s",
        "data",
    ),
}

CELL_COLUMNS = list(_CELL_COLUMNS)


def _tidy(df: pd.DataFrame) -> pd.DataFrame:
    """The ``cells`` rows read by pandas -> the tidy frame: each row read as a ``Cell`` and
    written back as its tidy row (``data`` a dict, a missing detail ""), any other column kept."""
    if df.empty:
        df["data"] = df["data"].astype(object)
        return df
    rows = [Cell.from_db_row(r).to_row() for r in df.to_dict("records")]
    out = pd.DataFrame(rows, index=df.index, columns=CELL_COLUMNS)
    for col in df.columns:
        if col not in CELL_COLUMNS:
            out.insert(0, col, df[col])
    return out


#: The engines' distributions of a run that recorded none under ``versions["engines"]``: every
#: ``adapters.ENGINES`` entry's (``Engine.dists``), as the nightly records them.
ENGINE_DISTS = tuple(dict.fromkeys(d for e in ENGINES.values() for d in e.dists))


def engine_series(versions: dict) -> tuple:
    """((dist, version), ...) of a run's engines (``versions["engines"]``, which the nightly records
    from the adapters): runs with the same tuple are one series."""
    engines = versions.get("engines")
    if not isinstance(engines, dict):
        engines = {}
    # A distribution the run did not record among its engines (Warp, before it was) is read from its
    # top level, where every run recorded it: a run stored earlier stays in its series.
    engines = {**{d: versions.get(d) for d in ENGINE_DISTS}, **engines}
    return tuple(sorted((d, v) for d, v in engines.items() if v is not None))


class History:
    """The run history at ``path`` (created on first use)."""

    def __init__(self, path: str | Path):
        from records import InvalidInput

        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with closing(self._connect()) as con, con:
                con.executescript(SCHEMA)
                missing = {
                    table: sorted(set(cols) - {r[1] for r in con.execute(f"PRAGMA table_info({table})")})
                    for table, cols in REQUIRED_COLUMNS.items()
                }
        except (OSError, sqlite3.DatabaseError) as exc:
            raise InvalidInput(
                f"--db {self.path}: not a readable history ({type(exc).__name__}: {exc}); valid: a "
                f"SQLite history written by harness nightly, or a new file"
            ) from None
        missing = {t: cols for t, cols in missing.items() if cols}
        if missing:
            lacks = "; ".join(f"{t} lacks {', '.join(cols)}" for t, cols in missing.items())
            raise InvalidInput(
                f"{self.path} was written by an older harness ({lacks}): not read, never mixed "
                f"with new runs; start a new history with --db"
            )

    def _connect(self) -> sqlite3.Connection:
        con = sqlite3.connect(self.path, timeout=30)
        con.row_factory = sqlite3.Row
        return con

    # ---------------------------------------------------------------- writing
    def start_run(
        self, *, started: str, suite: str, git_commit: str | None, versions: dict, machine: dict, settings: dict
    ) -> int:
        with closing(self._connect()) as con, con:
            cur = con.execute(
                "INSERT INTO runs (started, suite, measurement_version, git_commit, versions, machine, settings) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                (
                    started,
                    suite,
                    MEASUREMENT_VERSION,
                    git_commit,
                    to_json(versions),
                    to_json(machine),
                    to_json(settings),
                ),
            )
            return int(cur.lastrowid)

    def add_cell(self, run_id: int, cell: Cell | dict) -> None:
        """Store one measured cell (a ``Cell``, or its tidy row as a dict); a cell already stored
        for this run is replaced, never duplicated."""
        row = (cell if isinstance(cell, Cell) else Cell.from_row(cell)).to_db_row()
        with closing(self._connect()) as con, con:
            con.execute(
                f"INSERT OR REPLACE INTO cells (run_id, {', '.join(CELL_COLUMNS)}) "
                f"VALUES (?, {', '.join('?' for _ in CELL_COLUMNS)})",
                (run_id, *[row[c] for c in CELL_COLUMNS]),
            )

    def update_settings(self, run_id: int, settings: dict) -> None:
        with closing(self._connect()) as con, con:
            con.execute("UPDATE runs SET settings = ? WHERE run_id = ?", (to_json(settings), run_id))

    def add_task_cells(
        self,
        run_id: int,
        label: str,
        cells,
        wall_s: float | None = None,
        cpu_s: float | None = None,
        before_commit=None,
    ) -> None:
        """Store a task's cells and mark the task done, in one transaction: all or none of them.
        ``before_commit`` is called with the rows written and the transaction still open (the
        nightly's crash tests kill the process there: ``harness.execution.faults``)."""
        rows = [(c if isinstance(c, Cell) else Cell.from_row(c)).to_db_row() for c in cells]
        with closing(self._connect()) as con, con:
            con.executemany(
                f"INSERT OR REPLACE INTO cells (run_id, {', '.join(CELL_COLUMNS)}) "
                f"VALUES (?, {', '.join('?' for _ in CELL_COLUMNS)})",
                [(run_id, *[row[c] for c in CELL_COLUMNS]) for row in rows],
            )
            con.execute(
                "INSERT OR REPLACE INTO tasks (run_id, label, wall_s, cpu_s) VALUES (?, ?, ?, ?)",
                (run_id, label, wall_s, cpu_s),
            )
            if before_commit is not None:
                before_commit()

    def done_tasks(self, run_id: int) -> dict[str, tuple[float | None, float | None]]:
        """{label: (wall seconds, CPU seconds)} of the tasks the run has stored whole."""
        with closing(self._connect()) as con:
            rows = con.execute("SELECT label, wall_s, cpu_s FROM tasks WHERE run_id = ?", (run_id,)).fetchall()
        return {r["label"]: (r["wall_s"], r["cpu_s"]) for r in rows}

    def finish_run(self, run_id: int, *, finished: str, wall_s: float, timing: dict, regressions: int) -> None:
        with closing(self._connect()) as con, con:
            con.execute(
                "UPDATE runs SET finished = ?, wall_s = ?, timing = ?, regressions = ?, complete = 1 WHERE run_id = ?",
                (finished, wall_s, to_json(timing), regressions, run_id),
            )

    # ---------------------------------------------------------------- reading
    def runs(self, complete_only: bool = True) -> pd.DataFrame:
        q = "SELECT * FROM runs" + (" WHERE complete = 1" if complete_only else "") + " ORDER BY run_id"
        with closing(self._connect()) as con:
            df = pd.read_sql_query(q, con)
        # pandas >= 3 reads a text column as its string dtype, where SQL NULL (an unfinished
        # run's finish time and timing, an unknown commit) becomes NaN: back to None.
        for col in ("started", "finished", "suite", "git_commit"):
            df[col] = df[col].astype(object).map(lambda s: s if isinstance(s, str) else None)
        for col in ("versions", "machine", "settings", "timing"):
            df[col] = df[col].astype(object).map(lambda s: json.loads(s) if isinstance(s, str) and s else {})
        return df

    def run(self, run_id: int) -> dict:
        df = self.runs(complete_only=False)
        match = df[df.run_id == run_id]
        if match.empty:
            from records import InvalidInput

            valid = ", ".join(str(r) for r in df.run_id) or "none stored"
            raise InvalidInput(f"unknown run {run_id} in {self.path} (valid: {valid})")
        return match.iloc[0].to_dict()

    def cells(self, run_id: int) -> pd.DataFrame:
        """The run's cells as a tidy DataFrame; ``data`` decoded to dicts."""
        with closing(self._connect()) as con:
            df = pd.read_sql_query(
                "SELECT * FROM cells WHERE run_id = ? ORDER BY scene, method, measure, dt", con, params=(run_id,)
            )
        return _tidy(df)

    def cell_records(self, run_id: int) -> list[Cell]:
        """The run's cells as ``Cell`` records, in the order of ``cells``."""
        with closing(self._connect()) as con:
            rows = con.execute(
                "SELECT * FROM cells WHERE run_id = ? ORDER BY scene, method, measure, dt", (run_id,)
            ).fetchall()
        return [Cell.from_db_row(r) for r in rows]

    def cells_of_runs(self, run_ids, measures, data_of=()) -> pd.DataFrame:
        """The cells of several runs at once, of the given measures only; ``data`` decoded for the
        measures in ``data_of``, empty for the rest (an energy cell's series is most of its bytes)."""
        run_ids, measures, data_of = [int(r) for r in run_ids], list(measures), list(data_of) or [""]
        if not run_ids or not measures:
            return pd.DataFrame(columns=["run_id", *CELL_COLUMNS])
        marks = lambda xs: ", ".join("?" for _ in xs)  # noqa: E731
        columns = ", ".join(c for c in ("run_id", *CELL_COLUMNS) if c != "data")
        q = (
            f"SELECT {columns}, CASE WHEN measure IN ({marks(data_of)}) THEN data ELSE '{{}}' END AS data "
            f"FROM cells WHERE run_id IN ({marks(run_ids)}) AND measure IN ({marks(measures)}) "
            f"ORDER BY run_id, scene, method, measure, dt"
        )
        with closing(self._connect()) as con:
            df = pd.read_sql_query(q, con, params=(*data_of, *run_ids, *measures))
        return _tidy(df)

    def previous_complete(self, run_id: int, same_engines: bool = True) -> int | None:
        """The latest complete run before ``run_id`` of the same suite and measurement version
        (another suite measures other horizons and sweeps: its cells are not comparable) and, with
        ``same_engines``, of the same engine versions (``engine_series``): another engine release is
        another series, whose difference is a version change, never a regression."""
        runs = self.runs()
        mine = self.run(run_id)
        older = runs[
            (runs.run_id < run_id)
            & (runs.measurement_version == mine["measurement_version"])
            & (runs.suite == mine["suite"])
        ]
        if same_engines:
            series = engine_series(mine["versions"])
            older = older[[engine_series(v) == series for v in older.versions]]
        return int(older.run_id.iloc[-1]) if not older.empty else None

    def integrity_ok(self) -> bool:
        with closing(self._connect()) as con:
            return con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
