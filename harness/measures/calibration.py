"""The machine's own noise, measured beside every cost cell: a fixed calibration workload.

A cost figure is a ratio (the method's time per step over compiled explicit Euler's, timed in
interleaved repeats), which cancels a machine that is uniformly slower. What it does not cancel
is a machine whose *kinds* of code slow unequally: with another CPU-bound process sharing the
machine, an engine stepped from Python (``pymunk:applied_force``) can move against the compiled
baseline between two runs of one commit by far more than its repeats spread
(docs/performance.md records the case). So every cost cell times,
in the same interleaved repeats, a fixed pair that spans those kinds of code:

* ``python``: explicit Euler on the unit spring stepped in a plain Python loop
  (``PYTHON_STEPS`` steps of float arithmetic: the interpreter's dispatch, as an engine's
  Python-driven loop spends it);
* ``compiled``: the same scheme's compiled kernel (``reference.step_timer``, the cost cells'
  baseline kernel) on the same spring, ``COMPILED_STEPS`` steps.

Their ratio, ``python / compiled``, is the **calibration**: the same code every night, so any
change of it between two runs is the machine's (its load, its neighbours, its cache), measured
at the moment the cell was measured. ``harness.history.series`` credits a cost step with the
calibration's own move across it: a step no larger than what the calibration moved by is
explained by the machine, not reported as a change of the method's cost.

Timings can be injected (``HARNESS_INJECT_TIMINGS``, ``harness.measures.cost``): the
calibration then reads ``calibration`` of that file (``python`` and ``compiled`` seconds per
step), so that a test of a verdict drawn from it depends on no clock.
"""

from __future__ import annotations

import numpy as np

#: Steps of each workload per repeat: the two workloads' repeats last about as long as each other.
PYTHON_STEPS = 2_000
COMPILED_STEPS = 20_000


def _python_loop(n: int, x: float = 1.0, v: float = 0.0, h: float = 0.1) -> float:
    for _ in range(n):
        x, v = x + h * v, v - h * x
    return x


class Calibration:
    """The calibration pair timed a repeat at a time (to interleave with a cost cell's repeats)
    on ``clock``; ``injected``: the ``calibration`` entry of an injected-timings file instead."""

    def __init__(self, clock: str, injected: dict | None = None):
        from reference import CLOCKS

        self.now = CLOCKS[clock]
        self.clock = clock
        self.injected = injected
        self.python, self.compiled = [], []
        if injected is None:
            import reference
            from scenarios import make_scene

            _, self._once = reference.step_timer(
                reference.METHODS["explicit_euler"], make_scene("spring"), 0.1, COMPILED_STEPS, clock=clock
            )
            _python_loop(PYTHON_STEPS)  # warm

    def repeat(self) -> None:
        if self.injected is not None:
            from harness.measures.injected import jitter

            j = jitter(self.injected, len(self.python))
            self.python.append(float(self.injected["python"]) * j)
            self.compiled.append(float(self.injected["compiled"]))
            return
        t = self.now()
        _python_loop(PYTHON_STEPS)
        self.python.append((self.now() - t) / PYTHON_STEPS)
        self.compiled.append(self._once(COMPILED_STEPS))

    def result(self) -> dict:
        """The calibration ratio (median of the repeats' ratios) and its spread, (max - min) / min."""
        ratios = [p / c for p, c in zip(self.python, self.compiled) if c > 0]
        if not ratios:
            return {}
        return {
            "calibration": float(np.median(ratios)),
            "calibration_spread": (max(ratios) - min(ratios)) / min(ratios),
            "calibration_python_s_per_step": min(self.python),
            "calibration_compiled_s_per_step": min(self.compiled),
            "calibration_clock": "injected" if self.injected is not None else self.clock,
        }
