"""Scheme kinds: what a scheme's step takes besides the state, and everything that follows from it.

A step is ``step(accel, *kernels, [count,] state, t, h, p) -> state``: the scene's force
``accel``, then the scene kernels its kind names (``Kind.kernels``, as the scene's attributes),
then, where the kind has one, one integer (``Kind.count``: Newton iterations allowed, projection
passes). A kind owns that signature and so every place it shows: the interpreted driver's step
(``advance``), the call the compiled loops make (``step_call``), the in-memory loop of a pair whose
source cannot be copied (``in_memory_loop``), the variants a kernel file adds (``variants``), which
scenes it runs on (``supports``) and what a run reports of it (``run_iterations``, ``evals_text``,
``step_counts``).
The drivers, the kernel files and ``RefMethod`` ask the scheme's kind; none branches over kinds.

* ``EXPLICIT``: ``step(accel, state, t, h, p)`` (explicit Runge-Kutta tableaus, the splittings);
* ``IMPLICIT``: ``step(accel, solve, newton_max, state, t, h, p)``, ``solve`` the scene's linear
  solve, ``newton_max`` 1 on a linear scene (one Newton iteration from the old velocity is exact),
  unless the scheme declares otherwise (``Scheme.one_pass_on_linear``: coupled stages iterate);
* ``CONSTRAINED``: ``step(accel, project, iterations, state, t, h, p)``, ``project(q, p,
  iterations) -> q`` the scene's constraint projection; runs only on scenes with constraints,
  and those only with it;
* ``DECAY``: ``step(accel, damping_rate, state, t, h, p)``, ``damping_rate(p)`` the scene's
  gamma in a(x, v) = a(x, 0) - gamma v; runs only on scenes that have one;
* ``POSITION_BASED``: ``step(accel, constraints, substeps, iterations, state, t, h, p)``,
  ``constraints(p)`` the scene's springs and links as distance constraints (``scenarios.scene``);
  the compiled loops pass the two counts as one integer (``pack_counts``) that the step's call
  unpacks, and compute what the step computes before it reads ``state`` or ``t`` once per loop,
  not once per step (so the step computes its constraints first and never modifies them); a step
  that copies its state into one array and reads only that runs in the loop itself, its state
  carried in one such array (``_Source.add_loop_in_place``).
  Runs only on scenes that give their constraints.

A kind may also take **parameters**: options that set a constant of the step rather than a count
(``Kind.parameters``; Jacobi XPBD's relaxation, ``reference/schemes/xpbd_jacobi.py``), bound into
the scheme's kind (``with_parameters``) and carried by it into the integer the loops pass.
"""

from __future__ import annotations

from dataclasses import dataclass

from scenarios import no_solve

#: The names a kernel file gives a step split where it first reads the state or the time
#: (``reference._codegen``: ``_Source.add_hoisted``): the part computed once per compiled loop, and
#: the rest of the step, which takes its results.
SETUP, GIVEN = "scheme_setup", "scheme_step_given"

#: Newton iterations allowed per implicit step on a nonlinear scene.
NEWTON_MAX = 50


