"""One nightly task -> its measured cells (``records.cell.Cell``, one per measure).

A scene x method task measures, at the suite's nominal timestep h = homega / omega (or the
scene spec's ``dt`` where the study is fixed in the scene's units):
``energy`` (max |dE/E| against the exact energy, its classification, a downsampled series
for the chart), ``error`` (max global error over the same run), ``order`` (the dt sweep,
whose points also give the work-precision chart), ``stability`` (largest stable h*omega),
``cost`` (counted evaluations, and CPU time per step with its ratio to explicit Euler timed
side by side in the same worker; see below) and, for engine modes, ``identity`` (which
reference scheme it integrates). Some scenes add cells of their own (``harness.nightly.measures``:
constraint drift, damping far beyond the explicit limit, cost against size). A bound task
measures one reviewed energy bound exactly as the file states it.

Cost is timed on the worker's CPU clock, not the wall clock: the nightly runs its cells in
parallel on shared cores, where a repeat's wall time includes waiting for a core. Under load a
step's wall time spreads over several times its idle figure while its CPU time stays within
tens of percent of it (docs/performance.md). On an idle core the two clocks agree (the steps run in one thread).

A task's cells are sent back one by one as they are measured
(``pool.report_partial``), so a task that later crashes or hangs keeps them.

Every cell records the textbook claims it is judged against (from the scheme's
declarations, or for an engine mode from the scheme it was identified as), so the report
never needs to import the schemes or the engines.
"""

from __future__ import annotations

import math
from dataclasses import asdict, replace

import numpy as np

from scenarios import make_scene

from records.cell import (
    AdviceFigures,
    BoundFigures,
    Cell,
    Claims,
    CostFigures,
    EnergyFigures,
    ErrorFigures,
    IdentityFigures,
    NominalRun,
    OrderFigures,
    StabilityFigures,
)

from records.measures import Column, Comparison, Measure, TaskContext, Worse, measures, register
from records.method_id import scheme_name

from harness.nightly.cell_kit import energy_run, finite, guard, guard_many, make_cell, nominal_dt, plain
from harness.nightly.measures import declared
from harness.history.compare import ORDER_DROP, PROCESS_SPREAD, STABILITY_DROP
from harness.nightly.suites import SUITES, Suite

#: The scheme an engine mode's name suggests, for the findings ("implicit" that is not).
#: A bare "euler" suggests no one scheme (MuJoCo documents its Euler as semi-implicit).
NAME_SUGGESTS = {
    "implicit": "implicit_euler",
    "implicitfast": "implicit_euler",
    "rk4": "rk4",
    "discrete": "implicit_euler",
    "semi_implicit": "semi_implicit_euler",
    "leapfrog": "leapfrog",
}


def suite_of(task) -> Suite:
    """The task's suite: carried by the task (a worker needs nothing else), or named."""
    return task.suite if isinstance(task.suite, Suite) else SUITES[task.suite]


def context(task, method=None) -> TaskContext:
    """The task's ``TaskContext`` before any cell is measured. A reference scheme steps on its
    compiled loop wherever that computes the interpreted bits (``reference.RefMethod``)."""
    from harness.methods import get_method

    suite = suite_of(task)
    scene = make_scene(task.scene_id or task.scene, source=task.source, **task.params)
    if getattr(task, "only", ()) and task.scene not in suite.scenes:
        # A task of the suite's own tables (its contact cells, ``Task.only``): its measure reads the
        # scene and the method id; no scene spec sets its step, and no scheme's claims judge it.
        return TaskContext(task, suite, None, scene, claims=None)
    spec = suite.scenes[task.scene]
    method = method or get_method(task.method, compiled_where_bitwise=True)
    dt = nominal_dt(spec, scene)
    # Runs too long to interpret on the compiled loop whatever its bits, not counted (the scene's spec).
    run_method = method.compiled_twin() if spec.compiled else method
    return TaskContext(task, suite, spec, scene, method, run_method, dt, _claims(method, scene))


def _applies(measure, ctx) -> bool:
    only = getattr(ctx.task, "only", ())
    return (
        measure.run is not None
        and (not only or measure.name in only)
        and (measure.applies is None or bool(measure.applies(ctx)))
    )


def measures_for(task, method=None) -> list[str]:
    """The task's measures, in the order ``run_task`` measures them: the registry's
    (``records.measures``), each where it applies."""
    ctx = context(task, method)
    return [name for m in measures() if _applies(m, ctx) for name in m.cells]


