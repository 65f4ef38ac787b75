"""The nightly cells only some scenes have, measured beside the five every task measures.

* ``constraint`` (every scene with links or springs, ``Scene.has_stretch``: the rope, the chain, the
  cloth and net; every method): ``harness.measures.constraint`` over the energy run (the same dt,
  steps and recording). For a scheme with projection passes
  (``ref:verlet_constrained``) also at each pass count in ``extras.constraint_iterations``
  (``ConstraintFigures.by_iterations``). Value: the largest relative stretch.
* ``small_steps`` (scenes whose suite entry lists it: the cloth and the rope; the task of
  ``ref:xpbd``): ``harness.measures.small_steps`` at 60 Hz, XPBD's substeps against its passes
  against the implicit schemes and semi-implicit Euler at equal cost per frame, and the paper's
  claims judged. Value: the number of claims that hold (✓).
* ``damping`` (scenes whose suite entry lists it in ``extras``: the chain; every method):
  ``harness.measures.damping`` at ``extras.damping_factor`` (the suites' 100) times the explicit
  limit. Value: the energy kept after one step. As with ``stability``, a method found to
  grow there is a measured result (``DampingFigures.stable`` False, the run's own status in
  ``run_status``), not a failed cell; the status is ``crashed`` / ``timed_out`` only
  when the measurement itself did not finish.
* ``stability_vs_damping`` (scenes whose suite entry lists it: the damped spring; every
  method): ``harness.measures.stability_damping`` over ``extras.stability_zetas``, each
  limit beside the theory of the method's own scheme, or for an engine mode of the scheme it
  was identified as (the task's claims). Value: the number of damping ratios whose measured
  limit agrees with that theory; a reference scheme's cell also carries its theory curve.
* ``scaling`` (``extras.scaling``, for ``extras.scaling_methods``: the chain's backward Euler,
  the full suite's cloth's implicit schemes): compiled cost per step at each size of ``sizes``
  (the scene's parameters at each size; ``harness.measures.scaling.cost_vs_size``). Value: the
  log-log slope against the number of unknowns.
* ``brouwer`` (Kepler and the solar system, the methods ``extras.brouwer`` names): the
  energy error's RMS over an ensemble against time (``harness.measures.brouwer``). Value: its
  log-log slope, 0.5 by Brouwer's law where the error is roundoff.
* ``cross_engine`` (a model file's conservative variant where two engines load it; the task of
  each mode of ``extras.cross_engine`` after the first, compared with the first): the two modes
  from the same state at a step where each one's own error is at most a tenth of what is
  reported, over one period of the model's slowest mode (``harness.measures.cross_engine``). Value: their difference,
  relative; the figures say whether it is more than their own errors account for, and what the two built models differ
in.
"""

from __future__ import annotations

from records import MethodId, scheme_name
from scenarios import make_scene

from records.cell import (
    BrouwerFigures,
    Cell,
    Claims,
    ConstraintFigures,
    CrossEngineFigures,
    DampingFigures,
    ScalingFigures,
    SmallStepsFigures,
    StabilityVsDampingFigures,
)
from records.measures import Measure, TaskContext

from harness.nightly.cell_kit import energy_run, finite, guard, make_cell, plain


def _extras(ctx):
    return ctx.spec.extras


def _small_steps_scene_chart(cells, scene, path) -> bool:
    """The measure's chart of a scene (a module-level function: the report's pool pickles it)."""
    return _small_steps_chart(cells, path)


#: The measures a scene adds of its own, each where its scene spec asks for it.
MEASURES = [
    Measure(
        "constraint",
        ConstraintFigures,
        "constraint drift: how far the run leaves the constraints",
        run=lambda ctx: [_constraint(ctx.task, ctx.method, ctx.scene, ctx.dt, ctx.spec, ctx.suite, ctx.runs)],
        applies=lambda ctx: ctx.scene.has_stretch,
    ),
    Measure(
        "damping",
        DampingFigures,
        "damping far beyond the explicit limit: where an implicit scheme damps",
        run=lambda ctx: [_damping(ctx.task, ctx.method, ctx.scene, ctx.spec, ctx.suite)],
        applies=lambda ctx: _extras(ctx).damping_factor is not None,
    ),
    Measure(
        "stability_vs_damping",
        StabilityVsDampingFigures,
        "the largest stable h*omega against the damping ratio",
        run=lambda ctx: [_stability_vs_damping(ctx.task, ctx.method, ctx.spec, ctx.claims)],
        applies=lambda ctx: _extras(ctx).stability_zetas is not None,
    ),
    Measure(
        "scaling",
        ScalingFigures,
        "cost per step against the scene's size (the log-log slope)",
        run=lambda ctx: [_scaling(ctx.task, ctx.spec)],
        applies=lambda ctx: _extras(ctx).scaling is not None and ctx.task.method in _extras(ctx).scaling_methods,
    ),
    Measure(
        "brouwer",
        BrouwerFigures,
        "Brouwer's law: the roundoff walk of the energy error over an ensemble",
        run=lambda ctx: [_brouwer(ctx.task, ctx.method, ctx.scene, ctx.dt, ctx.spec)],
        applies=lambda ctx: bool(_extras(ctx).brouwer) and ctx.task.method in _extras(ctx).brouwer,
        section=lambda scene, piv: _report().brouwer_lines(scene, piv),
    ),
    Measure(
        "cross_engine",
        CrossEngineFigures,
        "two engines from the same state on a model file, at a resolved step, and what their built models differ in",
        run=lambda ctx: [_cross_engine(ctx.task, ctx.scene, ctx.spec, ctx.suite)],
        applies=lambda ctx: ctx.task.method in _extras(ctx).cross_engine[1:],
        section=lambda scene, piv: _cross_engine_section(scene, piv),
    ),
    Measure(
        "small_steps",
        SmallStepsFigures,
        "small steps: XPBD's substeps against its passes, the implicit schemes "
        "and semi-implicit Euler at equal cost per frame (Macklin et al. 2019)",
        run=lambda ctx: [_small_steps(ctx.task, ctx.spec)],
        applies=lambda ctx: _extras(ctx).small_steps is not None and ctx.task.method == "ref:xpbd",
        chart=_small_steps_scene_chart,
    ),
]


