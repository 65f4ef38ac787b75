"""Semi-implicit Euler, velocity first, declared as its splitting (``reference.splitting``): kick h,
drift h; with its stability limit on the damped spring in closed form."""

import math

from .._scheme import EVERY_SCENE
from ..splitting import DRIFT, KICK, Splitting, splitting_scheme


def damping_limit(z):
    """det M = 1 - 2 zeta y, tr M = 2 - 2 zeta y - y^2 (Jury): 2 (sqrt(1 + zeta^2) - zeta). Explicit
    damping lowers the limit."""
    return 2.0 * (math.sqrt(1.0 + z * z) - z)


semi_implicit_euler = splitting_scheme(
    "semi_implicit_euler",
    Splitting((KICK, 1), (DRIFT, 1)),
    order=1,
    module=__name__,
    damping_limit=damping_limit,
    suites={"standard": EVERY_SCENE},
    doc="""\
Semi-implicit (symplectic) Euler, velocity first: the games default (MuJoCo Euler, Bullet).

        v_{n+1} = v_n + h a(x_n, v_n, t_n)
        x_{n+1} = x_n + h v_{n+1}

    First order, symplectic: the energy error stays in an O(h) band. Stable for h w <= 2.
    """,
)
