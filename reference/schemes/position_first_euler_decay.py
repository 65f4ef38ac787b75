"""Position-first semi-implicit Euler with the linear damping integrated exactly, as a decay
factor e^{-gamma h}: Chipmunk's two ways of damping. They apply to forces a(x, v) = a(x, 0) -
gamma v with one rate gamma (the scene's ``damping_rate``)."""
import math

from ..kinds import DECAY
from .._scheme import scheme


@scheme(kind=DECAY, order=1, force_evals=1, symplectic=False, energy_claim="bounded", homega_max=2.0,
        same_without_velocity="semi_implicit_euler_position_first")
def position_first_euler_decay_after_kick(accel, rate, state, t, h, p):
    """Position-first Euler, then the whole new velocity decays (Chipmunk's DampedSpring):

        x_{n+1} = x_n + h v_n
        v_{n+1} = e^{-gamma h} (v_n + h a(x_{n+1}, 0, t_{n+1}))

    First order. The decay never destabilises: undamped it is position-first semi-implicit Euler.
    """
    q, v = state
    q = q + h * v
    return (q, math.exp(-rate(p) * h) * (v + h * accel(q, 0.0 * v, t + h, p)))


@scheme(kind=DECAY, order=1, force_evals=1, symplectic=False, energy_claim="bounded", homega_max=2.0,
        same_without_velocity="semi_implicit_euler_position_first")
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
