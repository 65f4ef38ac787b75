from .._scheme import EVERY_SCENE, Floor, scheme
from ..oscillator import drift, kick


def floor(s, h, k, m):
    x, v = s
    x = x + 0.5 * h * v
    v = v + h * (-k * x / m)
    return (x + 0.5 * h * v, v)


def amplification(y, z):
    return drift(0.5 * y) @ kick(y, z) @ drift(0.5 * y)


@scheme(order=2, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0,
        order_velocity_dependent=1, floor=Floor(floor), amplification=amplification,
        suites={"standard": EVERY_SCENE})
def leapfrog(accel, state, t, h, p):
    """Leapfrog, drift-kick-drift (the form REBOUND's ``leapfrog`` integrates):

        x_{n+1/2} = x_n + (h/2) v_n
        v_{n+1}   = v_n + h a(x_{n+1/2})
        x_{n+1}   = x_{n+1/2} + (h/2) v_{n+1}

    Second order, symplectic, stable for h w <= 2. A velocity-dependent force is kicked with
    a(x_{n+1/2}, v_n), not the midpoint velocity, and nothing solves for it: first order there.
    """
    q, v = state
    half = 0.5 * h
    q = q + half * v
    v = v + h * accel(q, v, t + half, p)
    return (q + half * v, v)
