"""A reference scheme as a method (``records.Method``): the reference package's own face to the
harness, beside the engine modes of ``adapters``."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

from records import REFERENCE, MethodId, Trajectory
from records.method import NO_BEHAVIOUR, NO_REASONS

from scenarios import Scene

from ._compiled import bitwise_why, integrate_compiled
from ._integrate import integrate
from ._scheme import Scheme


@dataclass(frozen=True)
class RefMethod:
    """A reference scheme as a method. ``options`` are the run-time options the scheme declares
    (``Scheme.options``: a constrained scheme's projection ``iterations``); unset ones keep the
    scheme's defaults. Its runs are interpreted (every evaluation counted as it happens) unless
    ``compiled_where_bitwise`` (the pair's compiled loop wherever it computes the interpreted bits)
    or ``compiled`` (the loop everywhere, not counted)."""

    scheme: Scheme
    options: dict = field(default_factory=dict, compare=False)
    #: Step on the pair's compiled loop (``reference.integrate_compiled``) whatever its bits, for
    #: runs too long to interpret; force evaluations are then not counted.
    compiled: bool = field(default=False, compare=False)
    #: Step on the pair's compiled loop wherever it computes the interpreted run's bits
    #: (``reference.bitwise_why``), its counts those the scheme declares (``reference._counts``;
    #: none where they vary), and interpreted elsewhere: the interpreted run's states, only faster.
    compiled_where_bitwise: bool = field(default=False, compare=False)

    # The capabilities of records.Method, declared: stepped in this process, at the dt it is
    # given, matching itself; no loop to choose, no engine model to reuse or to build off the
    # clock (its timing is the compiled kernel's, ``reference.step_timer``). Counted on every run
    # but one on its compiled loop where the counts vary (``reference._counts``), whose counting
    # run (``simulate(..., count=True)``) is the interpreted one.
    family = REFERENCE
    precision = "float64"
    isolated = False
    adaptive = False
    counting_run = True
    no_match = NO_REASONS
    behaviour = NO_BEHAVIOUR
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

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1, count: bool = False) -> Trajectory:
        """The run (``reference.integrate``'s, wherever it steps); ``count``: interpreted, every
        evaluation counted as it happens (the counting run)."""
        if self.compiled and not count:
            return integrate_compiled(self.scheme, scene, dt, steps, every, **self.options)
        if self.compiled_where_bitwise and not count and not bitwise_why(self.scheme, scene, **self.options):
            return integrate_compiled(self.scheme, scene, dt, steps, every, **self.options, counted=True)
        return integrate(self.scheme, scene, dt, steps, every, **self.options)

    def describe(self) -> dict:
        return {"id": self.id, "family": self.family,
                **{k: v for k, v in self.scheme.describe().items() if k != "id"}}
