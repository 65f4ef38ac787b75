"""A ball on a penalty ground, 1 DOF: x the height of the ball's lowest point, gravity g, and below
x = 0 a spring-dashpot of frequency omega_c and damping ratio zeta (per unit mass):

    a = -g                                  where x >= 0
    a = -g - omega_c^2 x - 2 zeta omega_c v where x < 0

The contact a penalty method gives an engine, as the reference schemes see it: the seed's "lively
bounces go dead" as a number (``harness.contact.penalty``). With gravity neglected inside the
contact a bounce restores the fraction e = exp(-pi zeta / sqrt(1 - zeta^2)) of the speed (1 where
zeta = 0); the scene's closed form keeps gravity there too, flight and contact each solved exactly
and joined where x = 0 (found to roundoff), so that every apex of the true motion is known.
The defaults make gravity's share small: g / (omega_c v_impact) = 2.2e-3.

Energy per unit mass: v^2/2 + g x, plus omega_c^2 x^2 / 2 in contact; conserved where zeta = 0.
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Param, Scene
from ._oscillator import damped_oscillator


def accel(q, v, t, p):
    g, w, z = p[0], p[1], p[2]
    inside = (q < 0.0) * 1.0
    return -g - inside * (w * w * q + 2.0 * z * w * v)


def solve(q, v, t, p, alpha, beta, r):
    w, z = p[1], p[2]
    inside = (q < 0.0) * 1.0
    return r / (1.0 + inside * (alpha * 2.0 * z * w + beta * w * w))


def zeta_for(e: float) -> float:
    """The damping ratio whose spring-dashpot restores the fraction e of the speed (gravity
    neglected in the contact); 1, critical damping, where e = 0 (no rebound)."""
    if e >= 1.0:
        return 0.0
    if e <= 0.0:
        return 1.0
    lg = math.log(e)
    return -lg / math.sqrt(math.pi**2 + lg * lg)


def restitution_of(zeta: float) -> float:
    """e = exp(-pi zeta / sqrt(1 - zeta^2)); 0 from critical damping on (no rebound)."""
    if zeta >= 1.0:
        return 0.0
    return math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta))


class PenaltyBall(Scene):
    id = "penalty_ball"
    title = "ball on a penalty (spring-dashpot) ground, 1 DOF; exact piecewise solution with every apex"
    params = {
        "g": Param(9.81, "gravity (m/s^2)", lo=0.0, lo_open=True),
        "omega_c": Param(1000.0, "the ground's natural frequency omega_c (rad/s)", lo=0.0, lo_open=True),
        "zeta": Param(0.0, "the ground's damping ratio (< 1: the ball rebounds)", lo=0.0, hi=1.0, hi_open=True),
        "h0": Param(1.0, "drop height (m)", lo=0.0, lo_open=True),
    }
    dof_names = ("x",)
    pointwise = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)

    @property
    def e(self) -> float:
        """The restitution a bounce would have with gravity neglected inside the contact."""
        return restitution_of(self.values["zeta"])

    def initial_state(self):
        return np.array([self.values["h0"]]), np.array([0.0])

    @property
    def omega(self):
        return self.values["omega_c"]

    def energy(self, q, v):
        g, w = self.values["g"], self.values["omega_c"]
        x = q[..., 0]
        return 0.5 * v[..., 0] ** 2 + g * x + 0.5 * w * w * x * x * (x < 0.0)

    def _phases(self, t_end: float):
        """The true motion's phases up to t_end: (start, kind, x0, v0, end) with kind "flight" or
        "contact", each solved exactly from its start."""
        g, w, z = self.values["g"], self.values["omega_c"], self.values["zeta"]
        eq = g / (w * w)  # the contact's equilibrium, below the ground
        t, x, v = 0.0, self.values["h0"], 0.0
        phases = []
        while t < t_end and len(phases) < 10_000:
            # Flight from (x >= 0, v) to the ground.
            hit = (v + math.sqrt(v * v + 2.0 * g * x)) / g
            phases.append((t, "flight", x, v, t + hit))
            t, v = t + hit, v - g * hit
            if t >= t_end:
                break

            # Contact from x = 0, speed v < 0: y = x + eq oscillates about 0 from y = eq.
            def x_at(s, v=v):
                y, _ = damped_oscillator(np.array([s]), w, z, eq, v)
                return float(y[0]) - eq

            period = 2.0 * math.pi / (w * math.sqrt(max(1.0 - z * z, 1e-12)))
            lowest = min((s for s in np.linspace(0.0, period, 65)[1:]), key=x_at)
            grid = np.linspace(lowest, period, 129)
            vals = [x_at(s) for s in grid]
            k = next((i for i in range(1, len(grid)) if vals[i] >= 0.0), None)
            if k is None:  # it comes to rest in the contact
                phases.append((t, "contact", 0.0, v, math.inf))
                break
            from scipy.optimize import brentq  # here: only the truth of a bounce needs it, and it is a large import

            out = brentq(x_at, grid[k - 1], grid[k], xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)
            phases.append((t, "contact", 0.0, v, t + out))
            _, vo = damped_oscillator(np.array([out]), w, z, eq, v)
            t, x, v = t + out, 0.0, float(vo[0])
        return phases

    def closed_form(self, t):
        t = np.asarray(t, dtype=float)
        g, w, z = self.values["g"], self.values["omega_c"], self.values["zeta"]
        eq = g / (w * w)
        x = np.empty_like(t)
        v = np.empty_like(t)
        for start, kind, x0, v0, end in self._phases(float(np.max(t)) if t.size else 0.0):
            sel = (t >= start) & (t <= end) if math.isfinite(end) else t >= start
            s = t[sel] - start
            if kind == "flight":
                x[sel], v[sel] = x0 + v0 * s - 0.5 * g * s * s, v0 - g * s
            else:
                y, vy = damped_oscillator(s, w, z, eq, v0)
                x[sel], v[sel] = y - eq, vy
        return x[:, None], v[:, None]

    def apexes(self, n: int) -> list[float]:
        """The true motion's first n + 1 apexes (the drop height, then after each bounce)."""
        out = [self.values["h0"]]
        g = self.values["g"]
        t_end = 0.0
        while True:
            t_end = 2.0 * t_end + 10.0
            exits = [p for p in self._phases(t_end) if p[1] == "flight"][1:]
            if len(exits) >= n or t_end > 1e6:
                break
        out += [p[3] ** 2 / (2.0 * g) for p in exits[:n]]
        return out
