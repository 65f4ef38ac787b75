"""The nightly comparison run: the matrix of scenes x methods, measured, stored, reported.

Flow: build the tasks (one per scene x method that supports it, plus one per reviewed
energy bound), longest first by the previous run's timings; run each in a reused, isolated
worker process (a crash, hang or blow-up becomes a recorded cell, and the cells measured
before a crash or hang are kept); store each task's cells as it ends, in one transaction with a
row saying the task is done; compare with the previous complete run of the suite, judging cost
over the suite's history (``harness.history.series``); measure every cell that would be reported
as a slowdown again in fresh processes, and judge again (``remeasure_slowdowns``); write the
report atomically, with the history and where the time went; and only then mark the run
complete. A run killed anywhere before that is continued by ``resume`` from the tasks it stored.
"""

from __future__ import annotations

import datetime as dt_
import math
import os
import platform
import time
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from records.cell import Cell
from records.run import RunSettings, RunTiming
from scenarios import SCENES, make_scene

from harness.execution.environment import run_metadata
from harness.execution.faults import checkpoint
from harness.history import bounds as bounds_mod
from harness.history.compare import compare_runs
from harness.history.series import load as load_trend
from harness.methods import active_plugins, all_methods, get_method, load_plugins
from harness.history.storage import MEASUREMENT_VERSION, History
from harness.nightly import cells as _cells  # noqa: F401 (registers the built-in measures the run reads)
from harness.nightly.progress import Progress, compile_line
from harness.nightly.suites import SUITES, Suite

DEFAULT_DB = Path("results/history.sqlite")
DEFAULT_OUT = Path("results/latest")


@dataclass(frozen=True)
class Task:
    """A self-contained unit of work: everything a worker needs to produce its cells."""

    kind: str  # "cell" (a scene x method), "bound" (one reviewed energy bound) or "cost"
    # (a cell's cost alone, measured again before a slowdown is reported)
    scene: str
    method: str
    family: str
    params: dict = field(default_factory=dict)
    suite: Suite | str = "standard"  # the Suite itself in the tasks a run builds (a name is looked up)
    dt: float | None = None
    steps: int | None = None
    bound: float | None = None
    plugins: tuple[str, ...] = ()  # plugin modules the worker loads before it looks the method up
    timings: dict | None = None  # injected timings (``harness.measures.cost``), the clock's if None
    source: str | None = None  # the file of a scene built from one (a model file)
    scene_id: str | None = None  # the scene's registry id where the cell's scene is named otherwise (a contact
    # scene by the parameters that differ: the ball at e = 1 is ball_e1)
    only: tuple[str, ...] = ()  # the measures the task measures where not every one that applies: a suite's
    # contact tables (harness.nightly.measures.contact_cells), ("contact",) for an
    # engine mode on a contact scene, ("penalty",) for a scheme on the penalty ground

    @property
    def label(self) -> str:
        extra = f" dt={self.dt:g} steps={self.steps}" if self.kind == "bound" else ""
        # A task of a suite's own table is named by its measure (``contact ball_e1 mujoco:rk4``).
        return f"{'+'.join(self.only) or self.kind} {self.scene} {self.method}{extra}"

    def measures(self) -> list[str]:
        if self.kind == "bound":
            return [self.kind]
        if self.only:
            return list(self.only)
        from harness.nightly.cells import measures_for

        return measures_for(self)


