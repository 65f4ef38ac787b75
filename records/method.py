"""What a method is: the one protocol that the reference schemes (``reference.RefMethod``) and
the engine modes (``adapters.EngineMode``, and a plugin's) both implement.

Every method answers every question below. A capability that only some methods have is a
declared field whose default says "not this method" (``scheme`` None for an engine mode,
``one_steps`` None for a reference scheme): callers read the field and never probe for an
attribute. ``OPTIONAL`` holds those defaults; ``harness.methods`` fills them in, in one place,
for a plugin's method that leaves some out (it must have ``REQUIRED``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable
from collections.abc import Callable, Mapping

from .trajectory import Trajectory

#: No scene on which the method, measured, integrates no reference scheme (``Method.no_match``).
NO_REASONS: Mapping[str, str] = MappingProxyType({})


@dataclass(frozen=True)
class Behaviour:
    """What a method was measured to do that its name does not say, which the judge checks again
    on every run where a scene's findings table names the field (``harness.judge``: the table
    decides where, the judge keeps the tolerance and the check or cross; it names no method).
    Every default says "not this method". An engine mode declares it; a reference scheme's claims
    are its scheme's (``Method.scheme``)."""

    #: Scene id -> the reference scheme the method integrates there (its identity cell's match).
    integrates_as: Mapping[str, str] = field(default_factory=dict)
    #: The reference scheme the method is named for, each of its steps two of that scheme's half
    #: steps (Drake's implicit Euler, by step doubling): where it integrates as declared
    #: (``integrates_as``), the energy it keeps is set beside that scheme's.
    half_steps_of: str | None = None
    #: Scene id -> the reference scheme the method integrates from a generic state, though from the
    #: scene's own state it matches none (``Method.no_match`` says why).
    from_a_generic_state: Mapping[str, str] = field(default_factory=dict)
    #: The reference scheme the method takes in the generalized velocity v, not the momentum
    #: M(q) v (v+ = v + h M(q)^-1 f, q+ = q + h v+: MuJoCo's Euler): where the scene's mass matrix
    #: varies it is not that scheme's map, and its energy may leave the scheme's class.
    in_velocity: str | None = None
    #: Its map is symplectic: on a conservative scene its energy error stays bounded.
    symplectic: bool = False
    #: Its error is roundoff alone (IAS15 at its default tolerance): the energy is kept to
    #: roundoff, and its error grows as Brouwer's law, t^(1/2).
    roundoff: bool = False
    #: The methods it was measured more accurate than at equal cost per simulated time (its max
    #: global error along the order sweep below each one's at the same cost).
    beats_at_equal_cost: tuple[str, ...] = ()


#: A method whose behaviour is its name's, or its scheme's claims (``Method.behaviour``).
NO_BEHAVIOUR = Behaviour()


@runtime_checkable
class Method(Protocol):
    """A way of stepping a scene: ``ref:NAME`` (a reference scheme) or ``ENGINE:MODE``."""

    #: ``family:name`` (``records.MethodId``).
    id: str
    #: ``ref`` for a reference scheme, else the engine (or a plugin's family).
    family: str
    #: The reference scheme it runs (``reference.Scheme``: order, force evaluations, claims),
    #: None for anything else. Declared claims are read from here.
    scheme: Any
    #: Stepped in a worker process, so that an abort or a hang becomes a recorded result.
    isolated: bool
    #: Chooses its own steps, ``dt`` being only the output interval: nothing is measured
    #: against dt (observed order, largest stable dt, substeps).
    adaptive: bool
    #: Counts its force evaluations only in a counting run (``simulate(..., count=True)``) where
    #: a plain run cannot: the counter a callback that would slow an engine's timed loop, or the
    #: counts varying where a reference scheme's compiled loop cannot count them (Newton's passes).
    counting_run: bool
    #: Scene id -> why, measured, the method integrates no reference scheme there (one line).
    no_match: Mapping[str, str]
    #: The loops ``simulate(..., loop=...)`` accepts; empty where it takes no ``loop``.
    LOOPS: tuple[str, ...]
    #: ``one_steps(scene, dt, states) -> [(y_1 | None, why)] | None``: one step of ``dt`` from each
    #: state on one model built once (None back where the model cannot be set to a state);
    #: None where the method has no such path.
    one_steps: Callable | None
    #: ``timed_run(scene, dt, steps, now, loop) -> (seconds, failed step or None)``: one run timed
    #: with its model built off the clock; None where the method has no setup to keep off it.
    timed_run: Callable | None
    #: The floating-point width its states are computed in: "float64", or "float32" (an engine on
    #: Warp), which is identified against the reference schemes to float32 rounding.
    precision: str
    #: What it was measured to do beyond its name, which the judge checks on every run (``Behaviour``).
    behaviour: Behaviour

    def available(self) -> tuple[bool, str]:
        """(True, "") or (False, why): whether it can run here at all (an engine installed)."""

    def supports(self, scene) -> tuple[bool, str]:
        """(True, "") or (False, why) for ``scene``."""

    def simulate(self, scene, dt: float, steps: int, every: int = 1) -> Trajectory:
        """``steps`` steps of ``dt`` on ``scene``, recorded every ``every`` steps (and the last)."""

    def describe(self) -> dict:
        """Plain JSON: ``id``, ``family`` and what else describes the method."""

    def compiled_twin(self) -> Method:
        """The same method on its fastest path that gives the same states: a reference scheme
        on its compiled driver (force evaluations then not counted); itself for a method that
        already runs its own loop."""


#: What every method must have itself; :data:`OPTIONAL` can be filled in for it.
REQUIRED = ("id", "available", "supports", "simulate", "describe")

#: Every optional capability of :class:`Method` and the value that means "not this method".
OPTIONAL: Mapping[str, Any] = MappingProxyType(
    {
        "scheme": None,
        "isolated": False,
        "adaptive": False,
        "counting_run": False,
        "no_match": NO_REASONS,
        "LOOPS": (),
        "one_steps": None,
        "timed_run": None,
        "precision": "float64",
        "behaviour": NO_BEHAVIOUR,
    }
)
