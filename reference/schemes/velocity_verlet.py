"""Velocity Verlet, declared as its splitting (``reference.splitting``): kick h/2, drift h, kick h/2,
the last kick's force carried to the next step's first (first same as last: one evaluation a step)."""

from ..splitting import DRIFT, KICK, Splitting, splitting_scheme

velocity_verlet = splitting_scheme(
    "velocity_verlet",
    Splitting((KICK, "1/2"), (DRIFT, 1), (KICK, "1/2"), fsal=True),
    order=2,
    module=__name__,
    # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
    # own (leapfrog, its limit, runs there); the solar system, where the issue names it against
    # REBOUND's modes; the full suite runs it everywhere.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system")},
    doc="""\
Velocity Verlet, kick-drift-kick:

        v_{n+1/2} = v_n + (h/2) a_n
        x_{n+1}   = x_n + h v_{n+1/2}
        v_{n+1}   = v_{n+1/2} + (h/2) a(x_{n+1})

    Second order, symplectic, stable for h w <= 2. Carries a_n, so one evaluation a step.
    A velocity-dependent force is taken at v_{n+1/2}, not v_{n+1}, without a solve: first order there.
    """,
)
