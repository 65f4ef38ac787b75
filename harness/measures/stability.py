"""Largest stable timestep, by a scan and bisection on dt, reported as dt and h*omega.

Two boundedness criteria, one rule each:

* ``spectral_radius`` (linear scenes, ``scene.linear``): a linear scene's one-step map is
  affine, y_1 = M y_0 + c. It is measured for any method, reference scheme or engine, by
  stepping one step from the zero state (giving c) and from each of the 2*ndof unit
  states (giving M's columns, minus c), y = (q, v). One more step from the sum of the unit
  states checks that the map really is affine (``linearity_residual``, the misfit relative
  to the unit inputs, <= LINEARITY_RTOL, else this criterion does not apply); the check
  runs at the smallest dt searched and at the dt the verdict rests on, not at every
  bisection step. An engine mode's 2*ndof + 2 one-step runs share one worker process.
  Stable iff rho(M) <= 1 + RHO_TOL. A reference scheme that carries more than (q, v) between
  steps (position Verlet the previous position, velocity Verlet the last acceleration) is
  measured on that carried state instead (``recurrence_map``): its recurrence's map, not a
  restart's. RHO_TOL = 1e-12
  is roundoff in M's entries (a few eps) with room; it is far below explicit Euler's
  rho - 1 = (h w)^2 / 2 = 5e-9 at the smallest h*omega searched, which a finite horizon
  never sees: 10,000 steps flag explicit Euler only above h*omega of a few hundredths.
  At h*omega = 2 exactly, semi-implicit Euler's M has a double eigenvalue -1 (rho = 1,
  polynomial growth); bisection never lands on it, so the limit is still 2.
* ``finite_horizon`` (every other scene, or on request): run ``steps`` steps (default
  10,000) and call the run stable iff it finishes (status ok, every state finite) and its
  size stays within GROWTH (10) times the true solution's:
  ``max_n ||y_n|| <= GROWTH * max_n ||y_true(t_n)||`` with y = (q, v/omega) and
  y_true the exact solution (or the reference solve) at the same times. A scene whose
  reference is trusted only up to ``reference_horizon`` (a chaotic rope) gives the true size
  from the recorded times within it: its size stays bounded by its energy after that.

The search: h*omega from ``lo`` (1e-4) up by factors of SCAN_RATIO (2) to ``hi``
(1e4); the first unstable grid point and the stable one before it are then bisected
(geometric midpoint) until they differ by BISECT_RTOL (1e-6) relative. Scanning up from
``lo`` finds the *first* loss of stability, not an island above it (a stretch of
instability narrower than a factor 2 can be stepped over). Verdicts: ``limited``
(``dt_max`` is the last stable dt found), ``unbounded`` (stable at every dt searched;
``dt_max`` is None and ``dt_searched_max`` says how far), ``unstable`` (unstable
already at ``lo``: explicit Euler's verdict on a spring, "unstable for every dt") or
``unresolved`` (no stable step resolved: ``growth_unresolved``).

A limit is a number only where the search resolves the growth below it. Heun's method on the
spring grows at every step, |R(iy)| = sqrt(1 + y^4/4), by rho - 1 = y^4/8: below RHO_TOL up to
y = 0.00168, so the spectral test calls every smaller step stable and the bisection "finds" the
step where the growth reaches the tolerance, a property of the criterion, not of the method.
Where the last step called stable still grows by more than a tenth of RHO_TOL (roundoff is far
below that) and half that step grows too, by less, the growth falls away with the step and never
reaches 1 at any step searched: the verdict is ``unresolved``, with no limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from records import InvalidInput, Method
from records.result import Result

from scenarios import Scene

from harness.measures.common import require_fixed_step, resolve, scaled_state, started_at, step
from harness.measures.error import true_state

RHO_TOL = 1e-12
#: The growth rho - 1 at the last stable step above which a limit is where an unresolved growth
#: reached RHO_TOL rather than where the method starts to grow (``growth_unresolved``).
UNRESOLVED_RHO = RHO_TOL / 10.0
LINEARITY_RTOL = 1e-8
GROWTH = 10.0
HORIZON_STEPS = 10_000
HOMEGA_LO = 1e-4
HOMEGA_HI = 1e4
SCAN_RATIO = 2.0
BISECT_RTOL = 1e-6
CRITERIA = ("auto", "spectral_radius", "finite_horizon")


def _one_step_here(method, scene: Scene, y0: np.ndarray, dt: float, timeout) -> tuple[np.ndarray | None, str]:
    n = scene.ndof
    traj = step(method, started_at(scene, y0[:n], y0[n:]), dt, 1, 1, timeout)
    if not traj.ok or traj.q.shape[0] < 2:
        return None, f"one step from {y0.tolist()} ended {traj.status}: {traj.detail}"
    return np.concatenate([traj.q[-1, 0], traj.v[-1, 0]]), ""


def _one_steps_here(method: Method, scene: Scene, states: np.ndarray, dt: float, timeout) -> list:
    """In this process. A method that can step many states on one model (an engine mode's
    ``one_steps``) builds it once, after the runner's checks."""
    if method.one_steps is not None:
        from harness import validate

        validate.scene_values(scene)
        stepped = method.one_steps(scene, validate.positive_finite("dt", dt), states)
        if stepped is not None:
            return stepped
    return [_one_step_here(method, scene, y, dt, timeout) for y in states]


