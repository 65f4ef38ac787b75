"""A reference scheme as a method (``records.Method``): the reference package's own face to the
harness, beside the engine modes of ``adapters``."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from records import REFERENCE, MethodId, Trajectory
from records.method import NO_BEHAVIOUR, NO_REASONS

from scenarios import Scene

from . import solvers
from ._compiled import bitwise_why, integrate_compiled, step_timer
from ._integrate import integrate
from ._scheme import Scheme

#: What the cost measure times of a scheme on its compiled path.
COMPILED_TIMING = "compiled (numba), min of repeats after warm-up"


@dataclass(frozen=True)
class RefMethod:
    """A reference scheme as a method. ``options`` are the run-time options the scheme declares
    (``Scheme.options``: a constrained scheme's projection ``iterations``; an implicit scheme's
    ``solver`` and its settings, ``reference.solvers``); unset ones keep the scheme's defaults. Its
    runs are interpreted (every evaluation counted as it happens) unless ``compiled_where_bitwise``
    (the pair's compiled loop wherever it computes the interpreted bits) or ``compiled`` (the loop
    everywhere, not counted). A library solve runs in Python, counted, whatever the driver asked
    for (numba cannot compile the library)."""

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
        return str(
            MethodId.of(REFERENCE, self.scheme.id, {**self.options, **self.scheme.kind.parameter_values(self.scheme)})
        )

    def with_options(self, options: dict) -> RefMethod:
        """The same scheme with ``options`` set (checked by the caller, ``harness.methods``): the
        counts the drivers take kept in ``options``, the parameters of the step (``Kind.parameters``:
        a Jacobi scheme's relaxation) bound into the scheme."""
        kind = self.scheme.kind
        declared = kind.parameters(self.scheme)
        bound = {k: v for k, v in options.items() if k in declared}
        counts = {k: v for k, v in options.items() if k not in declared}
        scheme = kind.with_parameters(self.scheme, bound) if bound else self.scheme
        merged = {**self.options, **counts}
        solvers.choice(scheme, merged)
        return replace(self, scheme=scheme, options=merged)

    @property
    def solver(self) -> solvers.Choice | None:
        """The library solve its options choose (None: the scene's own kernel)."""
        return solvers.split(self.scheme, self.options)[0]

    @property
    def _kernel_options(self) -> dict:
        """The options the kernels take (a constrained scheme's passes, ...), the solve's left out."""
        return solvers.split(self.scheme, self.options)[1]

    @property
    def options_declared(self) -> dict:
        """The options of its solve (``reference.solvers.options_for``); the counts a constrained or
        position-based scheme takes are declared by ``harness.methods``. A convergence knob
        (``Option.tighten``) is declared only where the solve it chose takes it: local/global
        passes tighten their passes, conjugate gradients their tolerance, a factorization nothing."""
        chosen = self.solver
        takes = chosen.solver.takes if chosen is not None else ()
        return {
            name: option if option.tighten is None or name in takes else replace(option, tighten=None)
            for name, option in solvers.options_for(self.scheme).items()
        }

    def available(self) -> tuple[bool, str]:
        return True, ""

    def supports(self, scene: Scene) -> tuple[bool, str]:
        if not scene.has_kernels:
            return False, (
                f"scene {scene.id} has no force kernel for a reference scheme to step: "
                "its physics is the engine's (a model file); engine modes run it"
            )
        why = self.scheme.kind.supports(self.scheme, scene, self.id)
        if why:
            return False, why
        solver = self.solver
        why = solver.supports(scene) if solver is not None else ""
        if why:
            return False, why
        return True, ""

    def compiled_twin(self) -> RefMethod:
        # A library solve has no compiled path: its run is already its fastest.
        return self if self.solver is not None else replace(self, compiled=True)

    def simulate(self, scene: Scene, dt: float, steps: int, every: int = 1, count: bool = False) -> Trajectory:
        """The run (``reference.integrate``'s, wherever it steps); ``count``: interpreted, every
        evaluation counted as it happens (the counting run). A library solve runs interpreted."""
        solver, options = solvers.split(self.scheme, self.options)
        if solver is not None:
            return integrate(self.scheme, scene, dt, steps, every, solver=solver)
        if self.compiled and not count:
            return integrate_compiled(self.scheme, scene, dt, steps, every, **options)
        if self.compiled_where_bitwise and not count and not bitwise_why(self.scheme, scene, **options):
            return integrate_compiled(self.scheme, scene, dt, steps, every, **options, counted=True)
        return integrate(self.scheme, scene, dt, steps, every, **options)

    def step_timer(self, scene: Scene, dt: float, steps: int, clock: str = "wall"):
        """``(warm-up seconds, once, what is timed)`` at its options: the compiled loop
        (``reference.step_timer``), or where a library solve is chosen the Python loop that runs
        it (``reference.solvers.step_timer``), which the third says."""
        solver, options = solvers.split(self.scheme, self.options)
        if solver is not None:
            return solvers.step_timer(solver, self.scheme, scene, dt, steps, clock)
        return (*step_timer(self.scheme, scene, dt, steps, clock=clock, **options), COMPILED_TIMING)

    def describe(self) -> dict:
        out = {"id": self.id, "family": self.family, **{k: v for k, v in self.scheme.describe().items() if k != "id"}}
        solver = self.solver
        if solver is not None:
            out["solver"] = solver.text
        return out
