"""One nightly task -> its measured cells (plain dicts, one per measure; see ``storage``).

A scene x method task measures, at the suite's nominal timestep h = homega / omega (or the
scene spec's ``dt`` where the study is fixed in the scene's units):
``energy`` (max |dE/E| against the exact energy, its classification, a downsampled series
for the chart), ``error`` (max global error over the same run), ``order`` (the dt sweep,
whose points also give the work-precision chart), ``stability`` (largest stable h*omega),
``cost`` (counted evaluations, and CPU time per step with its ratio to explicit Euler timed
side by side in the same worker; see below) and, for engine modes, ``identity`` (which
reference scheme it integrates). Some scenes add cells of their own (``harness.nightly.scene_cells``:
constraint drift, damping far beyond the explicit limit, cost against size). A bound task
measures one reviewed energy bound exactly as the file states it.

Cost is timed on the worker's CPU clock, not the wall clock: the nightly runs its cells in
parallel on shared cores, where a repeat's wall time includes waiting for a core. Measured
on this project's 2-core machine under a load of 7, pymunk's step read 30-73 us of wall
time and 9.2-13 us of CPU time; the compiled explicit-Euler step 93-990 ns wall, 93-108 ns
CPU. On an idle core the two clocks agree (the steps run in one thread).

A task's cells are sent back one by one as they are measured
(``pool.report_partial``), so a task that later crashes or hangs keeps them.

Every cell records the textbook claims it is judged against (from the scheme's
declarations, or for an engine mode from the scheme it was identified as), so the report
never needs to import the schemes or the engines.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict

import numpy as np

from scenarios import make_scene

from harness.nightly.suites import SUITES, Suite

#: The measures of a scene x method task, in the order they run (identity first for an engine
#: mode: the scheme it is identified as gives the claims its other cells are judged by). The
#: stability search runs last: its cost is the least bounded (a finite-horizon test against a
#: reference solve took 24 s at h*omega = 1 on the solar system), and a task that times out
#: in it keeps every cell before it.
MEASURES = ("energy", "error", "order", "cost", "stability")

#: The scheme an engine mode's name suggests, for the findings ("implicit" that is not).
#: A bare "euler" suggests no one scheme (MuJoCo documents its Euler as semi-implicit).
NAME_SUGGESTS = {"implicit": "implicit_euler", "implicitfast": "implicit_euler", "rk4": "rk4",
                 "discrete": "implicit_euler", "semi_implicit": "semi_implicit_euler", "leapfrog": "leapfrog"}


def suite_of(task) -> Suite:
    """The task's suite: carried by the task (a worker needs nothing else), or named."""
    return task.suite if isinstance(task.suite, Suite) else SUITES[task.suite]


def measures_for(task, method=None) -> list[str]:
    """The task's measures, in the order ``run_task`` measures them."""
    from harness.methods import get_method

    suite = suite_of(task)
    out = list(MEASURES)
    if not suite.scenes[task.scene].stability:
        out.remove("stability")
    if (method or get_method(task.method)).adaptive:
        # It picks its own steps (dt is the output interval): nothing to measure against dt.
        out = [m for m in out if m not in ("order", "stability")]
    if suite.scenes[task.scene].advise is not None and "order" in out:  # fixed-step methods only
        out.append("advise")
    if task.family != "ref" and suite.identify and not make_scene(task.scene, **task.params).constrained:
        # A constrained scene's only reference scheme projects positions; no engine integrates
        # that (MuJoCo's rope is reduced coordinates, pymunk's impulses): nothing to identify.
        out.insert(0, "identity")
    from harness.nightly.scene_cells import measures_for as scene_measures

    return out + scene_measures(task, suite.scenes[task.scene])


def _claims(method, scene=None) -> dict:
    """The textbook claims a method's cells are judged by; the order is the one declared for
    the scene (a lower one where its force depends on the velocity, with a note saying so)."""
    scheme = method.scheme
    if scheme is None:
        return {}
    velocity = scene is not None and scene.velocity_dependent
    order = scheme.order_for(velocity)
    note = {"order_note": f"{order} with a velocity-dependent force ({scheme.order} otherwise)"} \
        if order != scheme.order else {}
    return {"order": order, **note, "force_evals": scheme.force_evals,
            "force_evals_text": f"{scheme.force_evals} + solve" if scheme.implicit else str(scheme.force_evals),
            "energy": scheme.energy_claim, "homega_max": scheme.homega_max, "scheme": f"ref:{scheme.id}"}


def _cell(task, measure, status="ok", value=None, dt=None, steps=None, detail="", data=None, wall=0.0) -> dict:
    return {"scene": task.scene, "method": task.method, "family": task.family, "measure": measure,
            "dt": dt, "steps": steps, "status": status, "detail": detail or "", "value": value,
            "wall_s": wall, "data": data or {}}


