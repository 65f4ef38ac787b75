from .._scheme import scheme


@scheme(order=1, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0)
def semi_implicit_euler_position_first(accel, state, t, h, p):
    """Semi-implicit (symplectic) Euler, position first: what Chipmunk / pymunk integrates.

        x_{n+1} = x_n + h v_n
        v_{n+1} = v_n + h a(x_{n+1}, v_n, t_{n+1})

    First order, symplectic (the adjoint of the velocity-first form). Stable for h w <= 2.
    """
    q, v = state
    q = q + h * v
    return (q, v + h * accel(q, v, t + h, p))
