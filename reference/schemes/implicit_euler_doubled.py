from ..kinds import IMPLICIT
from .._scheme import largest_magnitude, scheme
from .implicit_euler import NEWTON_RTOL


@scheme(kind=IMPLICIT, order=1, force_evals=2, symplectic=False, energy_claim="decays", homega_max=float("inf"))
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
