"""Contact scenes whose bodies turn: a box dropped on an edge and on a corner, a box tipping over
its edge on an incline, and a ball rolling down one. Restitution, friction and rotation meet here
as they do in every real drop; each scene states its analytic truth or bound.

Geometry (SI units, z up; an incline is a level plane under a tilted field, gravity
(g sin(theta), 0, -g cos(theta)): x runs down the slope, z is its normal; a 2-D pose uses x and z):

* ``edge``: a cube of side 2 ``half`` leaning ``lean`` about y, its lowest edge ``h0`` above the
  plane, dropped at rest with restitution ``e`` and friction ``mu``. It lands on the edge, topples
  onto a face and must come to rest there (face down, at rest, centre ``half`` up) within a stated
  time bound, its energy never rising above the start: contact and friction only take energy.
* ``corner``: the same cube turned about y and then x so that one corner is lowest.
* ``tip``: a cube at rest on an incline of ``angle`` degrees with friction ``mu`` above what the
  pivot needs. Past 45 degrees (the line of gravity through the centre leaves the base) it tips
  over its downhill edge: while the edge holds (no slip, no lift), the box is a pendulum about it,
  I phi'' = m g a sqrt(2) sin(phi + theta - pi/4), I = 8/3 m a^2, and reaches ``TIP_ANGLE`` at the
  time that energy integral gives. Below 45 degrees it stays.
* ``roll``: a solid sphere at rest on an incline, friction above what rolling needs,
  (2/7) tan(theta): it rolls without slipping, x = 5/14 g sin(theta) t^2, its contact point at rest
  (v = omega r).

A run records each body's orientation (w, x, y, z, body to world) and angular velocity (world)
(``records.contact.ContactTrajectory``); every figure is read from those and the centres.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from records import InvalidInput

from .contact import _G, _HALF, _MASS, STOPPED, TOLERANCES, ContactScene, Figure, Tolerances
from .scene import Param


def quat_about(axis: tuple[float, float, float], degrees: float) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of a turn by ``degrees`` about ``axis`` (right-handed)."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    h = math.radians(degrees) / 2.0
    return np.concatenate([[math.cos(h)], math.sin(h) * u])


def quat_mul(p, q) -> np.ndarray:
    """p q: turn by q, then by p."""
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def rotation(q) -> np.ndarray:
    """The rotation matrices (..., 3, 3) of unit quaternions (..., 4) (w, x, y, z); normalised first
    (an engine's float32 quaternion drifts off unit length)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def cube_corners(half: float) -> np.ndarray:
    """The eight corners of a cube of side 2 ``half`` about its centre, body axes (8, 3)."""
    s = np.array([-1.0, 1.0])
    return half * np.array([[a, b, c] for a in s for b in s for c in s])


def _incline(scene) -> tuple[float, float, float]:
    th = math.radians(scene.angle)
    return (scene.g * math.sin(th), 0.0, -scene.g * math.cos(th))


def _needs_turning(run) -> str:
    if run.orientations is None or run.angular is None:
        return "the pose recorded no orientations: a scene whose bodies turn needs them"
    return ""


#: A corner within this fraction of the half-side of the plane touches it (a resting box that an
#: engine holds a hair above it still rests on it).
TOUCH = 1e-3


class Drop(ContactScene):
    """A cube dropped on an edge or a corner (``ORIENTATION``), measured from its centre,
    orientation and velocities: ``rest_time``, the first recorded time from which every point of
    the box stays slower than ``STOPPED`` (m/s) to the end (None: still moving at the end);
    ``energy_rise``, the largest rise of its energy (kinetic, turning and potential) above what it
    had when it first touched the plane, as a fraction of what it has to lose to rest on a face
    (contact and friction only take energy; the fall before, the scheme's free flight, is
    ``flight_rise``); ``tilt``, how far the resting
    box leans off its nearest face (degrees); ``sink``, how far its centre rests below ``half``;
    ``kinetic`` at the end."""

    params = {
        "e": Param(0.5, "coefficient of restitution requested of the engine", lo=0.0, hi=0.8),
        "mu": Param(0.5, "Coulomb friction of the box on the plane", lo=0.0, hi=2.0, lo_open=True),
        "h0": Param(0.3, "drop height of the lowest point (m)", lo=0.0, lo_open=True),
        "half": _HALF,
        "mass": _MASS,
        "g": _G,
    }
    FIGURES = (
        Figure(
            "rest_time", "at rest from (s)", truth="rest_by", chart="time to rest (s)", chart_truth=("rest_by", "bound")
        ),
        Figure("energy_rise", "energy rise", truth="energy_rise"),
        Figure("flight_rise", "flight's rise"),
        Figure("tilt", "tilt (°)", truth="tilt"),
        Figure("sink", "sink (m)", truth="sink"),
        Figure("kinetic", "kinetic (J)", truth="kinetic"),
    )
    #: The box's starting orientation (w, x, y, z): set by each scene.
    ORIENTATION: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    @property
    def rest_by(self) -> float:
        """The time bound: twice a point mass's bounces to rest from h0 at e,
        sqrt(2 h0 / g) (1 + e) / (1 - e), plus four of the box's toppling times sqrt(2 half / g)."""
        fall = math.sqrt(2.0 * self.h0 / self.g)
        return 2.0 * (fall * (1.0 + self.e) / (1.0 - self.e) + 4.0 * math.sqrt(2.0 * self.half / self.g))

    @property
    def duration(self) -> float:
        return self.rest_by + 0.5

    def truth(self) -> dict:
        return {"rest_by": self.rest_by, "energy_rise": 0.0, "tilt": 0.0, "sink": 0.0, "kinetic": 0.0}

    def initial_orientations(self):
        return [tuple(float(x) for x in self.ORIENTATION)]

    def initial_centres(self):
        low = float(np.max(-(rotation(self.ORIENTATION) @ cube_corners(self.half).T)[2]))
        return [(0.0, 0.0, self.h0 + low)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        why = _needs_turning(run)
        names = [f.name for f in self.FIGURES]
        if why:
            return {**dict.fromkeys(names), "passes": dict.fromkeys(names, False), "detail": why}
        c, v, w = run.centres[:, 0], run.velocities[:, 0], run.angular[:, 0]
        reach = math.sqrt(3.0) * self.half  # a corner's distance from the centre
        fastest = np.linalg.norm(v, axis=1) + np.linalg.norm(w, axis=1) * reach
        moving = np.nonzero(fastest >= STOPPED)[0]
        rest_i = None if len(moving) and moving[-1] == len(fastest) - 1 else (int(moving[-1]) + 1 if len(moving) else 0)
        energy = self.energy(c.reshape(len(c), 3), v.reshape(len(v), 3), w.reshape(len(w), 3))
        lose = energy[0] - self.mass * self.g * self.half
        # From the first step that finds a corner at the plane (``TOUCH``) on: before it the box is in
        # free flight, where a scheme's own energy error (position-first Euler gains g^2 h^2 / 2 a
        # step) is the integrator's, reported apart as ``flight_rise``.
        lowest = c[:, 2] + np.min(
            np.einsum("nij,kj->nki", rotation(run.orientations[:, 0]), cube_corners(self.half))[:, :, 2], axis=1
        )
        touched = np.nonzero(lowest <= TOUCH * self.half)[0]
        k = int(touched[0]) if len(touched) else len(energy) - 1
        rise = float(max(0.0, np.max(energy[k:] - energy[k])) / lose)
        flight = float(max(0.0, np.max(energy[: k + 1] - energy[0])) / lose)
        up = np.abs(rotation(run.orientations[-1, 0])[2])  # each body axis's z component
        tilt = float(math.degrees(math.acos(min(1.0, float(np.max(up))))))
        sink = float(max(0.0, self.half - c[-1, 2]))
        kinetic = float(0.5 * self.mass * v[-1] @ v[-1] + 0.5 * self.moment * w[-1] @ w[-1])
        rest_time = None if rest_i is None else float(run.t[rest_i])
        out = {
            "rest_time": rest_time,
            "energy_rise": rise,
            "flight_rise": flight,
            "tilt": tilt,
            "sink": sink,
            "kinetic": kinetic,
            "passes": {
                "rest_time": rest_time is not None and rest_time <= self.rest_by,
                "energy_rise": rise <= tol.gain,
                "tilt": tilt <= tol.tilt,
                "sink": sink <= tol.sink,
                "kinetic": kinetic <= tol.kinetic,
            },
        }
        if rest_time is None:
            out["detail"] = f"still moving at the end (t = {run.t[-1]:.3g} s, a point at {fastest[-1]:.3g} m/s)"
        return out

    def truth_text(self) -> str:
        return (
            f"at rest on a face by {self.rest_by:.3g} s (a bound: twice a point mass's bounces to rest, "
            "plus four toppling times), its energy never above the start"
        )

    def tolerance_text(self, tol: dict) -> str:
        return (
            f"energy never above its value at first contact by more than {tol.get('gain', 0):.0%} of what it loses; "
            "at the end "
            f"tilt ≤ {tol.get('tilt')}°, sink ≤ {tol.get('sink')} m, kinetic ≤ {tol.get('kinetic')} J"
        )


class Edge(Drop):
    id = "edge"
    title = "a box dropped on an edge: it topples onto a face and rests, its energy never rising"
    #: Leaning 30 degrees about y: one edge lowest, the centre off the line above it (so that the
    #: box topples one way, as a real drop does, not balance on the edge).
    ORIENTATION = tuple(quat_about((0.0, 1.0, 0.0), 30.0))


class Corner(Drop):
    id = "corner"
    title = "a box dropped on a corner: it topples onto a face and rests, its energy never rising"
    #: Turned 30 degrees about y, then 25 about x: one corner lowest, the centre off the line above it.
    ORIENTATION = tuple(quat_mul(quat_about((1.0, 0.0, 0.0), 25.0), quat_about((0.0, 1.0, 0.0), 30.0)))


#: The tipping box's angle about its edge (degrees) whose time is judged: the pivot holds (the
#: contact pushes, friction within its cone) to there at every incline the scene accepts.
TIP_ANGLE = 30.0
#: A box that turned this far (degrees) about y has tipped over.
TIPPED = 90.0


@functools.lru_cache(maxsize=32)
def pivot(theta: float, half: float, g: float, to: float = TIP_ANGLE) -> tuple[float, float, float]:
    """A cube at rest on an incline of ``theta`` (rad) pivoting about its downhill edge: the time
    (s) its rotation takes to reach ``to`` degrees, and over the way there the largest friction
    ratio |F| / N the edge needs and the smallest normal force per unit mass (m/s^2). From the
    energy integral phi'^2 = K (cos(alpha) - cos(phi + alpha)), alpha = theta - pi/4,
    K = 2 g a sqrt(2) / I, I = 8/3 a^2 per unit mass, the time int dphi / phi' (phi = u^2 removes
    the start's square-root singularity); the edge's reaction from the centre's acceleration."""
    from scipy.integrate import quad

    a, alpha = half, theta - math.pi / 4
    inertia = 8.0 / 3.0 * a * a
    k = 2.0 * g * a * math.sqrt(2.0) / inertia
    end = math.radians(to)
    c0 = math.cos(alpha)

    def integrand(u):
        return 2.0 * u / math.sqrt(k * (c0 - math.cos(u * u + alpha)))

    if alpha <= 0.0:
        return math.inf, 0.0, g * math.cos(theta)
    # The integrand's limit at u = 0 is 2 / sqrt(k sin(alpha)): finite.
    t, _ = quad(integrand, 0.0, math.sqrt(end), limit=200, epsabs=1e-13, epsrel=1e-11)
    r = a * math.sqrt(2.0)
    ratio, least = 0.0, math.inf
    for phi in np.linspace(0.0, end, 181):
        w2 = k * (c0 - math.cos(phi + alpha))
        acc = 0.5 * k * math.sin(phi + alpha)
        b = 3.0 * math.pi / 4.0 - phi  # the centre's direction from the edge, in the incline's x-z plane
        ax = r * (acc * math.sin(b) - w2 * math.cos(b))
        az = r * (-acc * math.cos(b) - w2 * math.sin(b))
        fx, fz = ax - g * math.sin(theta), az + g * math.cos(theta)
        least = min(least, fz)
        ratio = max(ratio, abs(fx) / fz if fz > 0 else math.inf)
    return t, ratio, least


class Tip(ContactScene):
    """The box's rotation about y, phi (from its z axis, (sin phi, 0, cos phi) in world axes),
    unwrapped over the run: ``tipped`` where it passed ``TIPPED`` degrees; ``tip_time`` when it
    reached ``TIP_ANGLE`` (between the two recorded steps it crossed it in, linearly: a step's
    sampling is not the engine's lag); ``pivot_slip`` how far the downhill bottom edge moved along the
    slope before then (over the whole run where it does not tip: the box should not slide)."""

    id = "tip"
    title = "a box on an incline past its tipping angle: it pivots over its downhill edge"
    params = {
        "angle": Param(50.0, "the incline (degrees); past 45 the cube tips", lo=0.0, hi=70.0),
        "mu": Param(1.5, "Coulomb friction: above what the pivot needs", lo=0.0, hi=10.0, lo_open=True),
        "half": _HALF,
        "mass": _MASS,
        "g": _G,
        "t_end": Param(1.0, "duration (s)", lo=0.0, lo_open=True),
    }
    FIGURES = (
        Figure("tipped", "tipped", "flag", truth="tipped"),
        Figure(
            "tip_time",
            f"time to {TIP_ANGLE:g}° (s)",
            truth="tip_time",
            chart=f"time to turn {TIP_ANGLE:g}° (s)",
            chart_truth=("tip_time", "pivot"),
        ),
        Figure("pivot_slip", "edge slip (m)", truth="pivot_slip"),
    )

    def _validate(self):
        theta = math.radians(self.angle)
        if self.angle <= 45.0:
            if math.tan(theta) >= self.mu:
                raise InvalidInput(
                    f"parameter mu={self.mu:g} lets the box slide at angle={self.angle:g} "
                    f"(allowed: above tan(angle) = {math.tan(theta):.4g})"
                )
            return
        _, ratio, least = pivot(theta, self.half, self.g)
        if least <= 0.0:
            raise InvalidInput(
                f"parameter angle={self.angle:g} throws the box off its edge before it turns {TIP_ANGLE:g}°"
            )
        if ratio >= self.mu:
            raise InvalidInput(
                f"parameter mu={self.mu:g} lets the edge slip while it pivots (allowed: above {ratio:.4g} at "
                f"angle={self.angle:g})"
            )

    @property
    def gravity(self):
        return _incline(self)

    @property
    def tips(self) -> bool:
        return self.angle > 45.0

    @property
    def duration(self) -> float:
        if self.tips:
            return max(self.t_end, 2.0 * self.truth()["tip_time"])
        return self.t_end

    def truth(self) -> dict:
        t = pivot(math.radians(self.angle), self.half, self.g)[0] if self.tips else None
        return {"tipped": self.tips, "tip_time": t, "pivot_slip": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.half)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        why = _needs_turning(run)
        if why:
            names = [f.name for f in self.FIGURES]
            return {**dict.fromkeys(names), "passes": dict.fromkeys(names, False), "detail": why}
        rot = rotation(run.orientations[:, 0])
        phi = np.degrees(np.unwrap(np.arctan2(rot[:, 0, 2], rot[:, 2, 2])))
        tipped = bool(np.max(phi) >= TIPPED)
        reached = np.nonzero(phi >= TIP_ANGLE)[0]
        end = int(reached[0]) if len(reached) else len(phi) - 1
        tip_time = None
        if len(reached):  # where the turn crossed TIP_ANGLE between two recorded steps, linearly
            a = max(end - 1, 0)
            span = phi[end] - phi[a]
            frac = (TIP_ANGLE - phi[a]) / span if span > 0 else 1.0
            tip_time = float(run.t[a] + frac * (run.t[end] - run.t[a]))
        edge = run.centres[:, 0] + rot @ np.array([self.half, 0.0, -self.half])
        slip = float(np.max(np.abs(edge[: end + 1, 0] - edge[0, 0])))
        truth = self.truth()
        passes = {"tipped": tipped == truth["tipped"], "pivot_slip": slip <= tol.creep}
        if truth["tipped"]:
            passes["tip_time"] = tip_time is not None and abs(tip_time - truth["tip_time"]) <= (
                tol.tip_time * truth["tip_time"]
            )
        return {"tipped": tipped, "tip_time": tip_time, "pivot_slip": slip, "passes": passes}

    def truth_text(self) -> str:
        truth = self.truth()
        if truth["tipped"]:
            return (
                f"tips over its downhill edge (past 45°), turning {TIP_ANGLE:g}° in {truth['tip_time']:.4g} s "
                "(the pivot's energy integral), the edge not slipping"
            )
        return "stays: no tipping (45° not reached) and no sliding (μ above tan θ)"

    def tolerance_text(self, tol: dict) -> str:
        return f"time to {TIP_ANGLE:g}° within {tol.get('tip_time', 0):.0%}; edge slip ≤ {tol.get('creep')} m"


class Roll(ContactScene):
    """``distance``: how far the ball went along x by ``t_end`` (its centre, interpolated between
    recorded steps); ``slip``: the largest speed of its contact point, |v_x - r omega_y|, from
    ``settle`` on (a ball placed exactly touching may fall free for its first step where an engine
    takes touching for apart, and its contact point then slips g sin(theta) h: the start's
    transient, reported apart as ``start_slip``)."""

    id = "roll"
    title = "a solid ball rolling down an incline without slipping: x = 5/14 g sin(θ) t²"
    params = {
        "angle": Param(20.0, "the incline (degrees)", lo=0.0, hi=60.0, lo_open=True),
        "mu": Param(0.5, "Coulomb friction: above (2/7) tan(angle), what rolling needs", lo=0.0, hi=10.0, lo_open=True),
        "radius": Param(0.1, "ball radius (m)", lo=0.0, lo_open=True),
        "mass": _MASS,
        "g": _G,
        "t_end": Param(1.0, "duration (s)", lo=0.0, lo_open=True),
        "settle": Param(0.05, "time (s) from which the contact point's slip is judged", lo=0.0),
    }
    FIGURES = (
        Figure(
            "distance",
            "distance (m)",
            truth="distance",
            chart="distance rolled (m)",
            chart_truth=("distance", "5/14 g sin θ t²"),
        ),
        Figure("slip", "slip (m/s)", truth="slip"),
        Figure("start_slip", "start slip (m/s)"),
    )

    def _validate(self):
        need = 2.0 / 7.0 * math.tan(math.radians(self.angle))
        if self.mu <= need:
            raise InvalidInput(
                f"parameter mu={self.mu:g} lets the ball slip (allowed: above (2/7) tan(angle) = {need:.4g})"
            )

    @property
    def gravity(self):
        return _incline(self)

    @property
    def duration(self) -> float:
        return self.t_end

    def truth(self) -> dict:
        d = 5.0 / 14.0 * self.g * math.sin(math.radians(self.angle)) * self.t_end**2
        return {"distance": d, "slip": 0.0}

    def initial_centres(self):
        return [(0.0, 0.0, self.radius)]

    def measure(self, run, tol: Tolerances = TOLERANCES) -> dict:
        why = _needs_turning(run)
        if why:
            return {
                "distance": None,
                "slip": None,
                "start_slip": None,
                "passes": {"distance": False, "slip": False},
                "detail": why,
            }
        x = run.centres[:, 0, 0] - run.centres[0, 0, 0]
        distance = float(np.interp(self.t_end, run.t, x))
        slipping = np.abs(run.velocities[:, 0, 0] - self.radius * run.angular[:, 0, 1])
        settled = run.t >= self.settle - 1e-12
        slip = float(np.max(slipping[settled])) if np.any(settled) else float(np.max(slipping))
        start = float(np.max(slipping[~settled])) if np.any(~settled) else 0.0
        truth = self.truth()
        return {
            "distance": distance,
            "slip": slip,
            "start_slip": start,
            "passes": {
                "distance": abs(distance - truth["distance"]) <= tol.distance * truth["distance"],
                "slip": slip <= tol.slip,
            },
        }

    def truth_text(self) -> str:
        return (
            f"rolls {self.truth()['distance']:.4g} m in {self.t_end:g} s (5/14 g sin θ t²), its contact point at rest"
        )

    def tolerance_text(self, tol: dict) -> str:
        return (
            f"distance within {tol.get('distance', 0):.0%}, slip ≤ {tol.get('slip')} m/s from t = {self.settle:g} s "
            "(the start's reported apart)"
        )


#: The contact scenes this module defines, registered with the engine scenes (``scenarios.ENGINE_SCENES``).
SCENES = (Edge, Corner, Tip, Roll)