@dataclass(frozen=True, eq=False)
class Kind:
    """An explicit step: the force alone (the base every kind extends)."""

    name: str = "explicit"
    #: The scene kernels the step takes after ``accel``, by the scene's attribute names.
    kernels: tuple[str, ...] = ()
    #: Whether the step takes the integer ``count`` after its kernels.
    counted: bool = False
    implicit: bool = False
    constrained: bool = False
    decay: bool = False

    def __repr__(self) -> str:
        return f"<kind {self.name}>"

    # ---------------------------------------------------------------- the signature
    def count(self, scheme, scene, iterations: int | None = None, substeps: int | None = None) -> int:
        """The integer the step takes (0 where it takes none: the compiled loops pass it anyway)."""
        return 0

    def run_iterations(self, scheme, iterations: int | None) -> int | None:
        """What a run reports as its ``iterations`` (projection passes; None where none)."""
        return None

    def options(self, scheme) -> dict[str, int]:
        """Run-time options a caller may set on a scheme of this kind, with their defaults."""
        return {}

    def parameters(self, scheme) -> dict:
        """Run-time options that set a constant of the step rather than a count the drivers take
        (``records.method_id.Option`` by name): bound into the scheme (``with_parameters``), whose
        kind carries them to its step. None here."""
        return {}

    def with_parameters(self, scheme, values: dict):
        """The scheme with these ``parameters`` set (InvalidInput where one cannot be carried)."""
        return scheme

    def parameter_values(self, scheme) -> dict:
        """The parameters set on ``scheme`` (written into its method's id)."""
        return {}

    def advance(
        self, scheme, scene, dt: float, kernels: dict, iterations: int | None = None, substeps: int | None = None
    ):
        """``advance(state, t) -> state``: one interpreted step of ``dt``; ``kernels`` maps the
        scene's kernel names (``accel`` and this kind's) to the callables to use (counted or not)."""
        p, step = scene.pvec, scheme.step
        args = (
            kernels["accel"],
            *(kernels[name] for name in self.kernels),
            *((self.count(scheme, scene, iterations),) if self.counted else ()),
        )
        return lambda state, t: step(*args, state, t, dt, p)

    def count_args(self, count: str = "k") -> list[str]:
        """What the step takes between its kernels and the state, as expressions of the integer
        ``count`` the compiled loops pass: the count itself where it takes one."""
        return [count] if self.counted else []

    def step_call(self, state: str, t: str, step: str = "scheme_step", count: str = "k", lead: str = "") -> str:
        """The compiled loops' call of a kernel file's step (its kernels bound as globals of the
        file): ``lead`` first (what a hoisted step is given: ``reference._codegen``), then the count
        where it takes one (``count_args``)."""
        return f"{step}({lead}{', '.join([*self.count_args(count), state, t, 'h', 'p'])})"

    def in_memory_loop(self, jit, step, accel, scene_cls):
        """``advance_n(state, t0, h, i0, n, p, k)`` compiled from function objects (a pair whose
        source cannot be copied): the step with the scene's kernels passed as arguments."""
        names = ("accel", *self.kernels)
        args = ", ".join((*names, *(("k",) if self.counted else ())))
        namespace = {"step": step, "accel": accel, **{n: jit(getattr(scene_cls, n)) for n in self.kernels}}
        exec(
            "def advance_n(state, t0, h, i0, n, p, k):\n"
            "    for i in range(i0, i0 + n):\n"
            f"        state = step({args}, state, t0 + i * h, h, p)\n"
            "    return state\n",
            namespace,
        )
        return jit(namespace["advance_n"])

    def variants(self, src, pointwise: bool) -> bool:
        """Add to a kernel file's source (``reference._codegen._Source``) the step variants its
        loop can use; True where it added the one-iteration step ``scheme_step_once``."""
        return False

    # ---------------------------------------------------------------- where it runs
    def pointwise(self, scene_cls) -> bool:
        """Whether the pair's compiled loop may run entry by entry on floats."""
        return bool(scene_cls.pointwise)

    def supports(self, scheme, scene, method_id: str) -> str:
        """Why ``scheme`` of this kind does not run on ``scene`` ("" where it does)."""
        if scene.constrained:
            return (
                f"scene {scene.id} is held together by constraints that only a constrained "
                f"scheme enforces (ref:verlet_constrained); here its particles would fall freely"
            )
        return ""

    def evals_text(self, scheme) -> str:
        """The force evaluations a step declares, as ``describe`` says them."""
        return str(scheme.force_evals)

    def step_counts(self, scheme, scene, count: int) -> tuple[int, int, int] | None:
        """(force evaluations, solves, projections) a step taking ``count`` makes, where they are
        fixed (the scheme's declared ``force_evals``); None where they vary from step to step (a
        run on the compiled loop then has none, and a counting run interprets: ``reference._counts``)."""
        return (scheme.force_evals, 0, 0)


