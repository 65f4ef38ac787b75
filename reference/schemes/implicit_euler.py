import numpy as np

from ..kinds import IMPLICIT
from .._scheme import Floor, largest_magnitude, scheme
from ..oscillator import oscillator, unbounded

#: Newton stops when the update is below this, relative to the iterate.
NEWTON_RTOL = 1e-13


def floor(s, h, k, m):
    # The spring is linear: one Newton iteration from w = v_n solves for v_{n+1} exactly, and
    # the harness takes one (newton_max = 1 on a linear scene).
    x, v = s
    dw = (h * (-k * (x + h * v) / m)) / (1.0 + h * h * (k / m))
    w = v + dw
    return (x + h * w, w)


def amplification(y, z):
    return np.linalg.inv(np.eye(2) - y * oscillator(z))


@scheme(
    kind=IMPLICIT,
    order=1,
    force_evals=1,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    floor=Floor(floor),
    amplification=amplification,
    damping_limit=unbounded,
    # Not the solar system, where the issue names the schemes it runs against REBOUND's modes.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain", "cloth")},
)
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