def _finite(x):
    return None if x is None or not np.isfinite(x) else float(x)


def _downsample(n: int, points: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, points)).astype(int))


def run_task(task) -> list[dict]:
    """Runs in a worker process. Any exception becomes a ``crashed`` cell with the message."""
    from harness.execution.pool import report_partial
    from harness.methods import get_method, use_plugins

    use_plugins(task.plugins)
    if task.kind == "bound":
        return [_guard(task, "bound", lambda: _bound(task))]
    suite = suite_of(task)
    spec = suite.scenes[task.scene]
    scene = make_scene(task.scene, **task.params)
    method = get_method(task.method)
    dt = nominal_dt(spec, scene)
    # Long runs of reference schemes on the compiled path (same states); counting stays interpreted.
    run_method = method.compiled_twin() if spec.compiled else method
    claims = _claims(method, scene)
    cells = []

    def keep(*new):
        for c in new:
            c["data"].setdefault("claims", claims)
            cells.append(c)
            report_partial(c)

    measures = measures_for(task, method)
    if "identity" in measures:
        identity = _guard(task, "identity", lambda: _identity(task, method, scene))
        if identity["status"] == "ok" and identity["data"].get("match_claims"):
            claims = identity["data"]["match_claims"]
        keep(identity)
    keep(*_guard_many(task, ("energy", "error"), lambda: _energy_and_error(task, run_method, scene, dt, spec, suite)))
    if "order" in measures:
        keep(_guard(task, "order", lambda: _order(task, run_method, scene, spec)))
    cost = _guard(task, "cost", lambda: _cost(task, method, scene, dt, suite))
    keep(cost)
    if "advise" in measures:
        keep(*_guard_many(task, ("advise",), lambda: _advise(task, method, scene, spec, suite, cost)))
    if "stability" in measures:
        keep(_guard(task, "stability", lambda: _stability(task, run_method, scene, suite, spec)))
    from harness.nightly.scene_cells import scene_cells

    keep(*scene_cells(task, method, scene, dt, spec, suite, claims))
    return cells


def nominal_dt(spec, scene) -> float:
    return spec.dt if spec.dt is not None else spec.homega / scene.omega


def energy_steps(spec, scene, dt: float) -> int:
    horizon = spec.horizon if spec.horizon is not None else spec.periods * scene.period
    return max(10, int(round(horizon / dt)))


def _kernels_since(before: dict, cell: dict) -> None:
    """Record in ``cell`` the compiled kernels its measure compiled or loaded from the disk
    cache (``reference._kernels.STATS`` counts both in this process), if any."""
    from reference import KERNEL_STATS as STATS

    now = STATS.snapshot()
    delta = {k: now[k] - before[k] for k in now}
    if delta["kernels_compiled"] or delta["kernels_loaded"]:
        cell["data"]["kernels"] = delta


def _guard(task, measure, fn) -> dict:
    from reference import KERNEL_STATS as STATS

    t0 = time.perf_counter()
    before = STATS.snapshot()
    try:
        cell = fn()
    except Exception as exc:  # a measurement error is a recorded result, not a dead run
        cell = _cell(task, measure, "crashed", detail=f"{type(exc).__name__}: {exc}"[:500])
    cell["wall_s"] = time.perf_counter() - t0
    _kernels_since(before, cell)
    return cell


def _guard_many(task, measures, fn) -> list[dict]:
    from reference import KERNEL_STATS as STATS

    t0 = time.perf_counter()
    before = STATS.snapshot()
    try:
        cells = fn()
    except Exception as exc:
        cells = [_cell(task, m, "crashed", detail=f"{type(exc).__name__}: {exc}"[:500]) for m in measures]
    for c in cells:
        c["wall_s"] = (time.perf_counter() - t0) / len(cells)
    _kernels_since(before, cells[0])
    return cells


