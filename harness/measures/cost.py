"""Cost of a step: force evaluations (counted) and wall time, and the ratio to explicit Euler.

The rule, one way for each kind of method. The figures that shaped it (how long the runs took,
how far repeats spread, which kernels hit the budget) were measured on one machine and live in
docs/performance.md ("The cost measure's rule and the figures behind it"); this docstring says
what the code does and why.

* **Force evaluations per step** are counted, never declared: a run of ``count_steps``
  steps (default 100) through the runner, ``Trajectory.force_evals / steps run``. The
  reference driver wraps the scene's force and subtracts start-up evaluations (Verlet's
  a_0), so these are per step proper; ``solves_per_step`` counts the implicit schemes'
  linear solves (one per Newton iteration), and where the method chose a library solve
  (``reference.solvers``) ``solver_iterations_per_step`` its iterations and ``unconverged_solves``
  those that stopped short of its tolerance. An engine mode reports what its engine counts
  (MuJoCo's forward passes, in every run), or, where counting needs a callback that would slow
  the timed loop (REBOUND, pymunk), what a counting run (``simulate(..., count=True)``, in this
  process, as the timing runs) counts over the steps the isolated run ran; or None with the
  adapter's reason (pybullet, Chipmunk's constraints).
* **Wall time per step**, reference schemes: the compiled path
  (:func:`reference._compiled.time_per_step`, the same step functions compiled by numba),
  one warm-up call (it compiles, or loads the pair's kernels from the disk cache), then ``repeats`` (5) timed runs of
  ``time_steps`` (REF_TIME_STEPS, 100,000) steps; the figure is the **minimum** over repeats (the least-disturbed
  run, as timeit and asv take it). A kernel so slow that a run would last longer than the run
  budget (``run_budget``, below; judged from a pilot run of REF_PILOT_STEPS, 2,000) runs fewer
  steps, at least REF_MIN_STEPS (5,000): one budget's run says what the full run would say,
  since the call's fixed cost is then a negligible share of a run and the clock's resolution a
  smaller one still. A scheme that chose a library solve (``ref:implicit_euler?solver=direct``,
  ``reference.solvers``), which numba cannot compile, is timed by the same rule on the Python
  loop that runs it, and its ``timing`` says so.
* **Wall time per step**, engine modes, two figures, each ``method.simulate`` timed in this
  process (no worker): one warm-up call of up to ENGINE_PILOT_STEPS (500) steps, then
  ``repeats`` timed runs of N steps and of 0 steps; the figure is ``(min t(N) - min t(0)) / N``.
  An engine mode's runs are timed with its model built off the clock (``EngineMode.timed_run``):
  on a shared core, building the model jitters by more than a short run of the engine's own
  loop takes, and subtracting it can leave a negative time per step. A plugin's whole
  ``simulate`` is timed and t(0) takes the building out.

  - ``s_per_step``, **engine s/step**: the engine's own loop (``loop="engine"``:
    ``mujoco.rollout``, REBOUND's ``sim.steps(n)``, a Python loop calling only the step
    function for pybullet and pymunk), N = ENGINE_TIME_STEPS (10,000), one output point. Where
    the scene's force has no native element in the engine and is applied from Python every
    step (pybullet's springs, pymunk's ``applied_force``), the loop says so
    (``engine_loop``, from the adapter's settings). Every ratio and chart uses this figure.
  - ``as_stepped``, **as stepped by the harness**: the per-step path (``loop="harness"``:
    state read and checked and forces applied after every step), N = HARNESS_TIME_STEPS
    (2,000): what stepping the engine one call at a time from Python costs.

  A run that diverges within the N steps (the engine's warning, or the harness's criterion)
  is timed over the steps before it, and the timing says so: its step-by-step replay, which
  finds the failing step, is no cost of a step.
  A model so slow that N steps would last longer than the run budget (judged from a pilot of
  the warm-up's steps, the model built off the clock) is timed over fewer steps, at least
  ENGINE_MIN_STEPS (200): a slow model (a long chain stepped from Python) says in one budget's
  run what N steps would, at a fraction of the measure's time.
* **The run budget** is a policy, not a measurement: a timed repeat is cut to at most
  REF_RUN_BUDGET_S or ENGINE_RUN_BUDGET_S (0.02 s each) where its asked steps would last
  longer, which bounds what a cost cell spends on a slow kernel (``repeats`` runs of it, of its
  baseline beside it and of the calibration). What the budget must be long against is the
  clock: a run is read as two clock readings, so it is known to about the clock's resolution.
  That resolution is measured at the start of the run (``clock_resolution``: the least
  positive difference between successive readings, the cost of a reading included), recorded
  in every timing (``clock_resolution_s``), and the budget in effect is
  ``run_budget``: the policy's, or ``1 / MAX_CLOCK_SHARE`` times the resolution where that is
  longer, so that the clock's rounding is at most MAX_CLOCK_SHARE (a thousandth) of a run,
  below the spread between repeats that the cell records beside it. On a clock that reads to
  the microsecond or finer the policy's budget is the one in effect.
* **Clock**: wall time (``time.perf_counter``) by default; ``clock="cpu"`` reads the CPU
  time of the process (``time.process_time``) instead, which other processes sharing the
  core do not inflate (the nightly runs its cells side by side on shared cores). The
  engine modes and the compiled loops run in one thread, so on an idle core the two agree.
* **Spread**: every repeat is kept, with the median and ``rel_spread = (max - min)/min``,
  so a later slowdown can be judged against this run's noise.
* **Ratio to explicit Euler**: ``ref:explicit_euler`` timed by the compiled rule above
  on the same scene at the same dt in the same call, on the same clock, its repeats
  interleaved with the method's (method, baseline, method, baseline, ...): a machine that
  slows for a while slows both of a pair, the CPU clock included (docs/performance.md records
  such a stretch). A reference scheme's baseline runs the scheme's loop length, since a
  shorter loop carries more of the call's fixed cost per step. The ratio is the median of the
  pairs' ratios, its ``ratio_spread`` (max - min) / min of them.
* **Calibration**: a fixed workload pair (``harness.measures.calibration``: explicit Euler in a
  plain Python loop over its compiled kernel) timed in the same interleaved repeats, so that
  the history can tell a method's step from the machine's (``harness.history.series``).
* **Injected timings** (``harness.measures.injected``): with ``HARNESS_INJECT_TIMINGS`` naming a JSON file (or
  ``injected`` given), the timed runs still run but their figures are the file's: ``s_per_step`` by method
  id (``"*"`` for any other), each repeat multiplied by ``jitter`` (cycled), and the
  ``calibration`` pair. The clock is then recorded as ``injected`` (and no resolution). Tests
  of verdicts drawn from timings use it, so that no test's outcome depends on the machine's load.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np

from records import InvalidInput, Method
from records.result import Result

import reference
from reference import CLOCKS, time_per_step
from reference.method import COMPILED_TIMING

from scenarios import Scene

from harness.measures.common import resolve, step
from harness.measures.injected import INJECT_VAR, calibration_injected, injected_value, jitter, load_injected

COUNT_STEPS = 100
REF_TIME_STEPS = 100_000
REF_PILOT_STEPS = 2_000
#: Policy (module docstring, the run budget): the longest a compiled loop's timed repeat runs where
#: its asked steps would run longer, what a cost cell may spend on a slow kernel. ``run_budget``
#: lengthens it where the clock's measured resolution needs a longer run.
REF_RUN_BUDGET_S = 0.02
#: Policy: the fewest steps a cut repeat runs, so that the call's fixed cost stays a small share.
REF_MIN_STEPS = 5_000
ENGINE_TIME_STEPS = 10_000
HARNESS_TIME_STEPS = 2_000
ENGINE_PILOT_STEPS = 500
#: Policy: the same budget for an engine mode's timed repeat (the model built off the clock).
ENGINE_RUN_BUDGET_S = 0.02
#: Policy: the fewest steps a cut engine repeat runs.
ENGINE_MIN_STEPS = 200
#: Policy: the largest share of a timed run the clock's resolution may be (a run read to a
#: thousandth of itself, below the spread between repeats the cell records).
MAX_CLOCK_SHARE = 1e-3
#: Clock ticks read to measure its resolution (the least positive difference between readings).
RESOLUTION_TICKS = 20
#: Readings at most while measuring it; a clock that never ticks in them falls back to its declared
#: resolution (``time.get_clock_info``).
RESOLUTION_READS = 1_000_000
REPEATS = 5
#: 0-step runs timed at most, beyond one per repeat, where none is faster than the fastest timed
#: run (``_Timing._resolve_setup``).
SETUP_RETRIES = 50
BASELINE = "ref:explicit_euler"


@functools.cache
def clock_resolution(clock: str) -> float:
    """Seconds: the least positive difference between successive readings of ``clock`` ("wall" or
    "cpu"), over ``RESOLUTION_TICKS`` ticks: the resolution a timed run is read to, the cost of a
    reading included. Measured once per process, at its first timing; at least the resolution
    the platform declares for the clock."""
    if clock not in CLOCKS:
        raise InvalidInput(f"clock {clock!r} is not one of {sorted(CLOCKS)}")
    now = CLOCKS[clock]
    declared = time.get_clock_info(now.__name__).resolution
    least, ticks, last = math.inf, 0, now()
    for _ in range(RESOLUTION_READS):
        t = now()
        if t != last:
            if t > last:
                least = min(least, t - last)
            last, ticks = t, ticks + 1
            if ticks >= RESOLUTION_TICKS:
                break
    return max(declared, least) if math.isfinite(least) else declared


def run_budget(policy_s: float, clock: str) -> float:
    """Seconds a timed repeat may last before it is cut: the policy's ``policy_s``, or where longer
    the run over which ``clock``'s measured resolution is ``MAX_CLOCK_SHARE`` of it."""
    return max(policy_s, clock_resolution(clock) / MAX_CLOCK_SHARE)