def _one_steps_in_worker(method_id: str, scene: Scene, states: np.ndarray, dt: float):
    """Runs in a worker process: the engine is stepped in it directly."""
    from harness.methods import get_method

    return _one_steps_here(get_method(method_id), scene, states, dt, None)


def one_steps(method: Method, scene: Scene, states: np.ndarray, dt: float, timeout: float | None = None):
    """``(y_1, why)`` after one step of ``dt`` from each state ``y_0 = (q, v)`` (rows of
    ``states``); ``y_1`` is None, with the reason, where the step did not finish.

    An isolated (engine) method steps every state in one worker process: a state need not
    travel through the scene's parameters there, and one worker is far cheaper than one per
    state (a chain of N masses needs 2N + 2), as is one engine model set to each state in
    turn (``EngineMode.one_steps``) rather than one built per state. Inside a worker (the
    nightly's cells) the method is stepped in-process. A method the registry does not know
    cannot be re-created in a worker: it is stepped through the runner one state at a time,
    which only works for states the scene's parameters can carry (``started_at``)."""
    from harness.execution import isolation
    from harness.methods import all_methods

    states = np.atleast_2d(np.asarray(states, dtype=float))
    if not method.isolated or isolation.IN_WORKER:
        return _one_steps_here(method, scene, states, dt, timeout)
    if all_methods().get(method.id) is not None:
        limit = isolation.DEFAULT_TIMEOUT_S if timeout is None else timeout
        out = isolation.run_in_worker(_one_steps_in_worker, (method.id, scene, states, float(dt)), timeout=limit)
        if isinstance(out, isolation.WorkerFailure):
            return [(None, f"the one-step runs ended {out.status}: {out.detail}")] * len(states)
        return out
    n = scene.ndof
    results = []
    for y in states:
        if not started_at(scene, y[:n], y[n:]).state_in_params:
            results.append(
                (
                    None,
                    f"scene {scene.id} cannot start from an arbitrary state through its parameters, "
                    f"and {method.id} runs in a worker process",
                )
            )
        else:
            results.append(_one_step_here(method, scene, y, dt, timeout))
    return results


