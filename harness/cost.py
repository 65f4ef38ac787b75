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
  one warm-up call (it compiles, or loads the pair's kernels from the disk cache), then ``repeats`` (5) timed runs of ``time_steps``
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
* **Clock**: wall time (``time.perf_counter``) by default; ``clock="cpu"`` reads the CPU
  time of the process (``time.process_time``) instead, which other processes sharing the
  core do not inflate (the nightly runs its cells side by side on shared cores). The
  engine modes and the compiled loops run in one thread, so on an idle core the two agree.
* **Spread**: every repeat is kept, with the median and ``rel_spread = (max - min)/min``,
  so a later slowdown can be judged against this run's noise.
* **Ratio to explicit Euler**: ``ref:explicit_euler`` timed by the compiled rule above
  on the same scene at the same dt in the same call, on the same clock, its repeats
  interleaved with the method's (method, baseline, method, baseline, ...): a machine that
  slows for a while slows both of a pair. Measured on this project's shared 2-core machine,
  a worker's compiled explicit Euler ran at 80 ns a step and, for seconds on end, at
  140-150 ns, on the CPU clock too. The ratio is the median of the pairs' ratios, its
  ``ratio_spread`` (max - min) / min of them.
"""
from __future__ import annotations

import numpy as np

import reference
from reference._compiled import CLOCKS, step_timer, time_per_step

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


_COMPILED_TIMING = "compiled (numba), min of repeats after warm-up"
_ENGINE_TIMING = ("in-process simulate, (min t(N) - min t(0))/N after warm-up; includes the adapter's "
                  "Python loop")


class _Timing:
    """One method's timing by the module's rule, a repeat at a time (so that two methods'
    repeats can be interleaved)."""

    def __init__(self, method, scene: Scene, dt: float, steps: int | None, clock: str):
        self.now = CLOCKS[clock]
        self.scheme = getattr(method, "scheme", None)
        self.times, self.empty = [], []
        if self.scheme is not None:
            self.n = int(steps or REF_TIME_STEPS)
            self.warmup_s, self._once = step_timer(self.scheme, scene, dt, self.n, clock=clock)
        else:
            self.asked = int(steps or ENGINE_TIME_STEPS)
            self.method, self.scene, self.dt = method, scene, dt
            pilot = min(self.asked, ENGINE_PILOT_STEPS)
            t = self.now()
            method.simulate(scene, dt, pilot, pilot)  # warm-up, and the pilot for the step count
            self.warmup_s = self.now() - t
            pilot_s = self.warmup_s / pilot
            n = self.asked
            if pilot_s * self.asked > ENGINE_RUN_BUDGET_S:
                n = max(ENGINE_MIN_STEPS, int(ENGINE_RUN_BUDGET_S / pilot_s))
            self.n = min(n, self.asked)

    def repeat(self) -> None:
        if self.scheme is not None:
            self.times.append(self._once())
            return
        t0 = self.now()
        self.method.simulate(self.scene, self.dt, 0, 1)
        t1 = self.now()
        self.method.simulate(self.scene, self.dt, self.n, self.n)
        t2 = self.now()
        self.empty.append(t1 - t0)
        self.times.append(t2 - t1)

    def per_step(self) -> list[float]:
        if self.scheme is not None:
            return list(self.times)
        setup = min(self.empty)
        return [(t - setup) / self.n for t in self.times]

    def result(self, clock: str) -> dict:
        out = {"timing": _COMPILED_TIMING if self.scheme is not None else _ENGINE_TIMING, "clock": clock,
               "time_steps": self.n, "warmup_s": self.warmup_s, **_spread(self.per_step())}
        if self.scheme is None:
            out["setup_s"] = min(self.empty)
            out["time_steps_asked"] = self.asked
        return out


def wall_time_per_step(method, scene: Scene, dt: float, *, steps: int | None = None,
                       repeats: int = REPEATS, clock: str = "wall") -> dict:
    """Seconds per step by the rule in the module docstring (compiled for reference schemes,
    in-process ``simulate`` for engine modes), on ``clock`` ("wall" or "cpu")."""
    method = resolve(method, scene)
    timing = _Timing(method, scene, dt, steps, clock)
    for _ in range(repeats):
        timing.repeat()
    return timing.result(clock)


def cost_per_step(method, scene: Scene, dt: float, *, time_steps: int | None = None, repeats: int = REPEATS,
                  count_steps: int = COUNT_STEPS, timeout: float | None = None,
                  baseline: dict | None = None, clock: str = "wall") -> dict:
    """Counted evaluations, time per step and the ratio to explicit Euler (compiled) on
    the same scene and dt, the two timed in interleaved repeats (module docstring).
    ``baseline`` reuses an explicit-Euler timing from the same run instead."""
    method = resolve(method, scene)
    out = {"scene": scene.id, "params": dict(scene.values), "method": method.id, "dt": float(dt),
           "omega_dt": float(dt) * scene.omega}
    out.update(counted_evaluations(method, scene, dt, steps=count_steps, timeout=timeout))
    if baseline is not None:
        out.update(wall_time_per_step(method, scene, dt, steps=time_steps, repeats=repeats, clock=clock))
        out["baseline"] = baseline
        out["ratio_to_explicit_euler"] = out["s_per_step"] / baseline["s_per_step"]
        out["ratio_spread"] = (out.get("rel_spread") or 0.0) + (baseline.get("rel_spread") or 0.0)
        return out
    timing = _Timing(method, scene, dt, time_steps, clock)
    from .methods import get_method

    ok, why = get_method(BASELINE).supports(scene)
    if not ok:  # a constrained scene (the rope): no explicit-Euler run to compare with
        for _ in range(repeats):
            timing.repeat()
        out.update(timing.result(clock))
        out["baseline"] = {"method": BASELINE, "unsupported": why}
        out["ratio_to_explicit_euler"] = None
        return out
    # A reference scheme and its baseline run the same compiled loop length: a shorter loop
    # carries more of the call's fixed cost per step (1.3x per step at 2,000 steps, measured).
    base_steps = timing.n if timing.scheme is not None else REF_TIME_STEPS
    base = _Timing(resolve(BASELINE, scene), scene, dt, base_steps, clock)
    for _ in range(repeats):
        timing.repeat()
        base.repeat()
    out.update(timing.result(clock))
    out["baseline"] = {"method": BASELINE, **base.result(clock)}
    ratios = [m / b for m, b in zip(timing.per_step(), base.per_step())]
    out["ratio_repeats"] = ratios
    out["ratio_to_explicit_euler"] = float(np.median(ratios))
    out["ratio_spread"] = (max(ratios) - min(ratios)) / min(ratios)
    return out


def explicit_euler_baseline(scene: Scene, dt: float, *, repeats: int = REPEATS, clock: str = "wall",
                            steps: int = REF_TIME_STEPS) -> dict:
    res = time_per_step(reference.METHODS["explicit_euler"], scene, dt, steps, repeats=repeats, clock=clock)
    return {"method": BASELINE, "timing": _COMPILED_TIMING, "clock": clock,
            "time_steps": steps, "warmup_s": res["warmup_s"], **_spread(res["repeats"])}
