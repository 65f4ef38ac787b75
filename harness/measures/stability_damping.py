"""How damping moves the stability limit: the largest stable h*omega as a function of the damping
ratio zeta, measured on ``damped_spring`` (k = m = 1, c = 2 zeta: omega = 1, so h*omega = h) and
set beside linear-stability theory.

**Theory.** On x'' = -x - 2 zeta x' every scheme is a linear recurrence of its carried state
(x, v), or (x, v, a) / (x_n, x_{n-1}, a) for the Verlet forms, whose matrix M(y, zeta), y = h*omega,
each scheme declares beside its step (``reference.Scheme.amplification``, written from its update
formulas on ``reference.oscillator``; a tableau's follows from it). The scheme is stable at y iff
the spectral radius of M is <= 1. The limit is

* in closed form where the scheme declares one (``Scheme.damping_limit``: from the Jury conditions
  on the 2x2 characteristic polynomial l^2 - tr l + det, or unbounded for an A-stable scheme);
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


def spectral_radius(scheme_id: str, y: float, zeta: float) -> float:
    with np.errstate(all="ignore"):
        return float(np.max(np.abs(np.linalg.eigvals(METHODS[scheme_id].amplification(y, zeta)))))


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
    "computed"}``; None for a scheme that declares no recurrence (constrained, position-based)."""
    scheme = METHODS.get(scheme_id)
    if scheme is None or scheme.amplification is None:
        return {"homega_max": None, "source": None}
    if scheme.damping_limit is not None:
        return {"homega_max": scheme.damping_limit(zeta), "source": "closed form"}
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


def limit_vs_damping(
    method, zetas=ZETAS, *, scheme: str | None = None, hi: float = HOMEGA_HI, timeout: float | None = None
) -> dict:
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
        rows.append(
            {
                "zeta": float(z),
                "measured": measured,
                "verdict": verdict,
                "theory": th["homega_max"],
                "theory_source": th["source"],
                "agrees": agrees(measured, theory) if sid else None,
            }
        )
    return {
        "method": method.id,
        "scheme": str(MethodId(REFERENCE, sid)) if sid else None,
        "rows": rows,
        "tolerance": THEORY_RTOL,
    }
