"""Work-precision of an error-controlled method, swept over its tolerance.

A method that takes a tolerance (``drake:runge_kutta3``, ``rebound:ias15``: ``Option`` named
``tolerance`` in its declared options) picks its own steps; its work-precision curve is drawn by
the tolerance, not by a timestep. The rule, one way for every such method:

* it runs over ``periods`` scene periods (default 5), recording ``outputs`` states (default 50)
  at equal intervals: the output interval is its ``dt`` and caps its step (Drake's maximum step,
  REBOUND's exact finish at each output);
* per tolerance, loosest first: the global error (``error_max``, sup over the outputs of the
  relative error against the scene's truth, as everywhere else), the steps the method took and
  rejected (Drake's ``get_num_steps_taken`` and its step shrinkages from error control;
  REBOUND's ``steps_done``, which counts no rejected steps), its counted force evaluations and
  its cost (``harness.measures.cost``: the engine's own loop over the run, model built off the
  clock), per unit of simulated time, as the work-precision chart's cost;
* the sweep ends at the tightest tolerance, or before a run whose work, extrapolated from the
  last two (their ratio of force evaluations, or of steps where evaluations are not counted),
  would pass ``max_evals`` (a first-order error estimate at a tight tolerance takes millions of
  steps); ``ended`` says which. Counts decide, never a clock: the same code gives the same sweep.

The tolerance is what the engine calls it (Drake's target accuracy, a local error per step;
IAS15's epsilon): how far the global error lies from it is the finding this measures.
"""

from __future__ import annotations

import math

from records import InvalidInput
from records.method_id import TOLERANCE

from scenarios import Scene

from harness.measures.common import resolve, step
from harness.measures.cost import wall_time_per_step
from harness.measures.error import run_error

TOLERANCES = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)
PERIODS = 5.0
OUTPUTS = 50
REPEATS = 3
#: Past this many force evaluations in one run, tighter tolerances are not run.
MAX_EVALS = 200_000


def takes_tolerance(method) -> bool:
    """Whether ``method`` (an id or a method) declares a tolerance it can be run at."""
    from harness.methods import declared_options, get_method

    return TOLERANCE in declared_options(get_method(method) if isinstance(method, str) else method)


def tolerance_sweep(
    method,
    scene: Scene,
    *,
    tolerances=TOLERANCES,
    periods: float = PERIODS,
    outputs: int = OUTPUTS,
    repeats: int = REPEATS,
    max_evals: int = MAX_EVALS,
    timeout: float | None = None,
    timing: bool = True,
    clock: str = "wall",
) -> dict:
    """``{"method", "rows": [...], "ended": why the sweep stopped}`` for ``method`` (its id
    without a tolerance, or with one: the sweep sets its own) on ``scene`` (module docstring);
    each run timed on ``clock`` (the nightly's ``cpu``, the clock of its cost cells, so that one
    work-precision chart holds one clock)."""
    from harness.methods import get_method

    base = resolve(method, scene)
    if not takes_tolerance(base):
        raise InvalidInput(
            f"method {base.id} takes no tolerance (error-controlled methods: those that declare "
            "a 'tolerance' option, e.g. drake:runge_kutta3, rebound:ias15)"
        )
    horizon = periods * scene.period
    dt = horizon / outputs
    rows, ended = [], f"the tightest tolerance, {min(tolerances):g}"
    for tol in sorted(tolerances, reverse=True):
        predicted = _next_work(rows)
        if predicted is not None and predicted > max_evals:
            ended = (
                f"before tolerance {tol:g}: its run would take about {predicted:.3g} force evaluations "
                f"(extrapolated from the last two), past {max_evals}"
            )
            break
        run = get_method(base.id, {TOLERANCE: tol})
        traj = step(run, scene, dt, outputs, 1, timeout)
        settings = traj.meta.settings or {}
        row = {
            "tolerance": float(tol),
            "method": run.id,
            "status": traj.status,
            "detail": traj.detail,
            "horizon": horizon,
            "outputs": int(outputs),
            "force_evals": traj.force_evals,
            "steps_taken": settings.get("steps_taken", settings.get("steps_done")),
            "steps_rejected": settings.get("steps_rejected"),
            "error": None,
            "s_per_unit_time": None,
            "clock": None,
        }
        if traj.ok:
            row["error"] = run_error(run, scene, traj, timeout)["error_max"]
            if timing:
                t = wall_time_per_step(run, scene, dt, steps=outputs, repeats=repeats, clock=clock)
                row.update(s_per_unit_time=t["s_per_step"] * outputs / horizon, clock=t["clock"])
        rows.append(row)
        if not traj.ok:
            ended = f"the run at tolerance {tol:g} {traj.status}: {traj.detail}"
            break
    return {"method": base.id, "scene": scene.id, "rows": rows, "ended": ended}


def _next_work(rows: list[dict]) -> float | None:
    """The next run's work, extrapolated geometrically from the last two runs: their force
    evaluations, or their steps where evaluations are not counted; None before two runs."""
    if len(rows) < 2:
        return None
    a, b = rows[-2], rows[-1]
    for key in ("force_evals", "steps_taken"):
        if a.get(key) and b.get(key):
            return b[key] * (b[key] / a[key])
    return None


def error_over_tolerance(rows: list[dict]) -> float | None:
    """The largest error / tolerance over the rows that ran (above 1: the global error exceeds
    what the tolerance asked for), None where none ran."""
    ratios = [
        r["error"] / r["tolerance"]
        for r in rows
        if r.get("error") is not None and math.isfinite(r["error"]) and r["tolerance"] > 0
    ]
    return max(ratios) if ratios else None
