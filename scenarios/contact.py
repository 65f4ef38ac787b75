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
from records.contact import PROFILE_DT  # noqa: F401 (each profile's step, read from here too)

from .scene import Param, Scene, no_solve


@dataclass(frozen=True)
class Tolerances:
    """What a contact figure may be off by and still be ✓: a named profile, stated with every
    verdict (``name``, and ``source``: where its lengths come from).

    ``restitution``: each bounce's restitution within this of the requested e (absolute);
    ``apex_ratio``: H5/H0 within this fraction of e**10;
    ``gain``: a bounce gains energy where its apex exceeds the one before by more than this
    fraction (the apex is the largest recorded height, which samples the flight at the step);
    a turning body, where its energy rises above its start by more than this fraction of what
    it has to lose;
    ``stop``: the slide's stop distance within this fraction of v0**2/(2 mu g);
    ``distance``: a rolling ball's distance within this fraction of the closed form's;
    ``creep``: the distance a body may move sideways once it has stopped, or while it rests (m);
    ``penetration``: depth into the plane or the box below: at impact for the ball, once
    settled for a body at rest (m); ``sink``: how far a resting body may settle below where it
    was placed (m); ``kinetic``: the kinetic energy left at the end (J); ``tilt``: how far a
    body that came to rest may lean off a face (degrees); ``slip``: a rolling ball's speed at
    its contact point (m/s); ``tip_time``: a tipping box's time to fall within this fraction of
    the pivot's."""

    name: str = "robotics"
    source: str = (
        "1 mm: Drake's MultibodyPlant penetration allowance (set_penetration_allowance, default 1e-3 m), "
        "the depth a robot's contact is stiffened to at its 1-2 ms steps"
    )
    restitution: float = 0.05
    apex_ratio: float = 0.1
    gain: float = 0.01
    stop: float = 0.05
    distance: float = 0.01
    creep: float = 1e-3
    penetration: float = 1e-3
    sink: float = 1e-3
    kinetic: float = 1e-6
    tilt: float = 1.0
    slip: float = 1e-2
    tip_time: float = 0.05


TOLERANCES = Tolerances()
#: The profiles a user chooses between (``--profile``): each states where its lengths come from.
PROFILES = {
    "robotics": TOLERANCES,
    "game": Tolerances(
        name="game",
        source=(
            "5 mm: Box2D's linear slop (b2_linearSlop 0.005 m, 'numerically significant, but visually "
            "insignificant'), the overlap a game engine at 60 Hz leaves on purpose"
        ),
        creep=5e-3,
        penetration=5e-3,
        sink=5e-3,
    ),
}


def profile_at(dt: float) -> Tolerances:
    """The profile a step is judged by where none is named: a game's below 200 Hz, a robot's from it."""
    return PROFILES["game"] if dt > 1.0 / 200.0 else PROFILES["robotics"]


def profile(name: str) -> Tolerances:
    """The tolerance profile ``name``, or one line naming the valid ones."""
    try:
        return PROFILES[name]
    except KeyError:
        raise InvalidInput(f"--profile {name!r} is not a tolerance profile (valid: {', '.join(PROFILES)})") from None


#: Below this speed (m/s) a sliding box has stopped.
STOPPED = 1e-3


