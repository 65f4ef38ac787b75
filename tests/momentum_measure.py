"""A ``HARNESS_PLUGINS`` module for the tests: a measure declared in one module, registered from
here and nowhere else (``records.measures``), which every part of the harness must then take.

``momentum``: the largest |m v| of the energy run on a 1-DOF scene (the spring's mass times its
velocity), against the exact solution's (m omega x0 on the undamped spring), as a ratio. A
symplectic scheme's stays near 1; a scheme that gains energy exceeds it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from records.cell import Cell
from records.figures import Figures
from records.measures import Column, Comparison, Measure, TaskContext, Worse


@dataclass(frozen=True)
class MomentumFigures(Figures):
    peak: float | None = None
    exact_peak: float | None = None
    t: list | None = None
    p: list | None = None


def _applies(ctx: TaskContext) -> bool:
    return ctx.scene.id == "spring" and not ctx.method.adaptive


def _run(ctx: TaskContext) -> list[Cell]:
    from harness.execution.simulate import simulate
    from harness.nightly.cell_kit import energy_run, make_cell

    steps, every = energy_run(ctx.scene, ctx.dt, ctx.spec, ctx.suite)
    traj = simulate(ctx.run_method, ctx.scene, ctx.dt, steps, every, timeout=ctx.suite.cell_timeout)
    if not traj.ok:
        return [make_cell(ctx.task, "momentum", traj.status, dt=ctx.dt, steps=steps, detail=traj.detail)]
    m = ctx.scene.values["m"]
    p = m * traj.v[:, 0, 0]
    exact = m * ctx.scene.omega * abs(ctx.scene.values["x0"]) if ctx.scene.values["v0"] == 0 else None
    peak = float(np.max(np.abs(p)))
    figures = MomentumFigures(peak=peak, exact_peak=exact, t=traj.t[::8].tolist(), p=p[::8].tolist())
    return [make_cell(ctx.task, "momentum", "ok", peak / exact if exact else None, ctx.dt, steps, figures=figures)]


def _regression(before: Cell, after: Cell, comparison: Comparison) -> Worse | None:
    va, vb = before.value, after.value
    if va is not None and vb is not None and abs(vb - 1) > 2 * abs(va - 1) + 1e-3:
        return Worse("momentum", va, vb, f"peak |p| / exact {va:.4g} -> {vb:.4g}")
    return None


def _findings(scene, piv):
    from records.findings import Finding

    out = []
    for (s, method), ms in sorted(piv.items()):
        c = ms.get("momentum")
        if s == scene and c is not None and c.value is not None:
            out.append(
                Finding(
                    f"`{method}` on `{scene}`: peak |p| is {c.value:.4g} of the exact solution's", None, scene, method
                )
            )
    return out


def _text(ms, mark) -> str:
    c = ms.get("momentum")
    return "–" if c is None or c.value is None else f"{c.value:.4g}"


def _chart(cells, scene, path) -> bool:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [c for c in cells if c.measure == "momentum" and c.figures.t]
    if not rows:
        return False
    fig, ax = plt.subplots(figsize=(5, 3))
    for c in rows:
        ax.plot(c.figures.t, c.figures.p, label=c.method)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("m v")
    ax.legend(fontsize=6)
    fig.savefig(path)
    plt.close(fig)
    return True


MEASURES = [
    Measure(
        "momentum",
        MomentumFigures,
        "peak |m v| of the energy run against the exact solution's",
        run=_run,
        applies=_applies,
        regression=_regression,
        findings=_findings,
        columns=(Column("peak \\|p\\| / exact", _text, 60),),
        chart=_chart,
        trend="peak |p| / exact",
    )
]
