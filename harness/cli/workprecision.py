"""``harness workprecision SCENE [--method M ...] [--tolerances T,T,...]``: (cost, error) pairs per
method across a shared timestep sweep, ready to chart; an error-controlled method (one that takes a
tolerance: ``drake:runge_kutta3``, ``rebound:ias15``) across the tolerances instead, with the steps
it took and rejected (``harness.measures.tolerance``)."""

from __future__ import annotations

from harness import validate
from harness.methods import all_methods
from harness.measures.tolerance import TOLERANCES, takes_tolerance, tolerance_sweep
from harness.measures.workprecision import (
    HOMEGA_MAX,
    PERIODS,
    POINTS,
    REPEATS,
    chart_ready,
    pareto_front,
    pareto_summary,
    work_precision,
)
from harness.cli.measure_args import add_common, emit, fmt, method_for, progress, scene_of, timeout_of


def add_parser(sub):
    p = sub.add_parser("workprecision", help="error against cost across a timestep sweep")
    add_common(p, method_required=False)
    p.add_argument("--method", action="append", help="method id (repeat; default: every available method)")
    p.add_argument("--points", default=str(POINTS), help="timesteps: h*omega = max/2^k")
    p.add_argument("--homega-max", default=repr(HOMEGA_MAX), help="largest h*omega")
    p.add_argument("--periods", default=repr(PERIODS), help="horizon in scene periods")
    p.add_argument("--repeats", default=str(REPEATS), help="timed repeats per point")
    p.add_argument("--chart", metavar="PNG", help="draw error against cost to this file, the Pareto front marked")
    p.add_argument(
        "--tolerances",
        default=",".join(f"{t:g}" for t in TOLERANCES),
        help="the tolerances an error-controlled method runs at (comma-separated)",
    )
    return p


def run(args) -> int:
    points = validate.count("--points", args.points, 1, validate.MAX_POINTS)
    homega_max = validate.positive_finite("--homega-max", args.homega_max)
    periods = validate.positive_finite("--periods", args.periods)
    repeats = validate.count("--repeats", args.repeats, 1, 1000)
    timeout = timeout_of(args)
    tolerances = [validate.positive_finite("--tolerances", t) for t in str(args.tolerances).split(",") if t.strip()]
    if not tolerances:
        validate.positive_finite("--tolerances", args.tolerances)
    scene = scene_of(args)
    if args.method:
        methods = [method_for(m, scene) for m in args.method]
    else:
        methods = [
            m for m in all_methods(compiled_where_bitwise=True).values() if m.available()[0] and m.supports(scene)[0]
        ]
    controlled = [m for m in methods if takes_tolerance(m) and "tolerance" not in m.options]
    stepped = [m for m in methods if m not in controlled]
    with progress() as say:
        rows = (
            work_precision(
                stepped,
                scene,
                points=points,
                homega_max=homega_max,
                periods=periods,
                repeats=repeats,
                timeout=timeout,
                progress=say,
            )
            if stepped
            else []
        )
        sweeps = []
        for m in controlled:
            say(f"workprecision: {m.id} error-controlled at tolerances {', '.join(f'{t:g}' for t in tolerances)}")
            sweeps.append(
                tolerance_sweep(m, scene, tolerances=tolerances, periods=periods, repeats=repeats, timeout=timeout)
            )
    curves = {m: (d["s_per_unit_time"], d["error"]) for m, d in chart_ready(rows).items()}
    for sweep in sweeps:
        pts = [r for r in sweep["rows"] if r.get("error") and r.get("s_per_unit_time")]
        if pts:
            curves[f"{sweep['method']} error-controlled"] = (
                [r["s_per_unit_time"] for r in pts],
                [r["error"] for r in pts],
            )
    front = pareto_front(curves)
    if args.chart:
        _draw(curves, scene, args.chart, {k for k in curves if k.endswith("error-controlled")})
    return emit(
        {
            "scene": scene.id,
            "params": dict(scene.values),
            "rows": rows,
            "chart": chart_ready(rows),
            "error_controlled": sweeps,
            "pareto_front": [{"method": m, "s_per_unit_time": c, "error": e} for c, e, m in front],
            "chart_file": args.chart,
        },
        args.json,
        _lines,
        scene,
    )


def _draw(curves: dict, scene, path: str, dotted) -> None:
    """The chart of ``harness workprecision --chart``: every method's sweep, the Pareto front marked,
    at most a handful named (``reports.charts.draw_workprecision``)."""
    from pathlib import Path

    from reports import charts

    fig, ax = charts.plt.subplots(figsize=(8, 4.5))
    charts.draw_workprecision(ax, curves, None, dotted)
    ax.set_xlabel(
        "cost: wall seconds per unit of simulated time (reference schemes: compiled loop; engines: their own loop)"
    )
    ax.set_ylabel("max global error")
    ax.set_title(f"{scene.id}: work-precision, the Pareto front marked")
    charts._legend_outside(ax)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    charts._save(fig, Path(path))


def _lines(r):
    yield f"work-precision on {r['scene']}"
    yield "  s/unit t: wall seconds per unit of simulated time; reference schemes compiled, engines their own loop"
    yield f"  {'method':40s} {'h*omega':>9s} {'error':>10s} {'s/unit t':>10s} {'evals/unit t':>12s}"
    for row in r["rows"]:
        yield (
            f"  {row['method']:40s} {row['omega_dt']:9.4g} {fmt(row['error'], '10.3e')} "
            f"{fmt(row['s_per_unit_time'], '10.3e')} {fmt(row['evals_per_unit_time'], '12.4g')}"
        )
    if r["error_controlled"]:
        yield "  error-controlled (steps chosen by the engine's error control at each tolerance):"
        yield (
            f"  {'method':40s} {'tolerance':>9s} {'error':>10s} {'s/unit t':>10s} {'steps':>8s} "
            f"{'rejected':>8s} {'evals':>8s}"
        )
    for sweep in r["error_controlled"]:
        for row in sweep["rows"]:
            yield (
                f"  {row['method']:40s} {row['tolerance']:9.0e} {fmt(row['error'], '10.3e')} "
                f"{fmt(row['s_per_unit_time'], '10.3e')} {fmt(row['steps_taken'], '8d')} "
                f"{fmt(row['steps_rejected'], '8d')} {fmt(row['force_evals'], '8d')}"
            )
        yield f"  {sweep['method']}: the sweep ended at {sweep['ended']}"
    front = r.get("pareto_front") or []
    if front:
        yield "  Pareto front (no other point is both cheaper and more accurate), cheapest first:"
        curve = [(p["s_per_unit_time"], p["error"], p["method"]) for p in front]
        for line in pareto_summary(curve):
            yield f"    {line}"
    if r.get("chart_file"):
        yield f"  chart: {r['chart_file']}"
