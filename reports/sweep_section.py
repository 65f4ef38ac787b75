"""The ``sweep`` cells in the report: under a scene's table, per sweep (one per size), each
family's cheapest frame at every value of the swept parameter and the crossovers; and the chart,
cost per frame against the parameter (h*omega at one substep on the top axis), one line per
method, one panel per sweep, the crossovers marked. Everything is read from the cells
(``records.advice.SweepFigures``): nothing is measured or judged here."""

from __future__ import annotations

import math
from pathlib import Path

from records.advice import SweepFigures, family_name

from .text import fmt as _fmt

#: One colour per family on the chart (its crossover marks and cheapest-frame band); others cycle.
FAMILY_COLOURS = {
    "explicit": "tab:blue",
    "implicit": "tab:red",
    "position_based": "tab:green",
    "constrained": "tab:purple",
    "decay": "tab:cyan",
}


def _sweeps(cells) -> list:
    """The ok sweep cells, smallest sheet first (by the label's size, then the method)."""
    rows = [c for c in cells if c.measure == "sweep" and c.status == "ok" and c.figures.points]
    return sorted(rows, key=lambda c: (_size(c), c.method))


def _size(cell) -> float:
    params = cell.figures.params or {}
    return float(params.get("n", 1)) * float(params.get("m", 1)) * float(params.get("N", 1))


def _us(seconds) -> str:
    return "–" if seconds is None else f"{seconds * 1e6:.3g} µs"


def _title(f: SweepFigures, scene: str) -> str:
    return f"`{scene}`" + (f" {f.label}" if f.label else "")


def sweep_section(scene: str, piv: dict) -> list[str]:
    """Per sweep cell on ``scene``: the request, a table of each family's cheapest frame at every
    value, the crossovers, and which bound ended the searches that met nothing."""
    cells = _sweeps([ms["sweep"] for (s, _), ms in piv.items() if s == scene and "sweep" in ms])
    broken = [ms["sweep"] for (s, _), ms in piv.items() if s == scene and "sweep" in ms and ms["sweep"].status != "ok"]
    if not cells and not broken:
        return []
    lines = []
    for c in cells:
        f = c.figures
        r = f.sweep_request()
        points = f.sweep_points()
        families = list(dict.fromkeys(e.family for p in points for e in p.entries))
        tol = " and ".join(
            t
            for t in (
                f"energy error ≤ {r.energy_tol:g}" if r.energy_tol else "",
                f"position error ≤ {r.error_tol:g}"
                if r.error_tol
                else f"position error ≤ {100 * r.error_rel:g}% of the scene's length scale"
                if r.error_rel
                else "",
            )
            if t
        )
        if not (r.error_tol or r.error_rel):
            tol = f"{tol}, no accuracy tolerance (positions not judged)"
        params = ", ".join(f"{k}={v:g}" for k, v in (f.params or {}).items())
        lines += [
            f"**Where the trade-off flips on {_title(f, scene)}** ({params}): the cheapest frame of each family "
            f"against {f.param}, at {f.hz:g} Hz over {_fmt(r.horizon, 'g')} s, {tol or 'the tolerances'}. "
            f"Each method is searched to {_fmt(r.max_substeps, 'd', '?')} substeps, then doubled until it meets "
            f"them, its frame would cost more than {f.factor:g} × the cheapest, or past {f.cap} substeps; "
            f"cost per frame = substeps × the compiled kernel's (an engine mode's step's; a library solve's, "
            f"`?solver=`, the Python loop that runs it) {f.clock.upper()}-clock time per step. Each pick: its energy "
            "error E and position error x; * where its win rests on "
            "the solve's own error (it misses the tolerances with its convergence knob tightened: ten times "
            "the passes, a tolerance a hundred times tighter).",
            "",
            f"| {f.param} | h·ω at 1 substep | " + " | ".join(family_name(k) for k in families) + " | cheapest |",
            "|---|---|" + "---|" * len(families) + "---|",
        ]
        for p in points:
            from_family = p.family_costs()
            cols = [
                (
                    f"`{e.method}` {e.substeps} × = {_us(e.cost_per_frame_s)} (E {_fmt(e.energy_error, '.2g')}, "
                    f"x {_fmt(e.position_error, '.2g')}){RESTS if e.rests_on_solve else ''}"
                    if e
                    else "–"
                )
                for e in (from_family.get(k) for k in families)
            ]
            best = p.cheapest
            lines.append(
                f"| {p.value:.3g} | {p.homega_one:.3g} | "
                + " | ".join(cols)
                + f" | {family_name(best.family) if best else 'none meets them'} |"
            )
        lines.append("")
        cross = f.sweep_crossovers()
        for x in cross:
            lines.append(
                f"Crossover: {family_name(x.from_family)} (`{x.from_method}`) → {family_name(x.to_family)} "
                f"(`{x.to_method}`) between {f.param} = {x.below:.3g} and {x.above:.3g}, "
                f"{'interpolated at' if x.interpolated else 'midway,'} {f.param} ≈ {x.value:.3g}, "
                f"h·ω ≈ {x.homega_one:.3g} at one substep."
            )
        if not cross:
            lines.append("No crossover: the cheapest family does not change over the grid.")
        ended = _ended(points)
        if ended:
            lines.append("Searches that met nothing: " + "; ".join(ended) + ".")
        lines.append("")
    for c in broken:
        lines += [f"Sweep in `{c.method}`'s task: {c.status}: {c.detail or '–'}", ""]
    return lines


