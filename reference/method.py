"""A reference scheme as a method (``records.Method``): the reference package's own face to the
harness, beside the engine modes of ``adapters``."""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

from records import REFERENCE, MethodId, Trajectory
from records.method import NO_REASONS

from scenarios import Scene

from . import solvers
from ._compiled import Exact, integrate_compiled, integrate_exact, step_timer
from ._integrate import integrate
from ._scheme import Scheme

#: What the cost measure times of a scheme on its compiled path.
COMPILED_TIMING = "compiled (numba), min of repeats after warm-up"


@dataclass(frozen=True)
class RefMethod:
    """A reference scheme as a method. ``options`` are the run-time options the scheme declares
    (``Scheme.options``: a constrained scheme's projection ``iterations``; an implicit scheme's
    ``solver`` and its settings, ``reference.solvers``); unset ones keep the scheme's defaults.
    ``compiled`` picks the compiled driver (same states, not counted). A library solve runs in
    Python, counted, whatever the driver asked for (numba cannot compile the library)."""

    scheme: Scheme
    options: dict = field(default_factory=dict, compare=False)
    #: Step on the compiled path (``reference.integrate_compiled``): the same states, for runs
    #: too long to interpret; force evaluations are then not counted.
    compiled: bool = field(default=False, compare=False)
    #: Step on the exact compiled run where it computes the interpreted bits (``Exact``), else
    #: interpreted; None: interpreted. The same states and counts either way, only faster.
    exact: Exact | None = field(default=None, compare=False)

    # The capabilities of records.Method, declared: stepped in this process, at the dt it is
    # given, counted on every run, matching itself; no loop to choose, no engine model to reuse
    # or to build off the clock (its timing is the compiled kernel's, ``reference.step_timer``).
    family = REFERENCE
    precision = "float64"
    isolated = False
    adaptive = False
    counting_run = False
    no_match = NO_REASONS
    LOOPS = ()
    one_steps = None
    timed_run = None

    @property
    def id(self) -> str:
        """``ref:<scheme>``, with the options set written in (``ref:xpbd?iterations=1&substeps=10``)."""
        return str(MethodId.of(REFERENCE, self.scheme.id, self.options))

    def with_options(self, options: dict) -> "RefMethod":
        """The same scheme with ``options`` set (each checked by the caller, ``harness.methods``;
        a solve's options together here: InvalidInput where one applies to another solve)."""
        merged = {**self.options, **options}
        solvers.choice(self.scheme, merged)
        return replace(self, options=merged)

    @property
    def solver(self) -> "solvers.Choice | None":
        """The library solve its options choose (None: the scene's own kernel)."""
        return solvers.split(self.scheme, self.options)[0]

    @property
    def _kernel_options(self) -> dict:
        """The options the kernels take (a constrained scheme's passes, ...), the solve's left out."""
        return solvers.split(self.scheme, self.options)[1]

    @property
    def options_declared(self) -> dict:
        """The options of its solve (``reference.solvers.options_for``); the counts a constrained or
        position-based scheme takes are declared by ``harness.methods``."""
        return solvers.options_for(self.scheme)

    def available(self) -> tuple[bool, str]:
        return True, ""

    def supports(self, scene: Scene) -> tuple[bool, str]:
        if not scene.has_kernels:
            return False, (f"scene {scene.id} has no force kernel for a reference scheme to step: "
                           "its physics is the engine's (a model file); engine modes run it")
        why = self.scheme.kind.supports(self.scheme, scene, self.id)
        if why:
            return False, why
        solver = self.solver
        why = solver.supports(scene) if solver is not None else ""
        if why:
            return False, why
        return True, ""

    def compiled_twin(self) -> "RefMethod":
        # A library solve has no compiled path: its run is already its fastest.
        return self if self.solver is not None else replace(self, compiled=True)

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1) -> Trajectory:
        solver, options = solvers.split(self.scheme, self.options)
        if solver is not None:
            return integrate(self.scheme, scene, dt, steps, every, solver=solver)
        if self.compiled:
            return integrate_compiled(self.scheme, scene, dt, steps, every, **options)
        if self.exact is not None:  # the same run, compiled where that is exact
            if self.exact.wants_rate(self.scheme, scene):  # what a step costs interpreted, to decide
                probe = min(int(steps), self.exact.probe_steps)
                self._interpreted(scene, dt, probe, max(1, probe))
            traj = integrate_exact(self.scheme, scene, dt, steps, every, **options,
                                   may_compile=self.exact.may_compile(self.scheme, scene, steps))
            if traj is not None:
                return traj
            return self._interpreted(scene, dt, steps, every)
        return integrate(self.scheme, scene, dt, steps, every, **options)

    def step_timer(self, scene: Scene, dt: float, steps: int, clock: str = "wall"):
        """``(warm-up seconds, once, what is timed)`` at its options: the compiled loop
        (``reference.step_timer``), or where a library solve is chosen the Python loop that runs
        it (``reference.solvers.step_timer``), which the third says."""
        solver, options = solvers.split(self.scheme, self.options)
        if solver is not None:
            return solvers.step_timer(solver, self.scheme, scene, dt, steps, clock)
        return (*step_timer(self.scheme, scene, dt, steps, clock=clock, **options), COMPILED_TIMING)

    def _interpreted(self, scene: Scene, dt: float, steps: int, every: int) -> Trajectory:
        """``integrate``, its CPU seconds and steps counted against the pair (``Exact.interpreted``)."""
        t = time.process_time()
        traj = integrate(self.scheme, scene, dt, steps, every, **self._kernel_options)
        self.exact.interpreted(self.scheme, scene, time.process_time() - t, max(1, traj.meta.steps_run or steps))
        return traj

    def describe(self) -> dict:
        out = {"id": self.id, "family": self.family,
               **{k: v for k, v in self.scheme.describe().items() if k != "id"}}
        solver = self.solver
        if solver is not None:
            out["solver"] = solver.text
        return out
