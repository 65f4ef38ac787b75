"""Largest stable timestep, by a scan and bisection on dt, reported as dt and h*omega.

Two boundedness criteria, one rule each:

* ``spectral_radius`` (linear scenes, ``scene.linear``): a linear scene's one-step map is
  affine, y_1 = M y_0 + c. It is measured for any method, reference scheme or engine, by
  stepping one step from the zero state (giving c) and from each of the 2*ndof unit
  states (giving M's columns, minus c), y = (q, v). One more step from the sum of the unit
  states checks that the map really is affine (``linearity_residual``, the misfit relative
  to the unit inputs, <= LINEARITY_RTOL, else this criterion does not apply); the check
  runs at the smallest dt searched and at the dt the verdict rests on, not at every
  bisection step (an engine's step costs a worker process each).
  Stable iff rho(M) <= 1 + RHO_TOL. RHO_TOL = 1e-12
  is roundoff in M's entries (a few eps) with room; it is far below explicit Euler's
  rho - 1 = (h w)^2 / 2 = 5e-9 at the smallest h*omega searched, which a finite horizon
  never sees: 10,000 steps flag explicit Euler only above h*omega of a few hundredths.
  At h*omega = 2 exactly, semi-implicit Euler's M has a double eigenvalue -1 (rho = 1,
  polynomial growth); bisection never lands on it, so the limit is still 2.
* ``finite_horizon`` (every other scene, or on request): run ``steps`` steps (default
  10,000) and call the run stable iff it finishes (status ok, every state finite) and its
  size stays within GROWTH (10) times the true solution's:
  ``max_n ||y_n|| <= GROWTH * max_n ||y_true(t_n)||`` with y = (q, v/omega) and
  y_true the exact solution (or the reference solve) at the same times.

The search: h*omega from ``lo`` (1e-4) up by factors of SCAN_RATIO (2) to ``hi``
(1e4); the first unstable grid point and the stable one before it are then bisected
(geometric midpoint) until they differ by BISECT_RTOL (1e-6) relative. Scanning up from
``lo`` finds the *first* loss of stability, not an island above it (a stretch of
instability narrower than a factor 2 can be stepped over). Verdicts: ``limited``
(``dt_max`` is the last stable dt found), ``unbounded`` (stable at every dt searched;
``dt_max`` is None and ``dt_searched_max`` says how far) or ``unstable`` (unstable
already at ``lo``: explicit Euler's verdict on a spring, "unstable for every dt").
"""
from __future__ import annotations

import math

import numpy as np

from scenarios import InvalidInput, Scene

from ._measure import require_fixed_step, resolve, scaled_state, started_at, step
from .error import true_state

RHO_TOL = 1e-12
LINEARITY_RTOL = 1e-8
GROWTH = 10.0
HORIZON_STEPS = 10_000
HOMEGA_LO = 1e-4
HOMEGA_HI = 1e4
SCAN_RATIO = 2.0
BISECT_RTOL = 1e-6
CRITERIA = ("auto", "spectral_radius", "finite_horizon")


