from ..kinds import IMPLICIT
from .._scheme import Floor, scheme
from ..oscillator import unbounded
from .implicit_euler import amplification as implicit_euler_amplification


def floor(s, h, k, m):
    # One solve of (1 + h^2 k/m) v_{n+1} = v_n + h a(x_n, 0).
    x, v = s
    w = (v + h * (-k * x / m)) / (1.0 + h * h * (k / m))
    return (x + h * w, w)


@scheme(
    kind=IMPLICIT,
    order=1,
    force_evals=1,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    floor=Floor(floor),
    # On a linear scene the step is backward Euler's (tests/test_cloth.py): so is its recurrence.
    amplification=implicit_euler_amplification,
    damping_limit=unbounded,
    # Not the solar system, where the issue names the schemes it runs against REBOUND's modes.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth")},
)
def linearly_implicit_euler(accel, solve, newton_max, state, t, h, p):
    """Linearly implicit backward Euler (Baraff and Witkin's cloth step): backward Euler with the
    force linearised at the start of the step, so one linear solve and no iteration.

        (I - h da/dv - h^2 da/dx) v_{n+1} = v_n + h a(x_n, 0, t_n)    (Jacobians at x_n, v_n)
        x_{n+1} = x_n + h v_{n+1}

    which is their dv = (I - h da/dv - h^2 da/dx)^-1 h (a(x_n, v_n) + h da/dx v_n) for a force
    affine in the velocity (a(x_n, v_n) - da/dv v_n = a(x_n, 0)). On a linear scene it is backward
    Euler exactly, to roundoff (the same solve, its right-hand side summed in another order).
    First order; one force evaluation and one solve a step whatever the scene (``newton_max``
    unused); never explodes on a linear scene, damps everything.
    """
    q, v = state
    # v - v: the zero velocity (not 0.0 * v, which is -0.0 where v < 0), on arrays and floats alike.
    w = solve(q, v, t, p, h, h * h, v + h * accel(q, v - v, t, p))
    return (q + h * w, w)