def _spread(times: list[float]) -> dict:
    lo = min(times)
    return {
        "s_per_step": lo,
        "median_s_per_step": float(np.median(times)),
        "repeats_s_per_step": list(times),
        "rel_spread": (max(times) - lo) / lo if lo > 0 else None,
    }


def counted_evaluations(
    method, scene: Scene, dt: float, *, steps: int = COUNT_STEPS, timeout: float | None = None
) -> dict:
    """Force evaluations and solves per step, counted over ``steps`` steps."""
    method = resolve(method, scene)
    traj = step(method, scene, dt, steps, steps, timeout)
    ran = traj.meta.steps_run if traj.meta.steps_run is not None else steps if traj.ok else (traj.failed_step or 1) - 1
    if traj.force_evals is None and ran > 0 and traj.status in ("ok", "unstable") and method.counting_run:
        counted = method.simulate(scene, dt, ran, ran, count=True)
        if counted.force_evals is not None:
            traj = counted
    out: dict = {"count_steps": int(ran), "count_status": traj.status}
    if traj.force_evals is None or ran <= 0:
        out.update(
            force_evals_per_step=None,
            force_evals_reason=traj.meta.force_evals_reason or "the engine mode does not count them",
        )
    else:
        out["force_evals_per_step"] = traj.force_evals / ran
        out["start_force_evals"] = traj.meta.start_force_evals
    out["solves_per_step"] = None if traj.solves is None or ran <= 0 else traj.solves / ran
    if traj.meta.linear_solver is not None and ran > 0:  # a library solve's own counts (reference.solvers)
        out["solver"] = traj.meta.linear_solver
        out["solver_iterations_per_step"] = traj.meta.solver_iterations / ran
        out["unconverged_solves"] = traj.meta.unconverged_solves
    scheme = method.scheme
    if scheme is not None:
        out["declared_force_evals"] = scheme.force_evals
        out["declared_implicit"] = scheme.implicit
    return out