def build_tasks(
    suite: Suite, bounds_path=bounds_mod.DEFAULT_PATH, timings: dict | None = None
) -> tuple[list[Task], list[dict]]:
    """The matrix, and the (scene, method) pairs left out with why (unavailable / unsupported).
    Methods registered by ``$HARNESS_PLUGINS`` modules join every suite's matrix; ``timings``
    (injected, ``harness.measures.cost``) ride in every cell task."""
    methods = all_methods()
    plugins = active_plugins()
    listed = methods if suite.methods is None else suite.methods
    chosen = tuple(dict.fromkeys((*listed, *load_plugins(plugins))))
    tasks, skipped = [], []
    for scene_id, spec in suite.scenes.items():
        scene = make_scene(scene_id, source=spec.source, **spec.params)
        variants = {str(m.id): m for m in map(get_method, spec.with_options)}
        for mid in (*chosen, *variants):
            m = variants.get(mid) or methods[mid]
            if m.family in spec.cannot_load:
                skipped.append(
                    {
                        "scene": scene_id,
                        "method": mid,
                        "reason": f"{m.family} cannot load the file: {spec.cannot_load[m.family]}",
                    }
                )
                continue
            ok, why = m.available()
            if ok:
                ok, why = m.supports(scene)
            if ok and mid not in variants:  # a mode the scene cannot pose says why, not that it was left out
                why = suite.leaves_out(scene_id, m)
                ok = not why
            if not ok:
                skipped.append({"scene": scene_id, "method": mid, "reason": why})
                continue
            tasks.append(
                Task(
                    "cell",
                    scene_id,
                    mid,
                    m.family,
                    dict(spec.params),
                    suite,
                    plugins=plugins,
                    timings=timings,
                    source=spec.source,
                )
            )
    if suite.contact:
        tasks += contact_tasks(suite, plugins, skipped)
    if suite.bounds:
        for b in bounds_mod.load(bounds_path):
            m = methods.get(b.method)
            if b.scene not in SCENES or m is None or not m.available()[0]:
                skipped.append({"scene": b.scene, "method": b.method, "reason": "bound's method unavailable"})
                continue
            tasks.append(Task("bound", b.scene, b.method, m.family, {}, suite, b.dt, b.steps, b.bound, plugins))
    return tasks, skipped


def contact_scene_list(settings: dict) -> tuple:
    """The (scene id, parameters) a suite's contact settings run: its ``scenes``, or where that is
    None every registered contact scene at its defaults, each followed by the variants the settings'
    ``also`` names for it."""
    from scenarios import contact_scenes

    if settings.get("scenes") is not None:
        return tuple(settings["scenes"])
    also = settings.get("also") or {}
    return tuple((sid, params) for sid in contact_scenes() for params in ({}, *also.get(sid, ())))


def contact_tasks(suite: Suite, plugins: tuple, skipped: list) -> list[Task]:
    """The suite's contact tasks (``Suite.contact``): each engine mode it selects on each contact
    scene the mode poses (the ``contact`` measure), and each scheme on the penalty ground (the
    ``penalty`` measure). A task carries its scene's id and parameters as they are; its cell's
    scene is named by them (``cell_scene``), never parsed back."""
    from scenarios.contact import make_contact_scene

    from harness.contact.run import contact_modes
    from harness.nightly.measures.contact_cells import cell_scene

    settings, tasks = suite.contact, []
    known = contact_modes()
    for mode_id in settings.get("modes") or ():  # a mode the suite names that no engine declares
        if mode_id not in known:
            reason = f"no contact mode {mode_id} (valid: {', '.join(known)})"
            skipped.append({"scene": "contact", "method": mode_id, "reason": reason})
    for scene_id, params in contact_scene_list(settings):
        name = cell_scene(scene_id, params)
        for mode_id, mode in contact_modes().items():
            if settings.get("modes") is not None and mode_id not in settings["modes"]:
                continue
            ok, why = mode.available()
            if ok:
                ok, why = mode.supports(make_contact_scene(scene_id, **params))
            if not ok:
                skipped.append({"scene": name, "method": mode_id, "reason": why})
                continue
            tasks.append(
                Task(
                    "cell",
                    name,
                    mode_id,
                    mode.engine,
                    dict(params),
                    suite,
                    plugins=plugins,
                    scene_id=scene_id,
                    only=("contact",),
                )
            )
    for scheme in settings.get("penalty", ()):
        tasks.append(
            Task("cell", settings["penalty_scene"], scheme, "ref", {}, suite, plugins=plugins, only=("penalty",))
        )
    return tasks


def schedule(tasks: list[Task], expected_s: dict[str, float]) -> list[Task]:
    """Longest first, so that no long cell starts last and runs alone at the end: by the
    seconds each task took in the previous complete run of the suite (``expected_s``, by
    label); a task it did not have (a new scene or method) first of all, as it may be long."""
    unknown = max(expected_s.values(), default=0.0) + 1.0
    return sorted(tasks, key=lambda t: -expected_s.get(t.label, unknown))


