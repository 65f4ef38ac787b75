import math

import numpy as np

from ..kinds import IMPLICIT
from .._scheme import Floor, largest_magnitude, scheme
from ..oscillator import drift
from .semi_implicit_euler import semi_implicit_euler

#: Newton stops when the update is below this, relative to the iterate (as implicit Euler's).
NEWTON_RTOL = 1e-13


def floor(s, h, k, m):
    # The spring's force does not depend on v: the implicit velocity solve divides by 1, and
    # the step is semi-implicit Euler's.
    x, v = s
    v = v + h * (-k * x / m)
    return (x + h * v, v)


def amplification(y, z):
    d = 1.0 + 2.0 * z * y  # (1 + 2 zeta y) v_1 = v - y x
    return drift(y) @ np.array([[1.0, 0.0], [-y / d, 1.0 / d]])


def damping_limit(z):
    """det M = 1/(1 + 2 zeta y) (Jury): 2 (sqrt(1 + zeta^2) + zeta). Implicit damping raises the limit."""
    return 2.0 * (math.sqrt(1.0 + z * z) + z)


@scheme(
    kind=IMPLICIT,
    order=1,
    force_evals=1,
    symplectic=True,
    energy_claim="bounded",
    homega_max=2.0,
    same_without_velocity=semi_implicit_euler,
    floor=Floor(floor),
    amplification=amplification,
    damping_limit=damping_limit,
    # Where the force depends on the velocity (the damped spring, the projectile), and the chain, where
    # the standard suite has run it since it first ran these schemes (undamped, it is semi-implicit Euler
    # there, bitwise). The full suite runs it everywhere.
    suites={"standard": ("damped_spring", "projectile", "chain")},
)
def semi_implicit_euler_velocity_implicit(accel, solve, newton_max, state, t, h, p):
    """Semi-implicit Euler, implicit in the velocity only: MuJoCo's Euler (eulerdamp), implicit
    and implicitfast with joint damping.

        v_{n+1} = v_n + h a(x_n, v_{n+1}, t_n)
        x_{n+1} = x_n + h v_{n+1}

    Newton on w = v_{n+1} from w = v_n with the scene's solve of (I - h da/dv) dw = r: the first
    residual is h a(x_n, v_n), so on a(x, v) = (-k x - c v)/m one iteration gives
    v += h(-k x - c v)/(m + h c). Without velocity dependence it is semi-implicit Euler, bitwise.
    First order; damping makes it stable to h w <= 2(zeta + sqrt(1 + zeta^2)).
    """
    q, v = state
    w = v
    r = h * accel(q, v, t, p)
    for i in range(newton_max):
        if i > 0:
            r = v + h * accel(q, w, t, p) - w
        dw = solve(q, w, t, p, h, 0.0, r)
        w = w + dw
        if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(w)):
            break
    return (q + h * w, w)
