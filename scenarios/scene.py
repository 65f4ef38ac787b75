"""What a scene is: parameters, initial state, forces, energy, exact solution.

Two array layouts, one rule each:

* **API layout** (everything a user sees: initial states, trajectories, energy):
  leading batch axis, ``q.shape == (batch, ndof)``; a trajectory is ``(T, batch, ndof)``.
* **Kernel layout** (the force and solve kernels the integrators call):
  component-major, ``q.shape == (ndof, batch)``.  The inner loop then runs over the
  batch and vectorises; with ``(batch, 1)`` numba's loops have an inner extent of 1
  (about ten times slower per spring-step for a batch of 1000: docs/performance.md).

Kernels are plain numpy functions of ``(q, v, t, p)`` where ``p`` is the scene's packed
parameter vector (``Scene.pvec``), so the same source runs interpreted (with force
evaluations counted) and compiled by numba (for timing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar
from collections.abc import Callable

import numpy as np

from records import InvalidInput


@dataclass(frozen=True)
class Param:
    """A scene parameter with its allowed range (``lo``/``hi`` inclusive unless ``*_open``); a
    value is finite unless the parameter says it may be infinite (``infinite``)."""

    default: float
    doc: str = ""
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    infinite: bool = False

    def allowed(self) -> str:
        left = "(" if self.lo_open or self.lo == -math.inf else "["
        right = ")" if self.hi_open or self.hi == math.inf and not self.infinite else "]"
        kind = "integer in " if self.integer else ""
        return f"{kind}{left}{_fmt(self.lo)}, {_fmt(self.hi)}{right}"

    def check(self, name: str, value) -> float:
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise InvalidInput(f"parameter {name}={value!r} is not a number (allowed: {self.allowed()})") from None
        ok = math.isfinite(x) or (self.infinite and x == math.inf and self.hi == math.inf and not self.hi_open)
        ok = ok and (x > self.lo if self.lo_open else x >= self.lo)
        ok = ok and (x < self.hi if self.hi_open else x <= self.hi)
        if self.integer and ok:
            ok = x == int(x)
        if not ok:
            raise InvalidInput(f"parameter {name}={value} is out of range (allowed: {self.allowed()})")
        return int(x) if self.integer else x


def _fmt(x: float) -> str:
    if x == math.inf:
        return "inf"
    if x == -math.inf:
        return "-inf"
    return f"{x:g}"


def no_solve(q, v, t, p, alpha, beta, r):  # pragma: no cover - only reached by a misuse
    raise NotImplementedError("this scene provides no implicit solve")


def no_damping_rate(p):  # pragma: no cover - only reached by a misuse
    raise NotImplementedError("this scene declares no single linear damping rate")


def no_velocity_dependence(p):
    """The damping rate of a scene whose force does not depend on the velocity: 0."""
    return 0.0


def no_project(q, p, iterations):  # pragma: no cover - only reached by a misuse
    raise NotImplementedError("this scene has no constraints to project")


def no_constraints(p):  # pragma: no cover - only reached by a misuse
    raise NotImplementedError("this scene gives no distance constraints")


@dataclass(frozen=True)
class SparseForm:
    """A scene's force and its implicit solve's matrix for the solves that run in Python, where a
    reference scheme's method takes a library solve in place of the scene's ``solve`` kernel
    (``reference.solvers``): ``accel(q, v, t, p)`` the scene's force in kernel layout, as whole-array
    numpy (the kernel's force, its sums taken in another order); ``matrix(q, v, t, alpha, beta)``
    the matrix I - alpha da/dv - beta da/dq that ``solve`` inverts, at one state (q, v of shape
    (ndof,)), scipy CSR with one sparsity pattern at every state; ``block`` the coordinates of a
    point (its d x d diagonal block: block-Jacobi's blocks, the translations multigrid keeps)."""

    accel: Callable
    matrix: Callable
    block: int


class Scene:
    """Base class. A subclass declares, and only declares, what its physics needs.

    Class attributes
    ----------------
    id, title : registry id and a one-line description.
    params : ordered ``{name: Param}``; their order is the order in ``pvec``.
    dof_names : names of the generalised coordinates (``q0, q1, ...`` in CSV).
    linear : the acceleration is affine in (q, v), so an implicit step is one linear solve.
    accel : kernel ``(q, v, t, p) -> a`` in kernel layout.
    solve : kernel ``(q, v, t, p, alpha, beta, r) -> x`` solving
        ``(I - alpha*da/dv - beta*da/dq) x = r`` at (q, v, t); needed by implicit schemes.
    project : kernel ``(q, p, iterations) -> q`` moving positions back onto the scene's
        constraints (``iterations`` relaxation passes); only constrained scenes have one, and
        only constrained schemes call it. ``accel`` of a constrained scene is the
        unconstrained acceleration.
    pointwise : entry (i, b) of ``accel`` and ``solve`` depends on entry (i, b) of q, v and r
        alone (and on t, p, alpha, beta), and the kernels run unchanged on floats: every entry
        is a system of its own, which the compiled loop steps as scalars (``reference._kernels``).
    damping_rate : kernel ``(p) -> gamma`` for scenes whose velocity dependence is one linear
        damping rate, a(x, v) = a(x, 0) - gamma v; the schemes that integrate the damping as an
        exact decay (``Scheme.decay``) run only on those.
    constraints : kernel ``(p) -> (ends, rest, compliance, inv_mass, anchors, gravity)``: the
        scene's springs and links as distance constraints, for the position-based schemes. The
        DOFs are points of d coordinates (point f: q[f d : f d + d]); ``anchors`` (na, d) are
        fixed points (a wall, a pin); ``ends`` (nc, 2) int64 each constraint's two points, an
        anchor a as -1 - a; ``rest`` its rest length, ``compliance`` 1/k (0: a rigid link);
        ``inv_mass`` (npoints,); ``gravity`` (d,) the acceleration of the forces that are not
        constraints, the same on every point. C = |x_b - x_a| - rest where d > 1; where d = 1,
        C = x_b - x_a - rest, the 1-D spring's signed extension (linear, as its force is).
        The scene's ``accel`` is then its constraints' forces plus ``gravity`` (a rigid link's
        force is the constraint's alone).
    """

    id: ClassVar[str]
    title: ClassVar[str]
    params: ClassVar[dict[str, Param]] = {}
    dof_names: ClassVar[tuple[str, ...]]
    linear: ClassVar[bool] = False
    pointwise: ClassVar[bool] = False
    accel: ClassVar[Callable]
    solve: ClassVar[Callable] = staticmethod(no_solve)
    project: ClassVar[Callable] = staticmethod(no_project)
    damping_rate: ClassVar[Callable] = staticmethod(no_damping_rate)
    constraints: ClassVar[Callable] = staticmethod(no_constraints)

    def __init__(self, **overrides):
        unknown = sorted(set(overrides) - set(self.params))
        if unknown:
            choices = ", ".join(self.params) or "none"
            raise InvalidInput(f"unknown parameter {unknown[0]!r} for scene {self.id} (valid: {choices})")
        self.values = {name: spec.check(name, overrides.get(name, spec.default)) for name, spec in self.params.items()}
        self._validate()

    # ------------------------------------------------------------------ hooks
    def _validate(self) -> None:
        """Cross-parameter checks; raise InvalidInput."""

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q0, v0), each of shape (ndof,)."""
        raise NotImplementedError

    def energy(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Total energy of states in API layout (..., ndof) -> (...)."""
        raise NotImplementedError

    @property
    def omega(self) -> float:
        """Characteristic angular frequency, so that h*omega compares timesteps across scenes."""
        raise NotImplementedError

    def closed_form(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """Exact (q, v) at times t, shape (len(t), ndof); None where no closed form exists."""
        return None

    def reference_solution(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(q, v) to measure errors against: the exact solution, or for a scene without one a
        high-accuracy numerical solution, trustworthy for t <= ``reference_horizon``."""
        return self.closed_form(t)

    #: How far ``reference_solution`` is accurate well below any scheme's error (inf: exact).
    reference_horizon: ClassVar[float] = float("inf")

    #: The engine family whose own run is ``reference_solution`` (a model file's: MuJoCo's RK4);
    #: a method of another family integrates the engine's model of the file, not that one, and
    #: is measured against its own refined run instead (``harness.measures.error``). None: the
    #: reference is the scene's own model, the same for every method.
    reference_engine: ClassVar[str | None] = None

    #: Every method is measured against its own refined run (a model file that only one engine
    #: loads: there is no other engine's reference to trust).
    own_run_reference: ClassVar[bool] = False

    def reference_error(self, t: np.ndarray) -> float | None:
        """The estimated relative error of ``reference_solution`` at times t, in the error
        measure's norm, where the scene's reference states its own (a refined engine run);
        None: the measure's rule (0 for an exact solution, its stated floor for a solve)."""
        return None

    def reference_judges(self) -> bool:
        """Whether ``reference_solution`` converged enough to judge a run against: a refined run
        that did not converge (its halvings still apart) judges nothing."""
        return True

    #: Where set, a run whose energy rose past this many times the scene's energy scale has
    #: blown up (``runaway``), whatever its size: a stability criterion of its own.
    runaway_limit: ClassVar[float | None] = None

    def runaway(self, energy: np.ndarray) -> float:
        """How many times its scale the energy of a run (recorded energies, first the initial
        one) rose above its start; only where ``runaway_limit`` is set."""
        raise NotImplementedError(f"scene {self.id} judges stability by size alone")

    @property
    def kind(self) -> str:
        """The registry id engines pose the scene by: the class's ``id``. A scene built from a
        file has an id of its own per file (its content hash) and the kind of its class."""
        return type(self).id

    def copy_with(self, **values) -> Scene:
        """The same scene with these parameter values (validated)."""
        return type(self)(**values)

    def constraint_error(self, q: np.ndarray) -> np.ndarray | None:
        """How far states (API layout) are off the constraints, or the springs off their rest
        lengths (the largest relative stretch of each state); None for a scene with neither."""
        return None

    @property
    def has_stretch(self) -> bool:
        """Whether ``constraint_error`` measures this scene (its links or springs)."""
        return type(self).constraint_error is not Scene.constraint_error

    def position_based_why(self) -> str:
        """Why the position-based schemes do not run on this scene ("" where they do): it gives
        no ``constraints``, or has a force they do not model."""
        if type(self).constraints is no_constraints:
            return (
                f"scene {self.id} gives no distance constraints (springs or links) for a "
                "position-based scheme to project"
            )
        return ""

    @property
    def solve_text(self) -> str:
        """What the scene's own ``solve`` kernel does, in words: an implicit scheme's solve unless
        its method id names a library's (``reference.solvers``)."""
        return "the scene's own solve kernel, compiled"

    def escaped(self, q: np.ndarray, v: np.ndarray) -> np.ndarray | None:
        """Per state (rows of q, v), whether a body had left the system; None for a scene that
        cannot tell (one without bodies that can leave)."""
        return None

    def mass_matrix_variation(self, q: np.ndarray) -> float | None:
        """How much the mass matrix M(q) changes over the configurations ``q`` (rows, API layout):
        max |eig(M(q_0)^-1 M(q)) - 1|, the largest relative change of the kinetic energy of one
        velocity (``scenarios._mass_matrix``). None: not measured; a built-in scene's mass matrix
        is constant in its own coordinates (particles in Cartesian coordinates, one hinge)."""
        return None

    def sparse_form(self) -> SparseForm | None:
        """The scene's force and its implicit solve's matrix as whole-array numpy and scipy sparse
        (:class:`SparseForm`), for the library solves a reference scheme may take in place of
        ``solve``; None where the scene gives none (its kernels alone)."""
        return None

    #: The scene's physics is its own kernels (``accel``, ...), which reference schemes step;
    #: False for a model file, whose physics is the engine's.
    has_kernels: ClassVar[bool] = True

    #: Where set, the scene is another force model posed on a built-in scene's grid (an engine's
    #: own model): what it is not, which every output about it says (``cloth_flex``).
    model_note: ClassVar[str | None] = None

    #: The scene has normal modes: ``mode_frequencies()`` and ``modal(q)`` (the chain).
    has_modes: ClassVar[bool] = False

    def mode_frequencies(self) -> np.ndarray:
        """The normal modes' angular frequencies (where ``has_modes``)."""
        raise NotImplementedError(f"scene {self.id} has no normal modes")

    def modal(self, q: np.ndarray) -> np.ndarray:
        """States in normal-mode coordinates (where ``has_modes``)."""
        raise NotImplementedError(f"scene {self.id} has no normal modes")

    def events(self, step: np.ndarray, t: np.ndarray, q: np.ndarray, v: np.ndarray) -> list[dict]:
        """What happened to the bodies in a run's recorded states (API layout, one batch member):
        a body ejected, a close approach; each ``{"kind", "step", "t", "text", ...}``, oldest first.
        An energy class says how the energy went; an event says what the orbit did (a run that
        spirals in and is then thrown out reads "grows"). None here: a scene without bodies that
        can leave or collide."""
        return []

    def identification_run(self) -> tuple[float, int] | None:
        """(dt, steps) of the run ``harness identify`` holds an engine mode against the reference
        schemes on, where its default (100 steps a period of ``omega``, 1000 steps) cannot tell
        them apart; None: the default."""
        return None

    def exact_energy(self, t: np.ndarray) -> np.ndarray:
        """Exact energy at times t. Conservative scenes keep their initial energy."""
        q0, v0 = self.initial_state()
        return np.full(np.shape(t), float(self.energy(q0, v0)))

    @property
    def period(self) -> float:
        return 2.0 * math.pi / self.omega

    @property
    def length_scale(self) -> float:
        """The scene's size in the unit of its positions: what a position error is judged against
        (``harness advise``'s accuracy tolerance is a share of it). Here the size of the initial
        state, max(max |q0|, max |v0| / omega): a displacement's amplitude (the spring, the chain,
        the pendulum's angle), the places of points laid out from the origin (the rope), a drag
        rate's reach (the projectile, v0 / gamma). A scene whose positions say another size declares its own."""
        q0, v0 = self.initial_state()
        size = max(float(np.max(np.abs(q0), initial=0.0)), float(np.max(np.abs(v0), initial=0.0)) / self.omega)
        return size if size > 0.0 and math.isfinite(size) else 1.0

    # ------------------------------------------------------------- derived
    @property
    def ndof(self) -> int:
        return len(self.dof_names)

    @property
    def pvec(self) -> np.ndarray:
        return np.array([float(self.values[name]) for name in self.params], dtype=np.float64)

    @property
    def conservative(self) -> bool:
        return True

    @property
    def velocity_dependent(self) -> bool:
        """Whether the force depends on the velocity (with these parameters): where it does, a
        scheme may keep a lower order (``Scheme.order_velocity_dependent``)."""
        return False

    @property
    def has_damping_rate(self) -> bool:
        return type(self).damping_rate is not no_damping_rate

    @property
    def constrained(self) -> bool:
        return type(self).project is not no_project

    def batch_state(self, batch: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """The initial state repeated over a batch, API layout (batch, ndof)."""
        q0, v0 = self.initial_state()
        return np.tile(q0, (batch, 1)), np.tile(v0, (batch, 1))

    def describe(self) -> dict:
        has_exact = self.closed_form(np.zeros(1)) is not None
        return {
            "id": self.id,
            "title": self.title,
            "ndof": self.ndof,
            "omega": self.omega,
            "linear": self.linear,
            "constrained": self.constrained,
            "has_exact": has_exact,
            "has_reference": has_exact or type(self).reference_solution is not Scene.reference_solution,
            "reference_horizon": None if self.reference_horizon == math.inf else self.reference_horizon,
            "model_note": self.model_note,
            "params": {
                name: {"value": self.values[name], "default": spec.default, "allowed": spec.allowed(), "doc": spec.doc}
                for name, spec in self.params.items()
            },
        }

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v:g}" for k, v in self.values.items())
        return f"{type(self).__name__}({args})"


class DampedByC:
    """A scene whose force depends on the velocity through its damping coefficient ``c`` alone
    (the damped spring, the chain's dashpots, the projectile's drag): c = 0 leaves it conservative.
    Mixed in before ``Scene``."""

    @property
    def velocity_dependent(self) -> bool:
        return self.values["c"] != 0.0

    @property
    def conservative(self) -> bool:
        return self.values["c"] == 0.0
