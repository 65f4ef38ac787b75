from .._scheme import scheme

#: theta = 1 / (2 - 2^(1/3)), the Forest-Ruth (Yoshida) coefficient.
THETA = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))


@scheme(order=4, force_evals=3, symplectic=True, energy_claim="bounded", homega_max=1.5734,
        order_velocity_dependent=1)
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
