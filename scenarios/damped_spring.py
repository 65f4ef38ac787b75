"""Spring with linear damping: a = -(k x + c v)/m, any damping ratio zeta = c / (2 sqrt(k m)) >= 0
(underdamped, critical and overdamped); the exact solution and its decaying energy in closed form."""

import math

import numpy as np

from .scene import DampedByC, Param, Scene
from ._oscillator import damped_oscillator


def accel(q, v, t, p):
    k, m, c = p[0], p[1], p[2]
    return (-k * q - c * v) / m


def solve(q, v, t, p, alpha, beta, r):
    k, m, c = p[0], p[1], p[2]
    return r / (1.0 + alpha * (c / m) + beta * (k / m))


class DampedSpring(DampedByC, Scene):
    id = "damped_spring"
    title = "damped oscillator (any damping ratio), 1 DOF; exact solution and exact decaying energy"
    params = {
        "k": Param(1.0, "stiffness", lo=0.0, lo_open=True),
        "m": Param(1.0, "mass", lo=0.0, lo_open=True),
        "c": Param(0.1, "damping coefficient; damping ratio zeta = c / (2 sqrt(k m)), 1 = critical", lo=0.0),
        "x0": Param(1.0, "initial position"),
        "v0": Param(0.0, "initial velocity"),
    }
    dof_names = ("x",)
    linear = True
    pointwise = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)

    @staticmethod
    def damping_rate(p):
        """gamma = c/m: a(x, v) = a(x, 0) - gamma v (what exponential-damping schemes read)."""
        return p[2] / p[1]

    @property
    def zeta(self) -> float:
        """Damping ratio c / (2 sqrt(k m)): < 1 underdamped, 1 critical, > 1 overdamped."""
        k, m, c = self.values["k"], self.values["m"], self.values["c"]
        return c / (2.0 * math.sqrt(k * m))

    @classmethod
    def c_for_zeta(cls, zeta: float, k: float = 1.0, m: float = 1.0) -> float:
        return 2.0 * zeta * math.sqrt(k * m)

    def initial_state(self):
        return np.array([self.values["x0"]]), np.array([self.values["v0"]])

    @property
    def omega(self):
        return math.sqrt(self.values["k"] / self.values["m"])

    def energy(self, q, v):
        k, m = self.values["k"], self.values["m"]
        return 0.5 * m * v[..., 0] ** 2 + 0.5 * k * q[..., 0] ** 2

    def closed_form(self, t):
        k, m, c = self.values["k"], self.values["m"], self.values["c"]
        x0, v0 = self.values["x0"], self.values["v0"]
        if c < 2.0 * math.sqrt(k * m):
            # Underdamped, in the form (and the rounding) used before the other regimes existed:
            # every stored accuracy number on the default scene rests on it.
            t = np.asarray(t, dtype=float)
            gamma = c / (2.0 * m)
            wd = math.sqrt(k / m - gamma * gamma)
            b = (v0 + gamma * x0) / wd
            decay, cos, sin = np.exp(-gamma * t), np.cos(wd * t), np.sin(wd * t)
            x = decay * (x0 * cos + b * sin)
            v = decay * ((b * wd - gamma * x0) * cos - (x0 * wd + gamma * b) * sin)
        else:
            x, v = damped_oscillator(t, self.omega, self.zeta, x0, v0)
        return x[:, None], v[:, None]

    def exact_energy(self, t):
        q, v = self.closed_form(t)
        return self.energy(q, v)
