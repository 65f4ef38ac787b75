"""Semi-implicit Euler, position first, declared as its splitting (``reference.splitting``): drift h,
kick h."""

from ..splitting import DRIFT, KICK, Splitting, splitting_scheme
from .semi_implicit_euler import damping_limit

semi_implicit_euler_position_first = splitting_scheme(
    "semi_implicit_euler_position_first",
    Splitting((DRIFT, 1), (KICK, 1)),
    order=1,
    module=__name__,
    damping_limit=damping_limit,  # the velocity-first form's characteristic polynomial
    # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
    # own (the velocity-first form runs there), nor the solar system (the schemes the issue names
    # against REBOUND's modes run there); the full suite runs it everywhere.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile")},
    doc="""\
Semi-implicit (symplectic) Euler, position first: what Chipmunk / pymunk integrates.

        x_{n+1} = x_n + h v_n
        v_{n+1} = v_n + h a(x_{n+1}, v_n, t_{n+1})

    First order, symplectic (the adjoint of the velocity-first form). Stable for h w <= 2.
    """,
)
