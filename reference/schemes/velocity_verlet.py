import numpy as np

from .._scheme import Floor, scheme


def start(accel, q, v, t, h, p):
    return (q, v, accel(q, v, t, p))


def observe(accel, state, t, h, p):
    return state[0], state[1]


def floor(s, h, k, m):
    x, v, a = s
    v = v + 0.5 * h * a
    x = x + h * v
    a = -k * x / m
    return (x, v + 0.5 * h * a, a)


def floor_start(x, v, h, k, m):
    return (x, v, -k * x / m)


def amplification(y, z):
    """On the carried (x, v, a): v_h = v + y/2 a; x_1 = x + y v_h; a_1 = -x_1 - 2 zeta v_h; v_1 = v_h + y/2 a_1."""
    vh = np.array([0.0, 1.0, 0.5 * y])
    x1 = np.array([1.0, 0.0, 0.0]) + y * vh
    a1 = -x1 - 2.0 * z * vh
    return np.vstack([x1, vh + 0.5 * y * a1, a1])


@scheme(order=2, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0,
        order_velocity_dependent=1, carries=("q", "v", "a"),
        start=start, observe=observe, floor=Floor(floor, floor_start), amplification=amplification,
        # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
        # own (leapfrog, its limit, runs there); the solar system, where the issue names it against
        # REBOUND's modes; the full suite runs it everywhere.
        suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system")})
def velocity_verlet(accel, state, t, h, p):
    """Velocity Verlet, kick-drift-kick:

        v_{n+1/2} = v_n + (h/2) a_n
        x_{n+1}   = x_n + h v_{n+1/2}
        v_{n+1}   = v_{n+1/2} + (h/2) a(x_{n+1})

    Second order, symplectic, stable for h w <= 2. Carries a_n, so one evaluation a step.
    A velocity-dependent force is taken at v_{n+1/2}, not v_{n+1}, without a solve: first order there.
    """
    q, v, a = state
    v_half = v + (0.5 * h) * a
    q = q + h * v_half
    a = accel(q, v_half, t + h, p)
    return (q, v_half + (0.5 * h) * a, a)
