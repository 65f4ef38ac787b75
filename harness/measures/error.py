"""Global error of a method against the exact solution, or a reference solve where the scene
has no closed form.

The rule, one way for every method:

* the state is compared in scaled form ``y = (q, v/omega)`` (positions and velocities in
  the same units), at every recorded step;
* ``error(t_n) = ||y_n - y(t_n)||_2 / max_m ||y(t_m)||_2``: the distance from the true
  state, relative to the largest size of the true state over the run;
* ``error_max`` is the largest of these over the run (the sup norm in time, which a lucky
  final-time cancellation cannot hide), ``error_final`` the one at the last step.

The true state is ``scene.closed_form(t)`` where that exists; otherwise the scene's own
``reference_solution(t)`` where it provides one (a solve of the scene's true model, vectorised
and cached: the rope's reduced model, the solar system's pair sum), trusted up to the scene's
``reference_horizon``: the error is then measured over ``t <= reference_horizon`` only
(``horizon`` in the result says how far, ``t_compared`` the last time compared; the energy needs no reference and
covers the whole run). Otherwise scipy's DOP853 at ``rtol = 1e-13`` (``atol`` 1e-15 of the initial state's
size) on the scene's force kernel, computed once per (scene, parameters, times) and cached
for the process. A reference is trusted to about 1e-11 relative, so smaller errors are not
measured (``order`` leaves them out).

Where the scene's reference is one engine's own run (``Scene.reference_engine``: a model
file's MuJoCo RK4) and the method is another engine's (pybullet on the same file), the method
integrates that engine's model of the file, and its distance from MuJoCo's run is mostly the
difference of the two models (``cross_engine`` measures it), not its discretisation error. Its
error is then measured against its **own refined run**, the same mode at dt/2 over the same
steps (``own_run_error``): Richardson's estimate ``||y(dt) - y(dt/2)|| / (1 - 2^-p)`` (p the
mode's declared order, 1 where it declares none), relative to the largest size of the refined
run; ``source`` says so. The order measured from these estimates is the slope of the halving
differences, which falls as dt^p for a method of order p whatever p was assumed (the factor
is a constant).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict

import numpy as np

from records import Trajectory

from scenarios import Scene

from harness.measures.common import resolve, scaled_state, step

#: DOP853 tolerances of the reference solve.
REFERENCE_RTOL = 1e-13
REFERENCE_ATOL_REL = 1e-15
#: A reference solve is trusted to this relative error (100x its rtol: DOP853's global
#: error over the horizons used here stays within a few hundred local tolerances).
REFERENCE_FLOOR = 1e-11
#: Reference solves kept per process.
CACHE_SIZE = 64

_CACHE: OrderedDict[tuple, tuple[np.ndarray, np.ndarray]] = OrderedDict()


def reference_solution(scene: Scene, t) -> tuple[np.ndarray, np.ndarray]:
    """(q, v) at times ``t`` (shape (len(t), ndof)) from DOP853 at REFERENCE_RTOL, cached
    per scene id, parameter values and the exact times asked for."""
    from scipy.integrate import solve_ivp

    t = np.ascontiguousarray(np.asarray(t, dtype=float).reshape(-1))
    key = (scene.id, tuple(sorted(scene.values.items())), hashlib.sha1(t.tobytes()).hexdigest())
    if key in _CACHE:
        _CACHE.move_to_end(key)
        q, v = _CACHE[key]
        return q.copy(), v.copy()
    q0, v0 = scene.initial_state()
    n, p = scene.ndof, scene.pvec
    y0 = np.concatenate([q0, v0]).astype(float)

    def rhs(time, y):
        q, v = y[:n].reshape(n, 1), y[n:].reshape(n, 1)
        return np.concatenate([y[n:], np.asarray(scene.accel(q, v, time, p)).reshape(n)])

    t_end = float(t.max(initial=0.0))
    if t_end <= 0.0:
        ys = np.tile(y0, (len(t), 1))
    else:
        atol = REFERENCE_ATOL_REL * max(1.0, float(np.max(np.abs(y0))))
        sol = solve_ivp(
            rhs, (0.0, t_end), y0, method="DOP853", t_eval=np.sort(np.unique(t)), rtol=REFERENCE_RTOL, atol=atol
        )
        if not sol.success:
            raise RuntimeError(f"reference solve of {scene.id} failed: {sol.message}")
        ys = sol.y.T[np.searchsorted(sol.t, t)]
    q, v = ys[:, :n].copy(), ys[:, n:].copy()
    _CACHE[key] = (q, v)
    while len(_CACHE) > CACHE_SIZE:
        _CACHE.popitem(last=False)
    return q.copy(), v.copy()


def true_state(scene: Scene, t) -> tuple[np.ndarray, np.ndarray, str]:
    """(q, v, source): the exact solution where the scene has one, else the scene's reference
    solution where it has one, else the reference solve."""
    t = np.asarray(t, dtype=float)
    exact = scene.closed_form(t)
    if exact is not None:
        return exact[0], exact[1], "exact"
    own = scene.reference_solution(t)  # Scene's default is exact(t): None here
    if own is not None:
        return own[0], own[1], f"{scene.id} reference_solution"
    q, v = reference_solution(scene, t)
    return q, v, f"reference DOP853 rtol={REFERENCE_RTOL:g}"


def trusted_until(scene: Scene) -> float:
    """How far the true state of ``true_state`` may be used: inf for an exact solution."""
    return float(scene.reference_horizon)


def trajectory_error(traj: Trajectory, scene: Scene) -> dict:
    """The global error of an already-run trajectory (batch member 0), by the rule above."""
    if traj.q.shape[0] == 0:
        return {"error_max": None, "error_final": None, "scale": None, "source": None}
    horizon = trusted_until(scene)
    keep = traj.t <= horizon  # t = 0 is always kept
    t = traj.t[keep]
    q_true, v_true, source = true_state(scene, t)
    y = scaled_state(scene, traj.q[keep, 0, :], traj.v[keep, 0, :])
    y_true = scaled_state(scene, q_true, v_true)
    scale = float(np.max(np.linalg.norm(y_true, axis=-1)))
    with np.errstate(all="ignore"):
        err = np.linalg.norm(y - y_true, axis=-1) / scale
    accuracy = reference_accuracy(scene, t, source)
    error_max = float(np.max(err))
    if source != "exact" and not scene.reference_judges():
        # A reference that did not converge judges nothing: its error is no bound on anything.
        return {
            "error_max": None,
            "error_final": None,
            "t_final": float(traj.t[-1]),
            "t_compared": float(t[-1]),
            "horizon": None if horizon == float("inf") else horizon,
            "compared_all": bool(keep.all()),
            "scale": scale,
            "source": source,
            "series": err,
            "series_t": t,
            "reference_error": accuracy,
            "below_reference": False,
            "not_judged": f"not judged: the reference did not converge ({scene.reference_description()})",
        }
    return {
        "error_max": error_max,
        "error_final": float(err[-1]),
        "t_final": float(traj.t[-1]),
        "t_compared": float(t[-1]),
        "horizon": None if horizon == float("inf") else horizon,
        "compared_all": bool(keep.all()),
        "scale": scale,
        "source": source,
        "series": err,
        "series_t": t,
        "reference_error": accuracy,
        "below_reference": bool(error_max <= accuracy),
    }


def measured_against_own_run(method, scene: Scene) -> bool:
    """Whether ``method`` is measured against its own refined run on ``scene`` (the rule above)."""
    if scene.own_run_reference:
        return True
    return scene.reference_engine is not None and method.family != scene.reference_engine


def richardson(
    scene: Scene, coarse: Trajectory, fine: Trajectory, order: int, scale: float | None = None, n: int | None = None
):
    """(estimate, difference series, scale): the error of ``coarse`` from the same method's run at
    half its step (``fine``, recorded at the same times), over their first ``n`` records (default
    all), ``||y_c - y_f|| / (1 - 2^-p)`` relative to ``scale`` (default: the largest size of the
    fine run)."""
    yc = scaled_state(scene, coarse.q[:n, 0, :], coarse.v[:n, 0, :])
    yf = scaled_state(scene, fine.q[:n, 0, :], fine.v[:n, 0, :])
    if scale is None:
        scale = float(np.max(np.linalg.norm(yf, axis=-1)))
    with np.errstate(all="ignore"):
        series = np.linalg.norm(yc - yf, axis=-1) / scale / (1.0 - 2.0**-order)
    return float(np.max(series)), series, scale


def own_run_error(method, scene: Scene, traj: Trajectory, timeout: float | None = None) -> dict:
    """The error of ``traj`` (a run of ``method``) against the method's own run at half its step,
    over the scene's reference horizon, with the fields of ``trajectory_error``; None fields
    where the refined run did not finish."""
    from harness.measures.common import declared_order

    dt = float(traj.dt)
    every = int(round((traj.t[1] - traj.t[0]) / dt)) if len(traj.t) > 1 else 1
    horizon = trusted_until(scene)
    keep = traj.t <= horizon
    steps = int(round(float(traj.t[keep][-1]) / dt))
    order = declared_order(method, scene) or 1
    why = (
        "no other engine's reference: only pybullet loads the file"
        if scene.own_run_reference
        else f"{scene.reference_engine}'s reference is another model"
    )
    source = f"own run at dt/2 (Richardson, order {order}): {why}"
    none = {
        "error_max": None,
        "error_final": None,
        "t_compared": None,
        "scale": None,
        "source": source,
        "reference_error": None,
        "below_reference": False,
    }
    fine = step(method, scene, dt / 2, 2 * steps, 2 * every, timeout)
    n = int(keep.sum())
    if not fine.ok or fine.q.shape[0] < n:
        return {**none, "detail": f"the refined run {fine.status}: {fine.detail}"}
    error_max, series, scale = richardson(scene, traj, fine, order, n=n)
    return {
        "error_max": error_max,
        "error_final": float(series[-1]),
        "t_final": float(traj.t[-1]),
        "t_compared": float(traj.t[n - 1]),
        "horizon": None if horizon == float("inf") else horizon,
        "compared_all": bool(keep.all()),
        "scale": scale,
        "source": source,
        "series": series,
        "series_t": traj.t[:n],
        "reference_error": error_max * 2.0**-order,
        "below_reference": False,
    }


def run_error(method, scene: Scene, traj: Trajectory, timeout: float | None = None) -> dict:
    """The global error of ``traj``, a finished run of ``method``: against the scene's truth
    (``trajectory_error``), or the method's own refined run where the rule above says so."""
    if measured_against_own_run(method, scene):
        return own_run_error(method, scene, traj, timeout)
    return trajectory_error(traj, scene)


