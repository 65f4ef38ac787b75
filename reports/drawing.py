"""Drawing a report's charts, in worker processes when more than one job is given.

Each chart is one independent call (stored records in, one PNG under the report's folder out),
so the charts are listed first (``Chart``: its file name, its drawing function, that function's
arguments) and drawn afterwards, in list order when ``jobs`` is 1, else spread over a pool of
``jobs`` worker processes. The text of the report is written from which charts were drawn, so it
is the same whichever way they were drawn.

A chart that raises, or whose worker process dies, is a chart not drawn: the report leaves it out
as it leaves out a chart with nothing to draw, and a ``ChartNotDrawn`` warning names it and why.
A worker that dies takes the pool with it; the charts it had not finished are then drawn each in
a process of its own, so one chart that kills its process costs that chart only.
"""

from __future__ import annotations

import multiprocessing
import warnings
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from collections.abc import Callable


class ChartNotDrawn(RuntimeWarning):
    """A chart raised, or its worker process died, while drawing: the report goes on without it."""


@dataclass(frozen=True)
class Chart:
    """One chart of the report: ``draw(*args, out_dir / name, **kwargs) -> bool`` (True when it drew)."""

    name: str  # relative to the report's folder, e.g. "charts/run4-spring-energy.png"
    draw: Callable[..., bool]
    args: tuple
    kwargs: dict = field(default_factory=dict)


def _draw(chart: Chart, out_dir: Path) -> tuple[bool, str | None]:
    """(drew, why not where it raised): the error comes back as text, since not every exception
    pickles back from a worker."""
    try:
        return bool(chart.draw(*chart.args, out_dir / chart.name, **chart.kwargs)), None
    except Exception as exc:  # noqa: BLE001 - a chart is never worth the report
        import matplotlib.pyplot as plt

        plt.close("all")  # the figure the failed chart left open
        return False, f"{type(exc).__name__}: {exc}"


def _context():
    """Fork where the platform has it: the workers start with matplotlib and the records
    already imported (spawning would import them again in every worker)."""
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else None)


def _in_pool(charts: list[Chart], out_dir: Path, jobs: int) -> tuple[dict, list[Chart]]:
    """({name: (drew, why not)} of the charts drawn or raising, the charts lost to a dead worker)."""
    results, lost = {}, []
    with ProcessPoolExecutor(max_workers=jobs, mp_context=_context()) as pool:
        futures = [(chart, pool.submit(_draw, chart, out_dir)) for chart in charts]
        for chart, future in futures:
            try:
                results[chart.name] = future.result()
            except BrokenProcessPool:
                lost.append(chart)
            except Exception:  # noqa: BLE001 - it could not be sent to a worker (a plugin's chart
                # declared as a lambda does not pickle): drawn here instead, where it needs no sending
                results[chart.name] = _draw(chart, out_dir)
    return results, lost


def draw_charts(charts: list[Chart], out_dir: Path, jobs: int = 1) -> list[str]:
    """The names of the charts drawn, in the order of ``charts``; ``jobs`` processes draw them
    (1: this process, one after another)."""
    out_dir = Path(out_dir)
    jobs = max(1, min(int(jobs), len(charts)))
    if jobs == 1:
        results = {chart.name: _draw(chart, out_dir) for chart in charts}
    else:
        results, lost = _in_pool(charts, out_dir, jobs)
        for chart in lost:  # each alone: a chart that kills its process loses that chart only
            results.update(_in_pool([chart], out_dir, 1)[0])
            results.setdefault(chart.name, (False, "its worker process died"))
    drawn = []
    for chart in charts:
        ok, why = results[chart.name]
        if ok:
            drawn.append(chart.name)
        elif why is not None:
            warnings.warn(f"chart {chart.name} not drawn, left out of the report: {why}", ChartNotDrawn, stacklevel=2)
    return drawn