#: The mark of a pick whose win rests on its solve's own error (escaped: a bare * is emphasis in markdown).
RESTS = " \\*"


#: What the section says of each bound that ended a search.
BOUNDS = {
    "cost": "past the cost factor",
    "cap": "past the most substeps",
    "crashed": "crashed",
    "timed_out": "timed out",
}


def _ended(points) -> list[str]:
    """``method``: the bound, at which values (the bound that ended each search that met nothing)."""
    by: dict = {}
    for p in points:
        for e in p.entries:
            if e.ended not in ("met", ""):
                at = f"{p.value:.3g}" + (f" ({e.next_substeps} substeps)" if e.next_substeps else "")
                by.setdefault((e.method, e.ended), []).append(at)
    return [f"`{m}` {BOUNDS.get(b, b)} at " + ", ".join(ats) for (m, b), ats in sorted(by.items())]


def sweep_chart(cells, scene: str, path) -> bool:
    """Cost per frame against the swept parameter, one panel per sweep (size): one line per method
    over the values where it meets the tolerances (its fewest substeps beside each point where
    it searched past the advice's most), an open triangle where the cost bound ended its search
    (the frame it did not run: at least that dear), each family's cheapest frame as a wide faint band, each
    crossover a vertical line with the families and its h*omega; the top axis h*omega at one
    substep."""
    from . import charts

    plt = charts.plt
    rows = _sweeps(cells)
    if not rows:
        return False
    styles = charts.method_styles(e.method for c in rows for p in c.figures.sweep_points() for e in p.entries)
    fig, axes = plt.subplots(1, len(rows), figsize=(5.2 * len(rows) + 2.5, 4.6), squeeze=False)
    drawn = False
    for ax, c in zip(axes[0], rows):
        f = c.figures
        points = f.sweep_points()
        limit = f.sweep_request().max_substeps or math.inf
        methods = list(dict.fromkeys(e.method for p in points for e in p.entries))
        for m in methods:
            pts = [
                (p.value, e.cost_per_frame_s * 1e6, e.substeps)
                for p in points
                for e in p.entries
                if e.method == m and e.ended == "met" and e.cost_per_frame_s
            ]
            if not pts:
                continue
            drawn = True
            style = dict(styles[m], linewidth=1.0)
            ax.plot([x for x, _, _ in pts], [y for _, y, _ in pts], markersize=3.5, label=m, **style)
            for x, y, s in pts:
                if s > limit:
                    ax.annotate(
                        str(s), (x, y), textcoords="offset points", xytext=(3, 3), fontsize=5.5, color=style["color"]
                    )
            cut = [
                (p.value, e.next_substeps * e.cost_per_step_s * 1e6)
                for p in points
                for e in p.entries
                if e.method == m and e.ended == "cost" and e.next_substeps and e.cost_per_step_s
            ]
            if cut:  # where the cost bound ended its search: the frame it did not run, a lower bound
                ax.scatter(*zip(*cut), marker="^", facecolors="none", edgecolors=style["color"], s=22, linewidths=0.8)
        families = list(dict.fromkeys(e.family for p in points for e in p.entries))
        for k in families:
            band = [(p.value, p.family_costs()[k].cost_per_frame_s * 1e6) for p in points if k in p.family_costs()]
            if band:
                ax.plot(
                    *zip(*band),
                    color=FAMILY_COLOURS.get(k, "0.5"),
                    linewidth=7,
                    alpha=0.18,
                    solid_capstyle="round",
                    label=f"cheapest: {family_name(k)}",
                )
        for x in f.sweep_crossovers():
            colour = FAMILY_COLOURS.get(x.to_family, "0.3")
            ax.axvline(x.value, color=colour, linestyle="--", linewidth=1.0)
            ax.annotate(
                f"{family_name(x.from_family)} → {family_name(x.to_family)}\n"
                f"{f.param} ≈ {x.value:.3g}, h·ω ≈ {x.homega_one:.3g}",
                (x.value, 0.98),
                xycoords=("data", "axes fraction"),
                xytext=(4, 0),
                textcoords="offset points",
                ha="left",
                va="top",
                fontsize=6.5,
                color=colour,
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f.param)
        ax.set_ylabel(f"cost per frame, µs ({f.clock.upper()} clock: substeps × compiled kernel per step)")
        ax.set_title(f"{scene} {f.label or ''} at {f.hz:g} Hz".replace("  ", " "), fontsize=9)
        _homega_axis(ax, points)
    if not drawn:
        plt.close(fig)
        return False
    handles, labels = axes[0][-1].get_legend_handles_labels()
    seen = dict(zip(labels, handles))
    for ax in axes[0][:-1]:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    axes[0][-1].legend(
        list(seen.values()),
        list(seen.keys()),
        fontsize=6,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        borderaxespad=0.0,
    )
    return charts._save(fig, Path(path))


