"""Position-first semi-implicit Euler with the linear damping integrated exactly, as a decay
factor e^{-gamma h}: Chipmunk's two ways of damping. They apply to forces a(x, v) = a(x, 0) -
gamma v with one rate gamma (the scene's ``damping_rate``).

The standard suite runs them where the force depends on the velocity (the damped spring and the
projectile): elsewhere each is position-first semi-implicit Euler, bitwise. The full suite runs
them everywhere."""

import math

import numpy as np

from ..kinds import DECAY
from .._scheme import Floor, scheme
from ..oscillator import drift
from .semi_implicit_euler_position_first import semi_implicit_euler_position_first

STANDARD = {"standard": ("damped_spring", "projectile")}


def floor_after_kick(s, h, k, m):
    # The spring's damping rate is 0: the decay factor e^{-0 h} is 1.
    x, v = s
    x = x + h * v
    return (x, math.exp(-0.0 * h) * (v + h * (-k * x / m)))


def amplification_after_kick(y, z):
    e = math.exp(-2.0 * z * y)  # v_1 = e (v - y x_1), x_1 = x + y v
    return np.array([[1.0, 0.0], [-e * y, e]]) @ drift(y)


@scheme(
    kind=DECAY,
    order=1,
    force_evals=1,
    symplectic=False,
    energy_claim="bounded",
    homega_max=2.0,
    same_without_velocity=semi_implicit_euler_position_first,
    floor=Floor(floor_after_kick),
    amplification=amplification_after_kick,
    suites=STANDARD,
)
def position_first_euler_decay_after_kick(accel, rate, state, t, h, p):
    """Position-first Euler, then the whole new velocity decays (Chipmunk's DampedSpring):

        x_{n+1} = x_n + h v_n
        v_{n+1} = e^{-gamma h} (v_n + h a(x_{n+1}, 0, t_{n+1}))

    First order. The decay never destabilises: undamped it is position-first semi-implicit Euler.
    """
    q, v = state
    q = q + h * v
    return (q, math.exp(-rate(p) * h) * (v + h * accel(q, 0.0 * v, t + h, p)))


def floor_before_kick(s, h, k, m):
    x, v = s
    x = x + h * v
    return (x, math.exp(-0.0 * h) * v + h * (-k * x / m))


def amplification_before_kick(y, z):
    e = math.exp(-2.0 * z * y)  # v_1 = e v - y x_1
    return np.array([[1.0, y], [-y, e - y * y]])


@scheme(
    kind=DECAY,
    order=1,
    force_evals=1,
    symplectic=False,
    energy_claim="bounded",
    homega_max=2.0,
    same_without_velocity=semi_implicit_euler_position_first,
    floor=Floor(floor_before_kick),
    amplification=amplification_before_kick,
    suites=STANDARD,
)
def position_first_euler_decay_before_kick(accel, rate, state, t, h, p):
    """Position-first Euler whose old velocity decays before the kick (Chipmunk's space.damping,
    v = v damping^h + h a):

        x_{n+1} = x_n + h v_n
        v_{n+1} = e^{-gamma h} v_n + h a(x_{n+1}, 0, t_{n+1})

    First order; undamped it is position-first semi-implicit Euler.
    """
    q, v = state
    q = q + h * v
    return (q, math.exp(-rate(p) * h) * v + h * accel(q, 0.0 * v, t + h, p))
