"""Contact scenes: a ball dropped on a plane, a box sliding with Coulomb friction, a box at rest and
a stack of three, each with its analytic truth. The engines pose them (``adapters/<engine>/contact.py``); the
harness measures what they did against the truth (``harness.contact.figures``).

A contact scene is a ``Scene`` that only engines step (``has_kernels`` False, as a model file):
no reference scheme steps a rigid contact. Its parameters are checked by ``Scene``'s machinery;
its state is its bodies' centres (q, flattened: body i at q[3 i : 3 i + 3]) and linear
velocities (v); its horizon is ``duration``; and beside its truth it declares its judge: how
each figure is computed from a run (``measure``), the truth each compares with, its tolerance,
and how the tables and charts show it (``FIGURES``, each a ``Figure``). Every consumer (``harness
contact``, its ``--json``, the nightly's ``contact`` cell, the report and its charts) reads these
declarations, so a new contact scene is this one module plus one pose per engine that poses it
(``adapters.<engine>.contact.POSES``). A pose records, per step, the centre and linear velocity
of each body (a ``records.contact.ContactTrajectory``); the scene says what those should have
done. The reference schemes meet contact on the penalty ball (``scenarios.penalty_ball``), whose
ground is a spring-dashpot.

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
from dataclasses import asdict, dataclass
from typing import ClassVar

import numpy as np

from records import InvalidInput

from .scene import Param, Scene, no_solve


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

#: Below this speed (m/s) a sliding box has stopped.
STOPPED = 1e-3


@dataclass(frozen=True)
class Figure:
    """One figure a contact scene's judge gives of a run (``ContactScene.measure`` computes it),
    as every table and chart shows it.

    ``name``: its key in the run's figures, rows and ``--json``; ``header``: its column in the
    report's table ("" : not a column of the tables, e.g. the flights between impacts, kept with
    the run); ``fmt``: how a value is printed (``num``; ``list``, a figure per bounce to three
    decimals; ``bounces``, integers); ``truth``: the key of the scene's ``truth()`` it is
    compared with (shown beside the table); ``chart``: where set, the label of the chart of this
    figure against the step (one figure a scene), ``chart_truth`` the truth drawn dashed on it
    with its legend (key, label), ``chart_log`` a symmetric log axis (figures that are 0 in
    truth)."""

    name: str
    header: str = ""
    fmt: str = "num"
    truth: str | None = None
    chart: str = ""
    chart_truth: tuple[str, str] | None = None
    chart_log: bool = False

    @property
    def shown(self) -> bool:
        return bool(self.header)


def no_accel(q, v, t, p):  # pragma: no cover - only reached by a misuse
    raise NotImplementedError("a contact scene's contact is the engine's: no reference kernel steps it")


class ContactScene(Scene):
    """A contact scene: a ``Scene`` only engines step (``has_kernels`` False). Its parameters are
    checked as every scene's are; its state is its bodies' centres and velocities; it states how
    long it runs (``duration``), its analytic truth (``truth``) and its judge: ``measure(run,
    tol)`` gives each figure of ``FIGURES`` and each judged figure's ✓/✗ (``passes``), read by every
    table, chart and cell that shows the scene."""

    id: ClassVar[str]
    title: ClassVar[str]
    params: ClassVar[dict[str, Param]]
    bodies: ClassVar[int] = 1
    #: The figures its judge gives, as the tables and charts show them.
    FIGURES: ClassVar[tuple[Figure, ...]] = ()
    has_kernels = False
    accel = staticmethod(no_accel)
    solve = staticmethod(no_solve)

    def __init_subclass__(cls, **kwargs):
        """A scene's declarations checked where it is written: each figure named once, one charted."""
        super().__init_subclass__(**kwargs)
        names = [f.name for f in cls.FIGURES]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise TypeError(f"contact scene {cls.__name__} declares figure(s) {twice} twice in FIGURES")
        charted = [f.name for f in cls.FIGURES if f.chart]
        if len(charted) > 1:
            raise TypeError(f"contact scene {cls.__name__} charts {charted}: a scene charts one figure")

    @property
    def dof_names(self) -> tuple[str, ...]:
        return tuple(f"{axis}{i}" for i in range(self.bodies) for axis in "xyz")

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

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        """The run's figures ({name: value} for each of ``FIGURES``), with ``passes`` ({judged
        figure: ✓ True or ✗ False}) and, where a figure could not be read, ``detail`` saying why.
        ``run``: its recorded ``t``, ``centres`` and ``velocities`` ((n, bodies, 3) each)."""
        raise NotImplementedError

    def truth_text(self) -> str:
        """The truth in words, as the report states it above the table."""
        raise NotImplementedError

    def tolerance_text(self, tol: dict) -> str:
        """The tolerances (``asdict(Tolerances)``) in words, as the report states them."""
        raise NotImplementedError

    def tolerances(self, tol: Tolerances = TOLERANCES) -> dict:
        """The tolerances stated with every run."""
        return asdict(tol)

    def initial_centres(self) -> list[tuple[float, float, float]]:
        """Each body's centre at the start."""
        raise NotImplementedError

    def initial_velocities(self) -> list[tuple[float, float, float]]:
        """Each body's linear velocity at the start (at rest unless the scene says otherwise)."""
        return [(0.0, 0.0, 0.0)] * self.bodies

    @property
    def gravity(self) -> tuple[float, float, float]:
        """The field every body falls in (m/s^2): g down z."""
        return (0.0, 0.0, -self.g)

    def initial_state(self):
        return (
            np.array(self.initial_centres(), dtype=float).reshape(-1),
            np.array(self.initial_velocities(), dtype=float).reshape(-1),
        )

    def energy(self, q, v):
        """Each body's kinetic energy (of its centre) and its potential in ``gravity``, summed."""
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        x = q.reshape(*q.shape[:-1], -1, 3)
        u = v.reshape(*v.shape[:-1], -1, 3)
        field = np.asarray(self.gravity)
        return self.mass * np.sum(0.5 * np.sum(u * u, axis=-1) - x @ field, axis=-1)

    @property
    def omega(self) -> float:
        """sqrt(g / L), L the scene's size (``length_scale``): the rate of a fall through it. The
        contact's own frequency is the engine's, not the scene's."""
        return math.sqrt(self.g / self.length_scale)

    @property
    def length_scale(self) -> float:
        return float(self.values.get("h0", self.values.get("half", 1.0)))

    def label(self) -> str:
        changed = {k: v for k, v in self.values.items() if v != self.params[k].default}
        return self.id + "".join(f" {k}={v:g}" for k, v in changed.items())

    def declared(self) -> list[dict]:
        """``FIGURES`` as plain dicts (what a stored cell carries for the report)."""
        return [asdict(f) for f in self.FIGURES]


