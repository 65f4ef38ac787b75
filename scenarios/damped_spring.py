"""Spring with linear damping: a = -(k x + c v)/m, underdamped; the exact energy decays."""
import math

import numpy as np

from ._base import InvalidInput, Param, Scene


def accel(q, v, t, p):
    k, m, c = p[0], p[1], p[2]
    return (-k * q - c * v) / m


def solve(q, v, t, p, alpha, beta, r):
    k, m, c = p[0], p[1], p[2]
    return r / (1.0 + alpha * (c / m) + beta * (k / m))


class DampedSpring(Scene):
    id = "damped_spring"
    title = "underdamped oscillator, 1 DOF; exact solution and exact decaying energy"
    params = {
        "k": Param(1.0, "stiffness", lo=0.0, lo_open=True),
        "m": Param(1.0, "mass", lo=0.0, lo_open=True),
        "c": Param(0.1, "damping coefficient (underdamped: c < 2 sqrt(k m))", lo=0.0),
        "x0": Param(1.0, "initial position"),
        "v0": Param(0.0, "initial velocity"),
    }
    dof_names = ("x",)
    linear = True
    pointwise = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)

    def _validate(self):
        k, m, c = self.values["k"], self.values["m"], self.values["c"]
        if c >= 2.0 * math.sqrt(k * m):
            raise InvalidInput(f"parameter c={c:g} is out of range (allowed: [0, 2*sqrt(k*m)) = "
                               f"[0, {2.0 * math.sqrt(k * m):g}), the underdamped range)")

    @property
    def conservative(self):
        return self.values["c"] == 0.0

    def initial_state(self):
        return np.array([self.values["x0"]]), np.array([self.values["v0"]])

    @property
    def omega(self):
        return math.sqrt(self.values["k"] / self.values["m"])

    def energy(self, q, v):
        k, m = self.values["k"], self.values["m"]
        return 0.5 * m * v[..., 0] ** 2 + 0.5 * k * q[..., 0] ** 2

    def exact(self, t):
        t = np.asarray(t, dtype=float)
        k, m, c = self.values["k"], self.values["m"], self.values["c"]
        x0, v0 = self.values["x0"], self.values["v0"]
        gamma = c / (2.0 * m)
        wd = math.sqrt(k / m - gamma * gamma)
        b = (v0 + gamma * x0) / wd
        decay, cos, sin = np.exp(-gamma * t), np.cos(wd * t), np.sin(wd * t)
        x = decay * (x0 * cos + b * sin)
        v = decay * ((b * wd - gamma * x0) * cos - (x0 * wd + gamma * b) * sin)
        return x[:, None], v[:, None]

    def exact_energy(self, t):
        q, v = self.exact(t)
        return self.energy(q, v)