def energy_run(scene, dt, spec, suite) -> tuple[int, int]:
    """(steps, every) of the energy run: ``spec.horizon`` (else ``spec.periods`` periods), about
    4 x series_points recorded."""
    steps = energy_steps(spec, scene, dt)
    return steps, max(1, steps // (4 * suite.series_points))


def _energy_and_error(task, method, scene, dt, spec, suite) -> list[dict]:
    from harness.measures.energy import classify, escaped_states, relative_error_defined, relative_error_series
    from harness.measures.error import trajectory_error
    from harness.execution.simulate import simulate

    steps, every = energy_run(scene, dt, spec, suite)
    traj = simulate(method, scene, dt, steps, every, timeout=suite.cell_timeout)
    settings = {"settings": traj.meta.get("settings"), "engine_version": traj.meta.get("engine_version"),
                "backend": traj.meta.get("backend")}
    if traj.status not in ("ok", "unstable") or traj.q.shape[0] == 0:
        return [_cell(task, m, traj.status, dt=dt, steps=steps, detail=traj.detail, data=dict(settings))
                for m in ("energy", "error")]
    e_exact, rel = relative_error_series(traj, scene)
    cls = classify(traj.energy[:, 0], e_exact, traj.t, unstable=traj.status == "unstable",
                   escaped=escaped_states(scene, traj))
    idx = _downsample(len(traj.t), suite.series_points)
    series = {"t": traj.t[idx], "energy": traj.energy[idx, 0], "exact": e_exact[idx]}
    # A falling projectile's exact energy crosses zero: there max |dE/E| is a number without
    # a meaning (it read 273 for explicit Euler), so none is stored.
    defined = relative_error_defined(e_exact)
    with np.errstate(all="ignore"):
        max_rel = _finite(np.nanmax(np.abs(rel))) if traj.ok and defined else None
    energy = _cell(task, "energy", traj.status, max_rel, dt, steps, traj.detail,
                   {"class": cls.get("classification"), "rule": cls.get("rule"), "rel_error_defined": defined,
                    "final_rel_error": _finite(abs(rel[-1])) if traj.ok and defined else None,
                    "failed_step": traj.failed_step, "series": series, "numbers": _plain(cls), **settings})
    err = trajectory_error(traj, scene) if traj.ok else {}
    error = _cell(task, "error", traj.status, _finite(err.get("error_max")), dt, steps, traj.detail,
                  {"error_final": err.get("error_final"), "source": err.get("source"),
                   "t_compared": err.get("t_compared"), "horizon": err.get("horizon"),
                   "t_final": err.get("t_final")})
    return [energy, error]


def _order(task, method, scene, spec) -> dict:
    from harness.measures.order import observed_order

    res = observed_order(method, scene, points=spec.order_points, span=spec.order_span, periods=spec.order_periods)
    order = res.get("order")
    excluded = res.get("excluded", [])
    status, detail = "ok", ""
    if order is None or not np.isfinite(order):
        status, detail = "unstable", "too few usable points"
        if not res.get("points") and excluded and all(p["reason"].startswith("roundoff floor") for p in excluded):
            # Nothing failed: the method is more accurate than the floor at every dt of the sweep
            # (SABA(10,6,4) on the solar system), so it has no measurable order here.
            status, detail = "ok", "no order: every error at or below the roundoff/reference floor"
    return _cell(task, "order", status, _finite(order), detail=detail,
                 data={"points": _plain(res.get("points", [])), "excluded": _plain(res.get("excluded", [])),
                       "rvalue": res.get("rvalue"), "range": _plain(res.get("range"))})


def _stability(task, method, scene, suite, spec) -> dict:
    from harness.measures.stability import largest_stable_dt

    hi = spec.stability_hi if spec.stability_hi is not None else suite.stability_homega_max
    res = largest_stable_dt(method, scene, steps=suite.stability_steps, hi=hi)
    verdict = res.get("verdict")
    data = {"criterion": res.get("criterion"), "criterion_rule": res.get("criterion_rule"), "verdict": verdict,
            "dt_max": res.get("dt_max"), "unbounded": verdict == "unbounded",
            "unstable_everywhere": verdict == "unstable",
            "homega_searched": (res.get("dt_searched_max") or 0) * scene.omega,
            "rho_above_dt_max": res.get("rho_above_dt_max")}
    value = res.get("omega_dt_max")
    if verdict == "unbounded":
        value = math.inf
    return _cell(task, "stability", "ok", value, detail=res.get("detail", ""), data=_plain(data))


def _cost(task, method, scene, dt, suite) -> dict:
    """Counted evaluations; CPU seconds per step and, timed in this worker on the same clock in
    repeats interleaved with the method's, explicit Euler's (the ratio's baseline)."""
    from harness.measures.cost import cost_per_step

    res = cost_per_step(method, scene, dt, time_steps=suite.cost_steps, repeats=suite.cost_repeats, clock="cpu")
    base = res["baseline"]
    return _cell(task, "cost", "ok", res.get("s_per_step"), dt, res.get("time_steps"),
                 data={"force_evals_per_step": res.get("force_evals_per_step"),
                       "solves_per_step": res.get("solves_per_step"), "timing": res.get("timing"),
                       "clock": res.get("clock"), "repeats_s_per_step": res.get("repeats_s_per_step"),
                       "spread": res.get("rel_spread") or 0.0,
                       "ratio_to_explicit_euler": res.get("ratio_to_explicit_euler"),
                       "ratio_spread": res.get("ratio_spread") or 0.0, "ratio_repeats": res.get("ratio_repeats"),
                       "baseline_s_per_step": base.get("s_per_step"),
                       "baseline_repeats_s_per_step": base.get("repeats_s_per_step"),
                       "loop": res.get("loop"), "engine_loop": res.get("engine_loop"),
                       # An engine mode's second figure: stepped one call at a time from Python.
                       "as_stepped_s_per_step": res.get("as_stepped_s_per_step"),
                       "as_stepped_repeats_s_per_step": (res.get("as_stepped") or {}).get("repeats_s_per_step"),
                       "as_stepped_timing": (res.get("as_stepped") or {}).get("timing")})


def _advise(task, method, scene, spec, suite, cost) -> list[dict]:
    """One cell per frame rate of the suite: the method's search over substeps
    (``harness.measures.advise.advise_method``), its cost per step from this task's cost cell. Value:
    the cost per frame of the fewest substeps that meet the tolerances (None where none does)."""
    from harness.measures.advise import Request, advise_method

    per_step = (cost["value"], f"{cost['data'].get('timing')}; {cost['data'].get('clock')} clock (the cost cell)") \
        if cost["status"] == "ok" and cost["value"] else None
    cells = []
    for hz in suite.frame_rates:
        request = Request(hz=hz, **spec.advise).checked()
        res = advise_method(method, scene, request, timeout=suite.cell_timeout, cost_per_step=per_step)
        best = res.best_row
        cells.append(_cell(task, "advise", "ok", best.cost_per_frame_s if best is not None else None, 1.0 / hz,
                           data=_plain({"hz": hz, "request": asdict(request), **res.as_dict()})))
    return cells


def _identity(task, method, scene) -> dict:
    from reference import METHODS

    from harness.measures.identify import identify

    res = identify(method, scene)
    match = res.get("match")
    mode = task.method.split(":", 1)[1]
    match_claims = {}
    if match and match.startswith("ref:"):
        from harness.methods import RefMethod

        match_claims = _claims(RefMethod(METHODS[match[4:]]), scene)
    if res.get("status") not in ("ok", "unstable"):
        return _cell(task, "identity", res.get("status"), detail=res.get("detail"))
    runner = res.get("runner_up") or {}
    closest = (res.get("candidates") or [{}])[0]
    note = None
    if match is None and closest:
        note = (f"matches no reference scheme; closest `{closest.get('method')}` "
                f"(max deviation {closest.get('max_deviation', float('nan')):.2e})")
        if res.get("why_no_match"):
            note += f": {res['why_no_match']}"
    return _cell(task, "identity", "ok", _finite(res.get("max_deviation") if match else closest.get("max_deviation")),
                 res.get("dt"), res.get("steps"),
                 data={"match": match, "matches": list(res.get("matches") or []), "closest": closest.get("method"),
                       "runner_up": runner.get("method"),
                       "runner_up_deviation": _finite(runner.get("max_deviation")),
                       "name_suggests": NAME_SUGGESTS.get(mode), "match_claims": match_claims, "note": note})


def _bound(task) -> dict:
    from harness.pytest_plugin import measure_max_rel_energy_error

    value, status, detail = measure_max_rel_energy_error(task.method, task.scene, task.dt, task.steps, **task.params)
    return _cell(task, "bound", status, _finite(value), task.dt, task.steps, detail, {"bound": task.bound})


def failed_cells(task, failure) -> list[dict]:
    """The worker died or hung: the cells it sent before (``failure.partial``) are kept, and
    every measure it did not finish is recorded with that outcome, the first of them (where
    the worker was lost) with why, the rest as not reached."""
    detail = getattr(failure, "detail", str(failure))
    status = getattr(failure, "status", "crashed")
    done = [c for c in getattr(failure, "partial", None) or [] if isinstance(c, dict)]
    measured = {c["measure"] for c in done}
    missing = [m for m in task.measures() if m not in measured]
    wall = getattr(failure, "seconds", 0.0) - sum(c.get("wall_s") or 0.0 for c in done)
    out = list(done)
    for i, m in enumerate(missing):
        why = detail if i == 0 else f"not reached: the worker was lost in {missing[0]} ({detail})"
        out.append(_cell(task, m, status, detail=why, dt=task.dt if task.kind == "bound" else None,
                         steps=task.steps if task.kind == "bound" else None,
                         data={"bound": task.bound} if task.kind == "bound" else {},
                         wall=max(wall, 0.0) if i == 0 else 0.0))
    return out


def _plain(x):
    """numpy values -> JSON-able Python."""
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items() if not isinstance(v, np.ndarray) or v.size <= 4096}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x