# ----------------------------------------------------------------------------- executors
class LocalExecutor:
    """Runs the tasks in ``jobs`` reused worker processes (``harness.execution.pool.WorkerPool``):
    a worker that crashes or hangs costs its task, recorded as such, and is replaced; numba
    kernels a worker compiled for one task serve its later tasks (the explicit-Euler baseline
    every cost cell times beside its method, a scene's kernels shared by its tasks)."""

    def __init__(self, jobs: int):
        self.jobs = max(1, jobs)
        self.task_stats: dict[str, object] = {}  # label -> pool.CallStats
        self.workers_started = 0

    def describe(self) -> str:
        return f"local worker processes ({self.jobs} at a time) on {platform.node()}"

    def run(self, tasks: list[Task], timeout: float):
        from harness.nightly.cells import run_task
        from harness.execution.isolation import engine_modules, preload_engines
        from harness.execution.pool import WorkerPool

        preload_engines(engine_modules(t.method for t in tasks))
        with WorkerPool(self.jobs) as pool, ThreadPoolExecutor(self.jobs) as threads:
            futures = {threads.submit(pool.call_with_stats, run_task, (t,), timeout=timeout): t for t in tasks}
            try:
                for fut in as_completed(futures):
                    result, stats = fut.result()
                    self.task_stats[futures[fut].label] = stats
                    yield futures[fut], result
            finally:
                for fut in futures:
                    fut.cancel()
                self.workers_started = pool.started

    def close(self):
        pass


def make_executor(jobs: int | None, scheduler: str | None):
    """A Dask cluster for ``--scheduler`` (else ``$HARNESS_SCHEDULER``, unless ``--jobs`` was given),
    local worker processes otherwise; see ``harness.execution.distributed``."""
    from harness.execution.distributed import DaskExecutor, resolve_scheduler
    from harness.nightly.cells import run_task

    chosen = resolve_scheduler(scheduler, jobs is not None)
    if chosen:
        return DaskExecutor(*chosen, run_task=run_task)
    return LocalExecutor(jobs or os.cpu_count() or 1)


# ----------------------------------------------------------------------------- metadata
def now() -> str:
    return dt_.datetime.now(dt_.UTC).isoformat(timespec="seconds")


# ----------------------------------------------------------------------------- the run
def previous_task_seconds(history: History, suite_name: str) -> dict[str, float]:
    """Seconds each task took in the latest complete run of the suite (for ``schedule``)."""
    runs = history.runs()
    runs = runs[runs.suite == suite_name]
    return dict(RunTiming.of(runs.timing.iloc[-1]).task_s) if not runs.empty else {}


def timing_summary(cells_by_task: dict[str, list[Cell]], stats: dict, wall_cells: float) -> dict:
    """Where the cells' time went: worker seconds by measure, by family, numba compilation
    (kernels compiled, and kernels loaded from the disk cache instead), per task (wall in the
    parent, CPU in the worker) and the slowest tasks."""
    by_measure, by_family = defaultdict(float), defaultdict(float)
    task_s, task_cpu = {}, {}
    kernels = defaultdict(float)  # compiled / loaded from the disk cache, and their seconds
    for label, cells in cells_by_task.items():
        for c in cells:
            w = c.wall_s or 0.0
            by_measure[c.measure] += w
            by_family[c.family] += w
            for k, v in (c.kernels or {}).items():
                kernels[k] += v
        st = stats.get(label)
        task_s[label] = st.wall_s if st is not None else sum(c.wall_s or 0.0 for c in cells)
        task_cpu[label] = st.cpu_s if st is not None else None
    known = [v for v in task_cpu.values() if v is not None]
    slowest = sorted(task_s.items(), key=lambda kv: -kv[1])[:5]
    return {
        "cells_s": wall_cells,
        "worker_seconds_by_measure": dict(by_measure),
        "worker_seconds_by_family": dict(by_family),
        "numba_compile_s": kernels["compile_s"],
        "kernels_compiled": int(kernels["kernels_compiled"]),
        "kernels_loaded": int(kernels["kernels_loaded"]),
        "kernel_load_s": kernels["load_s"],
        "numba_s": kernels["numba_s"],
        "task_s": task_s,
        "task_cpu_s": task_cpu,
        "slowest_tasks": slowest,
        "worker_cpu_s": sum(known) if known else None,
        "tasks_without_cpu": len(task_cpu) - len(known),
    }


