"""The report's section on stability against damping: a table of the largest stable h*omega at
each damping ratio, measured beside the theory of the scheme each method is (its own, or the one
an engine mode was identified as), and the chart. The agreement marks come with the cells
(``harness.measures.stability_damping`` judges them); this only prints."""

from __future__ import annotations

import math

from records.cell import Cell

from .text import limit_text

CHECK, CROSS = "✓", "✗"


def _limit(v) -> str:
    if isinstance(v, float) and math.isinf(v):
        return "∞"
    return limit_text(v)


def damping_stability_section(cells: list[Cell], chart_name: str | None) -> list[str]:
    rows = sorted((c for c in cells if c.measure == "stability_vs_damping"), key=lambda c: c.method)
    if not rows:
        return []
    ok = [c for c in rows if c.status == "ok"]
    zetas = []
    for r in ok:
        for row in r.figures.rows or []:
            if row["zeta"] not in zetas:
                zetas.append(row["zeta"])
    tol = ok[0].figures.tolerance if ok else None
    lines = [
        "## Stability against damping",
        "",
        "Largest stable h·ω on `damped_spring` (ω = 1, c = 2ζ) at each damping ratio ζ: measured (spectral "
        "radius of the measured one-step map) / theory (spectral radius of the scheme's own recurrence on the "
        "damped oscillator, closed form or computed), judged against the method's own scheme or, for an "
        f"engine mode, the scheme it was identified as; {CHECK} within {tol:.1%} (none: unstable at every h; "
        "∞: stable at every h searched). A reference scheme's map is measured on the state it carries "
        "between steps (the Verlet forms carry an acceleration, position Verlet also the previous "
        "position): the recurrence the scheme runs, not a restart from (q, v)."
        if tol is not None
        else "",
        "",
        "| method | theory of | " + " | ".join(f"ζ = {z:g}" for z in zetas) + " |",
        "|---|---|" + "---|" * len(zetas),
    ]
    for r in rows:
        if r.status != "ok":
            lines.append(f"| `{r.method}` | {r.status}: {r.detail} |" + " |" * len(zetas))
            continue
        by = {row["zeta"]: row for row in r.figures.rows or []}
        scheme = r.figures.scheme
        out = []
        for z in zetas:
            row = by.get(z)
            if row is None:
                out.append("–")
                continue
            mark = "" if row["agrees"] is None else (f" {CHECK}" if row["agrees"] else f" {CROSS}")
            theory = f" / {_limit(row['theory'])}" if scheme else ""
            out.append(f"{_limit(row['measured'])}{theory}{mark}")
        lines.append(f"| `{r.method}` | {f'`{scheme}`' if scheme else '–'} | " + " | ".join(out) + " |")
    lines.append("")
    if chart_name:
        lines += [f"![Largest stable h·ω against the damping ratio]({chart_name})", ""]
    return lines
