"""A projectile under gravity with linear air drag: a = -(c/m) v - g e_y, 2 DOF (x, y).

Exact, with gamma = c/m and terminal velocity v_inf = (0, -g/gamma):
    v(t) = v_inf + (v0 - v_inf) e^(-gamma t),  q(t) = v_inf t + (v0 - v_inf)(1 - e^(-gamma t))/gamma.
"""

import math

import numpy as np

from .scene import DampedByC, Param, Scene


def accel(q, v, t, p):
    g, m, c = p[0], p[1], p[2]
    a = (-c * v) / m
    a[1] = a[1] - g
    return a


def solve(q, v, t, p, alpha, beta, r):
    # Only the drag depends on the state: da/dv = -(c/m) I, da/dq = 0.
    m, c = p[1], p[2]
    return r / (1.0 + alpha * (c / m))


class Projectile(DampedByC, Scene):
    id = "projectile"
    title = "point mass under gravity and linear drag, 2 DOF; exact solution in closed form"
    params = {
        "g": Param(9.81, "gravitational acceleration", lo=0.0),
        "m": Param(1.0, "mass", lo=0.0, lo_open=True),
        "c": Param(0.1, "linear drag coefficient", lo=0.0),
        "speed": Param(10.0, "launch speed", lo=0.0),
        "angle": Param(45.0, "launch angle above the horizontal [deg]", lo=-90.0, hi=90.0),
    }
    dof_names = ("x", "y")
    linear = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)

    @staticmethod
    def damping_rate(p):
        """gamma = c/m: a(x, v) = a(x, 0) - gamma v (what exponential-damping schemes read)."""
        return p[2] / p[1]

    def initial_state(self):
        a = math.radians(self.values["angle"])
        s = self.values["speed"]
        return np.zeros(2), np.array([s * math.cos(a), s * math.sin(a)])

    @property
    def omega(self):
        # The only stiffness is the drag rate c/m; without drag, the inverse rise time g/speed.
        gamma = self.values["c"] / self.values["m"]
        if gamma > 0:
            return gamma
        return self.values["g"] / max(self.values["speed"], 1.0)

    def energy(self, q, v):
        g, m = self.values["g"], self.values["m"]
        return 0.5 * m * (v[..., 0] ** 2 + v[..., 1] ** 2) + m * g * q[..., 1]

    def closed_form(self, t):
        t = np.asarray(t, dtype=float)[:, None]
        g, m, c = self.values["g"], self.values["m"], self.values["c"]
        _, v0 = self.initial_state()
        gamma = c / m
        if gamma == 0.0:
            acc = np.array([0.0, -g])
            return v0 * t + 0.5 * acc * t * t, v0 + acc * t
        vinf = np.array([0.0, -g / gamma])
        decay = np.exp(-gamma * t)
        v = vinf + (v0 - vinf) * decay
        q = vinf * t + (v0 - vinf) * (-np.expm1(-gamma * t)) / gamma
        return q, v

    def exact_energy(self, t):
        q, v = self.closed_form(t)
        return self.energy(q, v)