def one_step_map(method, scene: Scene, dt: float, *, timeout: float | None = None,
                 check_affine: bool = True) -> dict:
    """The one-step map y_1 = M y_0 + c of ``method`` on a linear ``scene`` at ``dt``,
    measured by stepping unit states (module docstring). Returns ``matrix``, ``offset``,
    ``eigenvalues``, ``rho`` and ``linearity_residual`` (None if ``check_affine`` is off),
    or ``rho`` None and ``reason``."""
    method = resolve(method, scene)
    n = scene.ndof
    isolated = bool(getattr(method, "isolated", False))

    def one_step(y0: np.ndarray):
        moved = started_at(scene, y0[:n], y0[n:])
        if isolated and not moved.state_in_params:
            return None, (f"scene {scene.id} cannot start from an arbitrary state through its parameters, "
                          f"and {method.id} runs in a worker process")
        traj = step(method, moved, dt, 1, 1, timeout)
        if not traj.ok or traj.q.shape[0] < 2:
            return None, f"one step from {y0.tolist()} ended {traj.status}: {traj.detail}"
        return np.concatenate([traj.q[-1, 0], traj.v[-1, 0]]), ""

    zero = np.zeros(2 * n)
    c, why = one_step(zero)
    if c is None:
        return {"rho": None, "reason": why}
    cols = []
    for i in range(2 * n):
        y, why = one_step(np.eye(2 * n)[i])
        if y is None:
            return {"rho": None, "reason": why}
        cols.append(y - c)
    M = np.array(cols).T
    with np.errstate(all="ignore"):
        eig = np.linalg.eigvals(M) if np.all(np.isfinite(M)) else np.full(2 * n, np.nan)
    out = {"dt": float(dt), "omega_dt": float(dt) * scene.omega, "matrix": M, "offset": c,
           "eigenvalues": eig, "rho": float(np.max(np.abs(eig))), "linearity_residual": None}
    if not check_affine:
        return out
    probe = np.ones(2 * n)
    y, why = one_step(probe)
    if y is None:
        return {"rho": None, "reason": why}
    predicted = M @ probe + c
    # Absolute against the unit-sized inputs: a scheme's own cancellations (implicit Euler
    # at h*omega = 1e4 forms 1/(1 + h^2) as 1 - h^2/(1 + h^2)) leave errors of eps there.
    scale = max(1.0, float(np.max(np.abs(predicted))), float(np.max(np.abs(M))), float(np.max(np.abs(y))))
    residual = float(np.max(np.abs(y - predicted))) / scale
    out["linearity_residual"] = residual
    if not residual <= LINEARITY_RTOL:
        out.update(rho=None, reason=f"one-step map is not affine (residual {residual:.3g} > {LINEARITY_RTOL:g})")
    return out


def spectral_test(method, scene: Scene, dt: float, *, timeout: float | None = None) -> tuple[bool, dict]:
    res = one_step_map(method, scene, dt, timeout=timeout, check_affine=False)
    if res["rho"] is None:  # a step that did not finish is no stable step
        return False, {"rho": None, "reason": res["reason"]}
    return res["rho"] <= 1.0 + RHO_TOL, {"rho": res["rho"]}


def finite_horizon_test(method, scene: Scene, dt: float, *, steps: int = HORIZON_STEPS,
                        timeout: float | None = None) -> tuple[bool, dict]:
    """Stable iff the run finishes and max ||y_n|| <= GROWTH * max ||y_true(t_n)||."""
    traj = step(method, scene, dt, steps, 1, timeout)
    if not traj.ok:
        return False, {"status": traj.status, "failed_step": traj.failed_step}
    q_true, v_true, _ = true_state(scene, traj.t)
    size = float(np.max(np.linalg.norm(scaled_state(scene, traj.q[:, 0], traj.v[:, 0]), axis=-1)))
    true_size = float(np.max(np.linalg.norm(scaled_state(scene, q_true, v_true), axis=-1)))
    growth = size / true_size if true_size > 0 else math.inf
    return bool(growth <= GROWTH), {"growth": growth}


