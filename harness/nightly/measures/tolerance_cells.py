"""The ``tolerance`` cell: an error-controlled method's work-precision over its tolerance.

Where a scene's suite entry asks for it (``SceneExtras.tolerances``) and the task's method takes a
tolerance (``drake:runge_kutta3``, ``rebound:ias15``: a declared ``tolerance`` option), the task
runs ``harness.measures.tolerance.tolerance_sweep`` with the entry's settings. Value: the largest
global error over the tolerance asked for (above 1: the run missed what it was asked). Its rows
draw the error-controlled curves of the work-precision chart and a chart of their own (error
against tolerance, and against cost with the steps taken and rejected), and a table under the
scene's.
"""

from __future__ import annotations

from records.cell import Cell
from records.figures import ToleranceFigures
from records.findings import Finding
from records.measures import Column, Comparison, Measure, TaskContext, Worse

from harness.nightly.cell_kit import finite, make_cell, plain


def _applies(ctx: TaskContext) -> bool:
    settings = ctx.spec.extras.tolerances
    if not settings or ctx.method is None:
        return False
    methods = settings.get("methods")
    if methods is not None and ctx.task.method not in methods:
        return False
    from harness.measures.tolerance import takes_tolerance

    return takes_tolerance(ctx.method)


def _run(ctx: TaskContext):
    from harness.measures.tolerance import error_over_tolerance, tolerance_sweep

    settings = {k: v for k, v in ctx.spec.extras.tolerances.items() if k != "methods"}
    # On the CPU clock, as the cost cells: the work-precision chart puts both on one axis.
    res = tolerance_sweep(ctx.method, ctx.scene, timeout=ctx.suite.cell_timeout, clock="cpu", **settings)
    rows = plain(res["rows"])
    figures = ToleranceFigures(rows=rows, ended=res["ended"], settings=plain(settings))
    ran = [r for r in rows if r["status"] == "ok"]
    status = "ok" if ran else (rows[0]["status"] if rows else "crashed")
    detail = "" if ran else (rows[0]["detail"] if rows else "no tolerance ran")
    return [
        make_cell(ctx.task, "tolerance", status, finite(error_over_tolerance(rows)), detail=detail, figures=figures)
    ]


def _regression(before: Cell, after: Cell, comparison: Comparison) -> Worse | None:
    """The error at a tolerance both runs measured grew by more than half: the same request now
    buys a worse answer."""
    rows_a = {r["tolerance"]: r for r in before.figures.rows or []}
    for r in after.figures.rows or []:
        a = rows_a.get(r["tolerance"])
        if a and a.get("error") and r.get("error") and r["error"] > 1.5 * a["error"]:
            return Worse(
                "tolerance",
                a["error"],
                r["error"],
                f"error at tolerance {r['tolerance']:g} {a['error']:.3g} -> {r['error']:.3g}",
            )
    return None


def _text(ms: dict, mark) -> str:
    c = ms.get("tolerance")
    if c is None or c.value is None:
        return "–"
    return f"{c.value:.3g}"


def _findings(scene: str, piv: dict) -> list[Finding]:
    """Per method, how far its global error lies from the tolerance asked for, over the sweep."""
    out = []
    for (s, method), ms in sorted(piv.items()):
        c = ms.get("tolerance")
        if s != scene or c is None or c.status != "ok":
            continue
        ran = [r for r in c.figures.rows or [] if r.get("error") is not None]
        if not ran:
            continue
        ratios = [r["error"] / r["tolerance"] for r in ran]
        span = f"{min(ratios):.3g} to {max(ratios):.3g}" if len(ratios) > 1 else f"{ratios[0]:.3g}"
        tight = ran[-1]
        out.append(
            Finding(
                f"`{method}` on `{scene}`, error-controlled: global error / tolerance {span} over tolerances "
                f"{ran[0]['tolerance']:g} to {tight['tolerance']:g} ({tight['steps_taken']} steps taken, "
                f"{tight['steps_rejected'] if tight['steps_rejected'] is not None else 'uncounted'} rejected at "
                f"{tight['tolerance']:g}); the sweep ended: {c.figures.ended}.",
                None,
                scene,
                method,
            )
        )
    return out


def _section(scene: str, piv: dict) -> list[str]:
    """The sweep's rows under the scene's table, one per method and tolerance."""
    rows = []
    for (s, method), ms in sorted(piv.items()):
        c = ms.get("tolerance")
        if s != scene or c is None:
            continue
        for r in c.figures.rows or []:
            cost = r.get("s_per_unit_time")
            rows.append(
                f"| `{method}` | {r['tolerance']:.0e} | "
                f"{'–' if r.get('error') is None else format(r['error'], '.3g')} | "
                f"{r.get('steps_taken') if r.get('steps_taken') is not None else '–'} | "
                f"{r.get('steps_rejected') if r.get('steps_rejected') is not None else 'not counted'} | "
                f"{r.get('force_evals') if r.get('force_evals') is not None else 'not counted'} | "
                f"{'–' if cost is None else format(cost, '.3g')} |"
            )
        rows.append(f"| `{method}` | sweep ended | {c.figures.ended} | | | | |")
    if not rows:
        return []
    return [
        "Error-controlled integration: each method at each tolerance over the same horizon (max global "
        "error; steps taken and rejected by its error control; cost in seconds per unit of simulated time, "
        "the engine's own loop):",
        "",
        "| method | tolerance | error | steps taken | rejected | force evals | cost |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
    ]


def _chart(cells, scene, path) -> bool:
    from reports import charts

    return charts.tolerance_chart(cells, scene, path)


MEASURES = [
    Measure(
        "tolerance",
        ToleranceFigures,
        "error-controlled methods: error, steps taken and rejected, cost against tolerance",
        run=_run,
        applies=_applies,
        regression=_regression,
        findings=_findings,
        columns=(Column("error / tolerance", _text, 85),),
        section=_section,
        chart=_chart,
    )
]