def report_run(
    history: History,
    run_id: int,
    out: Path,
    regressions=(),
    previous=None,
    timing=None,
    trend=None,
    jobs: int | None = None,
) -> Path:
    """The run's stored cells judged (``harness.judge``) and written as its report (``reports.markdown``),
    its charts drawn by ``jobs`` processes (default: one a core)."""
    from harness.judge import judge
    from reports.markdown import write_report

    cells = history.cell_records(run_id)
    judged = judge(cells, regressions=regressions, previous=previous, trend=trend)
    return write_report(
        history.run(run_id),
        cells,
        judged,
        out,
        timing=timing,
        trend=trend,
        jobs=jobs or os.cpu_count() or 1,
        before_write=lambda: checkpoint("report"),
        extra=version_change_lines(history, run_id),
    )


def version_change_lines(history: History, run_id: int) -> list[str]:
    """Where the suite's previous complete run ran other engine releases: the version change, said
    as one (this run starts another series: ``harness.history.storage.engine_series``), with what
    changed in each upgraded engine's cells (``reports.versions_section``)."""
    from harness.history.storage import engine_series
    from reports.versions_section import between_versions_section

    last = history.previous_complete(run_id, same_engines=False)
    if last is None:
        return []
    before = dict(engine_series(history.run(last)["versions"]))
    now_ = dict(engine_series(history.run(run_id)["versions"]))
    changed = sorted(d for d in set(before) | set(now_) if before.get(d) != now_.get(d))
    if not changed:
        return []
    said = ", ".join(f"{d} {before.get(d)} → {now_.get(d)}" for d in changed)
    lines = [
        "## Engine versions changed",
        "",
        f"Run {last}, the suite's previous complete run, ran other engine releases ({said}): this run starts "
        "their series, so nothing is compared as a regression across the change; what the change did is below.",
        "",
    ]
    old_cells, new_cells = history.cell_records(last), history.cell_records(run_id)
    from adapters import ENGINES

    for d in changed:
        if before.get(d) and now_.get(d):
            # the engine whose numbers depend on the distribution (Warp's are Newton's)
            family = next((e.id for e in ENGINES.values() if d in e.dists), d)
            label = (lambda v: v) if family == d else (lambda v, d=d: f"({d} {v})")
            lines += between_versions_section(family, [(label(before[d]), old_cells), (label(now_[d]), new_cells)])
    return lines


def _resumable(history: History, suite_name: str, identity: dict) -> tuple[int, dict]:
    """The run ``--resume`` continues: the suite's latest run, if it is incomplete and was
    measured as this one would be (``identity``: commit and code, versions, platform, settings);
    else an ``InvalidInput`` saying what stands in the way."""
    from records import InvalidInput

    runs = history.runs(complete_only=False)
    runs = runs[runs.suite == suite_name]
    if runs.empty:
        raise InvalidInput(f"--resume: no {suite_name} run in {history.path} to resume (run without --resume)")
    last = runs.iloc[-1]
    run_id = int(last.run_id)
    if int(last.complete):
        raise InvalidInput(
            f"--resume: the latest {suite_name} run in {history.path}, run {run_id}, is complete: "
            f"nothing to resume (run without --resume)"
        )
    stored = {
        "commit": last.git_commit,
        "versions": last.versions,
        "machine": _platform(last.machine),
        "measurement version": int(last.measurement_version),
        **{k: last.settings.get(k) for k in _RESUME_SETTINGS},
    }
    differs = [k for k in identity if _plain(stored.get(k)) != _plain(identity[k])]
    if differs:
        what = "; ".join(f"{k}: {stored.get(k)!r} then, {identity[k]!r} now" for k in differs)
        raise InvalidInput(
            f"--resume: run {run_id} was measured otherwise ({what[:400]}): its cells are not "
            f"mixed with these; run without --resume to start a new run"
        )
    return run_id, last.settings


#: The run settings a resumed run must share with the run it continues.
_RESUME_SETTINGS = ("suite", "cell_timeout", "plugins", "bounds_file", "code_digest", "injected_timings")


def _platform(machine: dict) -> dict:
    return {k: (machine or {}).get(k) for k in ("node", "system", "machine", "processor", "cpus")}


def _plain(x):
    import json

    return json.loads(json.dumps(x, default=str))


