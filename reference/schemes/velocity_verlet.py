from .._scheme import scheme


def start(accel, q, v, t, h, p):
    return (q, v, accel(q, v, t, p))


def observe(accel, state, t, h, p):
    return state[0], state[1]


@scheme(order=2, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0,
        order_velocity_dependent=1, carries=("q", "v", "a"),
        start=start, observe=observe)
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
