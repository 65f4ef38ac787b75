"""Charts (matplotlib, Agg backend, PNG) drawn from stored cells. Each returns True when it drew."""

from __future__ import annotations

import math
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from matplotlib.ticker import Formatter, LogFormatterMathtext, NullFormatter  # noqa: E402

from records.cell import Cell  # noqa: E402


#: The report's colours: tab20's ten strong ones, its ten light ones, then tab20b's twenty (40 in
#: all: neighbours in id order differ in hue first), and the markers, cycling at another period.
COLOURS = (
    [plt.cm.tab20(i) for i in range(0, 20, 2)]
    + [plt.cm.tab20(i) for i in range(1, 20, 2)]
    + [plt.cm.tab20b(i) for i in range(20)]
)
MARKERS = "osD^v<>phXP*"


def method_styles(methods) -> dict[str, dict]:
    """One colour and marker per method, the same in every chart of a report: the methods in id
    order, the i-th the i-th colour (40 distinct) and marker; reference schemes solid lines,
    engine modes dashed. Charts of one scene show a subset, each method as in the others."""
    return {
        m: {
            "color": COLOURS[i % len(COLOURS)],
            "marker": MARKERS[i % len(MARKERS)],
            "linestyle": "-" if m.startswith("ref:") else "--",
            "linewidth": 1.2,
        }
        for i, m in enumerate(sorted(set(methods)))
    }


def _style(method: str, styles: dict | None) -> dict:
    return dict((styles or {}).get(method) or method_styles([method])[method])