_COMPILED_TIMING = COMPILED_TIMING
_LOOP_TIMING = {
    "engine": "engine s/step: in-process simulate through the engine's own loop, state read at the output "
    "point only, model built off the clock, (min t(N) - min t(0))/N after warm-up",
    "harness": "as stepped by the harness: in-process simulate one step at a time, state read and checked (and "
    "forces applied) after every step, model built off the clock, (min t(N) - min t(0))/N after warm-up",
}


class _Timing:
    """One method's timing by the module's rule, a repeat at a time (so that two methods'
    repeats can be interleaved). ``budget`` False: a compiled loop runs ``steps`` steps
    whatever they cost (explicit Euler timed beside a scheme runs the scheme's loop length)."""

    def __init__(
        self,
        method: Method,
        scene: Scene,
        dt: float,
        steps: int | None,
        clock: str,
        loop: str = "engine",
        budget: bool = True,
        injected: dict | None = None,
    ):
        self.now = CLOCKS[clock]
        self.injected, self.injected_value = injected, injected_value(injected, method.id)
        self.scheme = method.scheme
        self.times, self.empty = [], []
        self.loop, self.engine_loop = loop, None
        self.stopped = ""
        self.setup_unresolved = False
        if self.scheme is not None:
            self.n = int(steps or REF_TIME_STEPS)
            # At the method's own options (a constrained scheme's passes, a position-based one's
            # substeps; a library solve, timed on the Python loop that runs it, which it says).
            self.warmup_s, self._once, self.scheme_timing = method.step_timer(scene, dt, self.n, clock=clock)
            if budget:
                per_step = self._once(min(self.n, REF_PILOT_STEPS))
                budget_s = run_budget(REF_RUN_BUDGET_S, clock)
                if per_step * self.n > budget_s:
                    self.n = max(min(REF_MIN_STEPS, self.n), int(budget_s / per_step))
        else:
            self.asked = int(steps or (ENGINE_TIME_STEPS if loop == "engine" else HARNESS_TIME_STEPS))
            self.method, self.scene, self.dt = method, scene, dt
            pilot = min(self.asked, ENGINE_PILOT_STEPS)
            t = self.now()
            warm = self._simulate(pilot)  # warm-up, and the pilot for the step count
            self.warmup_s = self.now() - t
            if loop == "engine":
                self.engine_loop = (warm.meta.settings or {}).get("engine_loop")  # where the engine says
            # The pilot: the warm-up's steps timed again with the model built off the clock (the
            # warm-up also builds it, which can be most of the pilot's time on a large model).
            self.n = pilot
            pilot_s = (self._run_s(pilot) - self._run_s(0)) / self.n
            n, budget_s = self.asked, run_budget(ENGINE_RUN_BUDGET_S, clock)
            if pilot_s * self.asked > budget_s:
                n = max(ENGINE_MIN_STEPS, int(budget_s / pilot_s))
            self.n = self.n if self.stopped else min(n, self.asked)

    def repeat(self) -> None:
        if self.scheme is not None:
            self.times.append(self._once(self.n))
            return
        self.empty.append(self._run_s(0))
        self.times.append(self._run_s(self.n))

    def _simulate(self, n: int):
        if self.loop == "engine":  # an engine mode's default loop (a plugin's simulate takes no loop)
            return self.method.simulate(self.scene, self.dt, n, max(n, 1))
        return self.method.simulate(self.scene, self.dt, n, max(n, 1), loop=self.loop)

    def _run_s(self, n: int) -> float:
        """Seconds of one run of n steps: the run alone where the mode can time it (an engine
        mode's ``timed_run``, its model built off the clock), else the whole ``simulate``.

        Only steps the method runs are timed: a run that diverges within them (MuJoCo's implicit
        on the rope, at step 2434 of 10,000) is replayed step by step to find where, and
        (replay + steps run) / n is no cost per step of anything. Such a run sets ``n`` to the
        steps before the failing one and is timed again over those (a model diverges at the
        same step every run: it shows on the first run of n steps, before a repeat is kept)."""
        if self.method.timed_run is not None:
            seconds, failed = self.method.timed_run(self.scene, self.dt, n, self.now, self.loop)
        else:
            t = self.now()
            failed = self._simulate(n).failed_step
            seconds = self.now() - t
        if failed is not None and 0 < failed <= n:
            self.n = max(1, failed - 1)
            self.stopped = f"timed over the {self.n} steps before the run diverged at step {failed}"
            return self._run_s(self.n)
        return seconds

    def _resolve_setup(self) -> None:
        """Time more 0-step runs where none came out faster than the fastest timed run. Load only
        adds time, so that run took at least a 0-step run's time plus its steps'; a 0-step minimum
        above it means every 0-step run was slowed, which on a loaded machine happens where the
        timed run is a few steps long (MuJoCo's Euler on a spring past its limit diverges at step
        27, so 26 steps are timed against a setup that is a good share of their time:
        docs/performance.md), and would make the cost per step negative. Up to ``SETUP_RETRIES``
        more; where none resolves it, the runs are taken whole (``setup_unresolved``): an upper
        bound, said in the timing."""
        if self.scheme is not None or self.injected_value is not None or not self.times:
            return
        for _ in range(SETUP_RETRIES):
            if min(self.empty) < min(self.times):
                return
            self.empty.append(self._run_s(0))
        self.setup_unresolved = min(self.empty) >= min(self.times)

    def per_step(self) -> list[float]:
        if self.injected_value is not None:
            return [self.injected_value * jitter(self.injected, i) for i in range(len(self.times))]
        if self.scheme is not None:
            return list(self.times)
        setup = 0.0 if self.setup_unresolved else min(self.empty)
        return [(t - setup) / self.n for t in self.times]

    def result(self, clock: str) -> dict:
        self._resolve_setup()
        timing = self.scheme_timing if self.scheme is not None else _LOOP_TIMING[self.loop]
        if self.setup_unresolved:
            timing += (
                "; every 0-step run was slower than the fastest timed run (a loaded machine): "
                "whole runs per step, the setup included, an upper bound"
            )
        if self.injected_value is not None:
            timing, clock = f"injected from ${INJECT_VAR}, not measured (the runs timed: {timing})", "injected"
        out = {
            "timing": f"{timing}; {self.stopped}" if self.stopped else timing,
            "clock": clock,
            "time_steps": self.n,
            "warmup_s": self.warmup_s,
            **_spread(self.per_step()),
            "clock_resolution_s": None if clock == "injected" else clock_resolution(clock),
        }
        if self.scheme is None:
            out["setup_s"] = min(self.empty)
            out["time_steps_asked"] = self.asked
            out["loop"] = self.loop
            if self.engine_loop is not None:
                out["engine_loop"] = self.engine_loop
        return out