def one_step_map(
    method,
    scene: Scene,
    dt: float,
    *,
    timeout: float | None = None,
    check_affine: bool = True,
    base: np.ndarray | None = None,
) -> dict:
    """The one-step map y_1 = M y_0 + c of ``method`` on a linear ``scene`` at ``dt``,
    measured by stepping unit states (module docstring). Returns ``matrix``, ``offset``,
    ``eigenvalues``, ``rho`` and ``linearity_residual`` (None if ``check_affine`` is off),
    or ``rho`` None and ``reason``.

    ``base`` (default: the zero state) is the state the unit steps are taken from: the map
    is then measured from ``base`` and ``base + e_i`` (and probed at ``base + 1``). An affine
    map is the same from any base; an engine that branches on exact equalities is not
    (MuJoCo's discrete integrator leaves a tendon exactly at its rest length out of its
    implicit step), and a generic base shows the map it follows everywhere else."""
    method = resolve(method, scene)
    n = scene.ndof
    y_base = np.zeros(2 * n) if base is None else np.asarray(base, dtype=float).reshape(2 * n)
    eye = np.eye(2 * n)
    states = y_base + np.vstack([np.zeros(2 * n), eye] + ([np.ones(2 * n)] if check_affine else []))
    stepped = one_steps(method, scene, states, dt, timeout)
    for y, why in stepped:
        if y is None:
            return {"rho": None, "reason": why}
    M = np.array([y - stepped[0][0] for y, _ in stepped[1 : 2 * n + 1]]).T
    c = stepped[0][0] - M @ y_base
    with np.errstate(all="ignore"):
        eig = np.linalg.eigvals(M) if np.all(np.isfinite(M)) else np.full(2 * n, np.nan)
    out = {
        "dt": float(dt),
        "omega_dt": float(dt) * scene.omega,
        "matrix": M,
        "offset": c,
        "eigenvalues": eig,
        "rho": float(np.max(np.abs(eig))),
        "linearity_residual": None,
    }
    if not check_affine:
        return out
    probe = y_base + 1.0
    y = stepped[-1][0]
    predicted = M @ probe + c
    # Absolute against the unit-sized inputs: a scheme's own cancellations (implicit Euler
    # at h*omega = 1e4 forms 1/(1 + h^2) as 1 - h^2/(1 + h^2)) leave errors of eps there.
    scale = max(1.0, float(np.max(np.abs(predicted))), float(np.max(np.abs(M))), float(np.max(np.abs(y))))
    residual = float(np.max(np.abs(y - predicted))) / scale
    out["linearity_residual"] = residual
    if not residual <= LINEARITY_RTOL:
        out.update(rho=None, reason=f"one-step map is not affine (residual {residual:.3g} > {LINEARITY_RTOL:g})")
    return out


def recurrence_map(method, scene: Scene, dt: float, *, timeout: float | None = None, check_affine: bool = True) -> dict:
    """The map whose spectral radius is the method's stability: ``one_step_map`` on (q, v), except
    for a reference scheme that carries more between steps (``Scheme.carries``: the previous
    position, the last acceleration), whose map is measured on that carried state
    (``reference.carried_map``): restarting such a scheme from (q, v) would evaluate its carried
    acceleration afresh, at another velocity than the recurrence does where the force depends on
    it (position and velocity Verlet under damping). ``state`` names the map's coordinates."""
    method = resolve(method, scene)
    sch = method.scheme
    if sch is None or sch.carries == ("q", "v") or sch.constrained:
        res = one_step_map(method, scene, dt, timeout=timeout, check_affine=check_affine)
        res.setdefault("state", "(q, v)")
        return res
    from reference import carried_map

    M, c, names = carried_map(sch, scene, dt)
    with np.errstate(all="ignore"):
        eig = np.linalg.eigvals(M) if np.all(np.isfinite(M)) else np.full(len(M), np.nan)
    return {
        "dt": float(dt),
        "omega_dt": float(dt) * scene.omega,
        "matrix": M,
        "offset": c,
        "eigenvalues": eig,
        "rho": float(np.max(np.abs(eig))),
        "linearity_residual": None,
        "state": f"({', '.join(names)}): the state {sch.id} carries between steps",
    }


