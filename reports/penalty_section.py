"""The penalty table in the report: under the penalty ball, each reference scheme's restitution of
ONE impact against h*omega_c (the phase mean, its range, the closed form beside where the scheme has
one, the exact e), the bounces a dropped ball makes before it rests (apart), and the chart. Read
from the ``penalty`` cells alone; the seed's claim is judged in ``harness.contact.penalty_findings``.
The cell texts here are the command's too (``harness contact --penalty``).

A cell stored before the per-impact table (its rows have no ``impact_mean``) is shown as it was
measured, the mean of five bounces, under a note saying so."""

from __future__ import annotations

from .contact_section import _cells

#: A verdict's mark beside the figure (plain-text marks for the command).
MARKS = {
    "within": "",
    "scatters": "~",
    "too lively": "+",
    "gains energy": "↑",
    "loses energy": "−",
    "dead": "dead",
}
PLAIN_MARKS = {"↑": "^", "−": "-"}
#: How a drop run ended, after its count of bounces.
ENDS = {"rests": "", "cap": "+", "runaway": "↑", "blows up": "✗"}


def number(x) -> str:
    """A restitution: three decimals below 10, one below 1000, three figures above."""
    if x is None or x != x:
        return "–"
    if abs(x) < 10:
        return f"{x:.3f}"
    return f"{x:.1f}" if abs(x) < 1000 else f"{x:.3g}"


def impact_text(r: dict, plain: bool = False) -> str:
    """One impact's cell: the phase mean and its mark; ✗ where a phase blew up; "unsolved at N
    steps" where a Newton solve failed (no figure)."""
    verdict = r.get("verdict")
    if verdict == "blows up":
        return "x" if plain else "✗"
    if verdict == "unsolved":
        return _unsolved(r["unsolved"])
    mark = MARKS.get(verdict, "")
    if plain:
        mark = PLAIN_MARKS.get(mark, mark)
    return f"{number(r['impact_mean'])}{' ' if mark == 'dead' else ''}{mark}"


def _unsolved(n: int) -> str:
    return f"unsolved at {n} step{'' if n == 1 else 's'}"


def range_text(r: dict) -> str:
    if r.get("impact_min") is None:
        return "–"
    return f"{number(r['impact_min'])}–{number(r['impact_max'])}"


def newton_text(r: dict) -> str:
    """Implicit Euler's Newton run (``ref:implicit_euler`` as the harness solves it): its phase
    mean, or where a step's solve failed only the count."""
    if r.get("newton_unsolved"):
        return _unsolved(r["newton_unsolved"])
    return number(r.get("newton_mean"))


def bounces_text(r: dict, plain: bool = False) -> str:
    """The drop's bounces before it rests: N (rests), N+ (the cap), N↑ (ran away), N✗ (blew up);
    "unsolved" where a Newton solve failed in a contact."""
    if r.get("bounces") is None:
        return "–"
    if r.get("drop_unsolved"):
        return "unsolved"
    end = ENDS.get(r.get("bounces_end"), "?")
    if plain:
        end = {"↑": "^", "✗": "x"}.get(end, end)
    return f"{r['bounces']}{end}"


def exact_bounces_text(r: dict) -> str:
    if r.get("exact_end") == "cap":
        return f"never rests (≥ {r['exact_bounces']})"
    return f"rests after {r['exact_bounces']}"


def conditions_text(rows: list) -> str:
    """The impact runs' conditions, stated with the table."""
    r = rows[0]
    worst = max(x["step_gravity"] for x in rows)
    return (
        f"v_in = {r['v_in']:g} m/s, g = {r['g_impact']:g} m/s² in the impact runs: g/(ω_c v_in) = "
        f"{r['gravity_share']:.0e}, g h/v_in ≤ {worst:.0e}; {r['phases']} phases, the first contact at "
        f"(j + ½)/{r['phases']} of a step"
    )


def _new(rows) -> bool:
    return all("impact_mean" in r for r in rows)