def _claims(method, scene=None) -> Claims:
    """The textbook claims a method's cells are judged by (none known without a scheme); the
    order is the one declared for the scene (a lower one where its force depends on the
    velocity, with a note saying so)."""
    scheme = method.scheme
    if scheme is None:
        return Claims()
    velocity = scene is not None and scene.velocity_dependent
    order = scheme.order_for(velocity)
    note = f"{order} with a velocity-dependent force ({scheme.order} otherwise)" if order != scheme.order else None
    return Claims(
        scheme=f"ref:{scheme.id}",
        order=order,
        order_note=note,
        force_evals=scheme.force_evals,
        force_evals_text=scheme.kind.evals_text(scheme),
        energy=scheme.energy_claim,
        homega_max=scheme.homega_max,
        evals_per_pass=bool(scheme.implicit and not scheme.one_pass_on_linear),
    )


def _downsample(n: int, points: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, points)).astype(int))


def run_task(task) -> list[Cell]:
    """Runs in a worker process. Any exception becomes a ``crashed`` cell with the message.
    Reference schemes step on their compiled loop wherever it computes the interpreted run's
    bits (``reference.RefMethod``)."""
    from harness.methods import use_plugins

    use_plugins(task.plugins)
    if task.kind == "bound":
        return [guard(task, "bound", lambda: _bound(task))]
    if task.kind == "cost":  # a cell's cost measured again, in a fresh worker (the nightly's re-measure)
        return [guard(task, "cost", lambda: _cost_again(task))]
    return _scene_task(task)


def _scene_task(task) -> list[Cell]:
    """Every registered measure that applies to the task, in registry order, each cell sent back
    as it is measured (a crash in one measure is its cell, and the rest go on)."""
    from harness.execution.pool import report_partial

    ctx = context(task)
    cells = []
    for measure in measures():
        if not _applies(measure, ctx):
            continue
        new = guard_many(task, measure.cells, lambda measure=measure: measure.run(ctx))
        for c in new:
            if c.claims is None:
                c.claims = ctx.claims
            c.model_note = ctx.scene.model_note
            cells.append(c)
            ctx.cells.setdefault(c.measure, c)
            report_partial(c)
    return cells


#: The energy figures of a run (``harness.measures.energy.energy_figures``) that are not the
#: classification's numbers.
ENERGY_RUN_FIGURES = ("max_rel_error", "final_rel_error", "rel_error_defined", "events")


def _energy_and_error(task, method, scene, dt, spec, suite, runs: dict | None = None) -> list[Cell]:
    from harness.measures.energy import energy_figures
    from harness.execution.simulate import simulate

    steps, every = energy_run(scene, dt, spec, suite)
    traj = simulate(method, scene, dt, steps, every, timeout=suite.cell_timeout)
    if runs is not None:
        runs["energy"] = traj
    settings = {
        "settings": traj.meta.settings,
        "engine_version": traj.meta.engine_version,
        "backend": traj.meta.backend,
    }
    if traj.status not in ("ok", "unstable") or traj.q.shape[0] == 0:
        return [
            make_cell(
                task, "energy", traj.status, dt=dt, steps=steps, detail=traj.detail, figures=EnergyFigures(**settings)
            ),
            make_cell(task, "error", traj.status, dt=dt, steps=steps, detail=traj.detail, extra=settings),
        ]
    from harness.measures.cross_engine import built_differently, differs_word

    differs = built_differently(method, scene, dt)
    if differs:  # the file's energy is MuJoCo's function of MuJoCo's model: not this engine's
        word = differs_word(differs)
        built = "built another model of the file" if word == "model differs" else "built a model not compared"
        why = f"{word}: {method.family} {built} ({'; '.join(differs[:4])}" + (
            f"; {len(differs) - 4} more)" if len(differs) > 4 else ")"
        )
        energy = make_cell(
            task,
            "energy",
            "ok",
            None,
            dt,
            steps,
            why,
            EnergyFigures(**settings, numbers={"model_differs": differs}),
        )
        return [energy, _error_cell(task, method, scene, traj, dt, steps, settings, suite)]
    figures, _ = energy_figures(traj, scene, method, suite.cell_timeout)
    e_exact = np.asarray(scene.exact_energy(traj.t), dtype=float)
    idx = _downsample(len(traj.t), suite.series_points)
    series = {"t": traj.t[idx], "energy": traj.energy[idx, 0], "exact": e_exact[idx]}
    cls = {k: v for k, v in figures.items() if k not in ENERGY_RUN_FIGURES}
    energy = make_cell(
        task,
        "energy",
        traj.status,
        figures["max_rel_error"],
        dt,
        steps,
        traj.detail,
        EnergyFigures.pick(
            cls,
            energy_class=cls["classification"],
            rel_error_defined=figures["rel_error_defined"],
            final_rel_error=figures["final_rel_error"],
            failed_step=traj.failed_step,
            series=series,
            numbers=plain(cls),
            events=plain(figures["events"]) or None,
            **settings,
        ),
    )
    return [energy, _error_cell(task, method, scene, traj, dt, steps, settings, suite)]