@dataclass(frozen=True)
class Figure:
    """One figure a contact scene's judge gives of a run (``ContactScene.measure`` computes it),
    as every table and chart shows it.

    ``name``: its key in the run's figures, rows and ``--json``; ``header``: its column in the
    report's table ("" : not a column of the tables, e.g. the flights between impacts, kept with
    the run); ``fmt``: how a value is printed (``num``; ``list``, a figure per bounce to three
    decimals; ``bounces``, integers; ``flag``, yes or no); ``truth``: the key of the scene's ``truth()`` it is
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

    def initial_orientations(self) -> list[tuple[float, float, float, float]]:
        """Each body's orientation at the start, a unit quaternion (w, x, y, z) from body to world
        axes (a box's faces along the world's axes unless the scene says otherwise)."""
        return [(1.0, 0.0, 0.0, 0.0)] * self.bodies

    def initial_angular_velocities(self) -> list[tuple[float, float, float]]:
        """Each body's angular velocity at the start, in world axes (rad/s)."""
        return [(0.0, 0.0, 0.0)] * self.bodies

    @property
    def moment(self) -> float:
        """Each body's moment of inertia about its centre (kg m^2): a cube's and a solid sphere's
        are the same about every axis, so the rotational energy needs no orientation. A cube of
        side 2 ``half``: 2/3 m half^2; a sphere of ``radius``: 2/5 m r^2."""
        if "half" in self.values:
            return 2.0 / 3.0 * self.mass * self.half**2
        return 0.4 * self.mass * self.values.get("radius", 0.0) ** 2

    @property
    def gravity(self) -> tuple[float, float, float]:
        """The field every body falls in (m/s^2): g down z."""
        return (0.0, 0.0, -self.g)

    def initial_state(self):
        return (
            np.array(self.initial_centres(), dtype=float).reshape(-1),
            np.array(self.initial_velocities(), dtype=float).reshape(-1),
        )

    def energy(self, q, v, angular=None):
        """Each body's kinetic energy (of its centre, and of its turning where ``angular``, its
        angular velocities (..., bodies, 3), is given) and its potential in ``gravity``, summed."""
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        x = q.reshape(*q.shape[:-1], -1, 3)
        u = v.reshape(*v.shape[:-1], -1, 3)
        field = np.asarray(self.gravity)
        out = self.mass * np.sum(0.5 * np.sum(u * u, axis=-1) - x @ field, axis=-1)
        if angular is not None:
            w = np.asarray(angular, dtype=float).reshape(x.shape)
            out = out + 0.5 * self.moment * np.sum(w * w, axis=(-1, -2))
        return out

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


def impact_depths(z: np.ndarray) -> tuple[float, float]:
    """How deep the ball went into the plane beyond where a step first found it there, and that first
    depth: (the engine's depth, the step's overshoot), the largest of each over the impacts. A ball
    at speed u falls up to u h below the plane within the step that crosses it, before any contact
    acts: where the step falls against the crossing decides that depth (a lottery in [0, u h)), and
    only continuous collision or a margin takes it away. What the contact does after it found the
    ball is the engine's; the overshoot is the step's, reported beside it."""
    inside = z < 0.0
    depth = overshoot = 0.0
    i = 0
    while i < len(z):
        if not inside[i]:
            i += 1
            continue
        j = i
        while j < len(z) and inside[j]:
            j += 1
        first = float(-z[i])
        overshoot = max(overshoot, first)
        depth = max(depth, float(-np.min(z[i:j])) - first)
        i = j
    return depth, overshoot


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
        Figure("impact_depth", "impact depth (m)", truth="impact_depth"),
        Figure("overshoot", "first sample under (m)"),
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
            "impact_depth": 0.0,
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
        # A height that never cleared the chatter (a ball resting in a soft contact, its "apex" at
        # or below the surface) is no apex: the bounces stopped there.
        flown = next((i for i, a in enumerate(heights) if i and a <= lift), len(heights))
        heights, impacts = heights[:flown], impacts[: flown - 1]
        n = self.bounces
        h = heights[: n + 1] + [0.0] * (n + 1 - len(heights))
        e_n = [math.sqrt(max(h[i], 0.0) / h[i - 1]) if h[i - 1] > 0 else 0.0 for i in range(1, n + 1)]
        gained = [i for i in range(1, n + 1) if h[i - 1] > 0.0 and h[i] > h[i - 1] * (1.0 + tol.gain)]
        times = run.t[impacts]
        truth = self.truth()
        ratio = h[n] / h[0] if h[0] > 0 else None
        depth, overshoot = impact_depths(z)
        passes = {
            "restitution": all(abs(x - self.e) <= tol.restitution for x in e_n),
            "apex_ratio": (
                ratio is not None and abs(ratio - truth["apex_ratio"]) <= tol.apex_ratio * truth["apex_ratio"]
            ),
            "gain": not gained,
            "impact_depth": depth <= tol.penetration,
        }
        return {
            "restitution": e_n,
            "apex_ratio": ratio,
            "gained": gained,
            "impact_depth": depth,
            "overshoot": overshoot,
            "intervals": [float(b - a) for a, b in zip(times[:n], times[1 : n + 1])],
            "passes": passes,
        }

    def truth_text(self) -> str:
        truth = self.truth()
        return f"restitution {truth['restitution']:g} a bounce, H5/H0 {truth['apex_ratio']:.4g}"

    def tolerance_text(self, tol: dict) -> str:
        return (
            f"each bounce within {tol.get('restitution')} of e, H5/H0 within {tol.get('apex_ratio', 0):.0%}, "
            f"no apex above the one before by more than {tol.get('gain', 0):.0%}, "
            f"at most {tol.get('penetration')} m deeper into the plane at impact than the step first found it "
            "(that first overshoot, up to the impact speed times the step, reported apart)"
        )


