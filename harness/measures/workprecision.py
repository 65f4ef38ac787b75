"""Work-precision: for each method, (cost, error) pairs across a timestep sweep, ready to chart.

The rule: every method runs the same dts, ``h*omega = HOMEGA_MAX / 2^k`` for
k = 0 .. ``points``-1 (default 0.5 down to 0.0039), over ``periods`` (default 5) scene
periods, each dt adjusted to divide that horizon into whole steps. At each dt:

* ``error``: ``error_max`` of :mod:`harness.measures.error` (sup over the run of the relative
  global error); None where the run failed (the row stays, with its status);
* ``s_per_unit_time``: measured wall seconds per step (:mod:`harness.measures.cost` rules, at this
  dt, ``time_steps`` steps, ``repeats`` repeats) divided by dt: a reference scheme's compiled
  loop, an engine mode's own loop (``engine s/step``, never the harness's per-step path);
* ``evals_per_unit_time``: counted force evaluations per step (from the error run) / dt.

One row per (method, dt): the chart is error against either cost, one line per method.
"""

from __future__ import annotations

from records.pareto import pareto_front, pareto_summary  # noqa: F401 (read from here by the CLI)

import math

import numpy as np

from scenarios import Scene

from harness.measures.common import resolve
from harness.measures.cost import wall_time_per_step
from harness.measures.error import global_error

HOMEGA_MAX = 0.5
POINTS = 8
PERIODS = 5.0
TIME_STEPS_REF = 20_000
TIME_STEPS_ENGINE = 5_000
REPEATS = 3


def sweep(
    scene: Scene, *, points: int = POINTS, homega_max: float = HOMEGA_MAX, periods: float = PERIODS
) -> list[tuple[float, int]]:
    """The (dt, steps) pairs of the rule above."""
    horizon = periods * scene.period
    out = []
    for k in range(points):
        steps = max(1, int(round(horizon * scene.omega / (homega_max / 2.0**k))))
        out.append((horizon / steps, steps))
    return out


def work_precision(
    methods,
    scene: Scene,
    *,
    points: int = POINTS,
    homega_max: float = HOMEGA_MAX,
    periods: float = PERIODS,
    repeats: int = REPEATS,
    timeout: float | None = None,
    time_steps: int | None = None,
    progress=None,
) -> list[dict]:
    """Rows of (method, dt, error, cost) for each method (ids or objects) on ``scene``;
    ``progress``: told a line before each point (a command's progress)."""
    resolved = [resolve(m, scene) for m in methods]
    rows = []
    for j, method in enumerate(resolved, 1):
        isref = method.scheme is not None
        for i, (dt, steps) in enumerate(sweep(scene, points=points, homega_max=homega_max, periods=periods), 1):
            if progress is not None:
                progress(
                    f"workprecision: {method.id} (method {j} of {len(resolved)}), point {i} of {points} "
                    f"(h*omega {dt * scene.omega:.4g}, {steps} steps)"
                )
            res = global_error(method, scene, dt, steps, timeout=timeout)
            row = {
                "scene": scene.id,
                "params": dict(scene.values),
                "method": method.id,
                "dt": dt,
                "omega_dt": dt * scene.omega,
                "steps": steps,
                "horizon": periods * scene.period,
                "status": res["status"],
                "error": res["error_max"],
                "error_final": res["error_final"],
            }
            ran = steps if res["status"] == "ok" else None
            evals = res["force_evals"] / ran if (res["force_evals"] is not None and ran) else None
            row["force_evals_per_step"] = evals
            row["evals_per_unit_time"] = evals / dt if evals is not None else None
            n = time_steps or (TIME_STEPS_REF if isref else TIME_STEPS_ENGINE)
            if res["status"] == "ok":
                timing = wall_time_per_step(method, scene, dt, steps=n, repeats=repeats)
                row.update(
                    s_per_step=timing["s_per_step"],
                    s_per_unit_time=timing["s_per_step"] / dt,
                    rel_spread=timing["rel_spread"],
                    timing=timing["timing"],
                    clock=timing["clock"],
                )
            else:
                row.update(s_per_step=None, s_per_unit_time=None, rel_spread=None, timing=None, clock=None)
            rows.append(row)
    return rows


def chart_ready(rows: list[dict]) -> dict[str, dict[str, list]]:
    """Per method, the finite (cost, error) pairs sorted by cost: ``{method: {"s_per_unit_time":
    [...], "evals_per_unit_time": [...], "error": [...], "dt": [...]}}``."""
    out: dict[str, dict[str, list]] = {}
    for r in rows:
        if r["error"] is None or r["s_per_unit_time"] is None or not math.isfinite(r["error"]):
            continue
        d = out.setdefault(r["method"], {"dt": [], "s_per_unit_time": [], "evals_per_unit_time": [], "error": []})
        for k in d:
            d[k].append(r[k])
    for d in out.values():
        order = np.argsort(d["s_per_unit_time"])
        for k in d:
            d[k] = [d[k][i] for i in order]
    return out


def error_at_equal_cost(curve: dict, at: dict) -> list[dict]:
    """How one method's error compares with another's at the same cost.

    ``curve`` and ``at`` are ``{"cost": [...], "error": [...]}`` (a method's sweep, any cost
    measure, e.g. :func:`chart_ready`'s ``s_per_unit_time``). For every point of ``at`` whose
    cost lies within ``curve``'s range, ``curve``'s error at that cost is interpolated linearly
    in log(cost)-log(error) between its neighbouring points; the rows give both errors and
    ``ratio`` = curve's error / at's error (below 1: ``curve`` is ahead there). Points outside
    the range are left out, never extrapolated."""
    pts = sorted(
        (c, e)
        for c, e in zip(curve["cost"], curve["error"])
        if c is not None and e is not None and c > 0 and e > 0 and math.isfinite(c) and math.isfinite(e)
    )
    if len(pts) < 2:
        return []
    log_c = np.log([c for c, _ in pts])
    log_e = np.log([e for _, e in pts])
    out = []
    for c, e in zip(at["cost"], at["error"]):
        if c is None or e is None or not (c > 0 and e > 0) or not (log_c[0] <= math.log(c) <= log_c[-1]):
            continue
        interpolated = float(np.exp(np.interp(math.log(c), log_c, log_e)))
        out.append({"cost": float(c), "error": float(e), "curve_error": interpolated, "ratio": interpolated / e})
    return out
