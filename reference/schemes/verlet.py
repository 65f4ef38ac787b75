import numpy as np

from .._scheme import Floor, scheme
from .semi_implicit_euler import damping_limit


def start(accel, q, v, t, h, p):
    # Start-up: a fictitious x_{-1} = x_0 - h v_0 + h^2/2 a_0, so that the first step gives
    # the Taylor start x_1 = x_0 + h v_0 + h^2/2 a_0 (one evaluation, before step 0).
    a = accel(q, v, t, p)
    return (q, q - h * v + (0.5 * h * h) * a, a)


def observe(accel, state, t, h, p):
    # Velocity estimate for reporting energy: v_n = (x_n - x_{n-1})/h + (h/2) a_n. It is
    # second order and equals velocity Verlet's v_n; it costs no force evaluation (a_n is carried).
    q, q_prev, a = state
    return q, (q - q_prev) / h + (0.5 * h) * a


def floor(s, h, k, m):
    x, x_prev, a = s
    x_next = 2.0 * x - x_prev + h * h * a
    return (x_next, x, -k * x_next / m)


def floor_start(x, v, h, k, m):
    a = -k * x / m
    return (x, x - h * v + 0.5 * h * h * a, a)


def floor_observe(s, h, k, m):
    x, x_prev, a = s
    return x, (x - x_prev) / h + 0.5 * h * a


def amplification(y, z):
    """On the carried (x_n, x_{n-1}, a_n): x_{n+1} = 2 x_n - x_{n-1} + y^2 a_n,
    a_{n+1} = -x_{n+1} - 2 zeta (x_{n+1} - x_n)/y."""
    x1 = np.array([2.0, -1.0, y * y])
    a1 = -x1 - 2.0 * z * (x1 - np.array([1.0, 0.0, 0.0])) / y
    return np.vstack([x1, [1.0, 0.0, 0.0], a1])


@scheme(
    order=2,
    force_evals=1,
    symplectic=True,
    energy_claim="bounded",
    homega_max=2.0,
    order_velocity_dependent=1,
    carries=("q", "q_prev", "a"),
    start=start,
    observe=observe,
    floor=Floor(floor, floor_start, floor_observe),
    amplification=amplification,
    damping_limit=damping_limit,  # semi-implicit Euler's characteristic polynomial
    # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
    # own (leapfrog, its limit, runs there), nor the solar system (the schemes the issue names
    # against REBOUND's modes run there); the full suite runs it everywhere.
    suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile")},
)
def verlet(accel, state, t, h, p):
    """Position (Stormer) Verlet: the scheme of cloth and ropes.

        x_{n+1} = 2 x_n - x_{n-1} + a(x_n) h^2

    Second order, symplectic, stable for h w <= 2. Carries (x_n, x_{n-1}, a_n). A
    velocity-dependent force sees the backward difference (x_{n+1} - x_n)/h, a first-order
    velocity: first order there.
    """
    q, q_prev, a = state
    q_next = 2.0 * q - q_prev + (h * h) * a
    return (q_next, q, accel(q_next, (q_next - q) / h, t + h, p))
