"""What every nightly cell is built with, for ``cells`` (the measures every task has) and the
modules of ``measures`` (the built-in measures beyond them): the cell itself, the guard that turns
a measurement error into a recorded ``crashed`` cell, the energy run's length, and numbers made
JSON-able. They import this one; it imports none of them.
"""

from __future__ import annotations

import time

import numpy as np

from records.cell import Cell


def make_cell(
    task, measure, status="ok", value=None, dt=None, steps=None, detail="", figures=None, extra=None, wall=0.0
) -> Cell:
    """One measured cell of ``task``: ``figures`` of the measure's type (``records.cell.FIGURES``),
    anything else it recorded in ``extra``."""
    return Cell(
        scene=task.scene,
        method=task.method,
        family=task.family,
        measure=measure,
        status=status,
        params=dict(task.params or {}),
        dt=dt,
        steps=steps,
        value=value,
        wall_s=wall,
        detail=detail or "",
        figures=figures,
        extra=dict(extra or {}),
    )


def finite(x):
    """``x`` as a float, or None where it is missing or not finite."""
    return None if x is None or not np.isfinite(x) else float(x)


def plain(x):
    """numpy values -> JSON-able Python (arrays of more than 4096 numbers left out of a dict)."""
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items() if not isinstance(v, np.ndarray) or v.size <= 4096}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x


def nominal_dt(spec, scene) -> float:
    """The suite's nominal timestep on ``scene``: the spec's ``dt``, else h*omega / omega."""
    return spec.dt if spec.dt is not None else spec.homega / scene.omega


def energy_steps(spec, scene, dt: float) -> int:
    horizon = spec.horizon if spec.horizon is not None else spec.periods * scene.period
    return max(10, int(round(horizon / dt)))


def energy_run(scene, dt, spec, suite) -> tuple[int, int]:
    """(steps, every) of the energy run: ``spec.horizon`` (else ``spec.periods`` periods), about
    4 x series_points recorded."""
    steps = energy_steps(spec, scene, dt)
    return steps, max(1, steps // (4 * suite.series_points))


def _kernels_since(before: dict, cell: Cell) -> None:
    """Record in ``cell`` the compiled kernels its measure compiled or loaded from the disk
    cache (``reference.KERNEL_STATS`` counts both in this process), if any."""
    from reference import KERNEL_STATS as STATS

    now = STATS.snapshot()
    delta = {k: now[k] - before[k] for k in now}
    if delta["kernels_compiled"] or delta["kernels_loaded"] or delta["numba_s"] > 0:
        cell.kernels = delta


def guard(task, measure, fn) -> Cell:
    """``fn()``'s cell, timed; any exception becomes a ``crashed`` cell with the message."""
    from reference import KERNEL_STATS as STATS

    t0 = time.perf_counter()
    before = STATS.snapshot()
    try:
        cell = fn()
    except Exception as exc:  # a measurement error is a recorded result, not a dead run
        cell = make_cell(task, measure, "crashed", detail=f"{type(exc).__name__}: {exc}"[:500])
    cell.wall_s = time.perf_counter() - t0
    _kernels_since(before, cell)
    return cell


def guard_many(task, measures, fn) -> list[Cell]:
    """``guard`` for a function that measures several cells at once (their wall time shared)."""
    from reference import KERNEL_STATS as STATS

    t0 = time.perf_counter()
    before = STATS.snapshot()
    try:
        cells = fn()
    except Exception as exc:
        cells = [make_cell(task, m, "crashed", detail=f"{type(exc).__name__}: {exc}"[:500]) for m in measures]
    for c in cells:
        c.wall_s = (time.perf_counter() - t0) / len(cells)
    _kernels_since(before, cells[0])
    return cells
