"""The contact cells in the report: under each contact scene's heading, every engine mode's figures
at the report's three steps against the analytic truth, the largest step within each tolerance and
the settings behind them; under the penalty ball, each reference scheme's restitution against
h*omega_c with the seed's claim. Charts: the figure the scene charts (the ball's restitution, the
slide's stop distance, ...) against the step per mode, and restitution against h*omega_c per
scheme. Everything is read from the cells (``records.contact``), the columns, the truth and the
chart included: each cell carries its scene's own declaration of its figures
(``ContactCellFigures.declared``), so a new contact scene needs no table here. The claims are
judged in ``harness.contact.findings``."""

from __future__ import annotations

import math

from records.contact import REPORT_DTS

from .text import fmt


def _columns(figures) -> list[tuple[str, str, str]]:
    """The figures a cell's scene shows in its table, as it declared them: (header, key, format).
    A cell stored before the scenes' declarations were kept with it shows the figures its runs
    were judged on (their ``passes``), by name."""
    if figures.declared:
        return [(d["header"], d["name"], d.get("fmt", "num")) for d in figures.declared if d.get("header")]
    first = next((r for r in figures.runs or [] if r.get("passes")), None) or {}
    return [(name, name, "list" if isinstance(first.get(name), list) else "num") for name in first.get("passes", {})]


def _cells(scene: str, piv: dict, measure: str) -> list:
    return sorted((ms[measure] for (s, _), ms in piv.items() if s == scene and measure in ms), key=lambda c: c.method)


def _dt_text(dt) -> str:
    return "–" if dt is None else f"1/{1 / dt:.0f} s"


def _value(kind: str, v) -> str:
    if v is None:
        return "–"
    if kind == "list":
        return " ".join(f"{x:.3f}" for x in v) if v else "none"
    if kind == "bounces":
        return ", ".join(str(b) for b in v) if v else "none"
    if kind == "flag" or isinstance(v, bool):
        return "yes" if v else "no"
    return fmt(v)


def _at(runs: list, dt: float):
    return next((r for r in runs if abs(r["dt"] - dt) <= 1e-9 * dt), None)


def _mark(ok) -> str:
    return "✓" if ok else ("✗" if ok is not None else "")


def _convergence(cells) -> list[str]:
    """The scene's charted figure (the slide's stop distance, ...) at every step of the ladder, per
    mode, beside its truth: whether it converges as the step shrinks, and to what."""
    declared = next((d for d in cells[0].figures.declared or () if d.get("chart") and d.get("fmt") == "num"), None)
    if declared is None:
        return []
    name = declared["name"]
    dts = sorted({r["dt"] for c in cells for r in c.figures.runs if r.get("dt")})
    truth_key = declared.get("truth")
    truth = next((r.get("truth", {}).get(truth_key) for c in cells for r in c.figures.runs if r.get("truth")), None)
    lines = [
        "",
        f"{declared['chart']} at every step of the ladder"
        + (f" (truth {fmt(truth)})" if isinstance(truth, int | float) else "")
        + ": does it converge as the step shrinks, and to the truth?",
        "",
        "| mode | " + " | ".join(_dt_text(dt) for dt in dts) + " |",
        "|---|" + "---|" * len(dts),
    ]
    for c in cells:
        by = {r["dt"]: r for r in c.figures.runs}
        row = [_value("num", by[dt].get(name)) if dt in by and by[dt].get("status") == "ok" else "–" for dt in dts]
        lines.append(f"| `{c.method}` | " + " | ".join(row) + " |")
    return lines


