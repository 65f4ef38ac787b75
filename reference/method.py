"""A reference scheme as a method (``records.Method``): the reference package's own face to the
harness, beside the engine modes of ``adapters``."""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

from records import REFERENCE, MethodId, Trajectory
from records.method import NO_REASONS

from scenarios import Scene

from ._compiled import Exact, integrate_compiled, integrate_exact
from ._integrate import integrate
from ._scheme import Scheme


@dataclass(frozen=True)
class RefMethod:
    """A reference scheme as a method. ``options`` are the run-time options the scheme declares
    (``Scheme.options``: a constrained scheme's projection ``iterations``); unset ones keep the
    scheme's defaults. ``compiled`` picks the compiled driver (same states, not counted)."""

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
        return str(MethodId.of(REFERENCE, self.scheme.id,
                               {**self.options, **self.scheme.kind.parameter_values(self.scheme)}))

    def with_options(self, options: dict) -> "RefMethod":
        """The same scheme with ``options`` set (checked by the caller, ``harness.methods``): the
        counts the drivers take kept in ``options``, the parameters of the step (``Kind.parameters``:
        a Jacobi scheme's relaxation) bound into the scheme."""
        kind = self.scheme.kind
        declared = kind.parameters(self.scheme)
        bound = {k: v for k, v in options.items() if k in declared}
        counts = {k: v for k, v in options.items() if k not in declared}
        scheme = kind.with_parameters(self.scheme, bound) if bound else self.scheme
        return replace(self, scheme=scheme, options={**self.options, **counts})

    def available(self) -> tuple[bool, str]:
        return True, ""

    def supports(self, scene: Scene) -> tuple[bool, str]:
        if not scene.has_kernels:
            return False, (f"scene {scene.id} has no force kernel for a reference scheme to step: "
                           "its physics is the engine's (a model file); engine modes run it")
        why = self.scheme.kind.supports(self.scheme, scene, self.id)
        if why:
            return False, why
        return True, ""

    def compiled_twin(self) -> "RefMethod":
        return replace(self, compiled=True)

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1) -> Trajectory:
        if self.compiled:
            return integrate_compiled(self.scheme, scene, dt, steps, every, **self.options)
        if self.exact is not None:  # the same run, compiled where that is exact
            if self.exact.wants_rate(self.scheme, scene):  # what a step costs interpreted, to decide
                probe = min(int(steps), self.exact.probe_steps)
                self._interpreted(scene, dt, probe, max(1, probe))
            traj = integrate_exact(self.scheme, scene, dt, steps, every, **self.options,
                                   may_compile=self.exact.may_compile(self.scheme, scene, steps))
            if traj is not None:
                return traj
            return self._interpreted(scene, dt, steps, every)
        return integrate(self.scheme, scene, dt, steps, every, **self.options)

    def _interpreted(self, scene: Scene, dt: float, steps: int, every: int) -> Trajectory:
        """``integrate``, its CPU seconds and steps counted against the pair (``Exact.interpreted``)."""
        t = time.process_time()
        traj = integrate(self.scheme, scene, dt, steps, every, **self.options)
        self.exact.interpreted(self.scheme, scene, time.process_time() - t, max(1, traj.meta.steps_run or steps))
        return traj

    def describe(self) -> dict:
        return {"id": self.id, "family": self.family,
                **{k: v for k, v in self.scheme.describe().items() if k != "id"}}