def _error_cell(task, method, scene, traj, dt, steps, settings, suite) -> Cell:
    from harness.measures.error import run_error

    err = run_error(method, scene, traj, suite.cell_timeout) if traj.ok else {}
    value, detail = (finite(err["error_max"]) if err else None), traj.detail
    if err and err["below_reference"]:
        value, detail = None, f"below the reference's accuracy ({err['reference_error']:.2g})"
    elif err and err.get("not_judged"):
        value, detail = None, err["not_judged"]
    return make_cell(task, "error", traj.status, value, dt, steps, detail, ErrorFigures.pick(err))


def _order(task, method, scene, spec) -> Cell:
    from harness.measures.order import observed_order

    res = observed_order(method, scene, points=spec.order_points, span=spec.order_span, periods=spec.order_periods)
    order, excluded = res["order"], res["excluded"]
    status, detail = "ok", ""
    if order is None or not np.isfinite(order):
        status, detail = "unstable", "too few usable points"
        if excluded and all(p["reason"].startswith("not judged") for p in excluded):
            status, detail = "ok", excluded[0]["reason"]
        elif len(res["points"]) < 2 and excluded and all(p["reason"].startswith("roundoff floor") for p in excluded):
            # Nothing failed: the method is more accurate than the floor at every dt of the sweep
            # (SABA(10,6,4) on the solar system), or at all but the one largest, which alone gives no
            # slope (RK4 on the standard cloth), so it has no measurable order here.
            status, detail = "ok", "no order: every error at or below the roundoff/reference floor"
            if res["points"]:
                detail = (
                    f"no order: {len(excluded)} of {len(excluded) + len(res['points'])} errors at or below "
                    "the roundoff/reference floor, and one point gives no slope"
                )
    return make_cell(task, "order", status, finite(order), detail=detail, figures=OrderFigures.pick(plain(res)))


def _stability(task, method, scene, suite, spec) -> Cell:
    from harness.measures.stability import largest_stable_dt

    hi = spec.stability_hi if spec.stability_hi is not None else suite.stability_homega_max
    steps = spec.stability_steps if spec.stability_steps is not None else suite.stability_steps
    rtol = spec.stability_rtol if spec.stability_rtol is not None else suite.stability_rtol
    search = {k: v for k, v in (("lo", spec.stability_lo), ("rtol", rtol)) if v is not None}
    res = largest_stable_dt(method, scene, steps=steps, hi=hi, **search)
    verdict = res.verdict
    figures = StabilityFigures.pick(
        plain(res.as_dict()),
        unbounded=verdict == "unbounded",
        unstable_everywhere=verdict == "unstable",
        unresolved=verdict == "unresolved",
        homega_searched=plain((res.dt_searched_max or 0) * scene.omega),
    )
    value = math.inf if verdict == "unbounded" else res.omega_dt_max
    if res.criterion == "finite_horizon":
        figures = replace(
            figures, nominal=NominalRun(**plain(_nominal_run(method, scene, nominal_dt(spec, scene), steps, suite)))
        )
    return make_cell(task, "stability", "ok", value, detail=res.detail, figures=figures)


