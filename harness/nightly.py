"""The nightly comparison run: the matrix of scenes x methods, measured, stored, reported.

Flow: build the tasks (one per scene x method that supports it, plus one per reviewed
energy bound), run each task in an isolated worker (a crash, hang or blow-up becomes a
recorded cell), store every cell as it arrives, compare with the previous complete run,
write the report atomically, and only then mark the run complete.
"""
from __future__ import annotations

import datetime as dt_
import os
import platform
import subprocess
import sys
import time
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path

from scenarios import SCENES, make_scene

from . import bounds as bounds_mod
from .compare import compare_runs
from .methods import all_methods
from .storage import MEASUREMENT_VERSION, History
from .suites import SUITES, Suite

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
    suite: str = "standard"
    dt: float | None = None
    steps: int | None = None
    bound: float | None = None

    @property
    def label(self) -> str:
        extra = f" dt={self.dt:g} steps={self.steps}" if self.kind == "bound" else ""
        return f"{self.kind} {self.scene} {self.method}{extra}"

    def measures(self) -> list[str]:
        if self.kind == "bound":
            return ["bound"]
        from .cells import measures_for

        return measures_for(self)


def build_tasks(suite: Suite, bounds_path=bounds_mod.DEFAULT_PATH) -> tuple[list[Task], list[dict]]:
    """The matrix, and the (scene, method) pairs left out with why (unavailable / unsupported)."""
    methods = all_methods()
    chosen = suite.methods or tuple(methods)
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
            tasks.append(Task("cell", scene_id, mid, m.family, dict(spec.params), suite.name))
    if suite.bounds:
        for b in bounds_mod.load(bounds_path):
            m = methods.get(b.method)
            if b.scene not in SCENES or m is None or not m.available()[0]:
                skipped.append({"scene": b.scene, "method": b.method, "reason": "bound's method unavailable"})
                continue
            tasks.append(Task("bound", b.scene, b.method, m.family, {}, suite.name, b.dt, b.steps, b.bound))
    return tasks, skipped


# ----------------------------------------------------------------------------- executors
class LocalExecutor:
    """Runs each task in its own worker process (``harness.isolation``), ``jobs`` at a time."""

    def __init__(self, jobs: int):
        self.jobs = max(1, jobs)

    def describe(self) -> str:
        return f"local worker processes ({self.jobs} at a time) on {platform.node()}"

    def run(self, tasks: list[Task], timeout: float):
        from .cells import run_task
        from .isolation import run_in_worker

        with ThreadPoolExecutor(self.jobs) as pool:
            futures = {pool.submit(run_in_worker, run_task, (t,), timeout=timeout): t for t in tasks}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()

    def close(self):
        pass


def make_executor(jobs: int | None, scheduler: str | None):
    """A Dask cluster for ``--scheduler`` (else ``$HARNESS_SCHEDULER``, unless ``--jobs`` was given),
    local worker processes otherwise; see ``harness.distributed``."""
    from .distributed import DaskExecutor, resolve_scheduler

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
def run_metadata() -> tuple[str | None, dict, dict]:
    from importlib import metadata

    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10,
                                cwd=Path(__file__).resolve().parent).stdout.strip() or None
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True, timeout=10, cwd=Path(__file__).resolve().parent).stdout.strip()
        if commit and dirty:
            commit += "+dirty"
    except (OSError, subprocess.SubprocessError):
        commit = None
    versions = {"python": platform.python_version()}
    for pkg in ("integrator-harness", "numpy", "scipy", "numba", "pandas", "matplotlib",
                "mujoco", "pybullet", "pymunk", "rebound", "dask", "distributed"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    machine = {"node": platform.node(), "system": platform.system(), "release": platform.release(),
               "machine": platform.machine(), "processor": platform.processor(), "cpus": os.cpu_count()}
    return commit, versions, machine


def now() -> str:
    return dt_.datetime.now(dt_.timezone.utc).isoformat(timespec="seconds")


# ----------------------------------------------------------------------------- the run
def run_nightly(suite_name: str = "standard", out: Path = DEFAULT_OUT, db: Path = DEFAULT_DB, jobs: int | None = None,
                scheduler: str | None = None, bounds_path=bounds_mod.DEFAULT_PATH, progress_stream=None) -> dict:
    from .cells import failed_cells, finalize_cells
    from reports.markdown import write_report

    suite = SUITES[suite_name]
    t_start = time.perf_counter()
    tasks, skipped = build_tasks(suite, bounds_path)
    history = History(db)
    commit, versions, machine = run_metadata()
    executor = make_executor(jobs, scheduler)
    settings = {"suite": asdict(suite), "jobs": jobs, "executor": executor.describe(), "skipped": skipped,
                "bounds_file": str(bounds_path), "measurement_version": MEASUREMENT_VERSION}
    run_id = history.start_run(started=now(), suite=suite_name, git_commit=commit, versions=versions,
                               machine=machine, settings=settings)
    progress = Progress(len(tasks), progress_stream)
    time_by = defaultdict(float)
    t_cells = time.perf_counter()
    try:
        for task, result in executor.run(tasks, suite.cell_timeout):
            cells = result if isinstance(result, list) else failed_cells(task, result)
            for cell in cells:
                history.add_cell(run_id, cell)
                time_by[f"{cell['family']}:{cell['measure']}"] += cell.get("wall_s") or 0.0
            worst = next((c["status"] for c in cells if c["status"] != "ok"), "ok")
            progress.update(task, worst, sum(c.get("wall_s") or 0.0 for c in cells))
    finally:
        executor.close()
    t_cells = time.perf_counter() - t_cells
    finalize_cells(history, run_id)
    run_a, _, regressions = compare_runs(history, None, run_id, bounds_path)
    wall = time.perf_counter() - t_start
    timing = {"total_s": wall, "cells_s": t_cells, "worker_seconds_by_measure": dict(time_by),
              "tasks": len(tasks), "executor": executor.describe()}
    t_report = time.perf_counter()
    report = write_report(history, run_id, out, regressions=regressions, previous=run_a, timing=timing)
    timing["report_s"] = time.perf_counter() - t_report
    timing["total_s"] = time.perf_counter() - t_start
    history.finish_run(run_id, finished=now(), wall_s=timing["total_s"], timing=timing, regressions=len(regressions))
    return {"run_id": run_id, "previous": run_a, "regressions": regressions, "report": report, "timing": timing}