_G = Param(9.81, "gravity (m/s^2)", lo=0.0, lo_open=True)
_MASS = Param(1.0, "mass of each body (kg)", lo=0.0, lo_open=True)
_HALF = Param(0.1, "half the side of each cube (m)", lo=0.0, lo_open=True)


def apexes(z: np.ndarray, vz: np.ndarray, lift: float) -> tuple[list[float], list[int]]:
    """The recorded maxima of ``z`` (heights above the plane) between impacts, and the steps of the
    impacts themselves: apex 0 is the start, apex n the largest height after impact n. An impact
    is the velocity turning from down to up (in flight gravity never turns it) after the ball has
    risen above ``lift`` since the impact before: a soft contact's chatter, which never lifts the
    ball, is not a bounce; a long step that reverses the velocity far from the plane still is one."""
    impacts = []
    down, lifted = False, bool(z[0] > lift)
    for i in range(1, len(z)):
        if z[i] > lift:
            lifted = True
        if vz[i] < 0.0:
            down = True
        elif down and vz[i] > 0.0:
            if lifted:
                impacts.append(i)
            down, lifted = False, False
    heights = [float(z[0])]
    for j, i in enumerate(impacts):
        end = impacts[j + 1] if j + 1 < len(impacts) else len(z)
        heights.append(float(np.max(z[i:end])))
    return heights, impacts


