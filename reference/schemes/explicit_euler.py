from .._scheme import scheme


@scheme(order=1, force_evals=1, symplectic=False, implicit=False, energy_claim="grows", homega_max=None)
def explicit_euler(accel, state, t, h, p):
    """Explicit (forward) Euler: both updates from the old state.

        x_{n+1} = x_n + h v_n
        v_{n+1} = v_n + h a(x_n, v_n, t_n)

    First order. On a spring the energy grows by exactly (1 + h^2 w^2) per step: unstable for every h.
    """
    q, v = state
    a = accel(q, v, t, p)
    return (q + h * v, v + h * a)