def contact_lines(scene: str, piv: dict) -> list[str]:
    """The contact section of one contact scene (its cells' scene name, e.g. ``ball_e1``)."""
    cells = _cells(scene, piv, "contact")
    if not cells:
        return []
    f0 = cells[0].figures
    kind = f0.scene
    figures = _columns(f0)
    params = ", ".join(f"{k} = {v:g}" for k, v in f0.scene_params.items()) or "the scene's defaults"
    lines = [
        f"**Contact: `{kind}`** ({params}). Truth: "
        + (f0.truth_text or "not stored with this run's cells (stored before the scenes' declarations were)")
        + ". Tolerances: "
        + (f0.tolerance_text or "–")
        + ". CPU seconds per simulated second are the engine loop's alone "
        "(process CPU clock, a second pass with nothing recorded).",
        "",
        "| " + " | ".join(["mode", "step", *(label for label, _, _ in figures), "✓/✗", "CPU s per s"]) + " |",
        "|---|---|" + "---|" * len(figures) + "---|---|",
    ]
    for c in cells:
        for dt in REPORT_DTS:
            r = _at(c.figures.runs, dt)
            if r is None:
                continue
            if r.get("status") != "ok":
                cols = [f"`{c.method}`", _dt_text(dt), *("–" for _ in figures)]
                lines.append("| " + " | ".join([*cols, f"{r.get('status')}: {r.get('detail') or ''}", "–"]) + " |")
                continue
            passes = r.get("passes") or {}
            failed = sorted(k for k, v in passes.items() if not v)
            verdict = "✓" if not failed else "✗ " + ", ".join(failed)
            cols = [f"`{c.method}`", _dt_text(dt), *(_value(k, r.get(key)) for _, key, k in figures)]
            lines.append("| " + " | ".join([*cols, verdict, fmt(r.get("cpu_per_s"))]) + " |")
    lines += _convergence(cells)
    lines += ["", "Largest step of the ladder within each tolerance (there and at every shorter step):", ""]
    names = sorted({k for c in cells for k in c.figures.largest if k != "all"})
    lines += ["| mode | every figure | " + " | ".join(names) + " |", "|---|---|" + "---|" * len(names)]
    for c in cells:
        best = c.figures.largest
        lines.append(
            f"| `{c.method}` | {_dt_text(best.get('all'))} | " + " | ".join(_dt_text(best.get(n)) for n in names) + " |"
        )
    lines += [
        "",
        "Settings behind the figures, as each pose stated them (those every mode of an engine shares "
        "once, then each mode's own):",
        "",
    ]
    by_engine: dict[str, list] = {}
    for c in cells:
        r = next((r for r in c.figures.runs if r.get("settings")), None)
        by_engine.setdefault(c.method.split(":")[0], []).append(
            (c.method, (r or {}).get("settings") or c.figures.settings)
        )
    for engine, modes in by_engine.items():
        shared = {k: v for k, v in modes[0][1].items() if all(k in s and s[k] == v for _, s in modes)}
        if len(modes) > 1 and shared:
            lines.append(f"- {engine}, every mode: " + "; ".join(f"{k}: {v}" for k, v in shared.items()))
        for method, settings in modes:
            own = {k: v for k, v in settings.items() if len(modes) == 1 or k not in shared}
            lines.append(f"- `{method}`: " + ("; ".join(f"{k}: {v}" for k, v in own.items()) or "as above"))
    return lines + [""]


def contact_chart(cells, scene: str, path) -> bool:
    """The figure the scene charts (its declaration's ``chart``) against the step, one line per
    mode (log step axis), the truth it declares dashed: the first bounce's restitution for the ball
    (the requested e dashed; clipped at 1.5, a run that gained energy at a bounce circled: a mean
    over bounces would count a ball thrown four times its height and never back within the run as
    e), the stop distance for the slide (the truth dashed), the penetration at rest (symmetric log)."""
    from . import charts

    plt = charts.plt
    rows = [c for c in cells if c.measure == "contact" and c.status == "ok" and c.figures.runs]
    if not rows:
        return False
    chart = next((d for d in (rows[0].figures.declared or []) if d.get("chart")), None)
    if chart is None:
        return False
    key, label = chart["name"], chart["chart"]
    styles = charts.method_styles(c.method for c in rows)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    drawn = False
    for c in rows:
        pts = []
        for r in sorted(c.figures.runs, key=lambda r: r["dt"]):
            v = r.get(key)
            if r.get("status") != "ok" or v is None:
                continue
            v = min(v[0], 1.5) if isinstance(v, list) and v else v
            if isinstance(v, (int, float)) and math.isfinite(v):
                pts.append((r["dt"], v, bool(r.get("gained"))))
        if pts:
            drawn = True
            ax.plot([p[0] for p in pts], [p[1] for p in pts], label=c.method, markersize=4, **styles[c.method])
            gains = [p for p in pts if p[2]]
            if gains:
                ax.plot(
                    [p[0] for p in gains],
                    [p[1] for p in gains],
                    linestyle="none",
                    marker="o",
                    markersize=10,
                    markerfacecolor="none",
                    color=styles[c.method].get("color"),
                )
    if not drawn:
        plt.close(fig)
        return False
    truth = rows[0].figures.runs[0].get("truth", {})
    if chart.get("chart_truth"):
        truth_key, truth_label = chart["chart_truth"]
        if truth.get(truth_key) is not None:
            ax.axhline(truth[truth_key], color="0.4", linestyle="--", label=truth_label)
    if any("gained" in r for c in rows for r in c.figures.runs):
        ax.plot(
            [],
            [],
            linestyle="none",
            marker="o",
            markersize=10,
            markerfacecolor="none",
            color="0.3",
            label="energy gained at a bounce",
        )
    if chart.get("chart_log"):
        ax.set_yscale("symlog", linthresh=1e-6)
    ax.set_xscale("log")
    ax.set_xlabel("step dt (s)")
    ax.set_ylabel(label)
    ax.set_title(f"{scene}: {label} against the step (each engine mode)")
    charts._legend_outside(ax)
    return charts._save(fig, path)
