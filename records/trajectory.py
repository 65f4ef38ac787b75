"""The one result type every method returns: reference schemes and engine adapters alike.

Energy is never taken from a method: it is computed here by the scene, from the state,
with the same formula for every method.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING
from collections.abc import Callable

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

#: Outcomes of a run. A failure is a result, never an exception out of the harness.
OK, UNSTABLE, CRASHED, TIMED_OUT, UNSUPPORTED = "ok", "unstable", "crashed", "timed_out", "unsupported"
STATUSES = (OK, UNSTABLE, CRASHED, TIMED_OUT, UNSUPPORTED)

#: A state component beyond this magnitude is a blow-up even while still finite: its energy
#: overflows double precision (explicit Euler reaches 1e216 on a spring at h = 0.1). One
#: criterion for every method, reference or engine, so their failure steps compare.
DIVERGED = 1e100


#: Below this sum of squares no component can exceed ``DIVERGED`` (a margin of ten below
#: DIVERGED^2 keeps the squares' rounding from hiding one just past it).
_SAFE_SQUARES = DIVERGED * DIVERGED / 10.0


def diverged(q, v) -> bool:
    """True when any component of the state is not finite or beyond ``DIVERGED``.

    Every step of every run asks this, so the usual answer is taken cheaply: a finite sum of
    squares below ``_SAFE_SQUARES`` bounds every component (NaN and overflow compare false and
    fall through to the componentwise test)."""
    if float(np.vdot(q, q)) + float(np.vdot(v, v)) < _SAFE_SQUARES:
        return False
    return not (np.abs(q).max(initial=0.0) <= DIVERGED and np.abs(v).max(initial=0.0) <= DIVERGED)


def divergence_detail(n: int, t: float) -> str:
    return f"state diverged (not finite or |state| > {DIVERGED:g}) at step {n} (t = {t:g})"


def output_marks(steps: int, every: int) -> np.ndarray:
    """The steps a run records: 0, every ``every`` steps, and always the last. Every driver records
    these (``step_loop``; the engine loops and the compiled kernels read their states at them)."""
    return np.unique(np.append(np.arange(0, int(steps) + 1, int(every), dtype=np.int64), int(steps)))


def step_loop(
    advance: Callable[[int, int], None],
    check: Callable[[int], str],
    record: Callable[[int], None],
    steps: int,
    every: int,
    spans: bool = False,
    rewind: Callable[[], None] | None = None,
    marks=None,
) -> tuple[int | None, str]:
    """The rule every driver records and stops by (``reference.integrate``, the compiled run,
    ``adapters.drive`` and the engines' own loops): record step 0, then advance and check, stopping at the
    first point whose ``check(n)`` gives a reason (a diverged state, an engine's warning), and record
    each mark of :func:`output_marks`. Returns (the failed step, its reason), or (None, "").

    ``advance(a, b)`` takes steps a + 1 .. b. One step at a time by default. ``spans``: from one
    mark to the next in one call (an engine's own loop, a compiled loop), checked at the marks
    only; a span that fails is taken again one step at a time from its start after ``rewind()``
    puts the state back there, to find the step, or without ``rewind`` its end is returned for
    the caller to replay the run (a state that passes the bound and comes back within one span
    would be missed: blow-ups do not). ``marks``: the spans' ends, where a loop is asked for other
    points than a run's output marks."""
    record(0)
    if not spans:
        for n in range(1, steps + 1):
            advance(n - 1, n)
            why = check(n)
            if why:
                return n, why
            if n % every == 0 or n == steps:
                record(n)
        return None, ""
    marks = output_marks(steps, every) if marks is None else marks
    marks = marks.tolist() if isinstance(marks, np.ndarray) else [int(m) for m in marks]  # Python ints
    for a, b in zip(marks, marks[1:]):
        advance(a, b)
        why = check(b)
        if not why:
            record(b)
            continue
        if rewind is None:
            return b, why
        rewind()
        for n in range(a + 1, b + 1):
            advance(n - 1, n)
            why = check(n) or (why if n == b else "")
            if why:
                return n, why
    return None, ""


@dataclass
class RunMeta:
    """What a run recorded beside its states: each driver (``reference``'s interpreted and compiled
    ones, ``adapters``' engine loops, the worker that ran it) sets the fields it knows; a field
    it does not know is None."""

    backend: str | None = None  # interpreted | compiled | engine
    steps_run: int | None = None  # steps taken before a blow-up (all of them where none)
    params: dict = field(default_factory=dict)  # the scene's parameters
    start_force_evals: int | None = None  # evaluations a multistep scheme's start took
    force_evals_counted: str | None = None  # what was counted as a force evaluation
    force_evals_reason: str | None = None  # why they are not counted, where they are not
    iterations: int | None = None  # a constrained scheme's projection passes per step
    projections: int | None = None  # projections counted
    linear_solver: str | None = None  # a library solve the method chose (reference.solvers), where it did
    solver_iterations: int | None = None  # its iterations counted (conjugate gradients, local/global passes)
    unconverged_solves: int | None = None  # its solves that stopped at the iteration cap or broke down
    factorizations: int | None = None  # its matrix factorizations counted
    loop: str | None = None  # how an engine mode was stepped (adapters._loops)
    engine: str | None = None
    engine_version: str | None = None
    settings: dict | None = None  # the engine's settings, read back from the model that ran
    worker: dict | None = None  # the worker's failure, where the run was lost

    def as_dict(self) -> dict:
        """The fields that are set, as plain values (``Trajectory.summary``)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}


@dataclass
class Trajectory:
    """States recorded every ``every`` steps, API layout: ``q``/``v`` are (T, batch, ndof).

    ``status`` is ``ok`` or how the run failed; ``failed_step`` is the first step whose
    state was not finite (or where the engine reset itself), and the arrays stop at the
    last good recorded state. ``force_evals`` and ``solves`` are counted, not declared
    (None when the method cannot be counted).
    """

    scene: str
    method: str
    dt: float
    steps: int
    every: int
    step: np.ndarray
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    energy: np.ndarray
    status: str = OK
    detail: str = ""
    failed_step: int | None = None
    force_evals: int | None = None
    solves: int | None = None
    meta: RunMeta = field(default_factory=RunMeta)

    @classmethod
    def failed(
        cls,
        scene: str,
        method: str,
        dt: float,
        steps: int,
        status: str,
        detail: str,
        every: int = 1,
        ndof: int = 0,
        meta: RunMeta | None = None,
    ) -> Trajectory:
        empty = np.zeros((0, 1, ndof))
        return cls(
            scene,
            method,
            dt,
            steps,
            every,
            np.zeros(0, dtype=int),
            np.zeros(0),
            empty,
            empty.copy(),
            np.zeros((0, 1)),
            status=status,
            detail=detail,
            meta=meta or RunMeta(),
        )

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def ndof(self) -> int:
        return self.q.shape[-1]

    def final(self) -> tuple[np.ndarray, np.ndarray]:
        return self.q[-1], self.v[-1]

    def to_frame(self) -> pd.DataFrame:
        """Tidy table: one row per recorded state (and batch member, if more than one)."""
        import pandas as pd  # here: a run that never tabulates (a command's start, a worker) need not import pandas

        T, B, n = self.q.shape
        cols: dict[str, np.ndarray] = {}
        if B > 1:
            cols["batch"] = np.tile(np.arange(B), T)
        cols["step"] = np.repeat(self.step, B)
        cols["t"] = np.repeat(self.t, B)
        for i in range(n):
            cols[f"q{i}"] = self.q[:, :, i].reshape(-1)
        for i in range(n):
            cols[f"v{i}"] = self.v[:, :, i].reshape(-1)
        cols["energy"] = self.energy.reshape(-1)
        return pd.DataFrame(cols)

    def summary(self) -> dict:
        return {
            "scene": self.scene,
            "method": self.method,
            "dt": self.dt,
            "steps": self.steps,
            "status": self.status,
            "detail": self.detail,
            "failed_step": self.failed_step,
            "force_evals": self.force_evals,
            "solves": self.solves,
            "meta": self.meta.as_dict(),
        }
