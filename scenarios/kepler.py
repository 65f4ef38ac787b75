"""Planar Kepler problem (two bodies, reduced to one): a = -GM q/|q|^3, semi-major axis 1.

Starts at perihelion q = (1-e, 0), v = (0, sqrt(GM (1+e)/(1-e))). Exact solution from
Kepler's equation M = E - e sin E (Newton, to roundoff):
    x = cos E - e,  y = sqrt(1-e^2) sin E,  v = n/(1 - e cos E) (-sin E, sqrt(1-e^2) cos E).
"""

import math

import numpy as np

from .scene import Param, Scene, no_velocity_dependence


def accel(q, v, t, p):
    gm = p[0]
    dx, dy = q[0], q[1]
    # Spelled as REBOUND's gravity="basic" spells it, so a leapfrog matches bitwise.
    r = np.sqrt(dx * dx + dy * dy)
    pre = gm / (r * r * r)
    a = np.empty_like(q)
    a[0] = -pre * dx
    a[1] = -pre * dy
    return a


def solve(q, v, t, p, alpha, beta, r):
    # (I - beta J) x = r with J = -GM (I/r^3 - 3 q q^T / r^5), a 2x2 per batch member.
    gm = p[0]
    dx, dy = q[0], q[1]
    r2 = dx * dx + dy * dy
    r3 = r2 * np.sqrt(r2)
    s = beta * gm / r3
    a11 = 1.0 + s * (1.0 - 3.0 * dx * dx / r2)
    a22 = 1.0 + s * (1.0 - 3.0 * dy * dy / r2)
    a12 = -s * 3.0 * dx * dy / r2
    det = a11 * a22 - a12 * a12
    x = np.empty_like(r)
    x[0] = (a22 * r[0] - a12 * r[1]) / det
    x[1] = (a11 * r[1] - a12 * r[0]) / det
    return x


class Kepler(Scene):
    id = "kepler"
    title = "planar two-body orbit, 2 DOF, semi-major axis 1; exact solution via Kepler's equation"
    params = {
        "GM": Param(1.0, "gravitational parameter", lo=0.0, lo_open=True),
        "e": Param(0.5, "eccentricity", lo=0.0, hi=1.0, hi_open=True),
    }
    dof_names = ("x", "y")
    accel = staticmethod(accel)
    solve = staticmethod(solve)
    damping_rate = staticmethod(no_velocity_dependence)

    def initial_state(self):
        gm, e = self.values["GM"], self.values["e"]
        return np.array([1.0 - e, 0.0]), np.array([0.0, math.sqrt(gm * (1.0 + e) / (1.0 - e))])

    @property
    def omega(self):
        # Mean motion n = sqrt(GM/a^3) with a = 1: one orbit is 2 pi / n.
        return math.sqrt(self.values["GM"])

    @property
    def length_scale(self) -> float:
        """The orbit's semi-major axis, a = 1."""
        return 1.0

    def energy(self, q, v):
        gm = self.values["GM"]
        r = np.sqrt(q[..., 0] ** 2 + q[..., 1] ** 2)
        return 0.5 * (v[..., 0] ** 2 + v[..., 1] ** 2) - gm / r

    def events(self, step, t, q, v):
        """A close approach (r below half the perihelion 1 - e: the orbit spiralled in) and an
        ejection (the two-body energy v^2/2 - GM/r no longer negative: unbound), at the first
        recorded state each happens."""
        gm, e = self.values["GM"], self.values["e"]
        with np.errstate(all="ignore"):
            r = np.sqrt(q[:, 0] ** 2 + q[:, 1] ** 2)
            energy = 0.5 * (v[:, 0] ** 2 + v[:, 1] ** 2) - gm / r
        out = []
        perihelion = 1.0 - e
        close = np.flatnonzero(r < 0.5 * perihelion)
        if close.size:
            i = int(close[0] + np.argmin(r[close[0] :]))  # the closest it came from then on
            out.append(
                {
                    "kind": "close approach",
                    "step": int(step[i]),
                    "t": float(t[i]),
                    "r": float(r[i]),
                    "text": f"spiralled in to r = {r[i]:.3g} (perihelion {perihelion:g}) by step {int(step[i])}",
                }
            )
        unbound = np.flatnonzero(~(energy < 0.0))
        if unbound.size:
            i = int(unbound[0])
            out.append(
                {
                    "kind": "ejected",
                    "step": int(step[i]),
                    "t": float(t[i]),
                    "r": float(r[i]),
                    "text": f"ejected (unbound: v²/2 - GM/r >= 0) by step {int(step[i])}, at r = {r[i]:.3g}",
                }
            )
        return sorted(out, key=lambda ev: ev["step"])

    def closed_form(self, t):
        t = np.asarray(t, dtype=float)
        e, n = self.values["e"], self.omega
        M = np.mod(n * t, 2.0 * math.pi)
        E = M + e * np.sin(M) if e < 0.8 else np.full_like(M, math.pi)
        for _ in range(100):
            dE = (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
            E = E - dE
            if np.max(np.abs(dE), initial=0.0) < 1e-15:
                break
        c, s, b = np.cos(E), np.sin(E), math.sqrt(1.0 - e * e)
        q = np.stack([c - e, b * s], axis=-1)
        f = n / (1.0 - e * c)
        v = np.stack([-f * s, f * b * c], axis=-1)
        return q, v
