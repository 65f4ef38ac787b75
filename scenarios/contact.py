"""Contact scenes: a ball dropped on a plane, a box sliding with Coulomb friction, a box at rest and
a stack of three, each with its analytic truth. The engines pose them (``adapters.contact``); the
harness measures what they did against the truth (``harness.contact.figures``).

These are not ``Scene``s: no reference scheme steps a rigid contact, and their state is whatever
bodies the engine keeps. A pose records, per step, the centre and linear velocity of each body
(``records.contact.ContactRun``); the scene says what those should have done. The reference
schemes meet contact on the penalty ball (``scenarios.penalty_ball``), whose ground is a spring-dashpot.

Geometry shared by every engine (SI units, z up; the 2-D poses use x and z of it):

* ``ball``: a sphere of radius ``radius`` and mass ``mass`` whose lowest point starts ``h0`` above
  the plane, at rest; gravity ``g``; restitution ``e`` requested of the engine. With an ideal
  impact law the n-th apex is ``e**(2n) h0`` and the flight after impact n lasts
  ``2 e**n sqrt(2 g h0) / g``.
* ``slide``: a cube of side ``2 half`` resting on the plane, pushed along x at ``v0``; Coulomb
  friction ``mu`` (each engine's combining rule set so that the pair's coefficient is ``mu``).
  It stops after ``v0**2 / (2 mu g)`` in ``v0 / (mu g)`` and stays.
* ``rest``: the cube placed touching the plane at rest: it should stay, with no penetration,
  drift or kinetic energy.
* ``stack``: three such cubes, each touching the one below: the same.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from records import InvalidInput

from .scene import Param


@dataclass(frozen=True)
class Tolerances:
    """What a contact figure may be off by and still be ✓ (each stated with the verdict).

    ``restitution``: each bounce's restitution within this of the requested e (absolute);
    ``apex_ratio``: H5/H0 within this fraction of e**10;
    ``gain``: a bounce gains energy where its apex exceeds the one before by more than this
    fraction (the apex is the largest recorded height, which samples the flight at the step);
    ``stop``: the slide's stop distance within this fraction of v0**2/(2 mu g);
    ``creep``: the distance it may move once stopped (m);
    ``penetration``, ``drift``: depth into the plane or the box below, and a body's displacement
    from where it was placed (m); ``kinetic``: the kinetic energy left at the end (J).
    """

    restitution: float = 0.05
    apex_ratio: float = 0.1
    gain: float = 0.01
    stop: float = 0.05
    creep: float = 1e-3
    penetration: float = 1e-3
    drift: float = 1e-3
    kinetic: float = 1e-6


TOLERANCES = Tolerances()


class ContactScene:
    """A contact scene: its parameters (checked as a ``Scene``'s are, one line naming the bad
    field), how long it runs, and its analytic truth."""

    id: ClassVar[str]
    title: ClassVar[str]
    params: ClassVar[dict[str, Param]]
    bodies: ClassVar[int] = 1
    #: The figures its measure gives (``harness.contact.figures``).
    figures: ClassVar[tuple[str, ...]]

    def __init__(self, **overrides):
        unknown = sorted(set(overrides) - set(self.params))
        if unknown:
            raise InvalidInput(f"unknown parameter {unknown[0]!r} for contact scene {self.id} "
                               f"(valid: {', '.join(self.params)})")
        self.values = {name: spec.check(name, overrides.get(name, spec.default))
                       for name, spec in self.params.items()}
        self._validate()

    def _validate(self) -> None:
        """Cross-parameter checks; raise InvalidInput."""

    def __getattr__(self, name):
        values = self.__dict__.get("values", {})
        if name in values:
            return values[name]
        raise AttributeError(name)

    @property
    def duration(self) -> float:
        raise NotImplementedError

    def truth(self) -> dict:
        """The analytic figures the run is judged against."""
        raise NotImplementedError

    def initial_centres(self) -> list[tuple[float, float, float]]:
        """Each body's centre at the start."""
        raise NotImplementedError

    def label(self) -> str:
        changed = {k: v for k, v in self.values.items() if v != self.params[k].default}
        return self.id + "".join(f" {k}={v:g}" for k, v in changed.items())


_G = Param(9.81, "gravity (m/s^2)", lo=0.0, lo_open=True)
_MASS = Param(1.0, "mass of each body (kg)", lo=0.0, lo_open=True)
_HALF = Param(0.1, "half the side of each cube (m)", lo=0.0, lo_open=True)


