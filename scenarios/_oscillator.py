"""The damped linear oscillator x'' + 2 zeta w x' + w^2 x = 0 in closed form, for every
damping ratio zeta >= 0 (shared by the damped spring and the damped chain's normal modes).

With gamma = zeta w (the decay rate):

* underdamped (zeta < 1), w_d = w sqrt(1 - zeta^2), b = (v0 + gamma x0)/w_d:
      x = e^{-gamma t} (x0 cos w_d t + b sin w_d t)
* critical and overdamped (zeta >= 1), s = w sqrt(zeta^2 - 1) (0 at critical):
      x = e^{-gamma t} (x0 cosh s t + a sinh(s t)/s),  a = v0 + gamma x0
      v = a e^{-gamma t} cosh s t + x0 s^2 e^{-gamma t} sinh(s t)/s - gamma x
  with e^{-gamma t} cosh s t as the mean of the two decaying exponentials e^{(-gamma +- s) t},
  and e^{-gamma t} sinh(s t)/s as their half difference over s where s t >= 1, as
  e^{-gamma t} sinh(s t)/s below (no cancellation near critical damping; t e^{-w t} at s = 0).
"""

from __future__ import annotations

import math

import numpy as np


def damped_oscillator(t, w: float, zeta: float, x0, v0) -> tuple[np.ndarray, np.ndarray]:
    """(x(t), v(t)) of one oscillator; ``t`` an array, ``x0``/``v0`` scalars or arrays that
    broadcast against it (the chain passes one column per mode)."""
    t = np.asarray(t, dtype=float)
    gamma = zeta * w
    if zeta < 1.0:
        wd = w * math.sqrt(1.0 - zeta * zeta)
        b = (v0 + gamma * x0) / wd
        decay, cos, sin = np.exp(-gamma * t), np.cos(wd * t), np.sin(wd * t)
        x = decay * (x0 * cos + b * sin)
        v = decay * ((b * wd - gamma * x0) * cos - (x0 * wd + gamma * b) * sin)
        return x, v
    a = v0 + gamma * x0
    decay = np.exp(-gamma * t)
    s = w * math.sqrt(zeta * zeta - 1.0)
    if s == 0.0:
        ch, shs = decay, t * decay
    else:
        e1, e2 = np.exp((s - gamma) * t), np.exp(-(s + gamma) * t)
        ch = 0.5 * (e1 + e2)
        with np.errstate(over="ignore", invalid="ignore"):
            near = decay * np.sinh(s * t) / s
        shs = np.where(s * t < 1.0, near, (e1 - e2) / (2.0 * s))
    x = x0 * ch + a * shs
    v = a * ch + (x0 * s * s) * shs - gamma * x
    return x, v
