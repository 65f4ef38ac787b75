"""The explicit Runge-Kutta schemes, each one entry: its Butcher tableau (A, b, c), its declared
order and energy behaviour, its formulas, the scenes it joins. The step, the force evaluations (its
stages), the stability limit on the spring, the recurrence on the damped spring and the floor of
``harness bench`` follow from the tableau (``reference.tableau``). ``reference.METHODS`` holds
every entry of ``TABLEAUS``. An entry with an embedded row (``b_hat``: Bogacki-Shampine 3(2),
Dormand-Prince 5(4)) also runs error-controlled (``reference.tableau.error_controlled``); its fixed
step never reads the row."""

import math

from .._scheme import EVERY_SCENE
from ..tableau import tableau_scheme

_MODULE = __name__

#: The schemes that name Drake's Runge-Kutta modes run in the standard suite where it runs those modes
#: (the spring, the damped spring and the pendulum); the full suite runs them everywhere.
WHERE_DRAKE_RUNS = {"standard": ("spring", "damped_spring", "pendulum")}


def _explicit_euler_damping_limit(z):
    """l = 1 + y mu, mu the oscillator's roots (Jury): 2 zeta (zeta <= 1), 2 / (zeta + sqrt(zeta^2 - 1))
    (zeta > 1); unstable at every y undamped."""
    if z == 0.0:
        return None
    return 2.0 * z if z <= 1.0 else 2.0 / (z + math.sqrt(z * z - 1.0))


explicit_euler = tableau_scheme(
    "explicit_euler",
    A=[[0]],
    b=[1],
    c=[0],
    order=1,
    energy_claim="grows",
    module=_MODULE,
    damping_limit=_explicit_euler_damping_limit,
    suites={"standard": EVERY_SCENE},
    doc="""\
Explicit (forward) Euler: both updates from the old state.

        x_{n+1} = x_n + h v_n
        v_{n+1} = v_n + h a(x_n, v_n, t_n)

    First order. On a spring the energy grows by exactly (1 + h^2 w^2) per step: unstable for every h.
    """,
)

rk4 = tableau_scheme(
    "rk4",
    A=[[0, 0, 0, 0], ["1/2", 0, 0, 0], [0, "1/2", 0, 0], [0, 0, 1, 0]],
    b=["1/6", "1/3", "1/3", "1/6"],
    c=[0, "1/2", "1/2", 1],
    order=4,
    energy_claim="decays",
    module=_MODULE,
    suites={"standard": EVERY_SCENE},
    doc="""\
Classical 4-stage Runge-Kutta on y = (x, v), y' = (v, a):

        k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), k3 = f(t + h/2, y + h/2 k2), k4 = f(t + h, y + h k3)
        y_{n+1} = y_n + h/6 (k1 + 2 k2 + 2 k3 + k4)

    Fourth order, not symplectic: on a spring the energy falls by 1 - h^6/72 + ... per step.
    Stable for h w <= 2 sqrt(2).
    """,
)

heun = tableau_scheme(
    "heun",
    A=[[0, 0], [1, 0]],
    b=["1/2", "1/2"],
    c=[0, 1],
    order=2,
    energy_claim="grows",
    module=_MODULE,
    suites=WHERE_DRAKE_RUNS,
    doc="""\
Heun's method (explicit trapezoidal rule, Drake's runge_kutta2):

        k1 = f(t, y), k2 = f(t + h, y + h k1)
        y_{n+1} = y_n + h/2 (k1 + k2)

    Second order, two evaluations. On a spring |R(i y)|^2 = 1 + y^4/4: the energy grows for every h.
    """,
)

kutta_rk3 = tableau_scheme(
    "kutta_rk3",
    A=[[0, 0, 0], ["1/2", 0, 0], [-1, 2, 0]],
    b=["1/6", "2/3", "1/6"],
    c=[0, "1/2", 1],
    order=3,
    energy_claim="decays",
    module=_MODULE,
    suites=WHERE_DRAKE_RUNS,
    doc="""\
Kutta's third-order method (Drake's runge_kutta3 without its error estimate):

        k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), k3 = f(t + h, y - h k1 + 2 h k2)
        y_{n+1} = y_n + h/6 (k1 + 4 k2 + k3)

    Third order, three evaluations. On a spring |R(i y)|^2 = 1 - y^4/12 + y^6/36: the energy decays,
    stable for h w <= sqrt(3).
    """,
)

bogacki_shampine3 = tableau_scheme(
    "bogacki_shampine3",
    A=[[0, 0, 0], ["1/2", 0, 0], [0, "3/4", 0]],
    b=["2/9", "1/3", "4/9"],
    c=[0, "1/2", "3/4"],
    b_hat=["7/24", "1/4", "1/3", "1/8"],
    order=3,
    energy_claim="decays",
    module=_MODULE,
    suites=WHERE_DRAKE_RUNS,
    doc="""\
Bogacki-Shampine's third-order method (its fourth, first-same-as-last stage only feeds the error
estimate, so at a fixed step it is three stages):

        k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), k3 = f(t + 3h/4, y + 3h/4 k2)
        y_{n+1} = y_n + h/9 (2 k1 + 3 k2 + 4 k3)

    Third order, three evaluations; the same stability polynomial as every three-stage third-order
    scheme: the energy decays on a spring, stable for h w <= sqrt(3).
    """,
)

dormand_prince5 = tableau_scheme(
    "dormand_prince5",
    A=[
        [0, 0, 0, 0, 0, 0],
        ["1/5", 0, 0, 0, 0, 0],
        ["3/40", "9/40", 0, 0, 0, 0],
        ["44/45", "-56/15", "32/9", 0, 0, 0],
        ["19372/6561", "-25360/2187", "64448/6561", "-212/729", 0, 0],
        ["9017/3168", "-355/33", "46732/5247", "49/176", "-5103/18656", 0],
    ],
    b=["35/384", 0, "500/1113", "125/192", "-2187/6784", "11/84"],
    c=[0, "1/5", "3/10", "4/5", "8/9", 1],
    b_hat=["5179/57600", 0, "7571/16695", "393/640", "-92097/339200", "187/2100", "1/40"],
    order=5,
    energy_claim="decays",
    module=_MODULE,
    suites=WHERE_DRAKE_RUNS,
    doc="""\
Dormand-Prince 5(4), its fifth-order solution (Drake's runge_kutta5; the seventh, first-same-as-last
stage only feeds the error estimate, so at a fixed step it is six stages):

        k_i = f(t + c_i h, y + h sum_j a_ij k_j), i = 1..6
        y_{n+1} = y_n + h (35/384 k1 + 500/1113 k3 + 125/192 k4 - 2187/6784 k5 + 11/84 k6)

    Fifth order, six evaluations. R(z) = sum_k z^k/k! to k = 5, + z^6/600: the energy decays on a
    spring, stable for h w <= 0.997 (an undamped spring's eigenvalues +-i w lie on the imaginary
    axis, where |R(i y)| <= 1 holds only to y = 0.9972, and |R(3.4 i)| = 1.90). The negative real
    axis, a pure decay's, is stable to h |lambda| <= 3.307.
    """,
)

TABLEAUS = (explicit_euler, rk4, heun, kutta_rk3, bogacki_shampine3, dormand_prince5)