def _legend_outside(ax, fontsize: float = 7) -> None:
    """The legend right of the axes, never over the data."""
    ax.legend(fontsize=fontsize, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def plain_power_label(label: str) -> str:
    """A log axis's tick label as plain text: ``$\\mathdefault{4\\times10^{-3}}$`` -> ``4×10⁻³``
    (Unicode superscripts); any other label as it is."""
    m = re.fullmatch(r"\$\\mathdefault\{([-0-9.]*(?:\\times)?(?:10\^\{-?[0-9]+\})?)\}\$", label)
    if not m:
        return label
    body = m.group(1).replace("\\times", "×")
    if body.startswith("-"):
        body = "−" + body[1:]  # the minus sign mathtext sets
    return re.sub(r"\^\{(-?[0-9]+)\}", lambda e: e.group(1).translate(_SUPERSCRIPT), body)


class PlainPowerFormatter(Formatter):
    """A log (or symlog) axis's own tick labels, written as plain text (``plain_power_label``):
    the same labels, without mathtext, whose parser was the largest cost of drawing these
    charts after the ticks themselves."""

    def __init__(self, inner: Formatter):
        self.inner = inner

    def set_axis(self, axis):
        super().set_axis(axis)
        self.inner.set_axis(axis)

    def set_locs(self, locs):
        self.inner.set_locs(locs)

    def __call__(self, x, pos=None):
        return plain_power_label(self.inner(x, pos))

    def format_data_short(self, value):
        return self.inner.format_data_short(value)


def _plain_power_labels(fig) -> None:
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if isinstance(axis.get_major_formatter(), LogFormatterMathtext):
                axis.set_major_formatter(PlainPowerFormatter(axis.get_major_formatter()))
            if isinstance(axis.get_minor_formatter(), LogFormatterMathtext):
                axis.set_minor_formatter(PlainPowerFormatter(axis.get_minor_formatter()))


#: The charts' resolution (dots per inch) and the margin left around what they draw (inches).
DPI, PAD_INCHES = 90, 0.1


def _save(fig, path: Path) -> bool:
    """``fig`` written to ``path`` as PNG, cropped to what it draws plus PAD_INCHES: the crop of
    ``savefig(bbox_inches="tight")``, with the box measured once, at the PNG's dpi, and handed
    to savefig; "tight" draws the whole figure once to measure it and once more to write it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.set_dpi(DPI)
    _plain_power_labels(fig)
    box = fig.get_tightbbox(fig.canvas.get_renderer()).padded(PAD_INCHES)
    fig.savefig(tmp, dpi=DPI, bbox_inches=box)
    plt.close(fig)
    tmp.replace(path)
    return path.stat().st_size > 0


def _ok(cells: list[Cell], measure: str, statuses=("ok",)) -> list[Cell]:
    """The cells of one measure with one of these statuses, by method."""
    return sorted((c for c in cells if c.measure == measure and c.status in statuses), key=lambda c: c.method)


def energy_chart(cells: list[Cell], scene: str, path: Path, styles: dict | None = None) -> bool:
    """E(t)/E_exact(0) per method at the nominal timestep, log scale; the exact curve faint.
    Explicit Euler's energy runs away, symplectic schemes stay in a band, RK4 and implicit Euler sink."""
    rows = [c for c in _ok(cells, "energy", ("ok", "unstable")) if c.figures.series]
    if not rows:
        return False
    fig, ax = plt.subplots(figsize=(8, 4.5))
    exact_drawn = False
    for r in rows:
        s = r.figures.series
        t, e, ex = np.asarray(s["t"]), np.asarray(s["energy"], dtype=float), np.asarray(s["exact"], dtype=float)
        e0 = abs(ex[0]) if len(ex) and ex[0] != 0 else 1.0
        if not exact_drawn:
            ax.plot(t, np.abs(ex) / e0, color="0.7", linewidth=4, alpha=0.5, label="exact", zorder=0)
            exact_drawn = True
        with np.errstate(all="ignore"):
            drawn = np.where(np.isfinite(e) & (e != 0.0), np.abs(e) / e0, np.nan)  # as measured: no floor, no cap
        ax.plot(
            t,
            drawn,
            label=r.method,
            markersize=4,
            markevery=max(1, len(t) // 10),
            **_style(r.method, styles),
        )
    ax.set_yscale("log")
    ax.set_xlabel("t")
    ax.set_ylabel("|E(t)| / |E_exact(0)|  (as measured; a blow-up's non-finite states left out)")
    ax.set_title(f"{scene}: energy at the nominal timestep")
    _legend_outside(ax)
    return _save(fig, path)


def nominal_chart(cells: list[Cell], scene: str, path: Path, styles: dict | None = None) -> bool:
    """Energy against time over the stability measure's finite horizon at the nominal timestep
    (the stability cells' ``nominal`` runs), one line per method, a blow-up marked where it
    happened: drawn where a method blew up within it (the evidence of the findings' line)."""
    rows = [c for c in _ok(cells, "stability") if c.figures.nominal is not None and c.figures.nominal.has_series]
    if not any(c.figures.nominal.failed_step for c in rows):
        return False
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for r in rows:
        n = r.figures.nominal
        t, e = np.asarray(n.series["t"]), np.abs(np.asarray(n.series["energy"], dtype=float))
        st = _style(r.method, styles)
        label = r.method + (f" (blew up at step {n.failed_step})" if n.failed_step else "")
        e = np.where(np.isfinite(e) & (e > 0.0), e, np.nan)  # as measured: no floor, no cap
        ax.plot(t, e, label=label, markersize=4, markevery=max(1, len(t) // 10), **st)
        if n.failed_step:
            last = e[np.isfinite(e)][-1:] if np.any(np.isfinite(e)) else []
            ax.plot(t[-1:][: len(last)], last, marker="x", color="tab:red", markersize=10, linestyle="none")
    ax.set_yscale("log")
    ax.set_xlabel("t")
    ax.set_ylabel("|E(t)|")
    dt = rows[0].figures.nominal.dt
    ax.set_title(f"{scene}: energy at the nominal dt = {dt:.3g} over the stability measure's horizon")
    _legend_outside(ax)
    return _save(fig, path)


def cost_source(method: str) -> str:
    """Which loop a cost cell timed, as the chart's legend says it: a reference scheme's compiled
    loop, an engine mode's own loop (never the harness's per-step path)."""
    return "compiled" if method.startswith("ref:") else "engine's own loop"


#: The most series a work-precision chart names: those that hold the Pareto front first, then the
#: rest by how near their best point comes to it; the others are drawn faint and unnamed (their
#: figures are in the tables).
MAX_NAMED = 6


def draw_workprecision(ax, curves: dict, styles: dict | None = None, dotted=()) -> list[str]:
    """Error against cost, log-log, for ``curves`` ({label: (costs, errors)}), with the Pareto front
    (``harness.measures.workprecision.pareto_front``) drawn as a thick grey staircase and at most
    ``MAX_NAMED`` series named; ``dotted``: labels drawn dotted (error-controlled sweeps). Returns
    the labels named, those on the front first."""
    from records.pareto import pareto_front

    front = pareto_front(curves)
    on_front = list(dict.fromkeys(m for _, _, m in front))

    def gap(label):
        costs, errors = curves[label]
        best = min((e for e in errors if e and e > 0), default=math.inf)
        return best

    rest = sorted((m for m in curves if m not in on_front), key=gap)
    named = (on_front + rest)[:MAX_NAMED]
    methods = [label.split(" ")[0] for label in named]
    styles = {**method_styles(methods), **(styles or {})}
    faint = False
    for label, (costs, errors) in curves.items():
        pts = sorted((c, e) for c, e in zip(costs, errors) if c and e and c > 0 and e > 0)
        if not pts:
            continue
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        if label in named:
            style = _style(label.split(" ")[0], styles)
            if label in dotted:
                style.update(linestyle=":", marker="x")
            ax.plot(xs, ys, markersize=4, label=label, **style)
        else:
            ax.plot(xs, ys, color="0.8", linewidth=0.8, label=None if faint else "others (in the tables)", zorder=0)
            faint = True
    if front:
        ax.step(
            [p[0] for p in front],
            [p[1] for p in front],
            where="post",
            color="0.25",
            linewidth=3,
            alpha=0.35,
            label="Pareto front",
            zorder=1,
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    return named


def workprecision_chart(cells: list[Cell], scene: str, path: Path, styles: dict | None = None) -> bool:
    """Max global error against measured cost (seconds per unit of simulated time, on the
    clock the cost cells used), log-log, one line per method over its timestep sweep:
    reference schemes solid (compiled loop), engines dashed (the engine's own loop)."""
    order = {c.method: c for c in _ok(cells, "order")}
    cost = {c.method: c for c in _ok(cells, "cost")}
    fig, ax = plt.subplots(figsize=(8, 4.5))
    curves, dotted = {}, set()
    clocks = set()
    for method in sorted(order):
        if method not in cost:
            continue
        sps = cost[method].value
        pts = [p for p in order[method].figures.points or [] if p["error"] and p["error"] > 0]
        if not pts or not sps:
            continue
        curves[f"{method} ({cost_source(method)})"] = ([sps / p["dt"] for p in pts], [p["error"] for p in pts])
        clocks.add(cost[method].figures.clock or "wall")
    # Error-controlled methods (the ``tolerance`` cells): one point per tolerance, their own
    # curve, dotted, beside the fixed-step ones.
    for c in _ok(cells, "tolerance"):
        pts = [r for r in c.figures.rows or [] if r.get("error") and r["error"] > 0 and r.get("s_per_unit_time")]
        if pts:
            label = f"{c.method} error-controlled, tolerance {_tol_span(pts)} (engine's own loop)"
            curves[label] = ([r["s_per_unit_time"] for r in pts], [r["error"] for r in pts])
            dotted.add(label)
            clocks.add(next((r["clock"] for r in pts if r.get("clock")), "wall"))
    if not curves:
        plt.close(fig)
        return False
    draw_workprecision(ax, curves, styles, dotted)
    clock = (
        {"cpu": "CPU", "wall": "wall", "injected": "injected (not measured)"}.get(clocks.pop(), "wall")
        if len(clocks) == 1
        else "mixed-clock"
    )
    ax.set_xlabel(
        f"cost: {clock} seconds per unit of simulated time (measured; engines: their own loop, "
        "not the harness's per-step path)"
    )
    ax.set_ylabel("max global error")
    ax.set_title(f"{scene}: work-precision")
    _legend_outside(ax)
    return _save(fig, path)


def _tol_span(rows: list[dict]) -> str:
    tols = [r["tolerance"] for r in rows]
    return f"{max(tols):.0e} to {min(tols):.0e}" if len(tols) > 1 else f"{tols[0]:.0e}"


def tolerance_chart(cells: list[Cell], scene: str, path: Path, styles: dict | None = None) -> bool:
    """Error-controlled methods over their tolerance sweep (``harness.measures.tolerance``): left,
    max global error against the tolerance asked for (the diagonal: error = tolerance); right,
    the same error against measured cost per unit of simulated time (the engine's own loop,
    model built off the clock) with the steps taken and rejected written at each point."""
    rows = [c for c in _ok(cells, "tolerance") if any(r.get("error") for r in c.figures.rows or [])]
    if not rows:
        return False
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    clocks, lo, hi = set(), math.inf, 0.0
    for c in rows:
        pts = [r for r in c.figures.rows if r.get("error") and r["error"] > 0]
        st = {k: v for k, v in _style(c.method, styles).items() if k in ("color", "linestyle", "marker")}
        tol = [r["tolerance"] for r in pts]
        lo, hi = min(lo, *tol), max(hi, *tol)
        left.plot(tol, [r["error"] for r in pts], label=c.method, **st)
        timed = [r for r in pts if r.get("s_per_unit_time")]
        right.plot([r["s_per_unit_time"] for r in timed], [r["error"] for r in timed], label=c.method, **st)
        for r in timed:
            right.annotate(
                f"{r['steps_taken']}/{r['steps_rejected'] if r['steps_rejected'] is not None else '?'}",
                (r["s_per_unit_time"], r["error"]),
                fontsize=6,
                xytext=(3, 3),
                textcoords="offset points",
            )
            clocks.add(r.get("clock") or "wall")
    left.plot([lo, hi], [lo, hi], color="0.6", linewidth=0.8, linestyle="--", label="error = tolerance")
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylabel("max global error")
    left.set_xlabel("tolerance asked for\n(Drake: target accuracy; IAS15: epsilon)")
    clock = (
        {"cpu": "CPU", "wall": "wall", "injected": "injected (not measured)"}.get(clocks.pop(), "wall")
        if len(clocks) == 1
        else "mixed-clock"
    )
    right.set_xlabel(
        f"cost: {clock} seconds per unit of simulated time\n(the engine's own loop; labels: steps taken / rejected)"
    )
    right.xaxis.set_minor_formatter(NullFormatter())
    fig.suptitle(f"{scene}: error-controlled integration against its tolerance")
    _legend_outside(right)
    return _save(fig, path)


def stability_chart(cells: list[Cell], scene: str, path: Path, styles: dict | None = None) -> bool:
    """Largest stable h*omega per method: bars; unbounded methods drawn to the searched bound
    and hatched; methods unstable for every h drawn at zero and labelled."""
    rows = _ok(cells, "stability")
    if not rows:
        return False
    fig, ax = plt.subplots(figsize=(8, 0.35 * len(rows) + 1.2))
    small = [r.value for r in rows if r.value is not None and 0 < r.value < 10 and not math.isnan(r.value)]
    for i, r in enumerate(rows):
        f = r.figures
        if f.unstable_everywhere or f.unresolved:
            ax.barh(i, 0.0)
            ax.text(
                0.02,
                i,
                "unstable for every h" if f.unstable_everywhere else "no stable step resolved",
                va="center",
                fontsize=7,
            )
        elif f.unbounded:
            bound = f.homega_searched or 100.0
            ax.barh(i, bound, hatch="//", color="0.85", edgecolor="0.4")
            ax.text(bound, i, f" unbounded (searched to {bound:.3g})", va="center", fontsize=7)
        else:
            v = r.value if r.value is not None and not math.isnan(r.value) else 0.0
            st = _style(r.method, styles)
            ax.barh(i, v, color=st["color"], edgecolor="0.2", linestyle=st["linestyle"], linewidth=0.8)
            ax.text(v, i, f" {v:.4g}", va="center", fontsize=7)
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([r.method for r in rows], fontsize=7)
    # The nominal timestep (a model file's own opt.timestep) where the finite-horizon search ran
    # at one: a bar short of this line is a mode unstable at the step the model is run with.
    nominal = {r.figures.nominal.homega for r in rows if r.figures.nominal is not None}
    if len(nominal) == 1:
        x = nominal.pop()
        ax.axvline(x, color="crimson", linestyle=":", linewidth=1.2)
        ax.text(x, len(rows) - 0.4, f" nominal h·ω {x:.3g}", color="crimson", fontsize=7, va="bottom")
        linthresh = min([10.0, x] + small)  # values far below 10 (a model's h·ω) stay visible
    else:
        linthresh = 10.0
    ax.set_xscale("symlog", linthresh=linthresh)
    ax.set_xlabel("largest stable h·ω")
    ax.set_title(f"{scene}: stability limit (each method in its report colour; engine modes edged dashed)")
    return _save(fig, path)


def _stacked_labels(ax, at: dict, y: float) -> None:
    """One label a method under its point at the top edge (``at``: method -> x), each in the first
    row below where it overlaps no label already placed (measured on the drawn text), so that the
    names of methods that blow up at nearby costs stay readable."""
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    rows: list[list] = []
    for method, x in sorted(at.items(), key=lambda kv: kv[1]):
        for row in range(len(rows) + 1):
            text = ax.annotate(
                method,
                (x, y),
                textcoords="offset points",
                xytext=(0, -9 - 8 * row),
                ha="center",
                fontsize=6,
                color="tab:red",
            )
            box = text.get_window_extent(renderer).expanded(1.05, 1.0)
            if row == len(rows):
                rows.append([box])
                break
            if not any(box.overlaps(other) for other in rows[row]):
                rows[row].append(box)
                break
            text.remove()


def advice_chart(cells: list[Cell], scene: str, hz: float, path: Path, styles: dict | None = None) -> bool:
    """Cost per frame against the error the advice judges (energy error where the suite sets an
    energy tolerance, else position error), one point per (method, substeps) measured at ``hz``,
    the tolerance as a horizontal line; rows unstable there drawn at the top edge. Cost: s x the
    method's CPU seconds per step from its cost cell (compiled kernel / engine step)."""
    rows = [c for c in _ok(cells, "advise") if c.figures.hz == hz and c.figures.rows]
    if not rows:
        return False
    request = rows[0].figures.request
    key, tol, label = (
        ("energy_error", request["energy_tol"], "energy error (max |E - E_exact| / max |E_exact|)")
        if request["energy_tol"] is not None
        else ("position_error", request["error_tol"], "max position error")
    )
    fig, ax = plt.subplots(figsize=(8, 4.5))
    stable_pts, unstable_pts = [], []
    for r in rows:
        pts = [(x["cost_per_frame_s"] * 1e6, x[key], x["stable"]) for x in r.figures.rows if x["cost_per_frame_s"]]
        good = sorted((c, e) for c, e, stable in pts if stable and e is not None and e > 0)
        if good:
            xs, ys = zip(*good)
            ax.plot(xs, ys, markersize=4, label=r.method, **_style(r.method, styles))
            stable_pts += good
        unstable_pts += [(c, r.method) for c, _, stable in pts if not stable]
    if not stable_pts and not unstable_pts:
        plt.close(fig)
        return False
    ax.set_xscale("log")
    ax.set_yscale("log")
    top = max([e for _, e in stable_pts] + [tol]) * 10
    if unstable_pts:
        ax.scatter(
            [c for c, _ in unstable_pts],
            [top] * len(unstable_pts),
            marker="x",
            color="tab:red",
            label="unstable (drawn at the top edge)",
            zorder=3,
        )
    ax.axhline(tol, color="0.3", linestyle=":", label=f"tolerance {tol:g}")
    ax.set_xlabel("cost per frame: substeps x CPU µs per step (compiled kernel / engine step)")
    ax.set_ylabel(label)
    ax.set_title(f"{scene} at {hz:g} Hz: error against cost, one point per (method, substeps)")
    _legend_outside(ax)
    if unstable_pts:  # last, where the axes have their final size
        _stacked_labels(ax, {m: c for c, m in sorted(unstable_pts)}, top)
    return _save(fig, path)


#: Where an unbounded limit is drawn on the stability-against-damping chart (above every finite one).
DAMPING_CHART_TOP = 20.0


def damping_stability_chart(cells: list[Cell], path: Path, styles: dict | None = None) -> bool:
    """Largest stable h*omega against the damping ratio: one theory line per reference scheme
    (from its cell's ``theory_curve``), the measured limits as points: small dots for the
    reference schemes, larger markers for the engine modes. Unbounded limits are drawn at
    DAMPING_CHART_TOP; a scheme unstable at every h is left out at that zeta."""
    rows = _ok(cells, "stability_vs_damping")
    if not rows:
        return False

    def y(v):
        return DAMPING_CHART_TOP if v is not None and math.isinf(v) else v

    fig, ax = plt.subplots(figsize=(11, 5))
    refs = [r for r in rows if r.method.startswith("ref:")]
    for r in refs:
        curve = r.figures.theory_curve
        color = _style(r.method, styles)["color"]
        if curve:
            zs = [z for z, v in zip(curve["zeta"], curve["homega_max"]) if v is not None]
            vs = [y(v) for v in curve["homega_max"] if v is not None]
            ax.plot(zs, vs, color=color, linewidth=1.2, label=f"{r.method[4:]} (theory)")
        pts = [(row["zeta"], y(row["measured"])) for row in r.figures.rows or [] if row["measured"] is not None]
        if pts:
            ax.plot(*zip(*pts), linestyle="none", marker=".", color=color, markersize=5)
    engines = [r for r in rows if not r.method.startswith("ref:")]
    for r in engines:
        pts = [(row["zeta"], y(row["measured"])) for row in r.figures.rows or [] if row["measured"] is not None]
        if not pts:
            continue
        scheme = r.figures.scheme
        st = _style(r.method, styles)
        ax.plot(
            *zip(*pts),
            linestyle="none",
            marker=st["marker"],
            markersize=7,
            fillstyle="none",
            color=st["color"],
            label=f"{r.method} (as {scheme[4:] if scheme else '?'})",
        )
    ax.set_yscale("log")
    ax.axhline(DAMPING_CHART_TOP, color="0.8", linewidth=0.8)
    ax.text(0.0, DAMPING_CHART_TOP * 1.05, "unbounded", fontsize=7, color="0.4")
    ax.set_xlabel("damping ratio ζ")
    ax.set_ylabel("largest stable h·ω")
    ax.set_title("damped_spring: stability limit against damping (lines: theory; points: measured)")
    _legend_outside(ax, fontsize=6)
    return _save(fig, path)
