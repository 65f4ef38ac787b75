"""What got worse between two stored runs.

Cells are matched on (scene, method, measure, dt). Each measure declares its own rule with it
(``records.measures.Measure.regression``: given the two cells and a ``Comparison``, it answers
``Worse`` or None; the built-in ones in ``harness.nightly.cells``), and this module applies
whichever is declared. A regression is, in run B against run A:

* ``energy bound``: a ``bound`` cell whose max |dE/E| is above the reviewed bound (read from
  the bounds file at comparison time, so a tightened bound is checked against stored runs);
* ``order``: observed order down by more than ``ORDER_DROP`` (0.3);
* ``stability``: largest stable h*omega down by more than ``STABILITY_DROP`` (1%), or a method
  that was unbounded now has a limit;
* ``new failure``: a cell that was ``ok`` is now unstable or crashed (or a cell present in A is
  missing from B, where B has cells of its scene: a scene with none left the suite, as an edited
  model file does, whose id carries its content hash), or a cell new in B (a new method or scene)
  that crashed: the harness could not measure it. (A new cell that is ``unstable`` is a
  measurement: a blow-up is a result.) A cell that timed out in B, even after the run tried its
  task once more, is **not measured this run** (``not_measured``), never a regression: its limit is
  CPU seconds, so it says the method took too long there, and the verdict counts it apart.
* ``slowdown``: the cost ratio to explicit Euler worsens beyond the spread of its repeats:
  ratio_B > ratio_A * (1 + spread_A + spread_B + PROCESS_SPREAD), a run's spread being that
  of its interleaved repeats' ratios, (max - min) / min. Repeats in one process miss how
  much one process differs from the next (where the allocator and the compiled code land:
  docs/performance.md, "Process-to-process noise", gives the spreads measured in fresh worker
  processes with the code unchanged). PROCESS_SPREAD = 0.5 is policy, above those spreads with room:
  a slowdown is flagged from 1.5x on, gross changes (a kernel no longer compiled, a step
  doing twice the work), not noise. The calibration timed beside each cost cell
  (``harness.measures.calibration``) widens that by how far it moved between the two runs, and
  between two runs where nothing the cell depends on differs (code, versions, platform) no
  slowdown is flagged at all: it is the machine's (``harness.history.series``).

Only runs of the same suite and measurement version are compared. Once three complete runs of
the suite exist, the default comparison judges cost over the whole history instead of the last
two runs (``harness.history.series``): a drift of a few percent a night adds up past the noise there,
and one noisy night is not a step.
"""

from __future__ import annotations

import pandas as pd

from records import InvalidInput
from records.cell import Cell
from records.measures import Comparison, get

from harness.history import bounds as bounds_mod
from harness.history.regression import Regression
from harness.history.storage import History

ORDER_DROP = 0.3
STABILITY_DROP = 0.01
PROCESS_SPREAD = 0.5


def _key(row) -> tuple:
    dt = row["dt"]
    return (row["scene"], row["method"], row["measure"], None if dt is None or pd.isna(dt) else round(float(dt), 15))


def bound_violations(cells: pd.DataFrame, bounds: list[bounds_mod.Bound]) -> list[Regression]:
    by_key = {(b.scene, b.method, round(b.dt, 15), b.steps): b for b in bounds}
    out = []
    for _, row in cells[cells.measure == "bound"].iterrows():
        b = by_key.get((row["scene"], row["method"], round(float(row["dt"]), 15), int(row["steps"])))
        if b is None or row["status"] != "ok":
            continue  # failures are reported as new failures
        if not row["value"] <= b.bound:
            out.append(
                Regression(
                    "energy bound",
                    b.scene,
                    b.method,
                    "bound",
                    b.dt,
                    b.bound,
                    row["value"],
                    f"max |dE/E| = {row['value']:.3e} > bound {b.bound:.2g} over {b.steps} steps",
                )
            )
    return out


def compare_cells(
    a: pd.DataFrame, b: pd.DataFrame, bounds: list[bounds_mod.Bound], runs: tuple[dict, dict] | None = None
) -> list[Regression]:
    """Regressions of the cells ``b`` against ``a`` (module docstring); ``runs``: the two runs'
    stored rows, to tell a cost change where nothing differs (the machine's) from one."""
    from harness.history.series import NOTHING_DIFFERS, what_differs

    out = bound_violations(b, bounds)
    a_rows = {_key(r): r for _, r in a.iterrows()}
    b_rows = {_key(r): r for _, r in b.iterrows()}
    for key, rb in b_rows.items():
        if key not in a_rows and rb["status"] == "crashed":
            scene, method, measure, dt = key
            out.append(
                Regression(
                    "new failure",
                    scene,
                    method,
                    measure,
                    dt,
                    "absent",
                    rb["status"],
                    f"{measure}: {rb['status']}: {rb['detail'] or ''}".rstrip(": "),
                )
            )
    b_scenes = {key[0] for key in b_rows}
    machine_only: dict[str, bool] = {}  # by family: nothing a cell of it depends on differs between the runs
    for key, ra in a_rows.items():
        scene, method, measure, dt = key
        rb = b_rows.get(key)
        if rb is None:
            # A scene with no cell at all in the newer run left the suite, it did not fail there: a
            # model file edited since (its id carries its content hash) or no longer listed.
            if ra["status"] == "ok" and scene in b_scenes:
                out.append(
                    Regression(
                        "new failure",
                        scene,
                        method,
                        measure,
                        dt,
                        "ok",
                        "missing",
                        f"{measure} cell missing from the newer run",
                    )
                )
            continue
        if ra["status"] == "ok" and rb["status"] not in ("ok", "timed_out"):
            out.append(
                Regression(
                    "new failure",
                    scene,
                    method,
                    measure,
                    dt,
                    "ok",
                    rb["status"],
                    f"{measure}: {rb['status']}: {rb['detail'] or ''}".rstrip(": "),
                )
            )
            continue
        if ra["status"] != "ok" or rb["status"] != "ok":
            continue
        declared = get(measure)  # the measure's own regression rule (records.measures), if it has one
        if declared is None or declared.regression is None:
            continue
        family = rb["family"]
        if family not in machine_only:
            machine_only[family] = (
                runs is not None and what_differs(*runs, family, deterministic=False) == NOTHING_DIFFERS
            )
        worse = declared.regression(Cell.from_row(ra), Cell.from_row(rb), Comparison(machine_only[family]))
        if worse is not None:
            out.append(Regression(worse.kind, scene, method, measure, dt, worse.before, worse.after, worse.detail))
    return out


