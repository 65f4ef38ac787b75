"""The explicit Runge-Kutta schemes, each one entry: its Butcher tableau (A, b, c), its declared
order and energy behaviour, its formulas. The step, the force evaluations (its stages), the
stability limit on the spring, the recurrence on the damped spring and the floor of
``harness bench`` follow from the tableau (``reference.tableau``). ``reference.METHODS`` holds
every entry of ``TABLEAUS``."""
from ..tableau import tableau_scheme

_MODULE = __name__

explicit_euler = tableau_scheme(
    "explicit_euler", A=[[0]], b=[1], c=[0], order=1, energy_claim="grows", module=_MODULE, doc="""\
Explicit (forward) Euler: both updates from the old state.

        x_{n+1} = x_n + h v_n
        v_{n+1} = v_n + h a(x_n, v_n, t_n)

    First order. On a spring the energy grows by exactly (1 + h^2 w^2) per step: unstable for every h.
    """)

rk4 = tableau_scheme(
    "rk4", A=[[0, 0, 0, 0], ["1/2", 0, 0, 0], [0, "1/2", 0, 0], [0, 0, 1, 0]], b=["1/6", "1/3", "1/3", "1/6"],
    c=[0, "1/2", "1/2", 1], order=4, energy_claim="decays", module=_MODULE, doc="""\
Classical 4-stage Runge-Kutta on y = (x, v), y' = (v, a):

        k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), k3 = f(t + h/2, y + h/2 k2), k4 = f(t + h, y + h k3)
        y_{n+1} = y_n + h/6 (k1 + 2 k2 + 2 k3 + k4)

    Fourth order, not symplectic: on a spring the energy falls by 1 - h^6/72 + ... per step.
    Stable for h w <= 2 sqrt(2).
    """)

TABLEAUS = (explicit_euler, rk4)