def _nominal_run(method, scene, dt: float, steps: int, suite) -> dict:
    """The stability measure's finite horizon (``steps``, 10,000 by default) run once more at the
    suite's nominal dt, with its energy against time: a blow-up past the energy run's horizon
    (an engine mode's at step 2434 of a 1,257-step energy run: docs/engines.md) is seen where it
    happens, and the judge sets it beside the same engine's other modes (``harness.judge``)."""
    from harness.execution.simulate import simulate

    every = max(1, steps // (4 * suite.series_points))
    traj = simulate(method, scene, dt, steps, every, timeout=suite.cell_timeout)
    out = {
        "dt": dt,
        "homega": dt * scene.omega,
        "steps": steps,
        "status": traj.status,
        "failed_step": traj.failed_step,
        "detail": traj.detail,
    }
    if traj.q.shape[0]:
        idx = _downsample(len(traj.t), suite.series_points)
        out["series"] = {
            "t": traj.t[idx],
            "energy": traj.energy[idx, 0],
            "e0": float(scene.exact_energy(np.zeros(1))[0]),
        }
    return out


def _cost_again(task) -> Cell:
    from harness.methods import get_method

    suite = suite_of(task)
    scene = make_scene(task.scene, source=task.source, **task.params)
    return _cost(task, get_method(task.method), scene, nominal_dt(suite.scenes[task.scene], scene), suite)


def _cost(task, method, scene, dt, suite) -> Cell:
    """Counted evaluations; CPU seconds per step and, timed in this worker on the same clock in
    repeats interleaved with the method's, explicit Euler's (the ratio's baseline)."""
    from harness.measures.cost import cost_per_step

    res = cost_per_step(
        method, scene, dt, time_steps=suite.cost_steps, repeats=suite.cost_repeats, clock="cpu", injected=task.timings
    )
    # The baseline's figures and an engine mode's second figure (stepped one call at a time from
    # Python) are stored flat, under baseline_... and as_stepped_...
    flat = {
        **{k: v for k, v in res.as_dict().items() if v is not None},
        **{f"baseline_{k}": v for k, v in res.baseline.items()},
        **{f"as_stepped_{k}": v for k, v in (res.as_stepped or {}).items()},
    }
    return make_cell(
        task,
        "cost",
        "ok",
        res.s_per_step,
        dt,
        res.time_steps,
        figures=CostFigures.pick(flat, spread=res.rel_spread or 0.0, ratio_spread=res.ratio_spread or 0.0),
    )


def _advise(task, method, scene, spec, suite, cost: Cell) -> list[Cell]:
    """One cell per frame rate of the suite: the method's search over substeps
    (``harness.measures.advise.advise_method``), its cost per step from this task's cost cell. Value:
    the cost per frame of the fewest substeps that meet the tolerances (None where none does)."""
    from harness.measures.advise import Request, advise_method

    per_step = (
        (cost.value, f"{cost.figures.timing}; {cost.figures.clock} clock (the cost cell)")
        if cost.ok and cost.value
        else None
    )
    cells = []
    for hz in suite.frame_rates:
        request = Request(hz=hz, **spec.advise).checked()
        res = advise_method(method, scene, request, timeout=suite.cell_timeout, cost_per_step=per_step)
        spread = getattr(cost.figures, "spread", None) if per_step is not None else None
        res.cost_rel_spread = spread  # its repeats' spread: a pick within it is a tie (reports.answer_section)
        best = res.best_row
        figures, extra = AdviceFigures.from_data(
            plain(
                {
                    "hz": hz,
                    "request": asdict(request),
                    "length_scale": scene.length_scale,
                    "position_tol": request.position_tolerance(scene),
                    **res.as_dict(),
                }
            )
        )
        cells.append(
            make_cell(
                task,
                "advise",
                "ok",
                best.cost_per_frame_s if best is not None else None,
                1.0 / hz,
                figures=figures,
                extra={**(extra or {}), "cost_rel_spread": spread},
            )
        )
    return cells


def _identity(task, method, scene) -> Cell:
    from reference import METHODS

    from harness.measures.identify import identify

    # The candidates step as the reference tasks do, on their compiled loops where those compute
    # the interpreted bits (loaded from the kernel cache where a task compiled them).
    res = identify(method, scene, compiled_where_bitwise=True)
    match = res.match
    mode = task.method.split(":", 1)[1]
    match_claims = Claims()
    if match and match.startswith("ref:"):
        from harness.methods import RefMethod

        match_claims = _claims(RefMethod(METHODS[scheme_name(match)]), scene)
    if res.status not in ("ok", "unstable"):
        return make_cell(task, "identity", res.status, detail=res.detail)
    runner, closest = res.runner_up, res.closest
    note = None
    if match is None and closest is not None:
        note = f"matches no reference scheme; closest `{closest.method}` (max deviation {closest.max_deviation:.2e})"
        if res.why_no_match:
            note += f": {res.why_no_match}"
    return make_cell(
        task,
        "identity",
        "ok",
        finite(res.max_deviation if match else closest.max_deviation if closest else None),
        res.dt,
        res.steps,
        figures=IdentityFigures(
            match=match,
            matches=list(res.matches),
            closest=closest.method if closest else None,
            runner_up=runner.method if runner else None,
            runner_up_deviation=finite(runner.max_deviation) if runner else None,
            name_suggests=NAME_SUGGESTS.get(mode),
            match_claims=match_claims,
            note=note,
            precision=getattr(method, "precision", "float64"),
        ),
    )


def _bound(task) -> Cell:
    from harness.pytest_plugin import measure_max_rel_energy_error

    value, status, detail = measure_max_rel_energy_error(task.method, task.scene, task.dt, task.steps, **task.params)
    return make_cell(task, "bound", status, finite(value), task.dt, task.steps, detail, BoundFigures(bound=task.bound))


def failed_cells(task, failure) -> list[Cell]:
    """The worker died or hung: the cells it sent before (``failure.partial``) are kept, and
    every measure it did not finish is recorded with that outcome, the first of them (where
    the worker was lost) with why, the rest as not reached."""
    detail = getattr(failure, "detail", str(failure))
    status = getattr(failure, "status", "crashed")
    done = [c for c in getattr(failure, "partial", None) or [] if isinstance(c, Cell)]
    measured = {c.measure for c in done}
    missing = [m for m in task.measures() if m not in measured]
    wall = getattr(failure, "seconds", 0.0) - sum(c.wall_s or 0.0 for c in done)
    out = list(done)
    for i, m in enumerate(missing):
        why = detail if i == 0 else f"not reached: the worker was lost in {missing[0]} ({detail})"
        bound = task.kind == "bound"
        out.append(
            make_cell(
                task,
                m,
                status,
                detail=why,
                dt=task.dt if bound else None,
                steps=task.steps if bound else None,
                figures=BoundFigures(bound=task.bound) if bound else None,
                wall=max(wall, 0.0) if i == 0 else 0.0,
            )
        )
    return out


# ----------------------------------------------------------------------------- the measures
def _order_drop(before: Cell, after: Cell, comparison: Comparison) -> Worse | None:
    va, vb = before.value, after.value
    if va is not None and vb is not None and vb < va - ORDER_DROP:
        return Worse("order", va, vb, f"observed order {va:.2f} -> {vb:.2f} (drop > {ORDER_DROP})")
    return None


def _stability_drop(before: Cell, after: Cell, comparison: Comparison) -> Worse | None:
    va, vb = before.value, after.value
    if before.figures.unbounded and not after.figures.unbounded:
        return Worse("stability", "unbounded", vb, f"was unbounded, now h*omega max = {vb:.4g}")
    if va is not None and vb is not None and math.isfinite(va) and vb < va * (1 - STABILITY_DROP):
        return Worse("stability", va, vb, f"largest stable h*omega {va:.4g} -> {vb:.4g} (drop > {STABILITY_DROP:.0%})")
    return None


def _slowdown(before: Cell, after: Cell, comparison: Comparison) -> Worse | None:
    """The cost ratio to explicit Euler beyond the noise (``harness.history.compare``); never where
    nothing the cell depends on differs between the runs (``comparison.machine_only``: the machine's)."""
    if comparison.machine_only:
        return None
    fa, fb = before.figures, after.figures
    ra_ratio, rb_ratio = fa.ratio_to_explicit_euler, fb.ratio_to_explicit_euler
    if not (ra_ratio and rb_ratio):
        return None
    cal_a, cal_b = fa.calibration, fb.calibration
    moved = abs(cal_b / cal_a - 1.0) if cal_a and cal_b else 0.0
    spread = fa.noise + fb.noise + PROCESS_SPREAD + moved
    if rb_ratio > ra_ratio * (1 + spread):
        return Worse(
            "slowdown",
            ra_ratio,
            rb_ratio,
            (
                f"cost ratio to explicit Euler {ra_ratio:.2f} -> {rb_ratio:.2f}, beyond the noise allowed "
                f"({spread:.0%}: "
                f"the repeats' spreads, {PROCESS_SPREAD:.0%} from process to process"
                + (f" and the calibration's move, {moved:.0%}" if moved else "")
                + ")"
            ),
        )
    return None


def _identity_run(ctx) -> list[Cell]:
    cell = _identity(ctx.task, ctx.method, ctx.scene)
    match_claims = cell.figures.match_claims
    if cell.ok and match_claims is not None and match_claims.known:
        ctx.claims = match_claims  # the scheme it integrates: what its other cells are judged by
    return [cell]


def identifies(suite, scene, family: str) -> bool:
    """Whether a task of ``family`` on ``scene`` has an identity cell in ``suite``."""
    # A constrained scene's only reference scheme projects positions; no engine integrates that
    # (MuJoCo's rope is reduced coordinates, pymunk's impulses): nothing to identify. Nor on a
    # model file, which no reference scheme steps.
    return family != "ref" and suite.identify and not scene.constrained and scene.has_kernels


def _identifies(ctx) -> bool:
    return identifies(ctx.suite, ctx.scene, ctx.task.family)


def _fixed_step(ctx) -> bool:
    return not ctx.method.adaptive  # an adaptive method picks its own steps: nothing to measure against dt


def _text(name: str, measure: str):
    """A column's text: the report's function ``name`` of the row's ``measure`` cell (imported
    when a report is written, not in a worker)."""

    def text(ms, mark):
        from reports import markdown

        return getattr(markdown, name)(ms.get(measure))

    return text


def _cost_text(name: str):
    def text(ms, mark):
        from reports import markdown

        return getattr(markdown, name)(ms.get("cost"), mark)

    return text


_COLUMNS = {
    "energy": (
        Column("max \\|ΔE/E\\|", _text("energy_text", "energy"), 10),
        Column("energy", _text("class_text", "energy"), 11),
    ),
    "error": (Column("max global error", _text("error_text", "error"), 20),),
    "order": (Column("order", _text("order_text", "order"), 30),),
    "stability": (Column("largest stable h·ω", _text("homega_text", "stability"), 40),),
    "cost": (
        Column("evals/step", _cost_text("evals_text"), 50),
        Column("CPU µs/step", _cost_text("cpu_text"), 51),
        Column("as stepped µs/step", _cost_text("as_stepped_text"), 52),
        Column("time ratio", _cost_text("ratio_text"), 53),
    ),
}


def _columns(kind):
    return _COLUMNS[kind]


#: The task's own measures, in the order a task runs them.
MEASURES = [
    Measure(
        "identity",
        IdentityFigures,
        "which reference scheme an engine mode integrates (the claims its cells are judged by)",
        run=_identity_run,
        applies=_identifies,
    ),
    Measure(
        "energy",
        EnergyFigures,
        "max |dE/E| over the energy run and its class (bounded, drifts, grows, decays)",
        run=lambda ctx: _energy_and_error(ctx.task, ctx.run_method, ctx.scene, ctx.dt, ctx.spec, ctx.suite, ctx.runs),
        makes=("energy", "error"),
        columns=_columns("energy"),
        trend="max |dE/E|",
    ),
    Measure(
        "error",
        ErrorFigures,
        "max global error over the energy run",
        made_by="energy",
        columns=_columns("error"),
        trend="max global error",
    ),
    Measure(
        "order",
        OrderFigures,
        "observed order of the dt sweep (its points draw the work-precision chart)",
        run=lambda ctx: [_order(ctx.task, ctx.run_method, ctx.scene, ctx.spec)],
        applies=_fixed_step,
        regression=_order_drop,
        columns=_columns("order"),
        trend="observed order",
        higher_is_worse=False,
    ),
    Measure(
        "cost",
        CostFigures,
        "force evaluations and CPU time per step, with explicit Euler's timed beside it",
        run=lambda ctx: [_cost(ctx.task, ctx.method, ctx.scene, ctx.dt, ctx.suite)],
        regression=_slowdown,
        columns=_columns("cost"),
        trend="ratio to explicit Euler",
        deterministic=False,
    ),
    Measure(
        "advise",
        AdviceFigures,
        "the fewest substeps a frame that meet the tolerances, and their cost per frame",
        run=lambda ctx: _advise(ctx.task, ctx.method, ctx.scene, ctx.spec, ctx.suite, ctx.cells["cost"]),
        applies=lambda ctx: ctx.spec.advise is not None and _fixed_step(ctx),
    ),
    Measure(
        "stability",
        StabilityFigures,
        "largest stable h*omega (spectral radius on linear scenes, else a finite horizon)",
        run=lambda ctx: [_stability(ctx.task, ctx.run_method, ctx.scene, ctx.suite, ctx.spec)],
        applies=lambda ctx: ctx.spec.stability and _fixed_step(ctx),
        regression=_stability_drop,
        columns=_columns("stability"),
        trend="largest stable h*omega",
        higher_is_worse=False,
    ),
]

# The built-in measures: the task's own, then every module's of ``harness.nightly.measures``
# (``records.measures``: registered here, where the task loop that runs them all lives).
for _measure in (*MEASURES, *declared()):
    register(_measure, builtin=True)
