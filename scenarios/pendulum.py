"""The simple pendulum at large amplitude: theta'' = -(g/L) sin(theta).

Exact solution (released from rest at theta0), with k = sin(theta0/2), w = sqrt(g/L),
u = K(k) - w t and Jacobi elliptic functions of parameter m = k^2:
    theta(t) = 2 arcsin(k sn(u)),   theta'(t) = -2 k w cn(u).
"""

import math

import numpy as np
from scipy.special import ellipj, ellipk

from .scene import Param, Scene, no_velocity_dependence


def accel(q, v, t, p):
    g, L = p[0], p[1]
    return -(g / L) * np.sin(q)


def solve(q, v, t, p, alpha, beta, r):
    g, L = p[0], p[1]
    return r / (1.0 + beta * (g / L) * np.cos(q))


class Pendulum(Scene):
    id = "pendulum"
    title = "simple pendulum, 1 DOF, nonlinear; exact solution via Jacobi elliptic functions"
    params = {
        "g": Param(9.81, "gravitational acceleration", lo=0.0, lo_open=True),
        "L": Param(1.0, "length", lo=0.0, lo_open=True),
        "m": Param(1.0, "bob mass (point mass)", lo=0.0, lo_open=True),
        "theta0": Param(
            2.0,
            "initial angle from the downward vertical [rad], released from rest",
            lo=-math.pi,
            hi=math.pi,
            lo_open=True,
            hi_open=True,
        ),
    }
    dof_names = ("theta",)
    pointwise = True
    accel = staticmethod(accel)
    solve = staticmethod(solve)
    damping_rate = staticmethod(no_velocity_dependence)

    def initial_state(self):
        return np.array([self.values["theta0"]]), np.array([0.0])

    @property
    def omega(self):
        # Small-amplitude frequency: the largest |d a/d theta| = g/L, so it bounds the stiffness.
        return math.sqrt(self.values["g"] / self.values["L"])

    @property
    def period(self):
        k = math.sin(self.values["theta0"] / 2.0)
        return 4.0 * float(ellipk(k * k)) / self.omega

    def energy(self, q, v):
        g, L, m = self.values["g"], self.values["L"], self.values["m"]
        return 0.5 * m * L * L * v[..., 0] ** 2 - m * g * L * np.cos(q[..., 0])

    def closed_form(self, t):
        t = np.asarray(t, dtype=float)
        k = math.sin(self.values["theta0"] / 2.0)
        w = self.omega
        sn, cn, _, _ = ellipj(float(ellipk(k * k)) - w * t, k * k)
        theta = 2.0 * np.arcsin(k * sn)
        return theta[:, None], (-2.0 * k * w * cn)[:, None]
