"""A scheme as data (after scipy's ``_ivp``): its step function and what it declares.

Kernel contract (arrays in the component-major kernel layout, ``(ndof, batch)``):

* ``start(accel, q, v, t, h, p) -> state``: the carried state (a tuple of arrays);
  the default carries ``(q, v)``. Verlet-type schemes carry more (the previous position,
  the last acceleration) so that a step costs exactly the declared force evaluations.
* ``step(accel, *kernels, [count,] state, t, h, p) -> state``: the signature is the scheme's
  kind's (``reference.kinds``: explicit, implicit with the scene's solve and Newton iterations,
  constrained with the scene's projection and its passes, decay with the scene's damping rate).
  A constrained scheme's passes are its default (``Scheme.iterations``) unless the caller asks
  for another (``integrate(..., iterations=K)``, ``harness run --opt iterations=K``).
* ``observe(accel, state, t, h, p) -> (q, v)``: the state a user sees; it never calls ``accel``.

The functions are plain numpy, so the same source runs interpreted, with every force
evaluation counted, and compiled by numba for timing. An explicit Runge-Kutta scheme is
declared as its tableau (``reference.tableau``), its step generated as such source.

Beside its step a scheme declares, in its one file (as REBOUND keeps an integrator): its claims
(order, force evaluations, symplecticity, energy behaviour, stability limit on the spring), its
floor (``Floor``: the step written by hand on the unit spring, which ``harness bench`` times the
kernel against), its recurrence on the damped oscillator (``amplification``, and the stability
limit there in closed form where one exists, ``damping_limit``; ``reference.oscillator``), and the
scenes it joins in the suites that ask (``suites``). A tableau's floor and recurrence follow from
its tableau, a splitting's from its drifts and kicks (``reference.splitting``), a substepped
scheme's from the scheme it substeps (``reference.substepped``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from collections.abc import Callable

import numpy as np

from . import kinds


def start_qv(accel, q, v, t, h, p):
    return (q, v)


def observe_qv(accel, state, t, h, p):
    return state[0], state[1]


def largest_magnitude(x):
    """max |x| over the entries of x (Newton's stopping test). The compiled pointwise loop runs
    a step on one float at a time, where this is ``abs(x)`` (``reference._kernels``). The
    method call, not ``np.max``: the same maximum without numpy's dispatch layer, asked twice
    each Newton iteration."""
    return np.abs(x).max()


def floor_start_qv(x, v, h, k, m):
    return (x, v)


def floor_observe_qv(s, h, k, m):
    return s[0], s[1]


@dataclass(frozen=True)
class Floor:
    """What a step can cost at best: the scheme's updates written out by hand for the unit spring,
    a = (-k x)/m as the scene spells it, every value a float (no array, no temporary, no call the
    compiler does not inline). Written apart from the step's source, it also checks it: the kernel
    on the spring computes the floor's bits where the arithmetic is the same (tests/test_kernels.py).

    ``step(s, h, k, m) -> s`` over a tuple of floats; ``start(x, v, h, k, m) -> s`` and
    ``observe(s, h, k, m) -> (x, v)`` where the scheme carries more than (x, v). Plain Python:
    ``reference._floors`` compiles the step and drives it (one spring in registers, or a batch).

    ``scene_data``: how many entries at the end of the state are the scene's data that the kernel
    reads at run time (a constraint's anchor, rest length, inverse masses, the gravity, and what
    the kernel computes from them before its loop), put there by ``start`` and returned by the
    step as read. A floor reads them as the kernel does: a value the floor spelled as a literal
    the compiler would fold (x - 0.0 is x), which the general kernel never can. The batch loops
    pass them to every spring of the batch alike, as the kernel reads a constraint's data once
    for the whole batch, and store only the springs' own entries."""

    step: Callable
    start: Callable = floor_start_qv
    observe: Callable = floor_observe_qv
    scene_data: int = 0


class _EveryScene:
    """Every scene of a suite (``Scheme.suites``): the scheme runs on each that it can run on."""

    def __contains__(self, scene_id: str) -> bool:
        return True

    def __repr__(self) -> str:
        return "EVERY_SCENE"


EVERY_SCENE = _EveryScene()


@dataclass(frozen=True)
class Scheme:
    """A reference scheme and its declarations.

    ``order_velocity_dependent``: the order where the force depends on the velocity, if lower
    than ``order`` (a kick that takes a(x, v) at a velocity of the wrong time, without a solve,
    loses the symmetry that made the scheme second order or higher); None: ``order`` holds.

    ``same_without_velocity``: the scheme this one is, update for update, where the force does not
    depend on the velocity (its damping treatment is all that sets it apart); ``harness identify``
    does not offer it as a second match there, and a kernel on such a scene compiles as that one.

    ``one_pass_on_linear`` (implicit schemes): one Newton iteration from the old velocity solves
    the step exactly on a linear scene, so the step gets 1 there (``kinds.newton_max``); False
    where the scene's real solve cannot invert the coupling of the stages in one pass (two-stage
    Radau IIA), whose iteration then runs to convergence on linear scenes too.

    ``energy_claim`` and ``homega_max`` are what the textbook says on the unit spring
    (``homega_max``: ``None`` = unstable for every h, ``math.inf`` = never unstable);
    the harness measures both and reports them side by side.

    ``amplification(y, zeta)``: one step as the matrix of a linear recurrence of the state the
    scheme carries, on the damped oscillator x'' = -x - 2 zeta x' at y = h omega
    (``reference.oscillator``), written from the update formulas; None for a scheme that does not
    run there (constrained, position-based). ``damping_limit(zeta)``: the largest stable y on it in
    closed form (None: unstable for every y, ``math.inf``: never unstable); without one the
    harness computes it from ``amplification`` (``harness.measures.stability_damping``).

    ``suites``: suite name -> the scenes the scheme joins in it (scene ids, or ``EVERY_SCENE``), for
    the suites that let their schemes say where they run (the standard nightly,
    ``harness.nightly.suites``): a scheme that names no scenes for such a suite runs nowhere in it.
    """

    id: str
    step: Callable
    order: int
    force_evals: int
    symplectic: bool
    energy_claim: str
    homega_max: float | None
    #: What the step takes besides the state, and all that follows from it (``reference.kinds``).
    kind: kinds.Kind = kinds.EXPLICIT
    start: Callable = start_qv
    observe: Callable = observe_qv
    iterations: int | None = None
    #: Substeps a step is cut into by default (a position-based scheme's ``substeps`` option).
    substeps: int | None = None
    order_velocity_dependent: int | None = None
    same_without_velocity: Scheme | None = None
    one_pass_on_linear: bool = True
    carries: tuple[str, ...] = ("q", "v")  # the state carried between steps, as ``start`` builds it
    doc: str = field(default="", compare=False)
    #: The Butcher tableau an explicit Runge-Kutta scheme is declared as (``reference.tableau``).
    tableau: object = field(default=None, compare=False)
    #: The drifts and kicks a splitting scheme is declared as (``reference.splitting``).
    splitting: object = field(default=None, compare=False)
    #: ``(scheme, n)`` where this scheme is n steps of h/n of that one (``reference.substepped``).
    substepped_from: tuple | None = field(default=None, compare=False)
    #: The step by hand on the unit spring (``Floor``); None where the spring is not the scheme's.
    floor: Floor | None = field(default=None, compare=False)
    amplification: Callable | None = field(default=None, compare=False)
    damping_limit: Callable | None = field(default=None, compare=False)
    suites: dict = field(default_factory=dict, compare=False)

    @property
    def implicit(self) -> bool:
        return self.kind.implicit

    @property
    def constrained(self) -> bool:
        return self.kind.constrained

    @property
    def decay(self) -> bool:
        return self.kind.decay

    @property
    def options(self) -> dict[str, int]:
        """Run-time options a caller may set, with their defaults."""
        return self.kind.options(self)

    def order_for(self, velocity_dependent: bool) -> int:
        """The declared order on a scene whose force does (True) or does not depend on the velocity."""
        if velocity_dependent and self.order_velocity_dependent is not None:
            return self.order_velocity_dependent
        return self.order

    def joins(self, suite: str, scene_id: str) -> bool:
        """Whether the scheme declares ``scene_id`` among the scenes it joins in ``suite``."""
        return scene_id in self.suites.get(suite, ())

    @property
    def summary(self) -> str:
        return self.doc.strip().splitlines()[0] if self.doc else self.id

    def describe(self) -> dict:
        evals = self.kind.evals_text(self)
        limit = (
            "none (unstable for every h)"
            if self.homega_max is None
            else "unbounded"
            if self.homega_max == math.inf
            else f"{self.homega_max:.4g}"
        )
        out = {
            "id": self.id,
            "order": self.order,
            "order_velocity_dependent": self.order_for(True),
            "force_evals": evals,
            "symplectic": self.symplectic,
            "implicit": self.implicit,
            "constrained": self.constrained,
            "energy": self.energy_claim,
            "decay": self.decay,
            "same_without_velocity": self.same_without_velocity.id if self.same_without_velocity else None,
            "homega_max": limit,
            "doc": " ".join(self.doc.split()),
        }
        out.update(self.options)
        return out


def scheme(**declared) -> Callable[[Callable], Scheme]:
    """Decorator: ``@scheme(order=1, force_evals=1, kind=kinds.IMPLICIT, ...)`` over the step
    function; the kind may also be declared by flags (``implicit=True``: ``kinds.declared``)."""
    flags = {name: declared.pop(name) for name in ("implicit", "constrained", "decay") if name in declared}
    if flags:
        declared["kind"] = kinds.declared(**flags)

    def wrap(step: Callable) -> Scheme:
        return Scheme(id=step.__name__, step=step, doc=step.__doc__ or "", **declared)

    return wrap
