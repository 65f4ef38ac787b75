"""The penalty table in the report: under the penalty ball, each reference scheme's restitution
against h*omega_c, and its chart. Read from the ``penalty`` cells alone; the seed's claim is judged
in ``harness.contact.penalty_findings``."""

from __future__ import annotations

from .contact_section import _cells


def penalty_lines(scene: str, piv: dict) -> list[str]:
    """The penalty table: per scheme and e, the mean restitution and verdict at each h*omega_c."""
    cells = [c for c in _cells(scene, piv, "penalty") if c.status == "ok"]
    if not cells:
        return []
    f0 = cells[0].figures
    grid = list(f0.grid)
    lines = [
        f"**The reference schemes on a penalty ground** (ω_c = {f0.omega_c:g} rad/s, a spring–dashpot "
        "under the ball's lowest point): the mean restitution of five bounces against h·ω_c, each bounce "
        f"judged against the exact motion's (within {f0.tolerance}); ↑ a bounce whose apex rose above the one "
        f"before by more than {f0.gain:.0%}, ✗ blew up, ~ the bounces scatter about the mean, "
        "† the implicit solve did not converge at some step (the figure rests on it).",
        "",
    ]
    for e in sorted({r["e"] for c in cells for r in c.figures.rows}, reverse=True):
        exact = next((r for c in cells for r in c.figures.rows if r["e"] == e), None)
        lines += [
            f"e = {e:g} (exact restitution with gravity in the contact: "
            f"{sum(exact['exact_restitution']) / len(exact['exact_restitution']):.4f})",
            "",
            "| scheme | " + " | ".join(f"{g:g}" for g in grid) + " |",
            "|---|" + "---|" * len(grid),
        ]
        for c in cells:
            rows = {r["homega"]: r for r in c.figures.rows if r["e"] == e}
            lines.append(f"| `{c.method}` | " + " | ".join(_penalty_cell(rows.get(g)) for g in grid) + " |")
        lines.append("")
    return lines


def _penalty_cell(r) -> str:
    if r is None:
        return "–"
    if r["verdict"] == "blows up":
        return "✗"
    mark = {"within": "✓", "gains energy": "↑", "scatters": "~", "dead": "dead", "loses energy": ""}[r["verdict"]]
    dagger = " †" if r.get("unconverged") else ""
    return f"{r['mean_restitution']:.3f} {mark}{dagger}".strip()


def penalty_chart(cells, scene: str, path) -> bool:
    """Mean restitution against h*omega_c, one line per scheme, one panel per e; the exact value
    dashed; blow-ups marked at the top."""
    from . import charts

    plt = charts.plt
    rows = [c for c in cells if c.measure == "penalty" and c.status == "ok" and c.figures.rows]
    if not rows:
        return False
    es = sorted({r["e"] for c in rows for r in c.figures.rows}, reverse=True)
    styles = charts.method_styles(c.method for c in rows)
    fig, axes = plt.subplots(1, len(es), figsize=(5.5 * len(es) + 2.5, 4.5), squeeze=False)
    for ax, e in zip(axes[0], es):
        for c in rows:
            pts = sorted(
                (r["homega"], r["mean_restitution"])
                for r in c.figures.rows
                if r["e"] == e and r["mean_restitution"] is not None
            )
            if pts:
                ax.plot(
                    [p[0] for p in pts], [min(p[1], 3.0) for p in pts], label=c.method, markersize=4, **styles[c.method]
                )
            up = [r["homega"] for r in c.figures.rows if r["e"] == e and r["verdict"] == "blows up"]
            if up:
                ax.plot(up, [3.0] * len(up), linestyle="none", marker="x", color=styles[c.method].get("color"))
        exact = next(r for c in rows for r in c.figures.rows if r["e"] == e)
        ax.axhline(
            sum(exact["exact_restitution"]) / len(exact["exact_restitution"]),
            color="0.4",
            linestyle="--",
            label="exact",
        )
        ax.set_xscale("log")
        ax.set_ylim(0, 3.1)
        ax.set_xlabel("h·ω_c")
        ax.set_ylabel("mean restitution (clipped at 3; x: blew up)")
        ax.set_title(f"penalty ground, e = {e:g}")
    charts._legend_outside(axes[0][-1])
    return charts._save(fig, path)