@dataclass(frozen=True, eq=False)
class Implicit(Kind):
    name: str = "implicit"
    kernels: tuple[str, ...] = ("solve",)
    counted: bool = True
    implicit: bool = True

    def count(self, scheme, scene, iterations=None, substeps=None) -> int:
        return newton_max(scene) if scheme.one_pass_on_linear else NEWTON_MAX

    def supports(self, scheme, scene, method_id: str) -> str:
        return super().supports(scheme, scene, method_id) or (
            f"scene {scene.id} provides no implicit solve" if type(scene).solve is no_solve else ""
        )

    def variants(self, src, pointwise: bool) -> bool:
        # On a pointwise scene one Newton iteration (every linear scene: exact) runs the step
        # copied without the iteration loop's exit, straight-line code that vectorises. The
        # Newton parameter is the step's first after its kernels.
        if not pointwise:
            return False
        params = src.parameters("scheme_step")
        return bool(params) and src.add_one_iteration("scheme_step", "scheme_step_once", params[0])

    def evals_text(self, scheme) -> str:
        return f"{scheme.force_evals}{'' if scheme.one_pass_on_linear else ' a pass'} + solve"

    def step_counts(self, scheme, scene, count):
        # One Newton pass (``count`` 1: a linear scene) evaluates the force once per stage and
        # solves once for each; more may stop at any pass, on the update's size.
        return (scheme.force_evals, scheme.force_evals, 0) if count == 1 else None


@dataclass(frozen=True, eq=False)
class Constrained(Kind):
    name: str = "constrained"
    kernels: tuple[str, ...] = ("project",)
    counted: bool = True
    constrained: bool = True

    def count(self, scheme, scene, iterations=None, substeps=None) -> int:
        return iterations_for(scheme, iterations)

    def run_iterations(self, scheme, iterations):
        return iterations_for(scheme, iterations)

    def options(self, scheme) -> dict[str, int]:
        return {"iterations": scheme.iterations}

    def step_counts(self, scheme, scene, count):
        return (scheme.force_evals, 0, 1)  # one projection a step, of ``count`` passes

    def pointwise(self, scene_cls) -> bool:
        return False  # a projection couples the entries

    def supports(self, scheme, scene, method_id: str) -> str:
        if not scene.constrained:
            return f"scene {scene.id} has no constraints to project (without them {method_id} is plain ref:verlet)"
        return ""


@dataclass(frozen=True, eq=False)
class Decay(Kind):
    name: str = "decay"
    kernels: tuple[str, ...] = ("damping_rate",)
    decay: bool = True

    def supports(self, scheme, scene, method_id: str) -> str:
        return super().supports(scheme, scene, method_id) or (
            ""
            if scene.has_damping_rate
            else f"scene {scene.id} has no single linear damping rate for {method_id} to decay "
            "(it needs a(x, v) = a(x, 0) - gamma v with one rate gamma)"
        )


#: The position-based count packs substeps and iterations as ``substeps * COUNT_BASE + iterations``
#: (every compiled loop passes one integer; ``harness.methods.MAX_ITERATIONS`` is below the base).
COUNT_BASE = 1 << 20


def pack_counts(substeps: int, iterations: int) -> int:
    """The one integer the compiled loops pass for a position-based step's two counts."""
    if not 1 <= iterations < COUNT_BASE or substeps < 1:
        raise ValueError(
            f"substeps={substeps} and iterations={iterations} must be at least 1 (iterations below {COUNT_BASE})"
        )
    return int(substeps) * COUNT_BASE + int(iterations)