def _steppable_per_step(method: Method) -> bool:
    """An engine mode with a per-step path to time beside its own loop (``EngineMode.LOOPS``)."""
    return method.scheme is None and "harness" in method.LOOPS


def wall_time_per_step(
    method,
    scene: Scene,
    dt: float,
    *,
    steps: int | None = None,
    repeats: int = REPEATS,
    clock: str = "wall",
    loop: str = "engine",
    injected: dict | None = None,
) -> dict:
    """Seconds per step by the rule in the module docstring (compiled for reference schemes,
    in-process ``simulate`` for engine modes, through ``loop``), on ``clock`` ("wall" or "cpu")."""
    method = resolve(method, scene)
    injected = injected if injected is not None else load_injected()
    timing = _Timing(method, scene, dt, steps, clock, loop, injected=injected)
    for _ in range(repeats):
        timing.repeat()
    return timing.result(clock)


@dataclass(frozen=True)
class CostResult(Result):
    """What :func:`cost_per_step` measured (module docstring): the counted evaluations, the
    method's seconds per step on ``clock``, explicit Euler's beside it and their ratio, the
    calibration timed in the same repeats, and for an engine mode its per-step path too."""

    scene: str
    params: dict
    method: str
    dt: float
    omega_dt: float
    count_steps: int  # counted_evaluations'
    count_status: str
    force_evals_per_step: float | None
    solves_per_step: float | None
    timing: str  # what was timed, and how
    clock: str
    time_steps: int
    warmup_s: float
    s_per_step: float  # the fastest repeat
    median_s_per_step: float
    repeats_s_per_step: list
    rel_spread: float | None
    baseline: dict  # explicit Euler's timing (or why there is none)
    ratio_to_explicit_euler: float | None
    ratio_spread: float | None = None
    ratio_repeats: list | None = None
    force_evals_reason: str | None = None  # why they are not counted, where they are not
    start_force_evals: int | None = None
    declared_force_evals: float | None = None
    declared_implicit: bool | None = None
    calibration: float | None = None  # harness.measures.calibration
    calibration_spread: float | None = None
    calibration_python_s_per_step: float | None = None
    calibration_compiled_s_per_step: float | None = None
    calibration_clock: str | None = None
    clock_resolution_s: float | None = None  # the clock's resolution, measured (``clock_resolution``)
    setup_s: float | None = None  # an engine mode's: building the model, off the clock
    time_steps_asked: int | None = None
    loop: str | None = None
    engine_loop: str | None = None  # how the engine's own loop steps, where it says
    as_stepped: dict | None = None  # an engine mode stepped one call at a time from Python
    as_stepped_s_per_step: float | None = None
    solver: str | None = None  # a library solve the method chose (reference.solvers)
    solver_iterations_per_step: float | None = None  # its iterations (conjugate gradients, local/global passes)
    unconverged_solves: int | None = None  # its solves over the counted steps that stopped short of tol


