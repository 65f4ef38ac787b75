"""How damping moves the stability limit: the largest stable h*omega as a function of the damping
ratio zeta, measured on ``damped_spring`` (k = m = 1, c = 2 zeta: omega = 1, so h*omega = h) and
set beside linear-stability theory.

**Theory.** On x'' = -x - 2 zeta x' every scheme is a linear recurrence of its carried state
(x, v), or (x, v, a) / (x_n, x_{n-1}, a) for the Verlet forms, whose matrix M(y, zeta), y = h*omega,
is written here from the scheme's update formulas (the same formulas as its docstring in
``reference/``, applied to a = -x - 2 zeta v). The scheme is stable at y iff the spectral radius
of M is <= 1. The limit is

* in closed form where one exists (``CLOSED_FORM``), from the Jury conditions on the 2x2
  characteristic polynomial l^2 - tr l + det:
  - explicit Euler, l = 1 + y mu with mu the oscillator's roots: 2 zeta (zeta <= 1),
    2 / (zeta + sqrt(zeta^2 - 1)) (zeta > 1); unstable at every y when zeta = 0;
  - semi-implicit Euler (both forms; position Verlet has the same polynomial): det = 1 - 2 zeta y,
    tr = 2 - 2 zeta y - y^2, limit 2 (sqrt(1 + zeta^2) - zeta): explicit damping lowers it;
  - semi-implicit Euler implicit in the velocity (MuJoCo): det = 1/(1 + 2 zeta y),
    limit 2 (sqrt(1 + zeta^2) + zeta): implicit damping raises it;
  - implicit Euler, implicit midpoint and two-stage Radau IIA: A-stable, unbounded.
* computed otherwise (RK4, leapfrog, velocity Verlet, Forest-Ruth, the two exact-decay forms,
  whose conditions are transcendental or of higher degree): rho(M(y, zeta)) by ``numpy.linalg.eigvals``,
  the first y where it exceeds 1 + RHO_TOL found by the stability measure's own scan and bisection
  (from y = 1e-4 up by factors of 2 to 1e4, then to a relative 1e-12).

**Measured.** ``harness.measures.stability.largest_stable_dt`` (the spectral radius of the measured one-step
map) on ``damped_spring`` at c = 2 zeta, for reference schemes and engine modes alike. An engine
mode is judged against the theory of the scheme it was identified as: within THEORY_RTOL (0.5%).
A reference scheme's map is measured on the state it carries between steps
(``stability.recurrence_map``): for the Verlet forms, whose carried acceleration was evaluated at
another velocity than a restart from (q, v) would use, that is the recurrence the scheme runs.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from records import REFERENCE, MethodId, is_reference, scheme_name

from reference import METHODS
from scenarios import make_scene

from harness.measures.common import resolve
from harness.measures.stability import HOMEGA_HI, HOMEGA_LO, RHO_TOL, SCAN_RATIO, growth_unresolved, largest_stable_dt

#: The issue's sweep of damping ratios.
ZETAS = (0.0, 0.05, 0.1, 0.5, 1.0, 2.0)
#: A measured limit within this fraction of the theory agrees with it (the order and stability
#: checks' 0.5%).
THEORY_RTOL = 0.005
#: The theory line's damping ratios (for the chart).
CURVE_ZETAS = tuple(float(z) for z in np.round(np.linspace(0.0, 2.0, 41), 10))
THETA = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))


def _kick(d, zeta):
    """v += d a(x, v), a = -x - 2 zeta v, on (x, v)."""
    return np.array([[1.0, 0.0], [-d, 1.0 - 2.0 * zeta * d]])


def _drift(d):
    return np.array([[1.0, d], [0.0, 1.0]])


def _oscillator(zeta):
    return np.array([[0.0, 1.0], [-1.0, -2.0 * zeta]])


def _semi_implicit_euler(y, z):          # kick, then drift with the new velocity
    return _drift(y) @ _kick(y, z)


def _semi_implicit_euler_position_first(y, z):   # drift, then kick at the new position, old velocity
    return _kick(y, z) @ _drift(y)


def _semi_implicit_euler_velocity_implicit(y, z):
    d = 1.0 + 2.0 * z * y                  # (1 + 2 zeta y) v_1 = v - y x
    return _drift(y) @ np.array([[1.0, 0.0], [-y / d, 1.0 / d]])


def _decay_after_kick(y, z):
    e = math.exp(-2.0 * z * y)             # v_1 = e (v - y x_1), x_1 = x + y v
    return np.array([[1.0, 0.0], [-e * y, e]]) @ _drift(y)


def _decay_before_kick(y, z):
    e = math.exp(-2.0 * z * y)             # v_1 = e v - y x_1
    return np.array([[1.0, y], [-y, e - y * y]])


def _leapfrog(y, z):
    return _drift(0.5 * y) @ _kick(y, z) @ _drift(0.5 * y)


def _forest_ruth(y, z):
    c1, c2 = 0.5 * THETA * y, 0.5 * (1.0 - THETA) * y
    d1, d2 = THETA * y, (1.0 - 2.0 * THETA) * y
    return _drift(c1) @ _kick(d1, z) @ _drift(c2) @ _kick(d2, z) @ _drift(c2) @ _kick(d1, z) @ _drift(c1)


def _implicit_euler(y, z):
    return np.linalg.inv(np.eye(2) - y * _oscillator(z))


def _implicit_euler_doubled(y, z):      # two implicit Euler steps of h/2
    half = _implicit_euler(0.5 * y, z)
    return half @ half


def _implicit_midpoint(y, z):
    a = 0.5 * y * _oscillator(z)
    return np.linalg.solve(np.eye(2) - a, np.eye(2) + a)


def _radau_iia2(y, z):
    """Its stability function on the first-order form: (I - 2Y/3 + Y^2/6)^-1 (I + Y/3), Y = y M(zeta)."""
    a = y * _oscillator(z)
    return np.linalg.solve(np.eye(2) - (2.0 / 3.0) * a + (a @ a) / 6.0, np.eye(2) + a / 3.0)


def _velocity_verlet(y, z):
    """On the carried (x, v, a): v_h = v + y/2 a; x_1 = x + y v_h; a_1 = -x_1 - 2 zeta v_h; v_1 = v_h + y/2 a_1."""
    vh = np.array([0.0, 1.0, 0.5 * y])
    x1 = np.array([1.0, 0.0, 0.0]) + y * vh
    a1 = -x1 - 2.0 * z * vh
    return np.vstack([x1, vh + 0.5 * y * a1, a1])


def _verlet(y, z):
    """On the carried (x_n, x_{n-1}, a_n): x_{n+1} = 2 x_n - x_{n-1} + y^2 a_n,
    a_{n+1} = -x_{n+1} - 2 zeta (x_{n+1} - x_n)/y."""
    x1 = np.array([2.0, -1.0, y * y])
    a1 = -x1 - 2.0 * z * (x1 - np.array([1.0, 0.0, 0.0])) / y
    return np.vstack([x1, [1.0, 0.0, 0.0], a1])


#: Scheme id -> M(y, zeta) written from its formulas; an explicit Runge-Kutta scheme's comes from
#: its tableau (``reference.tableau.Tableau.damping_matrix``).
_WRITTEN = {
    "semi_implicit_euler": _semi_implicit_euler,
    "semi_implicit_euler_position_first": _semi_implicit_euler_position_first,
    "semi_implicit_euler_velocity_implicit": _semi_implicit_euler_velocity_implicit,
    "position_first_euler_decay_after_kick": _decay_after_kick,
    "position_first_euler_decay_before_kick": _decay_before_kick,
    "verlet": _verlet,
    "velocity_verlet": _velocity_verlet,
    "leapfrog": _leapfrog,
    "forest_ruth": _forest_ruth,
    "implicit_euler": _implicit_euler,
    "implicit_euler_doubled": _implicit_euler_doubled,
    # On a linear scene the linearly implicit step is backward Euler (tests/test_cloth.py).
    "linearly_implicit_euler": _implicit_euler,
    "implicit_midpoint": _implicit_midpoint,
    "radau_iia2": _radau_iia2,
}


class _Matrices(Mapping):
    """Scheme id -> M(y, zeta), the recurrence of its carried state on the damped oscillator: every
    scheme of ``reference.METHODS`` written above or declared as a tableau (one registered later too)."""

    def _ids(self) -> list[str]:
        return [sid for sid, s in METHODS.items() if sid in _WRITTEN or s.tableau is not None]

    def __getitem__(self, scheme_id: str):
        if scheme_id in _WRITTEN:
            return _WRITTEN[scheme_id]
        scheme = METHODS.get(scheme_id)
        if scheme is None or scheme.tableau is None:
            raise KeyError(scheme_id)
        return scheme.tableau.damping_matrix

    def __iter__(self):
        return iter(self._ids())

    def __len__(self) -> int:
        return len(self._ids())


MATRICES = _Matrices()


def _explicit_euler_limit(z):
    if z == 0.0:
        return None
    return 2.0 * z if z <= 1.0 else 2.0 / (z + math.sqrt(z * z - 1.0))


def _semi_implicit_limit(z):
    return 2.0 * (math.sqrt(1.0 + z * z) - z)


#: Scheme id -> the limit in closed form (None: unstable at every y; inf: unbounded).
CLOSED_FORM = {
    "explicit_euler": _explicit_euler_limit,
    "semi_implicit_euler": _semi_implicit_limit,
    "semi_implicit_euler_position_first": _semi_implicit_limit,
    "verlet": _semi_implicit_limit,
    "semi_implicit_euler_velocity_implicit": lambda z: 2.0 * (math.sqrt(1.0 + z * z) + z),
    "implicit_euler": lambda z: math.inf,
    "implicit_euler_doubled": lambda z: math.inf,
    "linearly_implicit_euler": lambda z: math.inf,
    "implicit_midpoint": lambda z: math.inf,
    "radau_iia2": lambda z: math.inf,
}


def spectral_radius(scheme_id: str, y: float, zeta: float) -> float:
    with np.errstate(all="ignore"):
        return float(np.max(np.abs(np.linalg.eigvals(MATRICES[scheme_id](y, zeta)))))


def computed_limit(scheme_id: str, zeta: float, rtol: float = 1e-12) -> float | None:
    """The first y where rho(M(y, zeta)) > 1 + RHO_TOL: scan up from HOMEGA_LO by SCAN_RATIO to
    HOMEGA_HI, then bisect. None: unstable already at HOMEGA_LO, or no stable step resolved (the
    measure's rule, ``stability.growth_unresolved``); inf: stable to HOMEGA_HI."""
    def stable(y):
        return spectral_radius(scheme_id, y, zeta) <= 1.0 + RHO_TOL

    if not stable(HOMEGA_LO):
        return None
    good, y = HOMEGA_LO, HOMEGA_LO
    while y < HOMEGA_HI:
        y = min(y * SCAN_RATIO, HOMEGA_HI)
        if not stable(y):
            bad = y
            break
        good = y
    else:
        return math.inf
    while bad / good - 1.0 > rtol:
        mid = math.sqrt(good * bad)
        good, bad = (mid, bad) if stable(mid) else (good, mid)
    return None if growth_unresolved(lambda y: spectral_radius(scheme_id, y, zeta), good)[0] else good


def theory_limit(scheme_id: str, zeta: float) -> dict:
    """``{"homega_max": value (None: unstable everywhere, inf: unbounded), "source": "closed form" |
    "computed"}``; None for a scheme without a matrix here (constrained ones)."""
    if scheme_id not in MATRICES:
        return {"homega_max": None, "source": None}
    if scheme_id in CLOSED_FORM:
        return {"homega_max": CLOSED_FORM[scheme_id](zeta), "source": "closed form"}
    return {"homega_max": computed_limit(scheme_id, zeta), "source": "computed"}


def theory_curve(scheme_id: str, zetas=CURVE_ZETAS) -> list:
    return [theory_limit(scheme_id, z)["homega_max"] for z in zetas]


def agrees(measured, theory) -> bool | None:
    """Measured limit vs theory: both unbounded, both unstable everywhere, or within THEORY_RTOL.
    A measured limit at the top of the search (the search stops at HOMEGA_HI) counts as unbounded."""
    if theory is None or measured is None:
        return theory is None and measured is None
    if math.isinf(theory) or math.isinf(measured):
        return math.isinf(theory) and math.isinf(measured)
    return abs(measured - theory) <= THEORY_RTOL * theory


def limit_vs_damping(method, zetas=ZETAS, *, scheme: str | None = None, hi: float = HOMEGA_HI,
                     timeout: float | None = None) -> dict:
    """The largest stable h*omega of ``method`` on ``damped_spring`` at each zeta (c = 2 zeta),
    with the theory of ``scheme`` (a reference scheme id, ``ref:`` or not; default: the method's
    own scheme where it is one) beside each: ``rows`` of {zeta, measured, verdict, theory,
    theory_source, agrees}."""
    method = resolve(method, make_scene("damped_spring"))
    if scheme is None:
        scheme = method.scheme.id if method.scheme is not None else None
    sid = scheme_name(scheme) if is_reference(scheme) else scheme
    rows = []
    for z in zetas:
        scene = make_scene("damped_spring", c=2.0 * float(z))
        res = largest_stable_dt(method, scene, criterion="spectral_radius", hi=hi, timeout=timeout)
        verdict = res.verdict
        measured = math.inf if verdict == "unbounded" else res.omega_dt_max
        th = theory_limit(sid, float(z)) if sid else {"homega_max": None, "source": None}
        theory = th["homega_max"]
        if theory is not None and math.isfinite(theory) and theory >= hi:
            theory = math.inf  # beyond the search: the measure can only say "unbounded"
        rows.append({"zeta": float(z), "measured": measured, "verdict": verdict, "theory": th["homega_max"],
                     "theory_source": th["source"], "agrees": agrees(measured, theory) if sid else None})
    return {"method": method.id, "scheme": str(MethodId(REFERENCE, sid)) if sid else None, "rows": rows,
            "tolerance": THEORY_RTOL}
