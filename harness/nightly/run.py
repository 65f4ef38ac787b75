"""The nightly comparison run: the matrix of scenes x methods, measured, stored, reported.

Flow: build the tasks (one per scene x method that supports it, plus one per reviewed
energy bound), longest first by the previous run's timings; run each in a reused, isolated
worker process (a crash, hang or blow-up becomes a recorded cell, and the cells measured
before a crash or hang are kept); store every cell as it arrives; compare with the previous
complete run of the suite, judging cost over the suite's history (``harness.history.series``); write
the report atomically, with the history and where the time went; and only then mark the run
complete.
"""
from __future__ import annotations

import datetime as dt_
import os
import platform
import sys
import time
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path

from records.cell import Cell
from scenarios import SCENES, make_scene

from harness.execution.environment import run_metadata
from harness.history import bounds as bounds_mod
from harness.history.compare import compare_runs
from harness.history.series import load as load_trend
from harness.methods import active_plugins, all_methods, load_plugins
from harness.history.storage import MEASUREMENT_VERSION, History
from harness.nightly.suites import SUITES, Suite

DEFAULT_DB = Path("results/history.sqlite")
DEFAULT_OUT = Path("results/latest")


@dataclass(frozen=True)
class Task:
    """A self-contained unit of work: everything a worker needs to produce its cells."""

    kind: str                  # "cell" (a scene x method) or "bound" (one reviewed energy bound)
    scene: str
    method: str
    family: str
    params: dict = field(default_factory=dict)
    suite: Suite | str = "standard"  # the Suite itself in the tasks a run builds (a name is looked up)
    dt: float | None = None
    steps: int | None = None
    bound: float | None = None
    plugins: tuple[str, ...] = ()  # plugin modules the worker loads before it looks the method up

    @property
    def label(self) -> str:
        extra = f" dt={self.dt:g} steps={self.steps}" if self.kind == "bound" else ""
        return f"{self.kind} {self.scene} {self.method}{extra}"

    def measures(self) -> list[str]:
        if self.kind == "bound":
            return ["bound"]
        from harness.nightly.cells import measures_for

        return measures_for(self)


def build_tasks(suite: Suite, bounds_path=bounds_mod.DEFAULT_PATH) -> tuple[list[Task], list[dict]]:
    """The matrix, and the (scene, method) pairs left out with why (unavailable / unsupported).
    Methods registered by ``$HARNESS_PLUGINS`` modules join every suite's matrix."""
    methods = all_methods()
    plugins = active_plugins()
    listed = methods if suite.methods is None else suite.methods
    chosen = tuple(dict.fromkeys((*listed, *load_plugins(plugins))))
    tasks, skipped = [], []
    for scene_id, spec in suite.scenes.items():
        scene = make_scene(scene_id, **spec.params)
        for mid in chosen:
            m = methods[mid]
            if mid in spec.skip:
                skipped.append({"scene": scene_id, "method": mid, "reason": f"left out on {scene_id} in the "
                                f"{suite.name} suite (harness/suites.py)"})
                continue
            ok, why = m.available()
            if ok:
                ok, why = m.supports(scene)
            if ok and spec.methods is not None and mid not in spec.methods:
                ok, why = False, f"not in the {suite.name} suite's selection for {scene_id}"
            if not ok:
                skipped.append({"scene": scene_id, "method": mid, "reason": why})
                continue
            tasks.append(Task("cell", scene_id, mid, m.family, dict(spec.params), suite, plugins=plugins))
    if suite.bounds:
        for b in bounds_mod.load(bounds_path):
            m = methods.get(b.method)
            if b.scene not in SCENES or m is None or not m.available()[0]:
                skipped.append({"scene": b.scene, "method": b.method, "reason": "bound's method unavailable"})
                continue
            tasks.append(Task("bound", b.scene, b.method, m.family, {}, suite, b.dt, b.steps, b.bound, plugins))
    return tasks, skipped


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
        from harness.execution.pool import WorkerPool

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

    chosen = resolve_scheduler(scheduler, jobs is not None)
    if chosen:
        return DaskExecutor(*chosen)
    return LocalExecutor(jobs or os.cpu_count() or 1)


# ----------------------------------------------------------------------------- progress
class Progress:
    """A bar on a terminal, plain lines otherwise (logs, CI)."""

    def __init__(self, total: int, stream=None):
        # Looked up at call time: a stream bound at import can be closed by then (pytest capture).
        stream = stream or sys.stderr
        self.total, self.done, self.stream = total, 0, stream
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.t0 = time.perf_counter()

    def update(self, task: Task, status: str, seconds: float):
        self.done += 1
        if self.tty:
            width = 30
            filled = int(width * self.done / max(self.total, 1))
            self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} "
                              f"{time.perf_counter() - self.t0:6.1f}s {task.scene} {task.method}"[:110].ljust(110))
            if self.done == self.total:
                self.stream.write("\n")
        else:
            self.stream.write(f"[{self.done}/{self.total}] {task.label}: {status} ({seconds:.1f}s)\n")
        self.stream.flush()


# ----------------------------------------------------------------------------- metadata
def now() -> str:
    return dt_.datetime.now(dt_.timezone.utc).isoformat(timespec="seconds")


