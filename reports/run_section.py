"""The report's last parts: the appendix (versions and settings, each engine mode's settings as
recorded) and the footer (the run, and where its time went)."""

from __future__ import annotations

from records.cell import Cell
from records.run import RunRecord, RunTiming

from .text import of_measure as _of


def appendix(run: RunRecord, cells: list[Cell]) -> list[str]:
    lines = ["## Appendix: versions and settings", "", "| package | version |", "|---|---|"]
    for pkg, ver in sorted(run.versions.items()):
        if isinstance(ver, dict):  # the engines' versions again, as the run's series
            continue
        lines.append(f"| {pkg} | {ver or 'not installed'} |")
    lines += ["", "Settings each engine adapter used (as the adapter recorded them):", ""]
    seen = set()
    engine_runs = sorted((c for c in _of(cells, "energy") if c.family != "ref"), key=lambda c: (c.method, c.scene))
    for r in engine_runs:
        settings = r.figures.settings
        key = (r.method, r.scene)
        if settings is None or key in seen:
            continue
        seen.add(key)
        items = "; ".join(f"{k}={v}" for k, v in settings.items()) if isinstance(settings, dict) else str(settings)
        lines.append(f"- `{r.method}` on `{r.scene}` ({r.figures.engine_version}): {items}")
    if not seen:
        lines.append("- none recorded: no engine run finished in this run")
    settings = run.settings
    suite = settings.suite
    if suite:
        lines += ["", "The suite's settings:", ""]
        for scene, spec in suite["scenes"].items():
            lines.append(f"- `{scene}`: " + "; ".join(f"{k}={v}" for k, v in spec.items()))
        rest = {k: v for k, v in suite.items() if k not in ("name", "scenes")}
        rest["cell_timeout"] = settings.cell_timeout if settings.cell_timeout is not None else rest["cell_timeout"]
        if settings.plugins:
            rest["plugins"] = ",".join(settings.plugins)
        lines.append("- " + "; ".join(f"{k}={v}" for k, v in rest.items()))
    skipped = settings.skipped
    if skipped:
        lines += ["", "Left out of the matrix:", ""]
        lines += [f"- `{s['method']}` on `{s['scene']}`: {s['reason']}" for s in skipped]
    return lines + [""]


def footer(run: RunRecord, timing: RunTiming) -> list[str]:
    lines = ["---", ""]
    executor = timing.executor if timing.executor is not None else (run.settings.executor or "?")
    lines.append(
        f"Run {run.run_id} ({run.suite} suite), started {run.started}, commit "
        f"`{run.git_commit or 'unknown'}`, measurement version {run.measurement_version}. "
        f"Cells ran on: {executor}."
    )
    if timing.resumed:
        r = timing.resumed
        lines += [
            "",
            f"Resumed: this run was killed and continued {r.get('attempts', 1)} time(s); "
            f"{r.get('tasks_carried', 0)} task(s) carried as the killed attempt stored them, "
            f"{r.get('tasks_run', 0)} run by the last attempt. Its wall and CPU times below are the "
            f"last attempt's, its worker seconds every attempt's.",
        ]
    if timing.total_s is not None:
        lines += [""] + where_the_time_went(timing) + kernel_cache(timing)
    if timing.machine_busy is not None:
        lines += [
            "",
            f"Other processes took {timing.machine_busy:.0%} of the machine's CPU while the cells ran "
            f"(/proc/stat, less the harness's own).",
        ]
    return lines + [""]


def _by(d: dict, n: int = 8) -> str:
    return ", ".join(f"{k} {v:.1f}s" for k, v in sorted(d.items(), key=lambda kv: -kv[1])[:n]) or "–"


def _kernels_phrase(timing: RunTiming) -> str:
    """How much of the workers' CPU compiled kernels, and how many came from the disk cache."""
    compiled, loaded = timing.kernels_compiled, timing.kernels_loaded
    if compiled is None:  # a run stored before kernels were cached
        return (
            f", {timing.numba_compile_s:.1f}s of it numba compiling the timing kernels"
            if timing.numba_compile_s
            else ""
        )
    if not compiled and not loaded:
        return ""
    share = timing.compile_share
    return (
        f", {timing.numba_compile_s or 0.0:.1f}s of it numba compiling {compiled} (scheme, scene) "
        f"kernels"
        + (f" ({share:.0%} of it)" if share is not None and compiled else "")
        + f", {loaded} more loaded from the disk cache in {timing.kernel_load_s:.1f}s"
    )


def kernel_cache(timing: RunTiming) -> list[str]:
    """What compiling cost this run and what a kept kernel cache would have saved; what the run
    expected to compile before it started."""
    plan = timing.kernel_plan
    if not timing.kernels_compiled and not plan:
        return []
    line = ""
    if timing.kernels_compiled:
        workers = timing.worker_cpu_s / timing.cells_s if timing.worker_cpu_s and timing.cells_s else 1.0
        saved = timing.cache_would_save_s
        line = (
            f"Kernel cache: a cache holding the {timing.kernels_compiled} kernels compiled here would have "
            f"saved about {saved:.0f} CPU-s (about {saved / max(workers, 1.0):.0f}s of wall at "
            f"{workers:.2f} workers busy)."
        )
        if timing.numba_s and timing.numba_s > 1.05 * (timing.numba_compile_s or 0.0):
            line += f" numba's own compile events add up to {timing.numba_s:.1f}s in all."
    if plan:
        # A run stored before each pair had one loop planned its timing and counted loops apart.
        expected = plan["compile"] if "compile" in plan else plan["timing"] + plan["counted"]
        line += f" Before the run: about {expected} kernels to compile; cache `{plan['cache']}`."
    return ["", line.strip()]


def where_the_time_went(timing: RunTiming) -> list[str]:
    """The footer's account of the run's time: wall against the CPU the workers spent, and
    where the worker seconds went (by measure, by family, numba compilation, slowest tasks)."""
    total, cells_s, jobs = timing.total_s or 0.0, timing.cells_s, timing.jobs
    tasks = "?" if timing.tasks is None else timing.tasks
    cpus = "?" if timing.cpus is None else timing.cpus
    lines = [
        f"Wall time {total:.1f}s to this report, {cells_s:.1f}s of it running {tasks} tasks"
        + (f" in {jobs} worker processes on {cpus} cores" if jobs else "")
        + "."
    ]
    cpu = timing.worker_cpu_s
    if cpu is not None:
        busy = f" (on average {cpu / cells_s:.2f} workers busy)" if cells_s > 0 else ""
        lost = timing.tasks_without_cpu or 0
        lines[-1] += (
            f" CPU time in the workers {cpu:.1f}s{busy}"
            + (f", not counting {lost} task(s) whose worker was lost" if lost else "")
            + _kernels_phrase(timing)
            + f"; in the main process {timing.main_cpu_s:.1f}s."
        )
    lines += [
        "",
        f"Worker seconds by measure: {_by(timing.worker_seconds_by_measure)}.",
        "",
        f"By family: {_by(timing.worker_seconds_by_family)}.",
    ]
    if timing.slowest_tasks:
        lines += ["", "Slowest tasks: " + ", ".join(f"{label} {sec:.1f}s" for label, sec in timing.slowest_tasks) + "."]
    return lines


# ----------------------------------------------------------------------------- the report
