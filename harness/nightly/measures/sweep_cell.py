"""The nightly's ``sweep`` cell (the full suite's cloth, net and chain): the advice over a log grid
of one scene parameter (``harness.measures.sweep``), every method of the sweep's selection at
every value, and where the cheapest family changes.

A scene's suite entry lists its sweeps in ``extras.sweep``: the grid and the request, and
``sizes``, one per sweep, each the scene's parameters at that size and the method whose task
measures it, and its own ``grid``, ``methods``, ``request`` or ``factor`` where it takes others (a
sweep covers every method, so one task holds it; the sizes go to different tasks, so that they run
side by side). The cell's value is the first crossover's h*omega at one
substep (None where the cheapest family never changes); its figures carry every value's entries
(``records.advice.SweepFigures``), which the chart, the report's section and the finding read, and
where positions are judged each value's predictable horizon (``harness.measures.horizon``: the
position error inside it, the centre of mass and the largest strain past it), which the findings
state beside the seed's claims.
"""

from __future__ import annotations

from dataclasses import asdict

from records.advice import SweepFigures
from records.measures import Measure

from harness.nightly.cell_kit import make_cell, plain


def sweeps_of(ctx) -> list[dict]:
    """The sweeps ``ctx``'s task measures (its scene spec's ``extras.sweep`` sizes naming its method)."""
    settings = ctx.spec.extras.sweep
    if not settings:
        return []
    return [size for size in settings["sizes"] if size["task"] == ctx.task.method]


def _run(ctx) -> list:
    from scenarios import make_scene

    from harness.measures.advise import Request
    from harness.measures.sweep import CAP, CLOCK, FACTOR, parse_grid, run_sweep

    settings = ctx.spec.extras.sweep
    size = sweeps_of(ctx)[0]
    scene = make_scene(ctx.task.scene, **{**ctx.task.params, **size["params"]})
    grid = parse_grid(size.get("grid", settings["grid"]), scene)
    request = Request(hz=settings["hz"], **size.get("request", settings["request"])).checked()
    factor, cap = size.get("factor", settings.get("factor", FACTOR)), settings.get("cap", CAP)
    res = run_sweep(
        scene,
        grid,
        request,
        list(size.get("methods", settings["methods"])),
        factor=factor,
        cap=cap,
        timeout=ctx.suite.cell_timeout,
        pool=False,
    )
    cross = res.crossovers
    figures = SweepFigures(
        label=size.get("label"),
        param=grid.param,
        params=plain(res.params),
        hz=request.hz,
        request=plain(asdict(request)),
        factor=factor,
        cap=cap,
        clock=CLOCK,
        points=plain([p.as_dict() for p in res.points]),
        crossovers=plain([c.as_dict() for c in cross]),
    )
    return [
        make_cell(ctx.task, "sweep", "ok", cross[0].homega_one if cross else None, 1.0 / request.hz, figures=figures)
    ]


def _section(scene, piv):
    from reports.sweep_section import sweep_section

    return sweep_section(scene, piv)


def _chart(cells, scene, path):
    from reports.sweep_section import sweep_chart

    return sweep_chart(cells, scene, path)


def _findings(scene, piv):
    from harness.sweep_findings import sweep_findings

    return sweep_findings(scene, piv)


MEASURES = [
    Measure(
        "sweep",
        SweepFigures,
        "the advice over a grid of one scene parameter: each method's cheapest frame, and where "
        "the cheapest family changes (the crossover)",
        run=_run,
        applies=lambda ctx: bool(sweeps_of(ctx)),
        findings=_findings,
        section=_section,
        chart=_chart,
    )
]