def cost_per_step(
    method,
    scene: Scene,
    dt: float,
    *,
    time_steps: int | None = None,
    repeats: int = REPEATS,
    count_steps: int = COUNT_STEPS,
    timeout: float | None = None,
    baseline: dict | None = None,
    clock: str = "wall",
    injected: dict | None = None,
    progress=None,
) -> CostResult:
    """Counted evaluations, time per step and the ratio to explicit Euler (compiled) on
    the same scene and dt, the two and the calibration timed in interleaved repeats (module
    docstring). ``baseline`` reuses an explicit-Euler timing from the same run instead (no
    calibration then); ``injected``: timings to record instead of the clock's (default: the
    ``HARNESS_INJECT_TIMINGS`` file, if set); ``progress``: told a line before the counted run
    and each repeat (a command's progress)."""
    from harness.measures.calibration import Calibration

    method = resolve(method, scene)
    say = progress or (lambda line: None)
    injected = injected if injected is not None else load_injected()
    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "dt": float(dt),
        "omega_dt": float(dt) * scene.omega,
    }
    say(f"cost: counting force evaluations over {count_steps} steps of {method.id}")
    out.update(counted_evaluations(method, scene, dt, steps=count_steps, timeout=timeout))
    stepped = (
        _Timing(method, scene, dt, time_steps, clock, "harness", injected=injected)
        if _steppable_per_step(method)
        else None
    )
    if baseline is not None:
        out.update(
            wall_time_per_step(method, scene, dt, steps=time_steps, repeats=repeats, clock=clock, injected=injected)
        )
        _add_as_stepped(out, stepped, repeats, clock)
        out["baseline"] = baseline
        out["ratio_to_explicit_euler"] = out["s_per_step"] / baseline["s_per_step"]
        out["ratio_spread"] = (out["rel_spread"] or 0.0) + (baseline["rel_spread"] or 0.0)
        return CostResult(**out)
    timing = _Timing(method, scene, dt, time_steps, clock, injected=injected)
    calibration = Calibration(clock, calibration_injected(injected))
    from harness.methods import get_method

    baseline_method = get_method(BASELINE)
    ok, why = baseline_method.supports(scene)
    if not ok:  # a constrained scene (the rope): no explicit-Euler run to compare with
        for _ in range(repeats):
            timing.repeat()
            calibration.repeat()
        out.update(timing.result(clock))
        out.update(calibration.result())
        _add_as_stepped(out, stepped, repeats, clock)
        out["baseline"] = {"method": BASELINE, "unsupported": why}
        out["ratio_to_explicit_euler"] = None
        return CostResult(**out)
    # A reference scheme and its baseline run the same compiled loop length: a shorter loop
    # carries more of the call's fixed cost per step (docs/performance.md has the figure).
    base_steps = timing.n if timing.scheme is not None else REF_TIME_STEPS
    base = _Timing(baseline_method, scene, dt, base_steps, clock, budget=timing.scheme is None, injected=injected)
    for i in range(repeats):
        say(f"cost: timed repeat {i + 1} of {repeats}, {method.id} and {BASELINE} interleaved")
        timing.repeat()
        base.repeat()
        calibration.repeat()
        if stepped is not None:
            stepped.repeat()
    out.update(timing.result(clock))
    out.update(calibration.result())
    _add_as_stepped(out, stepped, 0, clock)
    out["baseline"] = {"method": BASELINE, **base.result(clock)}
    ratios = [m / b for m, b in zip(timing.per_step(), base.per_step())]
    out["ratio_repeats"] = ratios
    out["ratio_to_explicit_euler"] = float(np.median(ratios))
    out["ratio_spread"] = (max(ratios) - min(ratios)) / min(ratios)
    return CostResult(**out)


def _add_as_stepped(out: dict, stepped: _Timing | None, repeats: int, clock: str) -> None:
    """The second figure of an engine mode (module docstring): ``as_stepped`` (the timing) and
    ``as_stepped_s_per_step``; ``repeats`` more repeats first where they were not interleaved."""
    if stepped is None:
        return
    for _ in range(repeats):
        stepped.repeat()
    res = stepped.result(clock)
    out["as_stepped"] = res
    out["as_stepped_s_per_step"] = res["s_per_step"]


def explicit_euler_baseline(
    scene: Scene, dt: float, *, repeats: int = REPEATS, clock: str = "wall", steps: int = REF_TIME_STEPS
) -> dict:
    res = time_per_step(reference.METHODS["explicit_euler"], scene, dt, steps, repeats=repeats, clock=clock)
    return {
        "method": BASELINE,
        "timing": _COMPILED_TIMING,
        "clock": clock,
        "time_steps": steps,
        "warmup_s": res["warmup_s"],
        **_spread(res["repeats"]),
        "clock_resolution_s": clock_resolution(clock),
    }