def spectral_test(method, scene: Scene, dt: float, *, timeout: float | None = None) -> tuple[bool, dict]:
    res = recurrence_map(method, scene, dt, timeout=timeout, check_affine=False)
    if res["rho"] is None:  # a step that did not finish is no stable step
        return False, {"rho": None, "reason": res["reason"]}
    return res["rho"] <= 1.0 + RHO_TOL, {"rho": res["rho"]}


def growth_unresolved(rho, homega: float) -> tuple[bool, float, float]:
    """Whether a spectral limit found at ``homega`` (the last step the search called stable; ``rho(y)``
    the spectral radius at h*omega = y) is no limit: (unresolved, rho - 1 there, rho - 1 at half of it).
    Unresolved where the step still grows by more than UNRESOLVED_RHO and half of it grows too, by
    less: a growth that shrinks with the step and is below what the search tells from 1 at every step
    below the "limit" (module docstring). A method that is stable below its limit has rho - 1 at or
    below roundoff there (a symplectic one) or below 0 at half of it (a damping one)."""
    at, half = rho(homega), rho(0.5 * homega)
    if at is None or half is None:  # a step that did not finish: nothing to say of its growth
        return False, math.nan, math.nan
    at, half = at - 1.0, half - 1.0
    return bool(at > UNRESOLVED_RHO and 0.0 < half < at), at, half


def unresolved_detail(homega: float, at: float, half: float) -> str:
    return (
        f"no stable step resolved: the one-step map grows at every step searched up to h*omega {homega:.6g}, "
        f"by less than the criterion tells from 1 (rho - 1 = {at:.3g} there, {half:.3g} at half of it; "
        f"stable means rho <= 1 + {RHO_TOL:g})"
    )


def finite_horizon_test(
    method, scene: Scene, dt: float, *, steps: int = HORIZON_STEPS, timeout: float | None = None
) -> tuple[bool, dict]:
    """Stable iff the run finishes and max ||y_n|| <= GROWTH * max ||y_true(t_n)||."""
    traj = step(method, scene, dt, steps, 1, timeout)
    if not traj.ok:
        return False, {"status": traj.status, "failed_step": traj.failed_step}
    blown, g, _ = blew_up(traj, scene)
    return not blown, {"growth": g}


def blew_up(traj, scene: Scene, true_size=None) -> tuple[bool, float, str]:
    """Whether a finished run blew up, by the scene's rule: (blown, the figure judged, what it
    says). A scene that declares ``runaway_limit`` (a model file, whose true solution is no
    closed form) is judged by how far its energy rose (``Scene.runaway``); every other by its
    size against the true solution's (``growth``, at most GROWTH; ``true_size``, called only
    there, gives the true solution's size where the caller holds the truth at other times)."""
    if scene.runaway_limit is not None:
        r = scene.runaway(traj.energy[:, 0])
        return not r <= scene.runaway_limit, r, f"energy rose {r:.3g}x its initial scale"
    g = growth(traj, scene, None if true_size is None else true_size())
    return not g <= GROWTH, g, f"grew to {g:.3g}x the true solution's size"


def horizon_rule(scene: Scene, steps: int) -> str:
    """The finite-horizon criterion in words, for ``scene``."""
    if scene.runaway_limit is not None:
        return (
            f"finite horizon: {steps} steps finish (no non-finite state, no engine warning) and the energy "
            f"rises at most {scene.runaway_limit:g} x its initial scale (kinetic + |potential|)"
        )
    return f"finite horizon: {steps} steps finish and max ||(q, v/omega)|| <= {GROWTH:g} x the true solution's"


