"""What a run on the compiled loop counted: the force evaluations, solves and projections the
interpreted driver (``reference._integrate``, the counting truth) counts on the same run, without
counting them in the loop, which is also the loop the timings time.

* Where a step takes a fixed number of each (``Kind.step_counts``: every kind but an implicit step
  that may iterate Newton more than once), they are that number times the steps taken: the
  numbers the scheme declares (its ``force_evals``).
* The start (a Verlet form's first acceleration) is the scheme's ``start``, interpreted once from
  the run's state with its force counted: one call, the count the interpreted run has.
* Where they vary from step to step (an implicit step that iterates Newton to a tolerance: on a
  nonlinear scene, or with coupled stages), no run on the compiled loop knows them: a few steps
  stall at the iteration cap (implicit Euler on Kepler: 50 passes against two or three), so no
  sample of a run's steps stands for the rest. The run says so, and a measure that needs them
  asks for an interpreted counting run of the steps it counts (``RefMethod.simulate(...,
  count=True)``; the cost measure's 100 steps).

``tests/test_compiled_runs.py`` checks these against the interpreted driver's counts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios import Scene

from ._integrate import Counted
from ._scheme import start_qv

#: Why a run on the compiled loop has no counts where they vary (``RunMeta.force_evals_reason``).
VARYING = "its Newton passes vary from step to step: counted by an interpreted counting run (simulate(..., count=True))"


@dataclass(frozen=True)
class RunCounts:
    """A run's counts, as ``reference.integrate`` reports them."""

    force_evals: int
    solves: int
    projections: int


def step_counts(
    scheme, scene: Scene, iterations: int | None = None, substeps: int | None = None
) -> tuple[int, int, int] | None:
    """(force evaluations, solves, projections) a step of the pair takes, declared; None where they vary."""
    kind = scheme.kind
    return kind.step_counts(scheme, scene, kind.count(scheme, scene, iterations, substeps))


def start_evaluations(scheme, scene: Scene, q, v, t0: float, dt: float) -> int:
    """The force evaluations of the scheme's start from (q, v) (kernel layout), counted as the
    interpreted driver counts them (none for the default start, which carries (q, v) as they are)."""
    if scheme.start is start_qv:
        return 0
    accel = Counted(scene.accel)
    with np.errstate(all="ignore"):
        scheme.start(accel, q, v, t0, dt, scene.pvec)
    return accel.calls


def of_run(
    scheme, scene: Scene, taken: int, iterations: int | None = None, substeps: int | None = None
) -> RunCounts | None:
    """The counts of a compiled run that took ``taken`` steps (the failing one included, as the
    interpreted driver counts it), where the pair's are declared; None where they vary."""
    per_step = step_counts(scheme, scene, iterations, substeps)
    if per_step is None:
        return None
    return RunCounts(*(n * taken for n in per_step))
