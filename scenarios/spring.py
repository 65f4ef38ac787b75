"""The unit spring: a = -(k/m) x. The scene every integrator is first judged on."""

import math

import numpy as np

from .scene import Param, Scene, no_velocity_dependence


def accel(q, v, t, p):
    k, m = p[0], p[1]
    return (-k * q) / m


def solve(q, v, t, p, alpha, beta, r):
    # (1 + beta k/m) x = r: the spring's Jacobian is the constant -k/m.
    k, m = p[0], p[1]
    return r / (1.0 + beta * (k / m))


def constraints(p):
    """The spring as one 1-D distance constraint (``Scene.constraints``) from a wall anchor at
    0 to the mass, rest length 0, compliance 1/k: C = x, whose force -k C is the spring's."""
    ends = np.empty((1, 2), np.int64)
    ends[0, 0] = -1
    ends[0, 1] = 0
    rest = np.zeros(1)
    compliance = np.empty(1)
    compliance[0] = 1.0 / p[0]
    inv_mass = np.empty(1)
    inv_mass[0] = 1.0 / p[1]
    return ends, rest, compliance, inv_mass, np.zeros((1, 1)), np.zeros(1)


class Spring(Scene):
    id = "spring"
    title = "undamped harmonic oscillator, 1 DOF; exact x = x0 cos(wt) + (v0/w) sin(wt)"
    params = {
        "k": Param(1.0, "stiffness", lo=0.0, lo_open=True),
        "m": Param(1.0, "mass", lo=0.0, lo_open=True),
        "x0": Param(1.0, "initial position"),
        "v0": Param(0.0, "initial velocity"),
    }
    dof_names = ("x",)
    linear = True
    pointwise = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)
    damping_rate = staticmethod(no_velocity_dependence)
    constraints = staticmethod(constraints)

    def initial_state(self):
        return np.array([self.values["x0"]]), np.array([self.values["v0"]])

    @property
    def omega(self):
        return math.sqrt(self.values["k"] / self.values["m"])

    def energy(self, q, v):
        k, m = self.values["k"], self.values["m"]
        return 0.5 * m * v[..., 0] ** 2 + 0.5 * k * q[..., 0] ** 2

    def closed_form(self, t):
        t = np.asarray(t, dtype=float)
        w, x0, v0 = self.omega, self.values["x0"], self.values["v0"]
        x = x0 * np.cos(w * t) + (v0 / w) * np.sin(w * t)
        v = -x0 * w * np.sin(w * t) + v0 * np.cos(w * t)
        return x[:, None], v[:, None]
