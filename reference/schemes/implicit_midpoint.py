from ..kinds import IMPLICIT
from .._scheme import largest_magnitude, scheme
from .implicit_euler import NEWTON_RTOL


@scheme(kind=IMPLICIT, order=2, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=float("inf"))
def implicit_midpoint(accel, solve, newton_max, state, t, h, p):
    """Implicit midpoint rule: the update uses the average of old and new state.

        x_{n+1} = x_n + h (v_n + v_{n+1})/2
        v_{n+1} = v_n + h a((x_n + x_{n+1})/2, (v_n + v_{n+1})/2, t_n + h/2)

    Solved for w = v_{n+1} by Newton (the scene's solve with h/2 and h^2/4): one force
    evaluation and one solve per iteration. Second order, symplectic, never explodes;
    conserves a spring's energy exactly.
    """
    q, v = state
    w = v
    half = 0.5 * h
    for _ in range(newton_max):
        v_mid = 0.5 * (v + w)
        q_mid = q + half * v_mid
        r = v + h * accel(q_mid, v_mid, t + half, p) - w
        dw = solve(q_mid, v_mid, t + half, p, half, 0.25 * h * h, r)
        w = w + dw
        if largest_magnitude(dw) <= NEWTON_RTOL * (1.0 + largest_magnitude(w)):
            break
    return (q + h * (0.5 * (v + w)), w)