class Ball(ContactScene):
    """The apexes are the largest recorded heights of the ball's lowest point between impacts
    (``apexes``); restitution per bounce sqrt(H_n / H_(n-1)) and H_bounces / H0, never a velocity
    ratio read from samples, which is ambiguous by g h / v. A bounce gains energy where its apex
    exceeds the one before by more than ``Tolerances.gain``. A ball that stops bouncing has
    restitution 0 for the bounces it did not make."""

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
    FIGURES = (
        Figure(
            "restitution",
            "restitution per bounce",
            "list",
            truth="restitution",
            chart="first bounce's restitution",
            chart_truth=("restitution", "requested e"),
        ),
        Figure("apex_ratio", "H5/H0", truth="apex_ratio"),
        Figure("gained", "gained at", "bounces"),
        Figure("intervals"),
    )

    def flight(self, n: int) -> float:
        """The flight after impact n (n >= 1) under an ideal impact law."""
        return 2.0 * self.e**n * math.sqrt(2.0 * self.g * self.h0) / self.g

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
        t = v / self.g + sum(2.0 * e**n * v / self.g for n in range(1, self.bounces))
        # Through the last measured apex and beyond, so that it is recorded as a maximum.
        return t + 0.75 * 2.0 * max(e**self.bounces, 0.2 * e) * v / self.g + 0.05

    def truth(self) -> dict:
        e, h0 = self.e, self.h0
        return {
            "apexes": [e ** (2 * n) * h0 for n in range(self.bounces + 1)],
            "restitution": e,
            "apex_ratio": e ** (2 * self.bounces),
            "intervals": [self.flight(n) for n in range(1, self.bounces + 1)],
        }

    def initial_centres(self):
        return [(0.0, 0.0, self.h0 + self.radius)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        z = run.centres[:, 0, 2] - self.radius
        vz = run.velocities[:, 0, 2]
        # A bounce lifts the ball clear of a contact's chatter (a soft contact's sink, g / omega_c^2, is a
        # fraction of a millimetre in every pose): a few millimetres of a metre's drop.
        lift = 2e-3 + 1e-3 * self.h0
        heights, impacts = apexes(z, vz, lift)
        n = self.bounces
        h = heights[: n + 1] + [0.0] * (n + 1 - len(heights))
        e_n = [math.sqrt(max(h[i], 0.0) / h[i - 1]) if h[i - 1] > 0 else 0.0 for i in range(1, n + 1)]
        gained = [i for i in range(1, n + 1) if h[i] > h[i - 1] * (1.0 + tol.gain)]
        times = run.t[impacts]
        truth = self.truth()
        ratio = h[n] / h[0] if h[0] > 0 else None
        passes = {
            "restitution": all(abs(x - self.e) <= tol.restitution for x in e_n),
            "apex_ratio": (
                ratio is not None and abs(ratio - truth["apex_ratio"]) <= tol.apex_ratio * truth["apex_ratio"]
            ),
            "gain": not gained,
        }
        return {
            "restitution": e_n,
            "apex_ratio": ratio,
            "gained": gained,
            "intervals": [float(b - a) for a, b in zip(times[:n], times[1 : n + 1])],
            "passes": passes,
        }

    def truth_text(self) -> str:
        truth = self.truth()
        return f"restitution {truth['restitution']:g} a bounce, H5/H0 {truth['apex_ratio']:.4g}"

    def tolerance_text(self, tol: dict) -> str:
        return (
            f"each bounce within {tol.get('restitution')} of e, H5/H0 within {tol.get('apex_ratio', 0):.0%}, "
            f"no apex above the one before by more than {tol.get('gain', 0):.0%}"
        )


class Slide(ContactScene):
    """Where the box stopped: the first recorded step whose speed along x is below ``STOPPED``
    (m/s) and stays below it to the end (its x from the start), and what it moved after."""

    id = "slide"
    title = "a box sliding with Coulomb friction: it stops after v0^2/(2 mu g)"
    params = {
        "mu": Param(
            0.5,
            "Coulomb friction coefficient of the box on the plane (above 1 the cube tips over rather than slides)",
            lo=0.0,
            hi=1.0,
        ),
        "v0": Param(2.0, "initial speed along x (m/s)", lo=0.0, lo_open=True),
        "half": _HALF,
        "mass": _MASS,
        "g": _G,
        "t_end": Param(1.5, "duration (s); long enough to see it stop and stay", lo=0.0, lo_open=True),
    }
    FIGURES = (
        Figure(
            "stop", "stop distance (m)", truth="stop", chart="stop distance (m)", chart_truth=("stop", "v0²/(2 μ g)")
        ),
        Figure("stop_time", truth="stop_time"),
        Figure("creep", "creep (m)", truth="creep"),
    )
    #: The stop distance's formula, as the report states it.
    STOP_FORMULA = "v0²/(2 μ g)"

    def _validate(self):
        if self.mu == 0.0:
            raise InvalidInput("parameter mu=0 never stops the box (allowed: (0, 1] for the slide)")

    @property
    def duration(self) -> float:
        return max(self.t_end, 1.5 * self.stop_time)

    @property
    def deceleration(self) -> float:
        """The box's deceleration while it slides (m/s^2)."""
        return self.mu * self.g

    @property
    def stop_time(self) -> float:
        return self.v0 / self.deceleration

    def truth(self) -> dict:
        return {"stop": self.v0**2 / (2.0 * self.deceleration), "stop_time": self.stop_time, "creep": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]

    def initial_velocities(self):
        return [(self.v0, 0.0, 0.0)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        x = run.centres[:, 0, 0] - run.centres[0, 0, 0]
        speed = np.abs(run.velocities[:, 0, 0])
        moving = np.nonzero(speed >= STOPPED)[0]
        truth = self.truth()
        if len(moving) and moving[-1] == len(x) - 1:
            return {
                "stop": None,
                "stop_time": None,
                "creep": None,
                "passes": {"stop": False, "creep": False},
                "detail": f"still moving at the end (t = {run.t[-1]:.3g} s, {speed[-1]:.3g} m/s)",
            }
        i = int(moving[-1]) + 1 if len(moving) else 0
        stop, creep = float(x[i]), float(np.max(np.abs(x[i:] - x[i])))
        return {
            "stop": stop,
            "stop_time": float(run.t[i]),
            "creep": creep,
            "passes": {"stop": abs(stop - truth["stop"]) <= tol.stop * truth["stop"], "creep": creep <= tol.creep},
        }

    def truth_text(self) -> str:
        truth = self.truth()
        return f"stops after {truth['stop']:.4g} m ({self.STOP_FORMULA}) in {truth['stop_time']:.3g} s, then stays"

    def tolerance_text(self, tol: dict) -> str:
        return f"stop within {tol.get('stop', 0):.0%}, creep ≤ {tol.get('creep')} m"


class Rest(ContactScene):
    """The deepest penetration (into the plane, or of a box into the one below, from the centres:
    the poses keep the boxes upright), the largest displacement of any body from where it was
    placed, and the kinetic energy left at the end."""

    id = "rest"
    title = "a box at rest on a plane: no penetration, drift or kinetic energy"
    params = {"half": _HALF, "mass": _MASS, "g": _G, "t_end": Param(2.0, "duration (s)", lo=0.0, lo_open=True)}
    FIGURES = (
        Figure("penetration", "penetration (m)", truth="penetration", chart="penetration (m)", chart_log=True),
        Figure("drift", "drift (m)", truth="drift"),
        Figure("kinetic", "kinetic (J)", truth="kinetic"),
    )

    @property
    def duration(self) -> float:
        return self.t_end

    def truth(self) -> dict:
        return {"penetration": 0.0, "drift": 0.0, "kinetic": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        half, mass = self.half, self.mass
        z = run.centres[:, :, 2]
        bottoms = z - half
        below = np.concatenate([np.zeros((len(z), 1)), z[:, :-1] + half], axis=1)  # the plane, then each box's top
        penetration = float(max(0.0, np.max(below - bottoms)))
        start = run.centres[0]
        drift = float(np.max(np.linalg.norm(run.centres - start[None], axis=2)))
        kinetic = float(0.5 * mass * np.sum(run.velocities[-1] ** 2))
        return {
            "penetration": penetration,
            "drift": drift,
            "kinetic": kinetic,
            "passes": {
                "penetration": penetration <= tol.penetration,
                "drift": drift <= tol.drift,
                "kinetic": kinetic <= tol.kinetic,
            },
        }

    def truth_text(self) -> str:
        return "no penetration, drift or kinetic energy"

    def tolerance_text(self, tol: dict) -> str:
        return f"penetration and drift ≤ {tol.get('penetration')} m, kinetic energy ≤ {tol.get('kinetic')} J"


class Stack(Rest):
    id = "stack"
    title = "three boxes stacked on a plane: no penetration, drift or kinetic energy"
    bodies = 3

    def initial_centres(self):
        return [(0.0, 0.0, (2 * i + 1) * self.half) for i in range(self.bodies)]


#: The contact scenes this module defines, registered with the engine scenes (``scenarios.ENGINE_SCENES``).
SCENES = (Ball, Slide, Rest, Stack)


def make_contact_scene(scene_id: str, **overrides) -> ContactScene:
    """The contact scene ``scene_id`` with these parameters, or one line naming what is wrong."""
    from . import contact_scenes

    scenes = contact_scenes()
    try:
        cls = scenes[scene_id]
    except KeyError:
        raise InvalidInput(f"unknown contact scene {scene_id!r} (valid: {', '.join(scenes)})") from None
    return cls(**overrides)