def engine_versions() -> dict[str, str | None]:
    """{distribution: installed version} of every distribution an engine's numbers depend on (each
    ``adapters.ENGINES`` entry's ``dists``: the engine's own and what it computes through, Newton's
    Warp): the run's series (``harness.history.storage.engine_series``), so that a Warp release
    alone starts a series as an engine's does."""
    from adapters import ENGINE_DISTS, engine_version

    return {dist: engine_version(dist) for dist in sorted(ENGINE_DISTS)}


def run_nightly(
    suite: str | Suite = "standard",
    out: Path = DEFAULT_OUT,
    db: Path = DEFAULT_DB,
    jobs: int | None = None,
    scheduler: str | None = None,
    bounds_path=bounds_mod.DEFAULT_PATH,
    progress_stream=None,
    cell_timeout: float | None = None,
    resume: bool = False,
    timings=None,
) -> dict:
    """Run the suite (a name in ``SUITES``, or a ``Suite``), store every task's cells as it ends,
    compare with the previous complete run of the same suite, write the report, mark the run
    complete. ``cell_timeout`` (seconds per task) overrides the suite's. ``resume``: continue the
    suite's latest run, left incomplete by a kill, running only the tasks it has not stored
    (``_resumable`` says when it cannot). ``timings``: an injected-timings file
    (``harness.measures.cost``; default ``$HARNESS_INJECT_TIMINGS``), recorded in the run."""
    from harness.execution.environment import code_digest, machine_busy_s, plugin_versions
    from harness.measures.injected import INJECT_VAR, load_injected
    from harness.nightly.cells import failed_cells
    from harness.nightly.kernels import plan as kernel_plan

    suite = SUITES[suite] if isinstance(suite, str) else suite
    suite_name = suite.name
    timeout = suite.cell_timeout if cell_timeout is None else float(cell_timeout)
    t_start = time.perf_counter()
    cpu_start = time.process_time()
    injected = load_injected(timings)
    tasks, skipped = build_tasks(suite, bounds_path, injected)
    history = History(db)
    commit, versions, machine = run_metadata()
    versions = {**versions, **plugin_versions(active_plugins()), "engines": engine_versions()}
    executor = make_executor(jobs, scheduler)
    settings = {
        "suite": asdict(suite),
        "jobs": jobs,
        "executor": executor.describe(),
        "skipped": skipped,
        "cell_timeout": timeout,
        "plugins": list(active_plugins()),
        "bounds_file": str(bounds_path),
        "measurement_version": MEASUREMENT_VERSION,
        "code_digest": code_digest(),
        "injected_timings": None
        if injected is None
        else {"file": str(timings or os.environ.get(INJECT_VAR)), **injected},
    }
    carried: dict[str, tuple] = {}
    if resume:
        identity = {
            "commit": commit,
            "versions": versions,
            "machine": _platform(machine),
            "measurement version": MEASUREMENT_VERSION,
            **{k: settings[k] for k in _RESUME_SETTINGS},
        }
        run_id, stored_settings = _resumable(history, suite_name, identity)
        carried = history.done_tasks(run_id)
        attempts = [*RunSettings.of(stored_settings).resumed, {"at": now(), "tasks_carried": len(carried)}]
        history.update_settings(run_id, {**stored_settings, "resumed": attempts})
    else:
        run_id = history.start_run(
            started=now(), suite=suite_name, git_commit=commit, versions=versions, machine=machine, settings=settings
        )
    to_run = schedule([t for t in tasks if t.label not in carried], previous_task_seconds(history, suite_name))
    progress = Progress(len(to_run), progress_stream)
    plan = None
    if isinstance(executor, LocalExecutor):  # a cluster's workers keep caches of their own
        plan = kernel_plan(to_run, suite)
        progress.say(plan.line())
    cells_by_task: dict[str, list[Cell]] = {}
    busy0, t_cells = machine_busy_s(), time.perf_counter()
    retried: list[str] = []

    def store(task, cells):
        stats = getattr(executor, "task_stats", {}).get(task.label)
        history.add_task_cells(
            run_id,
            task.label,
            cells,
            getattr(stats, "wall_s", None),
            getattr(stats, "cpu_s", None),
            before_commit=lambda: checkpoint("store"),
        )
        cells_by_task[task.label] = cells
        worst = next((c.status for c in cells if c.status != "ok"), "ok")
        progress.update(task, worst, sum(c.wall_s or 0.0 for c in cells), cells)

    try:
        again = []
        for task, result in executor.run(to_run, timeout):
            cells = result if isinstance(result, list) else failed_cells(task, result)
            if any(c.status == "timed_out" for c in cells):  # tried once more before it is stored
                again.append(task)
                continue
            store(task, cells)
        if again:
            progress.say(f"{len(again)} task(s) timed out: each run once more")
        for task, result in executor.run(again, timeout) if again else ():
            retried.append(task.label)
            store(task, result if isinstance(result, list) else failed_cells(task, result))
    finally:
        executor.close()
    t_cells = time.perf_counter() - t_cells
    busy1 = machine_busy_s()
    stats = dict(getattr(executor, "task_stats", {}))
    if carried:  # the tasks an earlier attempt stored: their cells and seconds, as stored
        stored = history.cell_records(run_id)
        for t in tasks:
            if t.label in carried:
                cells_by_task[t.label] = [c for c in stored if _of_task(c, t)]
                if carried[t.label][0] is not None:
                    stats[t.label] = _Stored(*carried[t.label])
    trend = load_trend(history, run_id=run_id)  # the suite's history, judged at this run
    run_a, _, regressions = compare_runs(history, None, run_id, bounds_path, trend=trend)
    remeasured = remeasure_slowdowns(history, run_id, tasks, regressions, timeout, getattr(executor, "jobs", 1))
    if remeasured:  # judged again on the cells as re-measured
        trend = load_trend(history, run_id=run_id)
        run_a, _, regressions = compare_runs(history, None, run_id, bounds_path, trend=trend)
    timing = {
        "tasks": len(tasks),
        "executor": executor.describe(),
        "jobs": getattr(executor, "jobs", None),
        "cpus": os.cpu_count(),
        "workers_started": getattr(executor, "workers_started", None),
        **timing_summary(cells_by_task, stats, t_cells),
    }
    timing["remeasured"] = remeasured
    timing["retried"] = retried  # tasks that timed out and were run once more
    timing["kernel_plan"] = asdict(plan) if plan is not None else None
    progress.say(compile_line(RunTiming.of(timing)))
    timing["machine_busy"] = _others_share(
        busy0, busy1, t_cells, cells_by_task, stats, set(carried), time.process_time() - cpu_start
    )
    if resume:
        timing["resumed"] = {
            "attempts": len(RunSettings.of(history.run(run_id)["settings"]).resumed),
            "tasks_carried": len(carried),
            "tasks_run": len(to_run),
        }
    timing["total_s"] = time.perf_counter() - t_start  # up to the report: what its footer can say
    timing["main_cpu_s"] = time.process_time() - cpu_start
    t_report = time.perf_counter()
    # The cells' workers are gone by now: as many chart processes as the cells had, at most one a core.
    chart_jobs = min(getattr(executor, "jobs", None) or os.cpu_count() or 1, os.cpu_count() or 1)
    report = report_run(
        history, run_id, out, regressions=regressions, previous=run_a, timing=timing, trend=trend, jobs=chart_jobs
    )
    timing["report_s"] = time.perf_counter() - t_report
    timing["finished_s"] = time.perf_counter() - t_start
    history.finish_run(run_id, finished=now(), wall_s=timing["finished_s"], timing=timing, regressions=len(regressions))
    from harness.history.compare import not_measured_runs

    return {
        "run_id": run_id,
        "previous": run_a,
        "regressions": regressions,
        "not_measured": not_measured_runs(history, run_a, run_id),
        "report": report,
        "timing": timing,
    }