def reference_accuracy(scene: Scene, t, source: str) -> float:
    """The relative error of the true state ``true_state`` gave at times t: 0 for the exact
    solution, the reference's own estimate where the scene states one (``Scene.reference_error``:
    a model file's refined RK4 run), else REFERENCE_FLOOR. An error at or below it is below the
    reference's accuracy: not a number to report."""
    if source == "exact":
        return 0.0
    own = scene.reference_error(t)
    return REFERENCE_FLOOR if own is None else float(own)


def global_error(
    method, scene: Scene, dt: float, steps: int, *, timeout: float | None = None, series: bool = False
) -> dict:
    """Step ``method`` for ``steps`` steps of ``dt`` and measure its global error.

    Returns ``error_max``/``error_final`` (None if the run failed), the run's ``status``,
    counted ``force_evals``/``solves`` and the error ``source``; ``series`` adds the error
    at every step."""
    method = resolve(method, scene)
    traj = step(method, scene, dt, steps, 1, timeout)
    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "dt": float(dt),
        "steps": int(steps),
        "status": traj.status,
        "detail": traj.detail,
        "force_evals": traj.force_evals,
        "solves": traj.solves,
    }
    if traj.ok:
        err = run_error(method, scene, traj, timeout)
        if series:
            out["t"] = err["series_t"]
            out["error_series"] = err["series"]
        out.update({k: v for k, v in err.items() if k not in ("series", "series_t")})
    else:
        out.update({"error_max": None, "error_final": None, "source": None, "reference_error": None})
    return out