def growth(traj, scene: Scene, true_size: float | None = None) -> float:
    """max_n ||y_n|| / max_n ||y_true(t_n)||, y = (q, v/omega), of a finished run (batch member 0);
    the true size from the recorded times within the scene's reference horizon, or as given."""
    if true_size is None:
        q_true, v_true, _ = true_state(scene, traj.t[traj.t <= max(scene.reference_horizon, traj.t[0])])
        true_size = float(np.max(np.linalg.norm(scaled_state(scene, q_true, v_true), axis=-1)))
    size = float(np.max(np.linalg.norm(scaled_state(scene, traj.q[:, 0], traj.v[:, 0]), axis=-1)))
    return size / true_size if true_size > 0 else math.inf


@dataclass(frozen=True)
class StabilityResult(Result):
    """What :func:`largest_stable_dt` found (the fields as its docstring and the module's describe)."""

    scene: str
    params: dict
    method: str
    criterion: str  # the criterion used (auto resolved)
    criterion_rule: str
    omega: float
    dt_searched_min: float
    dt_searched_max: float
    omega_dt_searched: list
    verdict: str  # limited | unbounded | unstable | unresolved
    dt_max: float | None  # None where unbounded or unstable
    omega_dt_max: float | None
    evaluations: int  # stability tests run
    detail: str = ""  # why there is no limit, where there is none
    note: str = ""  # a doubt about the criterion, where there is one
    horizon_steps: int | None = None  # the finite horizon's steps, where that criterion was used
    first_unstable_omega_dt: float | None = None
    rho_above_dt_max: float | None = None  # the spectral radius just above the limit (spectral criterion)
    spectral: dict | None = None  # the one-step map at the dt the verdict rests on (linear scenes)