#: Fresh worker processes a flagged cost cell is measured in again before its slowdown is reported.
REMEASURES = 3
#: The expected range of n gaussian draws, in standard deviations (the d2 of control charts): the
#: re-measured ratios' range, in log units, over it is the cell's process-to-process noise.
RANGE_IN_SIGMAS = {2: 1.128, 3: 1.693, 4: 2.059, 5: 2.326, 6: 2.534}
#: The most cells re-measured in one run (a run where everything slowed needs no confirmation cell by cell).
MAX_REMEASURED = 12


def remeasure_slowdowns(
    history: History, run_id: int, tasks: list[Task], regressions, timeout: float, jobs: int | None
) -> dict[str, list[float]]:
    """Each cost cell the verdict would call a slowdown, measured again ``REMEASURES`` times, each
    in a fresh worker process, before the verdict (asv re-runs a benchmark before it reports a
    regression). One process's figure can sit well away from another's with nothing changed (where
    the allocator and the compiled code land: ``harness.history.compare``, docs/performance.md), which one night's
    repeats, all in one process, cannot show. The stored cell becomes the median of the first
    measurement and the re-measurements, its spread theirs, and their range the cell's
    process-to-process noise (``process_noise``, log units), which the history takes as the
    least noise the cell's step detection may assume: judged against the noise measured now. Returns {cell label: the
    ratios, first one first}."""
    from concurrent.futures import ThreadPoolExecutor

    from harness.execution.isolation import run_in_worker
    from harness.nightly.cells import run_task

    flagged = [r for r in regressions if r.kind == "slowdown" and r.measure == "cost"][:MAX_REMEASURED]
    by_cell = {(t.scene, t.method): t for t in tasks if t.kind == "cell" and not t.only}
    todo = [by_cell[(r.scene, r.method)] for r in flagged if (r.scene, r.method) in by_cell]
    if not todo:
        return {}
    again = [
        Task(
            "cost",
            t.scene,
            t.method,
            t.family,
            t.params,
            t.suite,
            plugins=t.plugins,
            timings=t.timings,
            source=t.source,
        )
        for t in todo
        for _ in range(REMEASURES)
    ]
    with ThreadPoolExecutor(max(1, jobs or 1)) as threads:
        results = list(threads.map(lambda t: run_in_worker(run_task, (t,), timeout=timeout), again))
    out = {}
    stored = history.cells(run_id)
    for i, t in enumerate(todo):
        rows = stored[(stored.scene == t.scene) & (stored.method == t.method) & (stored.measure == "cost")]
        if rows.empty or rows.iloc[0]["status"] != "ok":
            continue
        cell = Cell.from_row(rows.iloc[0].to_dict())
        f = cell.figures
        first = f.first_ratio if f.first_ratio is not None else f.ratio_to_explicit_euler
        cells = [r[0] for r in results[i * REMEASURES : (i + 1) * REMEASURES] if isinstance(r, list) and r]
        again_ratios = [c.figures.ratio_to_explicit_euler for c in cells if c.ok]
        ratios = [float(x) for x in (first, *again_ratios) if x]
        if first is None or len(ratios) < 2:
            continue
        cell.figures = replace(
            f,
            first_ratio=float(first),
            remeasured_ratios=ratios[1:],
            process_noise=math.log(max(ratios) / min(ratios)) / RANGE_IN_SIGMAS[len(ratios)],
            ratio_to_explicit_euler=float(np.median(ratios)),
            ratio_spread=max(float(f.ratio_spread or 0.0), (max(ratios) - min(ratios)) / min(ratios)),
        )
        history.add_cell(run_id, cell)
        out[t.label] = ratios
    return out


