from ..kinds import IMPLICIT
from .._scheme import largest_magnitude, scheme

#: Newton stops when the update is below this, relative to the iterate.
NEWTON_RTOL = 1e-13


@scheme(kind=IMPLICIT, order=1, force_evals=1, symplectic=False, energy_claim="decays", homega_max=float("inf"))
def implicit_euler(accel, solve, newton_max, state, t, h, p):
    """Implicit (backward) Euler: both updates from the new state.

        x_{n+1} = x_n + h v_{n+1}
        v_{n+1} = v_n + h a(x_{n+1}, v_{n+1}, t_{n+1})

    Solved for w = v_{n+1} by Newton from w = v_n with the scene's solve of
    (I - h da/dv - h^2 da/dx) dw = v_n + h a(x_n + h w, w) - w: one force evaluation and
    one solve per iteration; one iteration is exact for linear forces. First order,
    never explodes, damps everything (a spring loses a factor 1/(1 + h^2 w^2) per step).
    """
    q, v = state
    w = v
    for _ in range(newton_max):
        q_new = q + h * w
        r = v + h * accel(q_new, w, t + h, p) - w
        dw = solve(q_new, w, t + h, p, h, h * h, r)
        w = w + dw
        if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(w)):
            break
    return (q + h * w, w)
