import numpy as np

from ..kinds import IMPLICIT
from .._scheme import Floor, largest_magnitude, scheme
from ..oscillator import oscillator, unbounded
from .implicit_euler import NEWTON_RTOL


def floor(s, h, k, m):
    x, v = s
    dw = (h * (-k * (x + 0.5 * h * v) / m)) / (1.0 + 0.25 * h * h * (k / m))
    w = v + dw
    return (x + h * (0.5 * (v + w)), w)


def amplification(y, z):
    a = 0.5 * y * oscillator(z)
    return np.linalg.solve(np.eye(2) - a, np.eye(2) + a)


@scheme(
    kind=IMPLICIT,
    order=2,
    force_evals=1,
    symplectic=True,
    energy_claim="bounded",
    homega_max=float("inf"),
    floor=Floor(floor),
    amplification=amplification,
    damping_limit=unbounded,
    # Not the solar system, where the issue names the schemes it runs against REBOUND's modes.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth")},
)
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