def _homega_axis(ax, points) -> None:
    """The top axis: h*omega at one substep, interpolated log-log between the grid's values."""
    import numpy as np

    xs = np.log([p.value for p in points])
    ys = np.log([p.homega_one for p in points])
    if len(xs) < 2 or not np.all(np.diff(xs) > 0):
        return

    def forward(x):
        with np.errstate(all="ignore"):
            return np.exp(_extrap(np.log(np.clip(x, 1e-300, None)), xs, ys))

    def inverse(y):
        with np.errstate(all="ignore"):
            return np.exp(_extrap(np.log(np.clip(y, 1e-300, None)), ys, xs))

    top = ax.secondary_xaxis("top", functions=(forward, inverse))
    top.set_xlabel("h·ω at one substep", fontsize=7)
    top.tick_params(labelsize=6)


def _extrap(x, xs, ys):
    """Piecewise-linear through (xs, ys), extended by its end segments' slopes."""
    import numpy as np

    x = np.asarray(x, dtype=float)
    y = np.interp(x, xs, ys)
    lo = ys[0] + (x - xs[0]) * (ys[1] - ys[0]) / (xs[1] - xs[0])
    hi = ys[-1] + (x - xs[-1]) * (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
    return np.where(x < xs[0], lo, np.where(x > xs[-1], hi, y))