def _report():
    from reports import markdown

    return markdown


def _cross_engine_section(scene: str, piv: dict) -> list[str]:
    lines = []
    for (s, _), ms in sorted(piv.items()):
        if s == scene and "cross_engine" in ms:
            head, *differences = _report().cross_engine_lines(ms["cross_engine"])
            lines += [f"Two engines from the same state: {head}", ""]
            lines += [f"- {d}" for d in differences] + ([""] if differences else [])
    return lines


def measures_for(task, spec) -> list[str]:
    """The scene's own measures of ``task`` (``MEASURES``, each where it applies)."""
    ctx = TaskContext(task, None, spec, make_scene(task.scene, source=task.source, **task.params))
    return [m.name for m in MEASURES if m.applies(ctx)]


def scene_cells(task, method, scene, dt, spec, suite, claims: Claims | None = None) -> list[Cell]:
    """The scene's own cells of ``task``, outside a nightly task (the nightly's task runs every
    registered measure: ``harness.nightly.cells``)."""
    ctx = TaskContext(task, suite, spec, scene, method, method, dt, claims or Claims())
    return [guard(task, m.name, lambda m=m: m.run(ctx)[0]) for m in MEASURES if m.applies(ctx)]


def _constraint(task, method, scene, dt, spec, suite, runs: dict | None = None) -> Cell:
    from harness.measures.constraint import constraint_drift, drift_of
    from harness.methods import get_method

    steps, every = energy_run(scene, dt, spec, suite)
    stepped = (runs or {}).get("energy")  # the energy run, the same dt, steps and recording: read, not rerun
    res = (
        drift_of(stepped, scene, method, dt, steps, every)
        if stepped is not None
        else constraint_drift(method, scene, dt, steps, every=every, timeout=suite.cell_timeout)
    )
    by_iterations = None
    passes = spec.extras.constraint_iterations
    if passes and method.scheme is not None and method.scheme.constrained:
        by_iterations = []
        for k in passes:
            r = constraint_drift(
                get_method(task.method, {"iterations": k}, compiled_where_bitwise=method.compiled_where_bitwise),
                scene,
                dt,
                steps,
                every=every,
                timeout=suite.cell_timeout,
            )
            by_iterations.append(
                {
                    key: r[key]
                    for key in (
                        "iterations",
                        "status",
                        "max_stretch",
                        "final_stretch",
                        "energy_change",
                        "max_energy_change",
                    )
                }
            )
    figures = ConstraintFigures.pick(plain(res), by_iterations=plain(by_iterations))
    return make_cell(task, "constraint", res["status"], finite(res["max_stretch"]), dt, steps, res["detail"], figures)


def _small_steps(task, spec) -> Cell:
    """The study on the task's scene and, where that is not the paper's case (soft springs) but the
    scene can be made stiff, on the stiff scene too (``harness.measures.small_steps``). Value: the
    claims that hold in both."""
    from harness.measures.small_steps import claims, papers_case, small_steps, stiff_params, stiff_text

    settings = dict(spec.extras.small_steps)
    frame = small_steps(task.scene, **settings, **(task.params or {}))
    judged = claims(frame)
    stiff = None
    stiffened = None if papers_case(frame) else stiff_params(task.scene, **(task.params or {}))
    if stiffened is not None:
        other = small_steps(task.scene, **settings, **stiffened)
        other.attrs["label"] = f"{task.scene} with stiff springs ({stiff_text()})"
        stiff_claims = claims(other)
        judged_all = judged + stiff_claims
        stiff = {
            "rows": plain(other.to_dict("records")),
            "paper_claims": stiff_claims,
            "settings": plain(dict(other.attrs)),
        }
    else:
        judged_all = judged
    held = sum(1 for r in judged_all if r["verdict"] == "✓")
    figures = SmallStepsFigures(
        rows=plain(frame.to_dict("records")), paper_claims=judged, settings=plain(dict(frame.attrs)), stiff=stiff
    )
    return make_cell(
        task,
        "small_steps",
        "ok",
        float(held),
        1.0 / settings.get("hz", 60.0),
        detail=f"{held} of {len(judged_all)} claims hold",
        figures=figures,
    )