# ----------------------------------------------------------------------------- the run
def previous_task_seconds(history: History, suite_name: str) -> dict[str, float]:
    """Seconds each task took in the latest complete run of the suite (for ``schedule``)."""
    runs = history.runs()
    runs = runs[runs.suite == suite_name]
    return dict(runs.timing.iloc[-1].get("task_s", {})) if not runs.empty else {}


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
    return {"cells_s": wall_cells, "worker_seconds_by_measure": dict(by_measure),
            "worker_seconds_by_family": dict(by_family), "numba_compile_s": kernels["compile_s"],
            "kernels_compiled": int(kernels["kernels_compiled"]), "kernels_loaded": int(kernels["kernels_loaded"]),
            "kernel_load_s": kernels["load_s"],
            "task_s": task_s, "task_cpu_s": task_cpu, "slowest_tasks": slowest,
            "worker_cpu_s": sum(known) if known else None,
            "tasks_without_cpu": len(task_cpu) - len(known)}


def report_run(history: History, run_id: int, out: Path, regressions=(), previous=None, timing=None,
               trend=None, jobs: int | None = None) -> Path:
    """The run's stored cells judged (``harness.judge``) and written as its report (``reports.markdown``),
    its charts drawn by ``jobs`` processes (default: one a core)."""
    from harness.judge import judge
    from reports.markdown import write_report

    cells = history.cell_records(run_id)
    judged = judge(cells, regressions=regressions, previous=previous, trend=trend)
    return write_report(history.run(run_id), cells, judged, out, timing=timing, trend=trend,
                        jobs=jobs or os.cpu_count() or 1)


def run_nightly(suite: str | Suite = "standard", out: Path = DEFAULT_OUT, db: Path = DEFAULT_DB,
                jobs: int | None = None, scheduler: str | None = None, bounds_path=bounds_mod.DEFAULT_PATH,
                progress_stream=None, cell_timeout: float | None = None) -> dict:
    """Run the suite (a name in ``SUITES``, or a ``Suite``), store every cell, compare with the
    previous complete run of the same suite, write the report, mark the run complete.
    ``cell_timeout`` (seconds per task) overrides the suite's."""
    from harness.nightly.cells import failed_cells

    suite = SUITES[suite] if isinstance(suite, str) else suite
    suite_name = suite.name
    timeout = suite.cell_timeout if cell_timeout is None else float(cell_timeout)
    t_start = time.perf_counter()
    cpu_start = time.process_time()
    tasks, skipped = build_tasks(suite, bounds_path)
    history = History(db)
    tasks = schedule(tasks, previous_task_seconds(history, suite_name))
    commit, versions, machine = run_metadata()
    executor = make_executor(jobs, scheduler)
    settings = {"suite": asdict(suite), "jobs": jobs, "executor": executor.describe(), "skipped": skipped,
                "cell_timeout": timeout, "plugins": list(active_plugins()),
                "bounds_file": str(bounds_path), "measurement_version": MEASUREMENT_VERSION}
    run_id = history.start_run(started=now(), suite=suite_name, git_commit=commit, versions=versions,
                               machine=machine, settings=settings)
    progress = Progress(len(tasks), progress_stream)
    cells_by_task: dict[str, list[Cell]] = {}
    t_cells = time.perf_counter()
    try:
        for task, result in executor.run(tasks, timeout):
            cells = result if isinstance(result, list) else failed_cells(task, result)
            for cell in cells:
                history.add_cell(run_id, cell)
            cells_by_task[task.label] = cells
            worst = next((c.status for c in cells if c.status != "ok"), "ok")
            progress.update(task, worst, sum(c.wall_s or 0.0 for c in cells))
    finally:
        executor.close()
    t_cells = time.perf_counter() - t_cells
    trend = load_trend(history, run_id=run_id)  # the suite's history, judged at this run
    run_a, _, regressions = compare_runs(history, None, run_id, bounds_path, trend=trend)
    timing = {"tasks": len(tasks), "executor": executor.describe(), "jobs": getattr(executor, "jobs", None),
              "cpus": os.cpu_count(), "workers_started": getattr(executor, "workers_started", None),
              **timing_summary(cells_by_task, getattr(executor, "task_stats", {}), t_cells)}
    timing["total_s"] = time.perf_counter() - t_start  # up to the report: what its footer can say
    timing["main_cpu_s"] = time.process_time() - cpu_start
    t_report = time.perf_counter()
    # The cells' workers are gone by now: as many chart processes as the cells had, at most one a core.
    chart_jobs = min(getattr(executor, "jobs", None) or os.cpu_count() or 1, os.cpu_count() or 1)
    report = report_run(history, run_id, out, regressions=regressions, previous=run_a, timing=timing, trend=trend,
                        jobs=chart_jobs)
    timing["report_s"] = time.perf_counter() - t_report
    timing["finished_s"] = time.perf_counter() - t_start
    history.finish_run(run_id, finished=now(), wall_s=timing["finished_s"], timing=timing,
                       regressions=len(regressions))
    return {"run_id": run_id, "previous": run_a, "regressions": regressions, "report": report, "timing": timing}
