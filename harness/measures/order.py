"""Observed order of accuracy: the least-squares slope of log(error) against log(dt).

The rule, one way for every method:

* **Error**: ``error_max`` of :mod:`harness.measures.error` (sup over the run of the relative
  global error) over a fixed horizon of ``periods`` scene periods (default 1/2: order is
  local, and half an orbit from perihelion skips the return to it, where a first-order
  method's phase error is multiplied about 14-fold); each dt is adjusted to divide the
  horizon into a whole number of steps.
* **Timesteps**: ``points`` (default 8, at least 6) geometric dts spanning a factor
  ``span`` (default 8). The largest is chosen from a pilot run so that the error there
  is about ``TOP_ERROR[p]`` for the method's declared order p (2 where it declares none;
  3e-2, 2e-3, 1e-4 and 3e-6 for orders 1, 2, 3 and 4+): small enough that the leading
  error term dominates (on the Kepler orbit it takes over slowly: slopes 0.97 and 4.07
  at these targets), large enough that the smallest dt's error stays far above roundoff.
  The pilot starts at h*omega = PILOT_HOMEGA and is quartered until it runs stably with
  error below EXCLUDE_ERROR; then
  ``dt_max = dt_pilot (TOP_ERROR[p] / error_pilot)^(1/p)``, capped at the pilot's
  dt times 4. ``dts=`` overrides the whole choice.
* **Left out, and shown with the reason**:
  - ``unstable``: the run did not finish (``status`` not ok) or the error is not finite;
  - ``past stability``: error >= EXCLUDE_ERROR (0.5): the solution is lost, not approximated;
  - ``roundoff floor``: error <= ROUNDOFF_FACTOR * eps * steps (rounding adds at most a few
    eps per step, so below this the error is noise), or, against a reference solve,
    <= the reference's own accuracy (:data:`harness.measures.error.REFERENCE_FLOOR`).
* **Fit**: ``scipy.stats.linregress`` of log(error) on log(dt) over the points used;
  at least MIN_USED points or no order is reported.
"""

from __future__ import annotations

import math

import numpy as np

from records import InvalidInput

from scenarios import Scene

from harness.measures.common import declared_order, require_fixed_step, resolve
from harness.measures.error import global_error

#: Target error at the largest dt, by the method's order.
TOP_ERROR = {1: 3e-2, 2: 2e-3, 3: 1e-4}
TOP_ERROR_HIGH = 3e-6  # order >= 4
PILOT_HOMEGA = 0.05
EXCLUDE_ERROR = 0.5
ROUNDOFF_FACTOR = 1e3
MIN_POINTS = 6
MIN_USED = 3
EPS = float(np.finfo(float).eps)


def top_error(order: int) -> float:
    return TOP_ERROR.get(order, TOP_ERROR_HIGH)


def _horizon_steps(scene: Scene, dt: float, horizon: float) -> tuple[float, int]:
    steps = max(1, int(round(horizon / dt)))
    return horizon / steps, steps


def choose_timesteps(
    method,
    scene: Scene,
    *,
    points: int = 8,
    span: float = 8.0,
    periods: float = 0.5,
    order: int | None = None,
    timeout: float | None = None,
    progress=None,
) -> dict:
    """The dt sweep by the rule in the module docstring, with the pilot runs that chose it;
    ``progress``: told a line before each pilot run."""
    method = resolve(method, scene)
    # The sweep is chosen by the scheme's order for position-only forces (a lower order declared
    # for velocity-dependent ones only judges the result): the timesteps stay those of every
    # stored run.
    declared = declared_order(method)
    p = order or declared or 2
    source = "given" if order else "declared" if declared else "none declared: assumed 2"
    horizon = periods * scene.period
    pilots = []
    dt = PILOT_HOMEGA / scene.omega
    for _ in range(12):
        dt, steps = _horizon_steps(scene, dt, horizon)
        if progress is not None:
            progress(f"order: pilot run {len(pilots) + 1} of at most 12 (dt {dt:.6g}, {steps} steps)")
        res = global_error(method, scene, dt, steps, timeout=timeout)
        err = res["error_max"]
        pilots.append({"dt": dt, "steps": steps, "error": err, "status": res["status"]})
        if err is not None and math.isfinite(err) and 0.0 < err < EXCLUDE_ERROR:
            break
        dt /= 4.0
    else:
        return {
            "dts": None,
            "order_used": p,
            "order_source": source,
            "top_error": top_error(p),
            "pilots": pilots,
            "reason": f"no pilot run with error below {EXCLUDE_ERROR:g} down to dt={pilots[-1]['dt']:g}",
        }
    if err > 0.0:
        dt_max = min(dt * (top_error(p) / err) ** (1.0 / p), 4.0 * dt)
    else:
        dt_max = dt
    dts = dt_max * span ** (-np.arange(points) / (points - 1))
    return {"dts": dts.tolist(), "order_used": p, "order_source": source, "top_error": top_error(p), "pilots": pilots}


