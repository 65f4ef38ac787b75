"""The nightly as a history: each cell's series across the complete runs of one suite, and what
changed in it.

A cell is (scene, method, measure, dt). Its series holds one point per complete run of the suite
and measurement version (the latest ``WINDOW`` runs, or ``last``): the run, its commit and date,
the value and the value's measured spread. Two kinds of cell are judged two ways:

* **Accuracy figures** (energy, error, order, stability) are deterministic: the same code,
  engine versions and platform give them bit for bit (the harness's tests hold them to that).
  So any change of one between two runs is reported at once, no statistics needed, with the
  commit range and whatever else differs between the two runs (an engine version, the
  platform); a change where nothing differs says so: it is the figure that is not deterministic.
* **Cost** (the CPU-time ratio to explicit Euler, timed beside it in the same worker; seconds
  per step where a scene has no explicit-Euler run) is noisy: its steps are found by
  ``harness.history.step_detect`` over the series, each point weighted by its measured spread, once
  ``MIN_RUNS`` runs exist. A regression is a detected rise of the latest level past the cell's
  noise (``step_detect.Fit.regression``); before ``MIN_RUNS`` runs, ``harness.history.compare``'s
  last-two rule judges.

A cost step is kept only when it is larger than what the machine's own noise explains, measured
in the runs themselves (``explained_by_machine``):

* **nothing changed**: a step between two runs whose code (commit and the code digest: a dirty
  tree's commit says nothing), the packages the cell depends on (plugins included) and the
  platform (its host included) are all the same is the machine's, whatever its size: it is listed
  as machine noise with no confidence claimed, and never makes a regression;
* **the calibration moved**: every cost cell times a fixed calibration pair beside it
  (``harness.measures.calibration``: the interpreter over the compiled kernel). A step of the
  cell's cost ratio is credited with how far the calibration's level moved across it (a
  machine whose interpreted code slowed against compiled code moves both), and its confidence
  is that of what remains: kept when what remains is ``KEEP_Z`` of its noise or more.

The same two rules stand between a detected rise and a ``slowdown`` regression.

Runs of another measurement version are never mixed in: they are left out and said so in one
line, and a history holding only such runs is refused in one line (or read on its own with
``measurement_version``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from adapters import ENGINES
from records import InvalidInput
from records.cell import figures_of
from records.measures import get, trended
from records.run import NUMBA_OPT_KEY, RunRecord

from harness.history import step_detect
from harness.history.regression import Regression
from harness.history.storage import MEASUREMENT_VERSION, History, engine_series

#: Which way is worse, by measure.
#: Complete runs of a suite from which cost is judged over the history.
MIN_RUNS = 3
#: Runs judged by default: about two months of nights.
WINDOW = 60
#: Packages whose version a cell's figures depend on, by method family (all cells: these and Python):
#: each engine's distributions (``adapters.ENGINES``).
FAMILY_PACKAGES = {e.id: e.dists for e in ENGINES.values()}
COMMON_PACKAGES = ("python", "numpy", "scipy", "numba", NUMBA_OPT_KEY)
#: What a run records of its machine (``harness.execution.environment.run_metadata``) that a figure
#: may depend on: the host ("node") with its platform, so that two hosts of one platform are two.
PLATFORM_KEYS = ("node", "system", "machine", "processor")
_PLATFORM_NAMES = {"node": "host"}


@dataclass(frozen=True)
class Point:
    run_id: int
    commit: str | None
    date: str
    value: float | None
    spread: float
    status: str
    calibration: float | None = None  # the machine's calibration ratio, timed beside a cost cell

    def as_dict(self) -> dict:
        return {
            "run": self.run_id,
            "commit": self.commit,
            "date": self.date,
            "value": _plain(self.value),
            "spread": self.spread,
            "status": self.status,
            "calibration": self.calibration,
        }


@dataclass(frozen=True)
class Change:
    """A change of level: from ``run_id`` on (``previous_run`` the run before it in the series)."""

    run_id: int
    previous_run: int
    before: float
    after: float
    commits: str
    cause: str
    worse: bool
    confidence: float | None = None  # None: a deterministic figure, changed for certain

    @property
    def size(self) -> float | None:
        if self.before in (0.0, None) or not math.isfinite(self.before) or not math.isfinite(self.after):
            return None
        return self.after / self.before - 1.0

    def as_dict(self) -> dict:
        return {
            "run": self.run_id,
            "previous_run": self.previous_run,
            "before": _plain(self.before),
            "after": _plain(self.after),
            "size": self.size,
            "worse": self.worse,
            "confidence": self.confidence,
            "commits": self.commits,
            "cause": self.cause,
        }


@dataclass
class CellHistory:
    scene: str
    method: str
    family: str
    measure: str
    dt: float | None
    unit: str
    points: list[Point]
    fit: step_detect.Fit | None = None
    changes: list[Change] = field(default_factory=list)
    regression: Regression | None = None
    machine_steps: list[Change] = field(default_factory=list)  # cost steps the machine explains

    @property
    def key(self) -> tuple:
        return (self.scene, self.method, self.measure, None if self.dt is None else round(float(self.dt), 15))

    @property
    def label(self) -> str:
        return f"{self.method} on {self.scene} ({self.measure})"

    def ok_points(self) -> list[Point]:
        return [p for p in self.points if p.value is not None]

    def levels(self) -> list[tuple[int, int, float]]:
        """(first run, last run, level) of each level of the series: the fit's for cost, the runs
        of equal values for an accuracy figure."""
        ok = self.ok_points()
        if self.fit is not None:
            return [(ok[a].run_id, ok[b - 1].run_id, lv) for (a, b), lv in zip(self.fit.segments, self.fit.levels)]
        out: list[tuple[int, int, float]] = []
        for p in ok:
            if out and _same(out[-1][2], p.value):
                out[-1] = (out[-1][0], p.run_id, out[-1][2])
            else:
                out.append((p.run_id, p.run_id, p.value))
        return out

    def as_dict(self) -> dict:
        return {
            "scene": self.scene,
            "method": self.method,
            "measure": self.measure,
            "dt": self.dt,
            "unit": self.unit,
            "points": [p.as_dict() for p in self.points],
            "noise": self.fit.noise if self.fit is not None else None,
            "levels": [{"from_run": a, "to_run": b, "level": _plain(lv)} for a, b, lv in self.levels()],
            "steps": [c.as_dict() for c in self.changes],
            "machine_steps": [c.as_dict() for c in self.machine_steps],
            "regression": self.regression.as_dict() if self.regression is not None else None,
        }


@dataclass
class Trend:
    """The history of every cell of a suite, as judged at its latest run."""

    path: str
    suite: str
    measurement_version: int
    runs: list[RunRecord]  # the runs of the series, oldest first
    cells: list[CellHistory]
    left_out: str = ""  # the runs of other measurement versions, in one line
    min_runs: int = MIN_RUNS

    @property
    def run_ids(self) -> list[int]:
        return [r.run_id for r in self.runs]

    @property
    def judged(self) -> bool:
        """Cost is judged over the history (else by the last-two rule)."""
        return len(self.runs) >= self.min_runs

    def judges(self, key: tuple) -> bool:
        return any(c.key == key and c.fit is not None for c in self.cells)

    def regressions(self) -> list:
        return [c.regression for c in self.cells if c.regression is not None]

    def changed(self) -> list[CellHistory]:
        return [c for c in self.cells if c.changes]

    def latest_changes(self) -> list[tuple[CellHistory, Change]]:
        """Changes of accuracy figures that arrived with the latest run."""
        last = self.run_ids[-1] if self.runs else None
        return [(c, ch) for c in self.cells if get(c.measure).deterministic for ch in c.changes if ch.run_id == last]

    def as_dict(self) -> dict:
        return {
            "db": self.path,
            "suite": self.suite,
            "measurement_version": self.measurement_version,
            "runs": [{"run": r.run_id, "commit": r.git_commit, "date": r.started} for r in self.runs],
            "judged_by_history": self.judged,
            "left_out": self.left_out or None,
            "cells": [c.as_dict() for c in self.cells],
        }


def _plain(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else ("inf" if x > 0 else "-inf") if not math.isnan(x) else None


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _short(commit: str | None) -> str:
    if not commit:
        return "unknown"
    return commit[:10] + ("+dirty" if commit.endswith("+dirty") else "")


def commit_range(run_a: RunRecord | dict, run_b: RunRecord | dict) -> str:
    a, b = RunRecord.of(run_a).git_commit, RunRecord.of(run_b).git_commit
    if a and a == b:
        return f"{_short(b)} (same commit)"
    return f"{_short(a)}..{_short(b)}"


#: What ``what_differs`` says when nothing a cell depends on differs.
NOTHING_DIFFERS = "same code, engine versions and platform"


def _same_code(run_a: RunRecord, run_b: RunRecord) -> bool:
    """One commit, and the same code digest where both runs have one (a ``+dirty`` commit
    without digests is not known to be the same code)."""
    a, b = run_a.git_commit, run_b.git_commit
    if not b or a != b:
        return False
    da, db = run_a.settings.code_digest, run_b.settings.code_digest
    if da and db:
        return da == db
    return not b.endswith("+dirty")


def _version(versions: dict, pkg: str) -> str | None:
    """``pkg``'s version in a run's ``versions``: its own entry, else the one the nightly records
    under ``versions["engines"]`` (a run from before the package was recorded on its own)."""
    if pkg in versions:
        return versions[pkg]
    engines = versions.get("engines")
    return engines.get(pkg) if isinstance(engines, dict) else None


def what_differs(run_a: RunRecord | dict, run_b: RunRecord | dict, family: str, deterministic: bool = True) -> str:
    """What differs between two runs that a cell of ``family`` depends on: the code, package
    versions (plugins' included), the platform; or that nothing does (``NOTHING_DIFFERS``; for a
    ``deterministic`` figure, that it is not)."""
    run_a, run_b = RunRecord.of(run_a), RunRecord.of(run_b)
    out = []
    if not _same_code(run_a, run_b):
        same_commit = run_a.git_commit == run_b.git_commit and run_b.git_commit
        out.append(f"code {commit_range(run_a, run_b)}" + (", its uncommitted changes differ" if same_commit else ""))
    va, vb = run_a.versions, run_b.versions
    plugins = sorted(k for k in {*va, *vb} if k.startswith("plugin "))
    for pkg in (*COMMON_PACKAGES, *FAMILY_PACKAGES.get(family, ()), *plugins):
        a, b = _version(va, pkg), _version(vb, pkg)
        if a != b:
            out.append(f"{pkg} {a} -> {b}")
    ma, mb = run_a.machine, run_b.machine
    plat = [k for k in PLATFORM_KEYS if ma.get(k) != mb.get(k)]
    if plat:
        out.append("platform " + ", ".join(f"{_PLATFORM_NAMES.get(k, k)} {ma.get(k)} -> {mb.get(k)}" for k in plat))
    if out:
        return "; ".join(out)
    return NOTHING_DIFFERS + (": the figure is not deterministic" if deterministic else "")


#: Noise units a cost step must exceed once the calibration's move is credited, to be kept.
KEEP_Z = 2.0


def _calibration_level(points: list[Point]) -> float | None:
    cal = [p.calibration for p in points if p.calibration]
    return float(np.median(cal)) if cal else None


def explained_by_machine(
    before: list[Point],
    after: list[Point],
    level_before: float,
    level_after: float,
    noise: float,
    runs: dict[int, RunRecord],
    family: str,
) -> tuple[str, float | None]:
    """Whether a cost change from the points ``before`` to the points ``after`` (levels
    ``level_before`` -> ``level_after``) is the machine's (module docstring): (why, "" if it is
    not; the confidence left once the calibration's move is credited, None where nothing
    changed)."""
    ra, rb = runs[before[-1].run_id], runs[after[0].run_id]
    if what_differs(ra, rb, family, deterministic=False) == NOTHING_DIFFERS:
        return f"{NOTHING_DIFFERS}: the machine's noise", None
    dx = abs(math.log(level_after / level_before))
    ca, cb = _calibration_level(before), _calibration_level(after)
    move = abs(math.log(cb / ca)) if ca and cb else 0.0
    z = max(0.0, dx - move) / (noise * math.sqrt(1.0 / len(before) + 1.0 / len(after)))
    from scipy.stats import norm  # here: scipy.stats is most of this module's import time

    confidence = float(1.0 - 2.0 * norm.sf(z))
    if z < KEEP_Z:
        return (
            f"within the machine's noise: the calibration moved {cb / ca - 1:+.0%} across it"
            if move
            else "within the cell's noise"
        ), confidence
    return "", confidence


def _cost_point(row) -> tuple[float | None, float, str]:
    """(value, relative spread, unit) of a cost cell: the ratio to explicit Euler where timed."""
    f = figures_of(row)
    if f.ratio_to_explicit_euler:
        return float(f.ratio_to_explicit_euler), float(f.ratio_spread or 0.0), "x explicit Euler"
    v = row["value"]
    return (None if v is None or pd.isna(v) else float(v)), float(f.spread or 0.0), "s/step"


def _accuracy_point(row) -> float | None:
    v = row["value"]
    if v is None or pd.isna(v):
        return None
    return float(v)


def load(
    history: History,
    *,
    run_id: int | None = None,
    suite: str | None = None,
    measurement_version: int = MEASUREMENT_VERSION,
    last: int | None = None,
    scene: str | None = None,
    method: str | None = None,
    measure: str | None = None,
) -> Trend:
    """The trend of a suite's cells up to ``run_id`` (default: the latest complete run; a run still
    being written, the nightly's own, is included when named). Filters name stored scenes, methods
    and a measure of ``MEASURES``; anything else is an ``InvalidInput`` naming the valid ones."""
    if measure is not None and measure not in trended():
        raise InvalidInput(f"unknown --measure {measure!r} (valid: {', '.join(trended())})")
    runs = history.runs(complete_only=False)
    chosen = runs[(runs.complete == 1) | (runs.run_id == (run_id if run_id is not None else -1))]
    if run_id is not None:
        target = history.run(run_id)
        suite = suite or target["suite"]
        chosen = chosen[chosen.run_id <= run_id]
    if chosen.empty:
        raise InvalidInput(f"no complete run stored in {history.path}")
    suites = list(dict.fromkeys(chosen.suite))
    if suite is None:
        suite = str(chosen.suite.iloc[-1])
    elif suite not in suites:
        raise InvalidInput(f"unknown --suite {suite!r} in {history.path} (valid: {', '.join(suites)})")
    chosen = chosen[chosen.suite == suite]
    same = chosen[chosen.measurement_version == measurement_version]
    other = chosen[chosen.measurement_version != measurement_version]
    other_versions = ", ".join(str(v) for v in sorted(set(other.measurement_version)))
    if same.empty:
        raise InvalidInput(
            f"{history.path} holds {suite} runs of measurement version {other_versions} only, and "
            f"version {measurement_version} was asked for (this harness measures version "
            f"{MEASUREMENT_VERSION}): not comparable; read them with --measurement-version "
            f"{other_versions.split(', ')[-1]}"
        )
    left_out = (
        (
            f"{len(other)} {suite} run(s) of measurement version {other_versions} left out: "
            f"not comparable with version {measurement_version}"
        )
        if not other.empty
        else ""
    )
    # One series: the engine releases of the run judged (another release is a version change).
    series = engine_series(same.versions.iloc[-1])
    mine = [engine_series(v) == series for v in same.versions]
    if not all(mine):
        n = len(mine) - sum(mine)
        said = ", ".join(f"{d} {v}" for d, v in series)
        left_out = "; ".join(
            x
            for x in (left_out, f"{n} {suite} run(s) on other engine releases left out: another series than {said}")
            if x
        )
        same = same[mine]
    same = same.tail(last or WINDOW)
    run_rows = [RunRecord.of(r.to_dict()) for _, r in same.iterrows()]
    by_id = {r.run_id: r for r in run_rows}
    cells = history.cells_of_runs(list(by_id), [measure] if measure else list(trended()), data_of=("cost",))
    for name, value in (("--scene", scene), ("--method", method)):
        column = name[2:]
        if value is not None:
            valid = sorted(set(cells[column]))
            if value not in valid:
                raise InvalidInput(
                    f"unknown {name} {value!r} in the {suite} history of {history.path} "
                    f"(valid: {', '.join(valid) or 'none stored'})"
                )
            cells = cells[cells[column] == value]
    trend = Trend(str(history.path), suite, measurement_version, run_rows, [], left_out)
    if cells.empty:
        return trend
    groups: dict[tuple, list[dict]] = {}
    for row in cells.to_dict("records"):  # ordered by run
        dt = row["dt"]
        key = (row["scene"], row["method"], row["measure"], None if dt is None or pd.isna(dt) else round(float(dt), 15))
        groups.setdefault(key, []).append(row)
    for rows in groups.values():
        trend.cells.append(_cell_history(rows, by_id, judged=trend.judged))
    trend.cells.sort(key=lambda c: (c.scene, c.method, trended().index(c.measure)))
    return trend


def _cell_history(rows: list[dict], runs: dict[int, RunRecord], judged: bool) -> CellHistory:
    """One cell's history from its stored rows, oldest run first."""
    first = rows[0]
    measure = first["measure"]
    dt = None if first["dt"] is None or pd.isna(first["dt"]) else float(first["dt"])
    points, unit = [], ""
    for row in rows:
        run = runs[int(row["run_id"])]
        if measure == "cost":
            value, spread, unit_row = _cost_point(row)
            unit = unit or unit_row
            if unit_row != unit or value is None or not value > 0 or not math.isfinite(value):
                value = None  # a run without the same unit (no baseline) is not a point of this series
        else:
            value, spread = _accuracy_point(row), 0.0
        if row["status"] != "ok":
            value = None
        cal = figures_of(row).calibration if measure == "cost" else None
        points.append(
            Point(
                int(row["run_id"]),
                run.git_commit,
                run.started,
                value,
                spread,
                row["status"],
                float(cal) if cal else None,
            )
        )
    declared = get(measure)  # unit, direction and determinism: the measure's declaration
    if measure != "cost":
        unit = declared.trend
    cell = CellHistory(first["scene"], first["method"], first["family"], measure, dt, unit, points)
    ok = cell.ok_points()
    worse_up = declared.higher_is_worse
    if declared.deterministic:
        for a, b in zip(ok, ok[1:]):
            if not _same(a.value, b.value):
                ra, rb = runs[a.run_id], runs[b.run_id]
                worse = (b.value > a.value) if worse_up else (b.value < a.value)
                cell.changes.append(
                    Change(
                        b.run_id,
                        a.run_id,
                        a.value,
                        b.value,
                        commit_range(ra, rb),
                        what_differs(ra, rb, cell.family),
                        worse,
                    )
                )
        return cell
    if not judged or len(ok) < step_detect.MIN_POINTS:
        return cell
    # The newest night's figure measured again in fresh processes (harness.nightly.run) says how far
    # one process's figure sits from another's on this machine now: the least noise the cell has.
    last = next((r for r in reversed(rows) if int(r["run_id"]) == ok[-1].run_id), None) if ok else None
    floor = float(figures_of(last).process_noise or 0.0) if last is not None and measure == "cost" else 0.0
    fit = step_detect.detect_steps([p.value for p in ok], [p.spread for p in ok], noise_floor=floor)
    cell.fit = fit
    for k, st in enumerate(fit.steps):
        (a0, a1), (b0, b1) = fit.segments[k], fit.segments[k + 1]
        pa, pb = ok[st.index - 1], ok[st.index]
        ra, rb = runs[pa.run_id], runs[pb.run_id]
        why, confidence = explained_by_machine(ok[a0:a1], ok[b0:b1], st.before, st.after, fit.noise, runs, cell.family)
        change = Change(
            pb.run_id,
            pa.run_id,
            st.before,
            st.after,
            commit_range(ra, rb),
            why or what_differs(ra, rb, cell.family, deterministic=False),
            (st.after > st.before) == worse_up,
            confidence,
        )
        (cell.machine_steps if why else cell.changes).append(change)
    found = fit.regression(worse_up)
    if found is not None:
        index, before, after = found
        best = next(i for i, (a, b) in enumerate(fit.segments) if b == index)
        (a0, a1), (l0, l1) = fit.segments[best], fit.segments[-1]
        if explained_by_machine(ok[a0:a1], ok[l0:l1], before, after, fit.noise, runs, cell.family)[0]:
            found = None
    if found is not None:
        index, before, after = found
        since = ok[index]
        steps = [c for c in cell.changes if c.run_id >= since.run_id]
        commits = (
            commit_range(runs[steps[0].previous_run], runs[steps[-1].run_id])
            if steps
            else commit_range(runs[ok[index - 1].run_id], runs[since.run_id])
        )
        what = "cost ratio to explicit Euler" if unit == "x explicit Euler" else "CPU time per step"
        cell.regression = Regression(
            "slowdown",
            cell.scene,
            cell.method,
            "cost",
            dt,
            before,
            after,
            f"{what} level {before:.3g} -> {after:.3g} ({after / before - 1:+.0%}) since run {since.run_id} "
            f"(commits {commits}), detected over the last {len(ok)} runs, beyond {step_detect.REGRESSION_NOISE:g}x "
            f"the cell's noise ({fit.noise:.1%})",
        )
    return cell
