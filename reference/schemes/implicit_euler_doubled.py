from ..kinds import IMPLICIT
from .._scheme import Floor, largest_magnitude, scheme
from ..oscillator import unbounded
from .implicit_euler import NEWTON_RTOL
from .implicit_euler import amplification as implicit_euler_amplification


def floor(s, h, k, m):
    # Two implicit Euler steps of h/2, each one Newton iteration from w = v (exact on the linear spring).
    x, v = s
    half = 0.5 * h
    for _ in range(2):
        dw = (half * (-k * (x + half * v) / m)) / (1.0 + half * half * (k / m))
        w = v + dw
        x, v = x + half * w, w
    return (x, v)


def amplification(y, z):
    """Two implicit Euler steps of h/2."""
    half = implicit_euler_amplification(0.5 * y, z)
    return half @ half


@scheme(kind=IMPLICIT, order=1, force_evals=2, symplectic=False, energy_claim="decays", homega_max=float("inf"),
        floor=Floor(floor), amplification=amplification, damping_limit=unbounded,
        # Where the standard suite runs Drake's modes that it names (the spring, the damped spring and the
        # pendulum); the full suite runs it everywhere.
        suites={"standard": ("spring", "damped_spring", "pendulum")})
def implicit_euler_doubled(accel, solve, newton_max, state, t, h, p):
    """Implicit Euler by step doubling: two implicit Euler steps of h/2 (what Drake's implicit_euler
    and velocity_implicit_euler advance by at a fixed step h, their error estimate's half steps).

        x_{n+1/2} = x_n + h/2 v_{n+1/2},          v_{n+1/2} = v_n + h/2 a(x_{n+1/2}, v_{n+1/2}, t_n + h/2)
        x_{n+1} = x_{n+1/2} + h/2 v_{n+1},        v_{n+1} = v_{n+1/2} + h/2 a(x_{n+1}, v_{n+1}, t_n + h)

    Each half solved by Newton as ref:implicit_euler solves its step (one force evaluation and one
    solve per iteration, per half). First order, never explodes; a spring keeps a factor
    1/(1 + h^2 w^2/4)^2 of its energy per step.
    """
    q, v = state
    half = 0.5 * h
    for k in range(2):
        t_end = t + half if k == 0 else t + h
        w = v
        for _ in range(newton_max):
            q_new = q + half * w
            r = v + half * accel(q_new, w, t_end, p) - w
            dw = solve(q_new, w, t_end, p, half, half * half, r)
            w = w + dw
            if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(w)):
                break
        q, v = q + half * w, w
    return (q, v)