def observed_order(
    method,
    scene: Scene,
    *,
    points: int = 8,
    span: float = 8.0,
    periods: float = 0.5,
    order: int | None = None,
    dts=None,
    timeout: float | None = None,
    progress=None,
) -> dict:
    """Observed order of ``method`` on ``scene``: slope, the points used and those left out.

    ``order`` only steers the dt range (default: the declared order); ``dts`` fixes the
    timesteps instead (each still adjusted to fit the horizon); ``progress``: told a line
    before each run (a command's progress)."""
    method = resolve(method, scene)
    require_fixed_step(method, "the observed order")
    if points < MIN_POINTS:
        raise InvalidInput(f"points={points} is out of range (allowed: integer >= {MIN_POINTS})")
    if span <= 1.0 or not math.isfinite(span):
        raise InvalidInput(f"span={span} is out of range (allowed: finite, > 1)")
    horizon = periods * scene.period
    choice: dict = {}
    if dts is None:
        choice = choose_timesteps(
            method, scene, points=points, span=span, periods=periods, order=order, timeout=timeout, progress=progress
        )
        dts = choice["dts"] or []
    used, excluded = [], []
    for i, dt in enumerate(sorted(float(x) for x in dts), 1):
        dt, steps = _horizon_steps(scene, dt, horizon)
        if progress is not None:
            progress(f"order: point {i} of {len(dts)} (dt {dt:.6g}, {steps} steps)")
        res = global_error(method, scene, dt, steps, timeout=timeout)
        err = res["error_max"]
        point = {
            "dt": dt,
            "omega_dt": dt * scene.omega,
            "steps": steps,
            "error": err,
            "status": res["status"],
            "force_evals": res["force_evals"],
        }
        floor = ROUNDOFF_FACTOR * EPS * steps
        accuracy = res["reference_error"] or 0.0
        if res["status"] == "ok" and res.get("not_judged"):
            point["reason"] = res["not_judged"]
        elif not res["status"] == "ok" or err is None or not math.isfinite(err):
            point["reason"] = f"unstable ({res['status']})"
        elif err >= EXCLUDE_ERROR:
            point["reason"] = f"past stability: error {err:.3g} >= {EXCLUDE_ERROR:g}"
        elif err <= floor:
            point["reason"] = f"roundoff floor: error {err:.3g} <= {floor:.3g}"
        elif err <= accuracy:
            point["reason"] = f"roundoff floor: below the reference's accuracy ({accuracy:.3g})"
        (excluded if "reason" in point else used).append(point)
    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "order_declared": declared_order(method, scene),
        "horizon": horizon,
        "periods": periods,
        "points": used,
        "excluded": excluded,
        "order": None,
        "stderr": None,
        "rvalue": None,
    }
    if choice:
        out["range"] = {k: v for k, v in choice.items() if k != "dts"}
    if len(used) >= MIN_USED:
        from scipy.stats import (
            linregress,
        )  # here: most processes importing this module never fit, and scipy.stats is a large import

        fit = linregress(np.log([u["dt"] for u in used]), np.log([u["error"] for u in used]))
        out.update(
            order=float(fit.slope), stderr=float(fit.stderr), rvalue=float(fit.rvalue), intercept=float(fit.intercept)
        )
    else:
        out["reason"] = choice.get("reason") or f"only {len(used)} usable points (need {MIN_USED})"
    return out