def penalty_lines(scene: str, piv: dict) -> list[str]:
    """The penalty tables: per e, one impact's restitution per scheme at each h*omega_c, then the
    bounces a drop makes before it rests."""
    cells = [c for c in _cells(scene, piv, "penalty") if c.status == "ok"]
    if not cells:
        return []
    f0 = cells[0].figures
    rows = [r for c in cells for r in c.figures.rows]
    if not rows:
        return []
    if not _new(rows):
        return _legacy_lines(cells)
    grid = list(f0.grid)
    tol = f0.tolerance
    r0 = rows[0]
    lines = [
        f"**The reference schemes on a penalty ground** (ω_c = {f0.omega_c:g} rad/s, a spring–dashpot "
        "under the ball's lowest point): what ONE impact keeps of the speed, v_out/v_in at the surface, "
        f"the mean over where the contact falls in the step ({conditions_text(rows)}), the range over those "
        "phases below; the closed form |λ|^(π/arg λ) of the scheme's step on the contact beside, where it has "
        f"one; the exact e in the heading. Marks: ↑ the mean above 1 by more than {f0.gain or 0.01:.0%} (energy "
        "gained); against "
        f"e: + above it by more than {tol}, − below it by more, dead under a tenth of it, ~ a phase beyond "
        f'{tol}; unmarked: every phase within {tol}; ✗ blew up; "unsolved": an implicit solve failed at '
        "that many steps (no figure). Implicit Euler's row is its step solved exactly (its branches and, "
        "where neither holds, the complementarity point); the harness's Newton run beside it.",
        "",
    ]
    for e in sorted({r["e"] for r in rows}, reverse=True):
        at_e = [r for r in rows if r["e"] == e]
        lines += [
            f"e = {e:g} (exact e = {at_e[0]['exact']:.4f}, ζ = {at_e[0]['zeta']:.4f})",
            "",
            "| scheme | " + " | ".join(f"{g:g}" for g in grid) + " |",
            "|---|" + "---|" * len(grid),
        ]
        for c in cells:
            by = {r["homega"]: r for r in c.figures.rows if r["e"] == e}
            lines.append(f"| `{c.method}` | " + " | ".join(_md(by.get(g), impact_text) for g in grid) + " |")
            lines.append("| range | " + " | ".join(_md(by.get(g), range_text) for g in grid) + " |")
            if any(r.get("closed_form") is not None for r in by.values()):
                lines.append(
                    "| closed form | "
                    + " | ".join(_md(by.get(g), lambda r: number(r["closed_form"])) for g in grid)
                    + " |"
                )
            if any("newton_unsolved" in r for r in by.values()):
                lines.append("| Newton | " + " | ".join(_md(by.get(g), newton_text) for g in grid) + " |")
                lines.append(
                    "| no branch (share, expected) | "
                    + " | ".join(
                        _md(by.get(g), lambda r: f"{r['no_branch_share']:.1%}, {r['no_branch_expected']:.1%}")
                        for g in grid
                    )
                    + " |"
                )
        lines.append("")
    lines += [
        f"Bounces before the ball rests, dropped from {r0['drop']:g} m (g = {r0['g']:g} m/s²) and run as long as "
        f"its motion needs: N rests after N; N+ still bouncing at the cap of {r0['bounce_cap']}; N↑ ran away (an "
        "apex past 1000 drop heights) after N; N✗ blew up.",
        "",
        "| scheme | " + " | ".join(f"{g:g}" for g in grid) + " |",
        "|---|" + "---|" * len(grid),
    ]
    for e in sorted({r["e"] for r in rows}, reverse=True):
        for c in cells:
            by = {r["homega"]: r for r in c.figures.rows if r["e"] == e}
            lines.append(
                f"| `{c.method}`, e = {e:g} | " + " | ".join(_md(by.get(g), bounces_text) for g in grid) + " |"
            )
        first = next(r for r in rows if r["e"] == e)
        lines.append(f"| exact motion, e = {e:g} | {exact_bounces_text(first)} |" + " |" * (len(grid) - 1))
    lines.append("")
    return lines


def _md(r, text) -> str:
    return "–" if r is None else text(r)


