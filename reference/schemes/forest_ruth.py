from .._scheme import Floor, scheme
from ..oscillator import drift, kick

#: theta = 1 / (2 - 2^(1/3)), the Forest-Ruth (Yoshida) coefficient.
THETA = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))


def floor(s, h, k, m):
    x, v = s
    x = x + 0.5 * THETA * h * v
    v = v + THETA * h * (-k * x / m)
    x = x + 0.5 * (1.0 - THETA) * h * v
    v = v + (1.0 - 2.0 * THETA) * h * (-k * x / m)
    x = x + 0.5 * (1.0 - THETA) * h * v
    v = v + THETA * h * (-k * x / m)
    return (x + 0.5 * THETA * h * v, v)


def amplification(y, z):
    c1, c2 = 0.5 * THETA * y, 0.5 * (1.0 - THETA) * y
    d1, d2 = THETA * y, (1.0 - 2.0 * THETA) * y
    return drift(c1) @ kick(d1, z) @ drift(c2) @ kick(d2, z) @ drift(c2) @ kick(d1, z) @ drift(c1)


@scheme(order=4, force_evals=3, symplectic=True, energy_claim="bounded", homega_max=1.5734,
        order_velocity_dependent=1, floor=Floor(floor), amplification=amplification,
        # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
        # own (RK4, the fourth order, runs there); the solar system, where the issue names it against
        # REBOUND's modes; the full suite runs it everywhere.
        suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile", "solar_system")})
def forest_ruth(accel, state, t, h, p):
    """Forest-Ruth: three leapfrogs of lengths theta h, (1 - 2 theta) h, theta h composed,
    theta = 1/(2 - 2^(1/3)):

        x += theta h/2 v;      v += theta h a(x);  x += (1 - theta) h/2 v;  v += (1 - 2 theta) h a(x)
        x += (1 - theta) h/2 v; v += theta h a(x); x += theta h/2 v

    Fourth order, symplectic, three evaluations; stable for h w <= 1.5734. Its kicks take a
    velocity-dependent force at the velocity before each kick, without a solve: first order there.
    """
    q, v = state
    c1 = 0.5 * THETA * h
    c2 = 0.5 * (1.0 - THETA) * h
    d1 = THETA * h
    d2 = (1.0 - 2.0 * THETA) * h
    q = q + c1 * v
    v = v + d1 * accel(q, v, t + c1, p)
    q = q + c2 * v
    v = v + d2 * accel(q, v, t + 0.5 * h, p)
    q = q + c2 * v
    v = v + d1 * accel(q, v, t + h - c1, p)
    return (q + c1 * v, v)