@dataclass(frozen=True, eq=False)
class PositionBased(Kind):
    """Position-based dynamics (PBD, XPBD): the scene's springs and links are distance
    constraints (``constraints(p)``), projected ``iterations`` Gauss-Seidel passes in each of
    ``substeps`` substeps of a step."""

    name: str = "position_based"
    kernels: tuple[str, ...] = ("constraints",)
    counted: bool = True

    def _counts(self, scheme, iterations, substeps) -> tuple[int, int]:
        return (
            int(scheme.substeps if substeps is None else substeps),
            int(scheme.iterations if iterations is None else iterations),
        )

    def count(self, scheme, scene, iterations=None, substeps=None) -> int:
        return pack_counts(*self._counts(scheme, iterations, substeps))

    def run_iterations(self, scheme, iterations):
        return iterations_for(scheme, iterations)

    def options(self, scheme) -> dict[str, int]:
        return {"substeps": scheme.substeps, "iterations": scheme.iterations}

    def advance(self, scheme, scene, dt, kernels, iterations=None, substeps=None):
        p, step = scene.pvec, scheme.step
        args = (kernels["accel"], kernels["constraints"], *self._counts(scheme, iterations, substeps))
        return lambda state, t: step(*args, state, t, dt, p)

    def count_args(self, count="k"):
        return [f"{count} // {COUNT_BASE}", f"{count} % {COUNT_BASE}"]

    def in_memory_loop(self, jit, step, accel, scene_cls):
        constraints = jit(scene_cls.constraints)

        def advance_n(state, t0, h, i0, n, p, k):
            for i in range(i0, i0 + n):
                state = step(accel, constraints, k // COUNT_BASE, k % COUNT_BASE, state, t0 + i * h, h, p)
            return state

        return jit(advance_n)

    def variants(self, src, pointwise: bool) -> bool:
        # What the step computes before it reads the state or the time (the scene's constraints,
        # what the scheme derives from them and h) is the same every step: the compiled loops
        # compute it once. The step must not modify it. Where the step copies its state into one
        # array, reads only that and returns views of the rows it copied into
        # (``_Source.add_loop_in_place``), the loop holds the step's statements and one such
        # array, so a step makes none and passes none in a call; else it calls the rest of the
        # step given what came before (``_Source.add_hoisted``).
        params = src.parameters("scheme_step")
        varying = (params[-4], params[-3], "scene_accel")
        if not src.add_loop_in_place("scheme_step", varying, self.count_args("_k")):
            src.add_hoisted("scheme_step", SETUP, GIVEN, varying)
        return False

    def pointwise(self, scene_cls) -> bool:
        return False  # a constraint couples its two ends

    def supports(self, scheme, scene, method_id: str) -> str:
        return scene.position_based_why()

    def evals_text(self, scheme) -> str:
        return (
            f"{scheme.force_evals} (the forces are constraints: {scheme.substeps} substep(s) x "
            f"{scheme.iterations} pass(es) over them)"
        )


EXPLICIT, IMPLICIT, CONSTRAINED, DECAY = Kind(), Implicit(), Constrained(), Decay()
POSITION_BASED = PositionBased()
KINDS = {k.name: k for k in (EXPLICIT, IMPLICIT, CONSTRAINED, DECAY, POSITION_BASED)}


def declared(implicit: bool = False, constrained: bool = False, decay: bool = False) -> Kind:
    """The kind a scheme declares by flags (``@scheme(implicit=True, ...)``): the one whose flags they are."""
    flags = (bool(implicit), bool(constrained), bool(decay))
    for kind in KINDS.values():
        if (kind.implicit, kind.constrained, kind.decay) == flags:
            return kind
    raise ValueError(f"no scheme kind is implicit={implicit}, constrained={constrained}, decay={decay}")


def newton_max(scene) -> int:
    return 1 if scene.linear else NEWTON_MAX


def iterations_for(scheme, iterations: int | None) -> int:
    """The projection passes a constrained scheme runs with: the caller's, else its default."""
    return int(scheme.iterations if iterations is None else iterations)
