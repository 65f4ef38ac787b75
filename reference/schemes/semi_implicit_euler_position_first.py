from .._scheme import Floor, scheme
from ..oscillator import drift, kick
from .semi_implicit_euler import damping_limit


def floor(s, h, k, m):
    x, v = s
    x = x + h * v
    return (x, v + h * (-k * x / m))


def amplification(y, z):
    """Drift, then kick at the new position and the old velocity."""
    return kick(y, z) @ drift(y)


@scheme(order=1, force_evals=1, symplectic=True, energy_claim="bounded", homega_max=2.0,
        floor=Floor(floor), amplification=amplification,
        damping_limit=damping_limit,  # the velocity-first form's characteristic polynomial
        # Not the chain and the cloth, where each pair would cost the standard suite a compile of its
        # own (the velocity-first form runs there), nor the solar system (the schemes the issue names
        # against REBOUND's modes run there); the full suite runs it everywhere.
        suites={"standard": ("spring", "damped_spring", "pendulum", "kepler", "projectile")})
def semi_implicit_euler_position_first(accel, state, t, h, p):
    """Semi-implicit (symplectic) Euler, position first: what Chipmunk / pymunk integrates.

        x_{n+1} = x_n + h v_n
        v_{n+1} = v_n + h a(x_{n+1}, v_n, t_{n+1})

    First order, symplectic (the adjoint of the velocity-first form). Stable for h w <= 2.
    """
    q, v = state
    q = q + h * v
    return (q, v + h * accel(q, v, t + h, p))