def small_steps_frame(cell):
    """A ``small_steps`` cell's rows as the study's DataFrame (its settings as ``attrs``)."""
    import pandas as pd

    frame = pd.DataFrame(cell.figures.rows or [])
    frame.attrs.update(cell.figures.settings or {})
    return frame


def _small_steps_chart(cells, path) -> bool:
    from harness.measures.small_steps import chart

    return chart([small_steps_frame(c) for c in cells if c.measure == "small_steps" and c.figures.rows], path)


def _damping(task, method, scene, spec, suite) -> Cell:
    from harness.measures.damping import damping_far_beyond_the_limit

    factor = spec.extras.damping_factor
    res = damping_far_beyond_the_limit(method, scene, factor=factor, timeout=suite.cell_timeout)
    status = res["status"] if res["status"] in ("crashed", "timed_out") else "ok"
    detail = res["detail"]
    if res["stable"] is False:
        detail = f"grows: spectral radius {res['rho']:.4g} at h*omega = {res['omega_dt']:.4g}"
    figures = DampingFigures.pick(plain(res), run_status=res["status"])
    return make_cell(
        task, "damping", status, finite(res["energy_kept_one_step"]), res["dt"], res["steps"], detail, figures
    )


def _stability_vs_damping(task, method, spec, claims: Claims) -> Cell:
    from harness.measures.stability_damping import CURVE_ZETAS, limit_vs_damping, theory_curve

    zetas = spec.extras.stability_zetas
    res = limit_vs_damping(method, zetas, scheme=claims.scheme)
    curve = None
    if task.family == "ref" and res["scheme"]:
        curve = {"zeta": list(CURVE_ZETAS), "homega_max": theory_curve(scheme_name(res["scheme"]))}
    agreeing = sum(1 for r in res["rows"] if r["agrees"])
    detail = "" if res["scheme"] else "no scheme identified: measured only"
    figures = StabilityVsDampingFigures(
        scheme=res["scheme"],
        rows=plain(res["rows"]),
        tolerance=plain(res["tolerance"]),
        judged_by="own scheme" if task.family == "ref" else "identified scheme",
        theory_curve=plain(curve),
    )
    return make_cell(
        task, "stability_vs_damping", "ok", float(agreeing) if res["scheme"] else None, detail=detail, figures=figures
    )


def _scaling(task, spec) -> Cell:
    from harness.measures.scaling import cost_vs_size

    settings = dict(spec.extras.scaling)
    sizes = [dict(size) for size in settings.pop("sizes")]
    frame = cost_vs_size(task.scene, sizes, scheme=MethodId.parse(task.method).name, **settings)
    settings["sizes"] = sizes
    return make_cell(
        task,
        "scaling",
        "ok",
        frame.attrs["slope"],
        figures=ScalingFigures(
            **plain(
                {
                    "rows": frame.to_dict("records"),
                    "rvalue": frame.attrs["rvalue"],
                    "intercept": frame.attrs["intercept"],
                    "settings": settings,
                }
            )
        ),
    )


def _brouwer(task, method, scene, dt, spec) -> Cell:
    """The energy error's growth over an ensemble (``harness.measures.brouwer``), with the
    suite's settings for this method: an adaptive method (IAS15) records ``outputs`` states over
    the horizon (its dt is the output interval), a fixed-step one steps at the nominal dt."""
    from harness.measures.brouwer import energy_walk

    settings = spec.extras.brouwer[task.method]
    horizon = settings["horizon"] if "horizon" in settings else settings["periods"] * scene.period
    outputs = int(settings["outputs"])
    if method.adaptive:
        step_dt, steps, every = horizon / outputs, outputs, 1
    else:
        steps = max(outputs, int(round(horizon / dt)))
        step_dt, every = dt, max(1, steps // outputs)
    res = energy_walk(method, scene, step_dt, steps, every, realizations=settings["realizations"])
    figures, extra = BrouwerFigures.from_data(plain(res))
    return make_cell(task, "brouwer", "ok", finite(res["slope"]), step_dt, steps, figures.reason or "", figures, extra)


def _cross_engine(task, scene, spec, suite) -> Cell:
    from harness.measures.cross_engine import cross_engine, verdict_text

    a, b = spec.extras.cross_engine[0], task.method
    res = cross_engine(scene, a, b, timeout=suite.cell_timeout)
    figures = CrossEngineFigures.pick(plain(res.as_dict()))
    if res.difference is None:  # a run did not finish: its own status, and where and why
        status = next((s for s in res.statuses if s != "ok"), "ok")
        detail = res.detail if status != "ok" else f"not resolved: {res.detail}"
        return make_cell(task, "cross_engine", status, None, res.dt, res.steps, detail, figures)
    detail = verdict_text(
        res.verdict, res.methods, res.difference, res.errors, res.dt, res.steps, res.horizon, res.differences
    )
    return make_cell(task, "cross_engine", "ok", finite(res.difference), res.dt, res.steps, detail, figures)