class Slide(ContactScene):
    """Where the box stopped: the first recorded step whose speed in the plane is below
    ``STOPPED`` (m/s) and stays below it to the end (its distance along the push from the start),
    and what it moved after. ``angle`` turns the push off the x axis: Coulomb's friction is the
    same in every direction (an elliptic cone), a pyramid's is not, and its force off the velocity
    also turns the path (``veer``: the largest distance from the line of the push)."""

    id = "slide"
    title = "a box sliding with Coulomb friction: it stops after v0^2/(2 mu g)"
    params = {
        "mu": Param(
            0.5,
            "Coulomb friction coefficient of the box on the plane (above 1 the cube tips over rather than slides)",
            lo=0.0,
            hi=1.0,
        ),
        "v0": Param(2.0, "initial speed (m/s), along x turned by angle", lo=0.0, lo_open=True),
        "angle": Param(0.0, "direction of the push in the plane, degrees from the x axis", lo=-180.0, hi=180.0),
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
        Figure("veer", "veer (m)", truth="veer"),
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
        return {
            "stop": self.v0**2 / (2.0 * self.deceleration),
            "stop_time": self.stop_time,
            "creep": 0.0,
            "veer": 0.0,
        }

    @property
    def direction(self) -> np.ndarray:
        """The unit vector of the push in the plane."""
        a = math.radians(self.angle)
        return np.array([math.cos(a), math.sin(a), 0.0])

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]

    def initial_velocities(self):
        u = self.v0 * self.direction
        # Exact zeros off the axis (cos 90° is 6e-17): a planar pose takes a push along x.
        return [tuple(0.0 if abs(c) < 1e-15 * self.v0 else float(c) for c in u)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        d = self.direction
        moved = run.centres[:, 0, :] - run.centres[0, 0, :]
        x = moved @ d
        side = np.array([-d[1], d[0], 0.0])
        speed = np.hypot(run.velocities[:, 0, 0], run.velocities[:, 0, 1])
        moving = np.nonzero(speed >= STOPPED)[0]
        truth = self.truth()
        if len(moving) and moving[-1] == len(x) - 1:
            return {
                "stop": None,
                "stop_time": None,
                "creep": None,
                "veer": None,
                "passes": {"stop": False, "creep": False, "veer": False},
                "detail": f"still moving at the end (t = {run.t[-1]:.3g} s, {speed[-1]:.3g} m/s)",
            }
        i = int(moving[-1]) + 1 if len(moving) else 0
        stop = float(x[i])
        creep = float(np.max(np.linalg.norm(moved[i:, :2] - moved[i, :2], axis=1)))
        veer = float(np.max(np.abs(moved @ side)))
        return {
            "stop": stop,
            "stop_time": float(run.t[i]),
            "creep": creep,
            "veer": veer,
            "passes": {
                "stop": abs(stop - truth["stop"]) <= tol.stop * truth["stop"],
                "creep": creep <= tol.creep,
                "veer": veer <= tol.creep,
            },
        }

    def truth_text(self) -> str:
        truth = self.truth()
        return f"stops after {truth['stop']:.4g} m ({self.STOP_FORMULA}) in {truth['stop_time']:.3g} s, then stays"

    def tolerance_text(self, tol: dict) -> str:
        return (
            f"stop within {tol.get('stop', 0):.0%}, creep once stopped and veer off the line of the push "
            f"≤ {tol.get('creep')} m"
        )


class Rest(ContactScene):
    """A body placed exactly touching starts with one step of free fall (g h^2 deep), a transient
    every engine shows and none should be judged by: the penetration (into the plane, or of a box
    into the one below, from the centres: the poses keep the boxes upright) is judged once settled
    (from ``settle`` on), the transient before it reported beside. A body's displacement from where
    it was placed is split into ``creep`` (sideways, over the whole run: a resting box should not
    wander) and ``sink`` (down, once settled: how far it sat into what holds it); the kinetic
    energy is the one left at the end."""

    id = "rest"
    title = "a box at rest on a plane: no penetration, creep, sink or kinetic energy"
    params = {
        "half": _HALF,
        "mass": _MASS,
        "g": _G,
        "t_end": Param(2.0, "duration (s)", lo=0.0, lo_open=True),
        "settle": Param(0.5, "time (s) from which a body placed touching is judged settled", lo=0.0),
    }
    FIGURES = (
        Figure("penetration", "penetration (m)", truth="penetration", chart="penetration (m)", chart_log=True),
        Figure("transient", "transient (m)"),
        Figure("creep", "creep (m)", truth="creep"),
        Figure("sink", "sink (m)", truth="sink"),
        Figure("kinetic", "kinetic (J)", truth="kinetic"),
    )

    def _validate(self):
        if self.settle >= self.t_end:
            raise InvalidInput(
                f"parameter settle={self.settle:g} leaves nothing to judge (allowed: below t_end={self.t_end:g})"
            )

    @property
    def duration(self) -> float:
        return self.t_end

    def truth(self) -> dict:
        return {"penetration": 0.0, "creep": 0.0, "sink": 0.0, "kinetic": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        half, mass = self.half, self.mass
        z = run.centres[:, :, 2]
        bottoms = z - half
        below = np.concatenate([np.zeros((len(z), 1)), z[:, :-1] + half], axis=1)  # the plane, then each box's top
        depth = np.max(below - bottoms, axis=1)
        settled = run.t >= self.settle - 1e-12
        penetration = float(max(0.0, np.max(depth[settled])))
        transient = float(max(0.0, np.max(depth[~settled]))) if np.any(~settled) else 0.0
        start = run.centres[0]
        moved = run.centres - start[None]
        creep = float(np.max(np.linalg.norm(moved[:, :, :2], axis=2)))
        sink = float(max(0.0, -np.min(moved[settled][:, :, 2])))
        kinetic = float(0.5 * mass * np.sum(run.velocities[-1] ** 2))
        return {
            "penetration": penetration,
            "transient": transient,
            "creep": creep,
            "sink": sink,
            "kinetic": kinetic,
            "passes": {
                "penetration": penetration <= tol.penetration,
                "creep": creep <= tol.creep,
                "sink": sink <= tol.sink,
                "kinetic": kinetic <= tol.kinetic,
            },
        }

    def truth_text(self) -> str:
        return "no penetration, creep, sink or kinetic energy"

    def tolerance_text(self, tol: dict) -> str:
        return (
            f"from t = {self.settle:g} s on (the start's transient reported apart): penetration ≤ "
            f"{tol.get('penetration')} m, sink ≤ {tol.get('sink')} m; creep ≤ {tol.get('creep')} m; "
            f"kinetic energy at the end ≤ {tol.get('kinetic')} J"
        )


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