def largest_stable_dt(method, scene: Scene, *, criterion: str = "auto", steps: int = HORIZON_STEPS,
                      lo: float = HOMEGA_LO, hi: float = HOMEGA_HI, scan_ratio: float = SCAN_RATIO,
                      rtol: float = BISECT_RTOL, timeout: float | None = None) -> dict:
    """Largest stable dt of ``method`` on ``scene`` by the rule in the module docstring.

    ``criterion``: ``auto`` (spectral radius on linear scenes where the map can be
    measured, else finite horizon), ``spectral_radius`` or ``finite_horizon``; ``lo``,
    ``hi`` are h*omega bounds of the search. For linear scenes the result also carries
    the one-step map at ``dt_max``."""
    method = resolve(method, scene)
    require_fixed_step(method, "the largest stable timestep")
    if criterion not in CRITERIA:
        raise InvalidInput(f"unknown criterion {criterion!r} (valid: {', '.join(CRITERIA)})")
    if not (0.0 < lo < hi and math.isfinite(hi)):
        raise InvalidInput(f"search range lo={lo}, hi={hi} is invalid (allowed: 0 < lo < hi, finite)")
    if not (scan_ratio > 1.0 and 0.0 < rtol < scan_ratio - 1.0):
        raise InvalidInput(f"scan_ratio={scan_ratio}, rtol={rtol} are invalid (allowed: scan_ratio > 1, "
                           "0 < rtol < scan_ratio - 1)")
    omega = scene.omega
    note = ""
    use = criterion
    if criterion == "auto":
        use = "spectral_radius" if scene.linear else "finite_horizon"
    if use == "spectral_radius":
        if not scene.linear:
            raise InvalidInput(f"criterion spectral_radius needs a linear scene ({scene.id} is not)")
        first = one_step_map(method, scene, lo / omega, timeout=timeout)
        if first["rho"] is None:
            if criterion != "auto":
                raise InvalidInput(f"criterion spectral_radius does not apply: {first['reason']}")
            use, note = "finite_horizon", f"spectral radius not measurable ({first['reason']}); finite horizon used"

    if use == "spectral_radius":
        def test(dt):
            return spectral_test(method, scene, dt, timeout=timeout)
        described = f"spectral radius of the one-step map <= 1 + {RHO_TOL:g}"
    else:
        def test(dt):
            return finite_horizon_test(method, scene, dt, steps=steps, timeout=timeout)
        described = (f"finite horizon: {steps} steps finish and max ||(q, v/omega)|| <= {GROWTH:g} x "
                     "the true solution's")

    evaluations = []

    def stable(homega):
        ok, info = test(homega / omega)
        evaluations.append({"omega_dt": homega, "stable": ok, **info})
        return ok

    out = {"scene": scene.id, "params": dict(scene.values), "method": method.id, "criterion": use,
           "criterion_rule": described, "omega": omega, "dt_searched_min": lo / omega,
           "dt_searched_max": hi / omega, "omega_dt_searched": [lo, hi]}
    if note:
        out["note"] = note
    if use == "finite_horizon":
        out["horizon_steps"] = steps
    if not stable(lo):
        out.update(verdict="unstable", dt_max=None, omega_dt_max=None,
                   detail=f"unstable already at the smallest h*omega searched ({lo:g}): unstable for every dt")
        out["evaluations"] = len(evaluations)
        return _with_map(out, method, scene, lo / omega, timeout)
    good, bad = lo, None
    x = lo
    while x < hi:
        x = min(x * scan_ratio, hi)
        if stable(x):
            good = x
        else:
            bad = x
            break
    if bad is None:
        out.update(verdict="unbounded", dt_max=None, omega_dt_max=None,
                   detail=f"stable at every h*omega searched, up to {hi:g}")
        out["evaluations"] = len(evaluations)
        return _with_map(out, method, scene, hi / omega, timeout)
    while bad / good - 1.0 > rtol:
        mid = math.sqrt(good * bad)
        if stable(mid):
            good = mid
        else:
            bad = mid
    out.update(verdict="limited", dt_max=good / omega, omega_dt_max=good,
               first_unstable_omega_dt=bad, evaluations=len(evaluations))
    if use == "spectral_radius":
        out["rho_above_dt_max"] = one_step_map(method, scene, bad / omega, timeout=timeout)["rho"]
    return _with_map(out, method, scene, good / omega, timeout)


def _with_map(out: dict, method, scene: Scene, dt: float, timeout) -> dict:
    """Attach the one-step map at the dt the verdict rests on (dt_max; the smallest dt
    searched when unstable; the largest when unbounded). On a linear scene judged by the
    finite horizon it is attached too, where measurable: it shows what the horizon missed."""
    if scene.linear:
        res = one_step_map(method, scene, dt, timeout=timeout)
        if res["rho"] is None:
            out["spectral"] = {"dt": dt, "rho": None, "reason": res["reason"]}
            if out["criterion"] == "spectral_radius":
                out["note"] = f"at the reported dt: {res['reason']}; the spectral verdict is doubtful"
        else:
            out["spectral"] = {k: res[k] for k in ("dt", "omega_dt", "rho", "eigenvalues", "matrix", "offset",
                                                   "linearity_residual")}
    return out
