"""Implicit Euler by step doubling: ref:implicit_euler substepped twice (``reference.substepped``)."""

from ..substepped import substepped
from .implicit_euler import implicit_euler

implicit_euler_doubled = substepped(
    implicit_euler,
    2,
    id="implicit_euler_doubled",
    module=__name__,
    # Where the standard suite runs Drake's modes that it names (the spring, the damped spring and the
    # pendulum); the full suite runs it everywhere.
    suites={"standard": ("spring", "damped_spring", "pendulum")},
    doc="""\
Implicit Euler by step doubling: two implicit Euler steps of h/2 (what Drake's implicit_euler
    and velocity_implicit_euler advance by at a fixed step h, their error estimate's half steps).

        x_{n+1/2} = x_n + h/2 v_{n+1/2},          v_{n+1/2} = v_n + h/2 a(x_{n+1/2}, v_{n+1/2}, t_n + h/2)
        x_{n+1} = x_{n+1/2} + h/2 v_{n+1},        v_{n+1} = v_{n+1/2} + h/2 a(x_{n+1}, v_{n+1}, t_n + h)

    Each half solved by Newton as ref:implicit_euler solves its step (one force evaluation and one
    solve per iteration, per half). First order, never explodes; a spring keeps a factor
    1/(1 + h^2 w^2/4)^2 of its energy per step.
    """,
)
