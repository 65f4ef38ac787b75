from .._scheme import scheme


@scheme(order=4, force_evals=4, symplectic=False, implicit=False, energy_claim="decays", homega_max=2.8284271247461903)
def rk4(accel, state, t, h, p):
    """Classical 4-stage Runge-Kutta on y = (x, v), y' = (v, a):

        k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), k3 = f(t + h/2, y + h/2 k2), k4 = f(t + h, y + h k3)
        y_{n+1} = y_n + h/6 (k1 + 2 k2 + 2 k3 + k4)

    Fourth order, not symplectic: on a spring the energy falls by 1 - h^6/72 + ... per step.
    Stable for h w <= 2 sqrt(2).
    """
    q, v = state
    half = 0.5 * h
    a1 = accel(q, v, t, p)
    q2, v2 = q + half * v, v + half * a1
    a2 = accel(q2, v2, t + half, p)
    q3, v3 = q + half * v2, v + half * a2
    a3 = accel(q3, v3, t + half, p)
    q4, v4 = q + h * v3, v + h * a3
    a4 = accel(q4, v4, t + h, p)
    sixth = h / 6.0
    return (q + sixth * (v + 2.0 * v2 + 2.0 * v3 + v4), v + sixth * (a1 + 2.0 * a2 + 2.0 * a3 + a4))