def _legacy_lines(cells) -> list[str]:
    """A cell stored before the per-impact table: its mean of five bounces, as it was measured."""
    f0 = cells[0].figures
    grid = list(f0.grid)
    lines = [
        f"**The reference schemes on a penalty ground** (ω_c = {f0.omega_c:g} rad/s), as stored before the "
        "per-impact table: the mean restitution of five bounces over the exact motion's length (a partial "
        "last flight and bounces that never happen read as low figures; not one impact's restitution). "
        "↑ a bounce above the one before, ✗ blew up, ~ scatters, † an implicit solve did not converge.",
        "",
    ]
    for e in sorted({r["e"] for c in cells for r in c.figures.rows}, reverse=True):
        lines += ["e = " + f"{e:g}", "", "| scheme | " + " | ".join(f"{g:g}" for g in grid) + " |"]
        lines.append("|---|" + "---|" * len(grid))
        for c in cells:
            by = {r["homega"]: r for r in c.figures.rows if r["e"] == e}
            lines.append(f"| `{c.method}` | " + " | ".join(_legacy_cell(by.get(g)) for g in grid) + " |")
        lines.append("")
    return lines


def _legacy_cell(r) -> str:
    if r is None:
        return "–"
    if r.get("verdict") == "blows up" or r.get("mean_restitution") is None:
        return "✗"
    mark = {"within": "", "gains energy": "↑", "scatters": "~", "dead": "dead", "loses energy": ""}.get(
        r.get("verdict"), ""
    )
    dagger = " †" if r.get("unconverged") else ""
    return f"{r['mean_restitution']:.3f} {mark}{dagger}".strip()


#: The chart's vertical range (log): figures beyond it are drawn at its edge.
CHART_LIMITS = (1e-4, 1e5)


def penalty_chart(cells, scene: str, path) -> bool:
    """One impact's restitution against h*omega_c, one panel per e (log-log): a line per scheme at
    its phase mean, its range a band, the closed forms dashed, the exact e dotted; a blow-up or an
    unsolved step marked x at the top, a zero at the bottom."""
    rows = [c for c in cells if c.measure == "penalty" and c.status == "ok" and c.figures.rows]
    if not rows or not _new([r for c in rows for r in c.figures.rows]):
        return False
    from . import charts

    plt = charts.plt
    lo, hi = CHART_LIMITS
    es = sorted({r["e"] for c in rows for r in c.figures.rows}, reverse=True)
    styles = charts.method_styles(c.method for c in rows)
    fig, axes = plt.subplots(1, len(es), figsize=(5.5 * len(es) + 2.5, 4.8), squeeze=False)
    for ax, e in zip(axes[0], es):
        for c in rows:
            style = styles[c.method]
            at = sorted((r for r in c.figures.rows if r["e"] == e), key=lambda r: r["homega"])
            pts = [r for r in at if r.get("impact_mean") is not None]
            if pts:
                xs = [r["homega"] for r in pts]
                ax.plot(xs, [min(max(r["impact_mean"], lo), hi) for r in pts], label=c.method, markersize=4, **style)
                ax.fill_between(
                    xs,
                    [min(max(r["impact_min"], lo), hi) for r in pts],
                    [min(max(r["impact_max"], lo), hi) for r in pts],
                    color=style.get("color"),
                    alpha=0.15,
                    linewidth=0,
                )
            cf = [r for r in at if r.get("closed_form") is not None]
            if cf:
                ax.plot(
                    [r["homega"] for r in cf],
                    [min(max(r["closed_form"], lo), hi) for r in cf],
                    linestyle="--",
                    linewidth=1.0,
                    color=style.get("color"),
                    label=f"{c.method} closed form",
                )
            bad = [r["homega"] for r in at if r.get("verdict") in ("blows up", "unsolved")]
            if bad:
                ax.plot(bad, [hi] * len(bad), linestyle="none", marker="x", color=style.get("color"))
        exact = next(r["exact"] for c in rows for r in c.figures.rows if r["e"] == e)
        ax.axhline(exact, color="0.4", linestyle=":", label="exact e")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(lo * 0.8, hi * 1.25)
        ax.set_xlabel("h·ω_c")
        ax.set_ylabel("one impact's v_out/v_in (band: over phases)")
        ax.set_title(f"penalty ground, e = {e:g}")
    charts._legend_outside(axes[0][-1])
    return charts._save(fig, path)