def largest_stable_dt(
    method,
    scene: Scene,
    *,
    criterion: str = "auto",
    steps: int = HORIZON_STEPS,
    lo: float = HOMEGA_LO,
    hi: float = HOMEGA_HI,
    scan_ratio: float = SCAN_RATIO,
    rtol: float = BISECT_RTOL,
    timeout: float | None = None,
    progress=None,
) -> StabilityResult:
    """Largest stable dt of ``method`` on ``scene`` by the rule in the module docstring.

    ``criterion``: ``auto`` (spectral radius on linear scenes where the map can be
    measured, else finite horizon), ``spectral_radius`` or ``finite_horizon``; ``lo``,
    ``hi`` are h*omega bounds of the search. For linear scenes the result also carries
    the one-step map at ``dt_max``. ``progress``: told a line before each test (a command's
    progress), with how many the search will run."""
    method = resolve(method, scene)
    require_fixed_step(method, "the largest stable timestep")
    if criterion not in CRITERIA:
        raise InvalidInput(f"unknown criterion {criterion!r} (valid: {', '.join(CRITERIA)})")
    if not (0.0 < lo < hi and math.isfinite(hi)):
        raise InvalidInput(f"search range lo={lo}, hi={hi} is invalid (allowed: 0 < lo < hi, finite)")
    if not (scan_ratio > 1.0 and 0.0 < rtol < scan_ratio - 1.0):
        raise InvalidInput(
            f"scan_ratio={scan_ratio}, rtol={rtol} are invalid (allowed: scan_ratio > 1, 0 < rtol < scan_ratio - 1)"
        )
    omega = scene.omega
    note = ""
    use = criterion
    if criterion == "auto":
        use = "spectral_radius" if scene.linear else "finite_horizon"
    if use == "spectral_radius":
        if not scene.linear:
            raise InvalidInput(f"criterion spectral_radius needs a linear scene ({scene.id} is not)")
        first = recurrence_map(method, scene, lo / omega, timeout=timeout)
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

        described = horizon_rule(scene, steps)

    evaluations = []
    scan_runs = 1 + math.ceil(math.log(hi / lo) / math.log(scan_ratio) - 1e-9)
    runs = f"{steps} steps" if use == "finite_horizon" else "one step from each unit state"

    def stable(homega, doing, of):
        if progress is not None:
            progress(f"stability: {doing}: run {len(evaluations) + 1} of {of} ({runs} at h*omega {homega:.6g})")
        ok, info = test(homega / omega)
        evaluations.append({"omega_dt": homega, "stable": ok, **info})
        return ok

    out = {
        "scene": scene.id,
        "params": dict(scene.values),
        "method": method.id,
        "criterion": use,
        "criterion_rule": described,
        "omega": omega,
        "dt_searched_min": lo / omega,
        "dt_searched_max": hi / omega,
        "omega_dt_searched": [lo, hi],
    }
    if note:
        out["note"] = note
    if use == "finite_horizon":
        out["horizon_steps"] = steps
    scanning = f"scanning h*omega from {lo:g} up to {hi:g} by x{scan_ratio:g}"
    if not stable(lo, scanning, f"at most {scan_runs}"):
        out.update(
            verdict="unstable",
            dt_max=None,
            omega_dt_max=None,
            detail=f"unstable already at the smallest h*omega searched ({lo:g}): unstable for every dt",
        )
        out["evaluations"] = len(evaluations)
        return _with_map(out, method, scene, lo / omega, timeout)
    good, bad = lo, None
    x = lo
    while x < hi:
        x = min(x * scan_ratio, hi)
        if stable(x, scanning, f"at most {scan_runs}"):
            good = x
        else:
            bad = x
            break
    if bad is None:
        out.update(
            verdict="unbounded",
            dt_max=None,
            omega_dt_max=None,
            detail=f"stable at every h*omega searched, up to {hi:g}",
        )
        out["evaluations"] = len(evaluations)
        return _with_map(out, method, scene, hi / omega, timeout)
    while bad / good - 1.0 > rtol:
        mid = math.sqrt(good * bad)
        # Each geometric midpoint halves log(bad / good): the runs left until it is within rtol.
        left = max(1, math.ceil(math.log2(math.log(bad / good) / math.log1p(rtol))))
        if stable(
            mid, f"bisecting h*omega in [{good:.6g}, {bad:.6g}] to {rtol:g} relative", f"~{len(evaluations) + left}"
        ):
            good = mid
        else:
            bad = mid
    if use == "spectral_radius":
        unresolved, at, half = growth_unresolved(
            lambda y: recurrence_map(method, scene, y / omega, timeout=timeout, check_affine=False)["rho"], good
        )
        if unresolved:
            out.update(
                verdict="unresolved",
                dt_max=None,
                omega_dt_max=None,
                first_unstable_omega_dt=bad,
                evaluations=len(evaluations),
                detail=unresolved_detail(good, at, half),
            )
            return _with_map(out, method, scene, good / omega, timeout)
    out.update(
        verdict="limited",
        dt_max=good / omega,
        omega_dt_max=good,
        first_unstable_omega_dt=bad,
        evaluations=len(evaluations),
    )
    if use == "spectral_radius":
        out["rho_above_dt_max"] = recurrence_map(method, scene, bad / omega, timeout=timeout)["rho"]
    return _with_map(out, method, scene, good / omega, timeout)


def _with_map(out: dict, method, scene: Scene, dt: float, timeout) -> StabilityResult:
    """Attach the one-step map at the dt the verdict rests on (dt_max; the smallest dt
    searched when unstable; the largest when unbounded). On a linear scene judged by the
    finite horizon it is attached too, where measurable: it shows what the horizon missed."""
    if scene.linear:
        res = recurrence_map(method, scene, dt, timeout=timeout)
        if res["rho"] is None:
            out["spectral"] = {"dt": dt, "rho": None, "reason": res["reason"]}
            if out["criterion"] == "spectral_radius":
                out["note"] = f"at the reported dt: {res['reason']}; the spectral verdict is doubtful"
        else:
            out["spectral"] = {
                k: res[k]
                for k in ("dt", "omega_dt", "rho", "eigenvalues", "matrix", "offset", "linearity_residual", "state")
            }
    return StabilityResult(**out)