@dataclass(frozen=True)
class _Stored:
    """A carried task's seconds, as its attempt stored them (``pool.CallStats``'s two figures)."""

    wall_s: float | None
    cpu_s: float | None


def _of_task(cell: Cell, task: Task) -> bool:
    """Whether a stored cell is one of ``task``'s: a bound task's one ``bound`` cell, a cell task's
    every other cell of its scene and method."""
    if cell.scene != task.scene or cell.method != task.method:
        return False
    if task.kind == "bound":
        return cell.measure == "bound" and cell.dt is not None and round(cell.dt, 15) == round(task.dt, 15)
    if task.only:
        return cell.measure in task.only
    return cell.measure != "bound"


def _others_share(
    busy0, busy1, wall_s: float, cells_by_task: dict, stats: dict, carried: set, main_cpu_s: float
) -> float | None:
    """The share of the machine's CPU that other processes took while the cells ran: its busy
    seconds (``/proc/stat``) less the workers' and this process's, over wall x cores."""
    if busy0 is None or busy1 is None or wall_s <= 0:
        return None
    ours = main_cpu_s + sum(
        getattr(stats.get(label), "cpu_s", None) or 0.0 for label in cells_by_task if label not in carried
    )
    return max(0.0, (busy1 - busy0 - ours) / (wall_s * (os.cpu_count() or 1)))
