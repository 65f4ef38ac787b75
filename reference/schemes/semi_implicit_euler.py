from .._scheme import scheme


@scheme(order=1, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0)
def semi_implicit_euler(accel, state, t, h, p):
    """Semi-implicit (symplectic) Euler, velocity first: the games default (MuJoCo Euler, Bullet).

        v_{n+1} = v_n + h a(x_n, v_n, t_n)
        x_{n+1} = x_n + h v_{n+1}

    First order, symplectic: the energy error stays in an O(h) band. Stable for h w <= 2.
    """
    q, v = state
    a = accel(q, v, t, p)
    v = v + h * a
    return (q + h * v, v)
