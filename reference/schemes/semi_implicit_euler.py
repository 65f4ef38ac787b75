import math

from .._scheme import EVERY_SCENE, Floor, scheme
from ..oscillator import drift, kick


def floor(s, h, k, m):
    x, v = s
    v = v + h * (-k * x / m)
    return (x + h * v, v)


def amplification(y, z):
    """Kick, then drift with the new velocity."""
    return drift(y) @ kick(y, z)


def damping_limit(z):
    """det M = 1 - 2 zeta y, tr M = 2 - 2 zeta y - y^2 (Jury): 2 (sqrt(1 + zeta^2) - zeta). Explicit
    damping lowers the limit."""
    return 2.0 * (math.sqrt(1.0 + z * z) - z)


@scheme(order=1, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0,
        floor=Floor(floor), amplification=amplification, damping_limit=damping_limit,
        suites={"standard": EVERY_SCENE})
def semi_implicit_euler(accel, state, t, h, p):
    """Semi-implicit (symplectic) Euler, velocity first: the games default (MuJoCo Euler, Bullet).

        v_{n+1} = v_n + h a(x_n, v_n, t_n)
        x_{n+1} = x_n + h v_{n+1}

    First order, symplectic: the energy error stays in an O(h) band. Stable for h w <= 2.
    """
    q, v = state
    a = accel(q, v, t, p)
    v = v + h * a
    return (q + h * v, v)