NOT_MEASURED = "not measured"


def not_measured(b: pd.DataFrame, a: pd.DataFrame | None = None) -> list[Regression]:
    """The cells of run ``b`` that timed out (the run tried each such task once more first): not
    measured this run, each with what it was in run ``a`` where it was there. Never a regression."""
    before = {} if a is None else {_key(r): r for _, r in a.iterrows()}
    out = []
    for _, rb in b.iterrows():
        if rb["status"] != "timed_out":
            continue
        key = _key(rb)
        ra = before.get(key)
        was = "absent" if ra is None else ra["status"]
        out.append(
            Regression(
                NOT_MEASURED,
                key[0],
                key[1],
                key[2],
                key[3],
                was,
                "timed_out",
                f"{key[2]}: timed out ({rb['detail'] or 'no detail'}); "
                + ("new this run" if ra is None else f"{was} in the run before"),
            )
        )
    return out


def not_measured_runs(history: History, run_a: int | None, run_b: int) -> list[Regression]:
    """``not_measured`` of two stored runs (``run_a`` None: none before)."""
    return not_measured(history.cells(run_b), None if run_a is None else history.cells(run_a))


def compare_runs(
    history: History,
    run_a: int | None = None,
    run_b: int | None = None,
    bounds_path=bounds_mod.DEFAULT_PATH,
    trend=None,
) -> tuple[int | None, int, list[Regression]]:
    """Regressions of ``run_b`` (default: the latest complete run) against ``run_a`` (default: the
    complete run before it of the same suite and measurement version). With no earlier run, only the
    bounds are checked. Against the default run, once ``history.MIN_RUNS`` runs of the suite exist,
    cost is judged over the history (``harness.history.series``, its step detection; ``trend`` is that
    history if already loaded) instead of by the slowdown rule above, for every cost cell with
    that many measured points."""
    if run_b is None:
        runs = history.runs()
        if runs.empty:
            raise InvalidInput(f"no complete run stored in {history.path}")
        run_b = int(runs.run_id.iloc[-1])
    info_b = history.run(run_b)
    explicit_pair = run_a is not None
    if run_a is None:
        run_a = history.previous_complete(run_b)
    else:
        info_a = history.run(run_a)
        if info_a["measurement_version"] != info_b["measurement_version"]:
            raise InvalidInput(
                f"runs {run_a} and {run_b} have different measurement versions "
                f"({info_a['measurement_version']} vs {info_b['measurement_version']}): not comparable"
            )
        if info_a["suite"] != info_b["suite"]:
            raise InvalidInput(
                f"runs {run_a} and {run_b} ran different suites ({info_a['suite']} vs "
                f"{info_b['suite']}): not comparable"
            )
    bounds = bounds_mod.load(bounds_path)
    cells_b = history.cells(run_b)
    if run_a is None:
        return None, run_b, bound_violations(cells_b, bounds)
    regressions = compare_cells(history.cells(run_a), cells_b, bounds, runs=(history.run(run_a), info_b))
    if explicit_pair:
        return run_a, run_b, regressions
    if trend is None:
        from harness.history import series as history_mod

        trend = history_mod.load(history, run_id=run_b, measurement_version=int(info_b["measurement_version"]))
    if trend.judged:
        regressions = [
            r
            for r in regressions
            if not (
                r.kind == "slowdown"
                and trend.judges(_key({"scene": r.scene, "method": r.method, "measure": r.measure, "dt": r.dt}))
            )
        ]
        regressions += trend.regressions()
    return run_a, run_b, regressions


def regression_lines(regressions: list[Regression], unmeasured: list[Regression] = ()) -> list[str]:
    """The lines the CLI prints: one per regression, or that there were none; then one per cell
    not measured this run (timed out), counted apart."""
    lines = [f"REGRESSION {r.line()}" for r in regressions] or ["no regressions"]
    if unmeasured:
        lines.append(f"{len(unmeasured)} cell(s) not measured this run (timed out; not regressions):")
        lines += [f"NOT MEASURED {r.line()}" for r in unmeasured]
    return lines
