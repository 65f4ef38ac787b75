"""The report's "History" section and its trend charts, drawn from a judged history
(``harness.history.series.Trend``): it prints and draws what it is given, and judges nothing."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .charts import _save  # noqa: E402
from .drawing import Chart  # noqa: E402

#: Trend charts drawn at most (regressions first, then the latest changes); the rest are listed.
MAX_CHARTS = 12


def _fmt(x) -> str:
    if x is None:
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "unbounded"
    return format(x, ".4g")


def trend_chart(cell, run_ids: list[int], path: Path) -> bool:
    """Value against run for one cell: the points, each with its noise as a band (the larger of
    the cell's noise and the night's measured spread, as the step detection weighed it), the
    detected levels as a step line, a changed level in red where it is worse."""
    ok = cell.ok_points()
    pts = [p for p in ok if math.isfinite(p.value)]
    if not pts:
        return False
    pos = {r: i for i, r in enumerate(run_ids)}
    fig, ax = plt.subplots(figsize=(5.0, 2.2))
    x = [pos[p.run_id] for p in pts]
    y = [p.value for p in pts]
    if cell.fit is not None:
        noise = {p.run_id: s for p, s in zip(ok, cell.fit.point_noise)}
        lo = [p.value * math.exp(-noise[p.run_id]) for p in pts]
        hi = [p.value * math.exp(noise[p.run_id]) for p in pts]
        ax.bar(
            x,
            [h - lw for h, lw in zip(hi, lo)],
            bottom=lo,
            width=0.7,
            color="tab:blue",
            alpha=0.18,
            linewidth=0,
            label="noise band",
        )
    ax.plot(x, y, "o", color="tab:blue", markersize=3.5, label="measured")
    worse_from = {ch.run_id for ch in cell.changes if ch.worse}
    for a, b, level in cell.levels():
        if not math.isfinite(level):
            continue
        colour = "tab:red" if a in worse_from else "0.2"
        ax.hlines(level, pos[a] - 0.4, pos[b] + 0.4, colors=colour, linewidth=1.6)
    ax.plot([], [], color="0.2", linewidth=1.6, label="detected levels")
    ax.set_xticks(range(len(run_ids)))
    step = max(1, len(run_ids) // 12)
    ax.set_xticklabels([str(r) if i % step == 0 else "" for i, r in enumerate(run_ids)], fontsize=7)
    ax.set_xlim(-0.6, len(run_ids) - 0.4)
    ax.set_xlabel("run", fontsize=8)
    ax.set_ylabel(cell.unit, fontsize=8)
    ax.tick_params(axis="y", labelsize=7)
    ax.set_title(cell.label, fontsize=8)
    ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)  # never over the data
    return _save(fig, path)


def _changed_in_order(trend) -> list:
    """The changed cells, in the order the section lists them: regressions first, then the
    latest changes."""
    return sorted(trend.changed(), key=lambda c: (c.regression is None, -max(ch.run_id for ch in c.changes), c.label))


def _chart_name(run_id: int, i: int) -> str:
    return f"charts/run{run_id}-history-{i}.png"


def history_charts(trend, run_id: int) -> list[Chart]:
    """The trend charts the section shows (MAX_CHARTS at most), to be drawn (``reports.drawing``)."""
    if trend is None or not trend.runs:
        return []
    return [
        Chart(_chart_name(run_id, i), trend_chart, (cell, trend.run_ids))
        for i, cell in enumerate(_changed_in_order(trend)[:MAX_CHARTS])
    ]


def history_section(trend, run_id: int, drawn) -> list[str]:
    """The section's markdown lines, none without a history; ``drawn``: the names of the charts
    drawn (of ``history_charts``), the others left out."""
    if trend is None or not trend.runs:
        return []
    lines = ["## History", ""]
    ids = trend.run_ids
    how = (
        f"cost judged by step detection over them (from {trend.min_runs} runs on)"
        if trend.judged
        else f"cost judged by the last two runs until {trend.min_runs} runs exist"
    )
    which = ", ".join(map(str, ids)) if len(ids) <= 6 else f"{ids[0]}–{ids[-1]}"
    intro = (
        f"{len(ids)} run(s) of the `{trend.suite}` suite, measurement version {trend.measurement_version} "
        f"(runs {which}); accuracy figures compared run to run, {how}."
    )
    if trend.left_out:
        intro += f" {trend.left_out}."
    order = _changed_in_order(trend)
    machine = [(c, ch) for c in trend.cells for ch in c.machine_steps]
    if machine:
        runs = sorted({ch.run_id for _, ch in machine})
        intro += (
            f" {len(machine)} cost step(s) the fit found (at run(s) {', '.join(map(str, runs))}) are the "
            f"machine's, not the methods': nothing they depend on changed, or the calibration timed beside "
            f"them moved as much (`harness history` lists them)."
        )
    if not order:
        return lines + [
            intro
            + " **Unchanged**: no accuracy figure changed and no cost step was detected"
            + (" beyond the machine's noise" if machine else "")
            + ".",
            "",
        ]
    lines += [
        intro,
        "",
        "| cell | measure | change | from run | commits | what differs | |",
        "|---|---|---|---|---|---|---|",
    ]
    for cell in order:
        for ch in cell.changes:
            size = f" ({ch.size:+.1%})" if ch.size is not None else ""
            conf = f", confidence {ch.confidence:.3f}" if ch.confidence is not None else ""
            flag = "**regression**" if cell.regression is not None and ch.worse else ("worse" if ch.worse else "better")
            lines.append(
                f"| `{cell.method}` on {cell.scene} | {cell.measure} | {_fmt(ch.before)} → {_fmt(ch.after)}"
                f"{size}{conf} | {ch.run_id} | {ch.commits} | {ch.cause} | {flag} |"
            )
    lines.append("")
    drawn = set(drawn)
    for i, cell in enumerate(order[:MAX_CHARTS]):
        name = _chart_name(run_id, i)
        if name in drawn:
            lines += [f"![History of {cell.label}]({name})", ""]
    if len(order) > MAX_CHARTS:
        lines += [f"{len(order) - MAX_CHARTS} more changed cell(s) listed above without a chart.", ""]
    return lines
