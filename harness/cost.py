"""Cost of a step: force evaluations (counted) and wall time, and the ratio to explicit Euler.

The rule, one way for each kind of method:

* **Force evaluations per step** are counted, never declared: a run of ``count_steps``
  steps (default 100) through the runner, ``Trajectory.force_evals / steps run``. The
  reference driver wraps the scene's force and subtracts start-up evaluations (Verlet's
  a_0), so these are per step proper; ``solves_per_step`` counts the implicit schemes'
  linear solves (one per Newton iteration). An engine mode reports what its adapter can
  count, or None with the adapter's reason.
* **Wall time per step**, reference schemes: the compiled path
  (:func:`reference._compiled.time_per_step`, the same step functions compiled by numba),
  one warm-up call (it compiles), then ``repeats`` (5) timed runs of ``time_steps``
  (100,000) steps; the figure is the **minimum** over repeats (the least-disturbed run, as
  timeit and asv take it).
* **Wall time per step**, engine modes: ``method.simulate`` timed in this process (no
  worker), one warm-up call of up to ENGINE_PILOT_STEPS (500) steps, then ``repeats`` timed
  runs of ``time_steps`` (2,000) steps and of 0 steps; the figure is
  ``(min t(N) - min t(0)) / N``, so building the engine model is not counted. It includes
  the adapter's Python loop (reading state, applying forces): that is what an engine step
  costs a Python user. A model so slow that N steps would take longer than
  ENGINE_RUN_BUDGET_S (0.25 s, judged from the warm-up) is timed over fewer steps, at least
  ENGINE_MIN_STEPS (200): a 32-body chain stepped from Python costs ~100 us a step, and
  20,000 steps x 6 runs would take a minute to say what 0.25 s says.
* **Spread**: every repeat is kept, with the median and ``rel_spread = (max - min)/min``,
  so a later slowdown can be judged against this run's noise.
* **Ratio to explicit Euler**: ``ref:explicit_euler`` timed by the compiled rule above
  on the same scene at the same dt in the same call; one baseline for every method.
"""
from __future__ import annotations

import time

import numpy as np

import reference
from reference._compiled import time_per_step

from scenarios import Scene

from ._measure import resolve, step

COUNT_STEPS = 100
REF_TIME_STEPS = 100_000
ENGINE_TIME_STEPS = 2_000
ENGINE_PILOT_STEPS = 500
ENGINE_RUN_BUDGET_S = 0.25
ENGINE_MIN_STEPS = 200
REPEATS = 5
BASELINE = "ref:explicit_euler"


def _spread(times: list[float]) -> dict:
    lo = min(times)
    return {"s_per_step": lo, "median_s_per_step": float(np.median(times)), "repeats_s_per_step": list(times),
            "rel_spread": (max(times) - lo) / lo if lo > 0 else None}


def counted_evaluations(method, scene: Scene, dt: float, *, steps: int = COUNT_STEPS,
                        timeout: float | None = None) -> dict:
    """Force evaluations and solves per step, counted over ``steps`` steps."""
    method = resolve(method, scene)
    traj = step(method, scene, dt, steps, steps, timeout)
    ran = traj.meta.get("steps_run", steps if traj.ok else (traj.failed_step or 1) - 1)
    out: dict = {"count_steps": int(ran), "count_status": traj.status}
    if traj.force_evals is None or ran <= 0:
        out.update(force_evals_per_step=None,
                   force_evals_reason=traj.meta.get("force_evals_reason") or "the engine mode does not count them")
    else:
        out["force_evals_per_step"] = traj.force_evals / ran
        out["start_force_evals"] = traj.meta.get("start_force_evals")
    out["solves_per_step"] = None if traj.solves is None or ran <= 0 else traj.solves / ran
    scheme = getattr(method, "scheme", None)
    if scheme is not None:
        out["declared_force_evals"] = scheme.force_evals
        out["declared_implicit"] = scheme.implicit
    return out


def wall_time_per_step(method, scene: Scene, dt: float, *, steps: int | None = None,
                       repeats: int = REPEATS) -> dict:
    """Seconds per step by the rule in the module docstring (compiled for reference schemes,
    in-process ``simulate`` for engine modes)."""
    method = resolve(method, scene)
    scheme = getattr(method, "scheme", None)
    if scheme is not None:
        n = int(steps or REF_TIME_STEPS)
        res = time_per_step(scheme, scene, dt, n, repeats=repeats)
        return {"timing": "compiled (numba), min of repeats after warm-up", "time_steps": n,
                "warmup_s": res["warmup_s"], **_spread(res["repeats"])}
    asked = int(steps or ENGINE_TIME_STEPS)
    pilot = min(asked, ENGINE_PILOT_STEPS)
    t0 = time.perf_counter()
    method.simulate(scene, dt, pilot, pilot)  # warm-up, and the pilot for the step count
    pilot_s = (time.perf_counter() - t0) / pilot
    n = asked if pilot_s * asked <= ENGINE_RUN_BUDGET_S else max(ENGINE_MIN_STEPS, int(ENGINE_RUN_BUDGET_S / pilot_s))
    n = min(n, asked)
    full, empty = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        method.simulate(scene, dt, 0, 1)
        t1 = time.perf_counter()
        method.simulate(scene, dt, n, n)
        t2 = time.perf_counter()
        empty.append(t1 - t0)
        full.append(t2 - t1)
    setup = min(empty)
    per_step = [(t - setup) / n for t in full]
    return {"timing": "in-process simulate, (min t(N) - min t(0))/N after warm-up; includes the adapter's "
                      "Python loop", "time_steps": n, "time_steps_asked": asked, "setup_s": setup,
            **_spread(per_step)}


def cost_per_step(method, scene: Scene, dt: float, *, time_steps: int | None = None, repeats: int = REPEATS,
                  count_steps: int = COUNT_STEPS, timeout: float | None = None,
                  baseline: dict | None = None) -> dict:
    """Counted evaluations, wall time per step and the ratio to explicit Euler (compiled) on
    the same scene and dt. ``baseline`` reuses an explicit-Euler timing from the same run."""
    method = resolve(method, scene)
    out = {"scene": scene.id, "params": dict(scene.values), "method": method.id, "dt": float(dt),
           "omega_dt": float(dt) * scene.omega}
    out.update(counted_evaluations(method, scene, dt, steps=count_steps, timeout=timeout))
    out.update(wall_time_per_step(method, scene, dt, steps=time_steps, repeats=repeats))
    if baseline is None:
        baseline = explicit_euler_baseline(scene, dt, repeats=repeats)
    out["baseline"] = baseline
    out["ratio_to_explicit_euler"] = out["s_per_step"] / baseline["s_per_step"]
    return out


def explicit_euler_baseline(scene: Scene, dt: float, *, repeats: int = REPEATS) -> dict:
    res = time_per_step(reference.METHODS["explicit_euler"], scene, dt, REF_TIME_STEPS, repeats=repeats)
    return {"method": BASELINE, "timing": "compiled (numba), min of repeats after warm-up",
            "time_steps": REF_TIME_STEPS, **_spread(res["repeats"])}