class Ball(ContactScene):
    id = "ball"
    title = "a ball dropped on a plane at a requested restitution: apex n at e^(2n) h0"
    params = {
        "e": Param(0.8, "coefficient of restitution requested of the engine", lo=0.0, hi=1.0),
        "h0": Param(1.0, "drop height of the ball's lowest point (m)", lo=0.0, lo_open=True),
        "radius": Param(0.1, "ball radius (m)", lo=0.0, lo_open=True),
        "mass": _MASS,
        "g": _G,
        "bounces": Param(5, "bounces measured", lo=1, hi=20, integer=True),
    }
    figures = ("restitution", "apex_ratio", "gain", "interval")

    def flight(self, n: int) -> float:
        """The flight after impact n (n >= 1) under an ideal impact law."""
        return 2.0 * self.e ** n * math.sqrt(2.0 * self.g * self.h0) / self.g

    def impacts(self) -> list[float]:
        """The times of impacts 1..bounces+1 under an ideal impact law."""
        t = [math.sqrt(2.0 * self.h0 / self.g)]
        for n in range(1, self.bounces + 1):
            t.append(t[-1] + self.flight(n))
        return t

    #: The run lasts as long as a ball whose every bounce restores this much more than e would need
    #: to reach its last measured apex: an engine that bounces higher than asked has its apexes
    #: recorded, and its gain measured, rather than cut off by the end of the run.
    HEADROOM = 0.1

    @property
    def duration(self) -> float:
        e = self.e + self.HEADROOM
        v = math.sqrt(2.0 * self.g * self.h0)
        t = v / self.g + sum(2.0 * e ** n * v / self.g for n in range(1, self.bounces))
        # Through the last measured apex and beyond, so that it is recorded as a maximum.
        return t + 0.75 * 2.0 * max(e ** self.bounces, 0.2 * e) * v / self.g + 0.05

    def truth(self) -> dict:
        e, h0 = self.e, self.h0
        return {"apexes": [e ** (2 * n) * h0 for n in range(self.bounces + 1)],
                "restitution": e, "apex_ratio": e ** (2 * self.bounces),
                "intervals": [self.flight(n) for n in range(1, self.bounces + 1)]}

    def initial_centres(self):
        return [(0.0, 0.0, self.h0 + self.radius)]


class Slide(ContactScene):
    id = "slide"
    title = "a box sliding with Coulomb friction: it stops after v0^2/(2 mu g)"
    params = {
        "mu": Param(0.5, "Coulomb friction coefficient of the box on the plane (above 1 the cube tips over "
                      "rather than slides)", lo=0.0, hi=1.0),
        "v0": Param(2.0, "initial speed along x (m/s)", lo=0.0, lo_open=True),
        "half": _HALF,
        "mass": _MASS,
        "g": _G,
        "t_end": Param(1.5, "duration (s); long enough to see it stop and stay", lo=0.0, lo_open=True),
    }
    figures = ("stop", "creep")

    def _validate(self):
        if self.mu == 0.0:
            raise InvalidInput("parameter mu=0 never stops the box (allowed: (0, 1] for the slide)")

    @property
    def duration(self) -> float:
        return max(self.t_end, 1.5 * self.stop_time)

    @property
    def stop_time(self) -> float:
        return self.v0 / (self.mu * self.g)

    def truth(self) -> dict:
        return {"stop": self.v0 ** 2 / (2.0 * self.mu * self.g), "stop_time": self.stop_time, "creep": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]


class Rest(ContactScene):
    id = "rest"
    title = "a box at rest on a plane: no penetration, drift or kinetic energy"
    params = {"half": _HALF, "mass": _MASS, "g": _G,
              "t_end": Param(2.0, "duration (s)", lo=0.0, lo_open=True)}
    figures = ("penetration", "drift", "kinetic")

    @property
    def duration(self) -> float:
        return self.t_end

    def truth(self) -> dict:
        return {"penetration": 0.0, "drift": 0.0, "kinetic": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]


class Stack(Rest):
    id = "stack"
    title = "three boxes stacked on a plane: no penetration, drift or kinetic energy"
    bodies = 3

    def initial_centres(self):
        return [(0.0, 0.0, (2 * i + 1) * self.half) for i in range(self.bodies)]


CONTACT_SCENES: dict[str, type[ContactScene]] = {cls.id: cls for cls in (Ball, Slide, Rest, Stack)}


def make_contact_scene(scene_id: str, **overrides) -> ContactScene:
    """The contact scene ``scene_id`` with these parameters, or one line naming what is wrong."""
    try:
        cls = CONTACT_SCENES[scene_id]
    except KeyError:
        raise InvalidInput(f"unknown contact scene {scene_id!r} (valid: {', '.join(CONTACT_SCENES)})") from None
    return cls(**overrides)
