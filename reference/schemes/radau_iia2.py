import math

import numpy as np

from ..kinds import IMPLICIT, NEWTON_MAX
from .._scheme import Floor, largest_magnitude, scheme
from ..oscillator import oscillator, unbounded
from .implicit_euler import NEWTON_RTOL


def floor(s, h, k, m):
    # The scheme's own algorithm, not the closed form its stages converge to: the simplified
    # Newton passes on the stage velocities W1, W2 (the spring's solve divides by 1 + beta k/m
    # for each real shift), each pass two forces and two solves, until the passes stall in
    # roundoff below the tolerance. Same operations in the same order, so the same bits.
    x, v = s
    w1 = v
    w2 = v
    d_prev = math.inf
    for _ in range(NEWTON_MAX):
        a1 = -k * (x + (h / 12.0) * (5.0 * w1 - w2)) / m
        a2 = -k * (x + (0.25 * h) * (3.0 * w1 + w2)) / m
        r1 = v + (h / 12.0) * (5.0 * a1 - a2) - w1
        r2 = v + (0.25 * h) * (3.0 * a1 + a2) - w2
        u1 = ((35.0 * r1 + 7.0 * r2) / 33.0) / (1.0 + 0.09 * (h * h) * (k / m))
        u2 = ((10.0 * r1 + 35.0 * r2) / 33.0) / (1.0 + 0.25 * (h * h) * (k / m))
        dw1 = u1 - 0.2 * u2
        dw2 = u2 - (2.0 / 7.0) * u1
        w1 = w1 + dw1
        w2 = w2 + dw2
        d = max(abs(dw1), abs(dw2))
        scale = 1.0 + max(abs(w1), abs(w2))
        stalled = d >= 0.5 * d_prev or d <= 1e-16 * scale
        d_prev = d
        if d <= NEWTON_RTOL * scale and stalled:
            break
    return (x + (0.25 * h) * (3.0 * w1 + w2), w2)


def amplification(y, z):
    """Its stability function on the first-order form: (I - 2Y/3 + Y^2/6)^-1 (I + Y/3), Y = y J(zeta)."""
    a = y * oscillator(z)
    return np.linalg.solve(np.eye(2) - (2.0 / 3.0) * a + (a @ a) / 6.0, np.eye(2) + a / 3.0)


@scheme(
    kind=IMPLICIT,
    order=3,
    force_evals=2,
    symplectic=False,
    energy_claim="decays",
    homega_max=float("inf"),
    one_pass_on_linear=False,
    floor=Floor(floor),
    amplification=amplification,
    damping_limit=unbounded,
    # Not the cloth, where it iterates its coupled stages on every step of the stiff sheet (the
    # standard suite's longest reference task), nor the solar system (the schemes the issue names
    # against REBOUND's modes run there); the full suite runs it everywhere.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "chain")},
)
def radau_iia2(accel, solve, newton_max, state, t, h, p):
    """Two-stage Radau IIA (c = 1/3, 1; A = [[5/12, -1/12], [3/4, 1/4]]; b = A's last row): stage
    velocities W1, W2 at t_n + h/3 and t_n + h.

        X_i = x_n + h sum_j A_ij W_j,     W_i = v_n + h sum_j A_ij a(X_j, W_j, t_n + c_j h)
        x_{n+1} = X_2,                    v_{n+1} = W_2

    A's eigenvalues are complex (1/3 +- i/sqrt(18)) and the scene's solve takes real shifts only,
    so the stages are solved by a simplified Newton iteration with a nearby real matrix
    B = T diag(3/10, 1/2) T^-1, T = [[1, -1/5], [-2/7, 1]]: each pass two force evaluations and two
    solves (alpha = d h, beta = d^2 h^2), contracting by at most 0.28 on any damped or undamped
    linear mode, run until roundoff stalls it, on linear scenes too. Third order, L-stable: never
    explodes, damps every mode; a spring keeps (1 + z^2/9)/(1 + z^2/9 + z^4/36) of its energy per
    step, z = h w.
    """
    q, v = state
    w1 = v
    w2 = v
    third = h / 3.0
    d_prev = math.inf
    for _ in range(newton_max):
        x1 = q + (h / 12.0) * (5.0 * w1 - w2)
        x2 = q + (0.25 * h) * (3.0 * w1 + w2)
        a1 = accel(x1, w1, t + third, p)
        a2 = accel(x2, w2, t + h, p)
        r1 = v + (h / 12.0) * (5.0 * a1 - a2) - w1
        r2 = v + (0.25 * h) * (3.0 * a1 + a2) - w2
        # T^-1 r, each component solved with its real shift d at the end stage, then back by T.
        u1 = solve(x2, w2, t + h, p, 0.3 * h, 0.09 * (h * h), (35.0 * r1 + 7.0 * r2) / 33.0)
        u2 = solve(x2, w2, t + h, p, 0.5 * h, 0.25 * (h * h), (10.0 * r1 + 35.0 * r2) / 33.0)
        dw1 = u1 - 0.2 * u2
        dw2 = u2 - (2.0 / 7.0) * u1
        w1 = w1 + dw1
        w2 = w2 + dw2
        # A pass leaves about rho times its update as error (linear convergence, not Newton's
        # quadratic): below the Newton tolerance, go on while the passes still shrink by more
        # than half (rho <= 0.28 on linear modes), so the iteration ends where roundoff stalls it.
        d = max(largest_magnitude(dw1), largest_magnitude(dw2))
        scale = 1.0 + max(largest_magnitude(w1), largest_magnitude(w2))
        stalled = d >= 0.5 * d_prev or d <= 1e-16 * scale
        d_prev = d
        if d <= NEWTON_RTOL * scale and stalled:
            break
    return (q + (0.25 * h) * (3.0 * w1 + w2), w2)
