"""``harness contact --penalty``: the reference schemes on a penalty ground, printed or as
``--json`` (the table of ``harness.contact.penalty``: one impact's restitution per scheme, e and
h*omega_c, and the bounces a drop makes before it rests), with the seed's claim judged on it."""

from __future__ import annotations

import json
import sys

from records import InvalidInput
from scenarios import parse_overrides

from harness.measures.frames import jsonable

from harness import validate


def run_penalty(args) -> int:
    from scenarios import make_scene

    from harness.contact.penalty import GRID, SCHEMES, penalty_rows, seed_claim
    from harness.methods import get_method

    methods = [m.strip() for m in args.methods.split(",")] if args.methods else list(SCHEMES)
    for m in methods:
        if not m.startswith("ref:"):
            raise InvalidInput(
                f"--methods: {m!r} is not a reference scheme (the penalty ground is stepped by ref:NAME)"
            )
        get_method(m)
    grid = validate.positive_list("--grid", args.grid) if args.grid else list(GRID)
    overrides = parse_overrides(args.set)
    unknown = sorted(set(overrides) - {"omega_c"})
    if unknown:
        raise InvalidInput(
            f"--set {unknown[0]}: the penalty table takes omega_c only (e is 1 and 0.8, the rest the scene's defaults)"
        )
    omega_c = make_scene("penalty_ball", **overrides).values["omega_c"]
    rows = penalty_rows(methods, grid=grid, omega_c=omega_c)
    both = {"ref:implicit_euler", "ref:semi_implicit_euler"} <= set(methods)
    if args.json:
        json.dump(jsonable({"rows": rows, "seed_claim": seed_claim(rows) if both else None}), sys.stdout, indent=1)
        print()
        return 0
    for line in penalty_text(rows, grid, omega_c):
        print(line)
    if both:
        claim = seed_claim(rows)
        where = ", ".join(
            f"h*omega_c {hw:g}: {claim['symplectic'][hw]:.3f} vs {claim['implicit'][hw]:.3f}" for hw in claim["where"]
        )
        print(
            "the seed's claim, implicit Euler makes lively bounces go dead: "
            + (
                f"holds ({where}: one impact, semi-implicit vs implicit Euler, e = 1)"
                if claim["holds"]
                else "not seen (at no h*omega_c does semi-implicit Euler keep an elastic impact within "
                "tolerance while implicit Euler keeps under half the speed)"
            )
        )
    return 0


def penalty_text(rows: list[dict], grid: list[float], omega_c: float) -> list[str]:
    """The printed tables: per e, one impact's v_out/v_in (phase mean, range, closed form, and
    implicit Euler's Newton run), then the bounces to rest."""
    from reports.penalty_section import (
        bounces_text,
        conditions_text,
        exact_bounces_text,
        impact_text,
        newton_text,
        number,
        range_text,
    )

    from harness.contact.penalty import GAIN, TOLERANCE

    out = [
        f"One impact on a penalty ground (omega_c = {omega_c:g} rad/s): v_out/v_in at the surface, mean over "
        f"where the contact falls in the step, min-max below; {conditions_text(rows)}.",
        f"Marks: ^ the mean above 1 by > {GAIN:.0%} (energy gained); against the exact e: + above it by > "
        f"{TOLERANCE}, - below it by more, dead under e/10, ~ a phase beyond {TOLERANCE}; no mark: every phase "
        "within; x blew up; unsolved at N steps: an implicit solve failed (no figure).",
        "",
    ]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    es = list(dict.fromkeys(r["e"] for r in rows))
    for e in es:
        at = {(r["method"], r["homega"]): r for r in rows if r["e"] == e}
        first = next(r for r in rows if r["e"] == e)
        table = [[f"e = {e:g} (exact {first['exact']:.4f})", *[f"{g:g}" for g in grid]]]
        for m in methods:
            by = [at.get((m, g)) for g in grid]
            solved = " (exact solve)" if any(r and r.get("newton_unsolved") is not None for r in by) else ""
            table.append([m + solved, *[impact_text(r, plain=True) if r else "-" for r in by]])
            table.append(["  min-max", *[range_text(r).replace("–", "-") if r else "-" for r in by]])
            if any(r and r.get("closed_form") is not None for r in by):
                table.append(["  closed form", *[number(r["closed_form"]) if r else "-" for r in by]])
            if any(r and r.get("newton_unsolved") is not None for r in by):
                table.append(["  Newton (harness)", *[newton_text(r) if r else "-" for r in by]])
                table.append(
                    [
                        "  no branch: share (expected)",
                        *[f"{r['no_branch_share']:.1%} ({r['no_branch_expected']:.1%})" if r else "-" for r in by],
                    ]
                )
        out += _columns(table) + [""]
    r0 = rows[0]
    out.append(
        f"Bounces before the ball rests: dropped from {r0['drop']:g} m (g = {r0['g']:g}), run until it rests, "
        f"blows up (x), runs away (^, an apex past 1000 drop heights) or reaches {r0['bounce_cap']} bounces (+)."
    )
    table = [["scheme", *[f"{g:g}" for g in grid]]]
    for e in es:
        at = {(r["method"], r["homega"]): r for r in rows if r["e"] == e}
        for m in methods:
            table.append(
                [f"{m}, e = {e:g}", *[bounces_text(at[(m, g)], plain=True) if (m, g) in at else "-" for g in grid]]
            )
        first = next(r for r in rows if r["e"] == e)
        table.append([f"exact motion, e = {e:g}", exact_bounces_text(first).replace("≥", ">=")])
    out += _columns(table) + [""]
    return out


def _columns(table: list[list[str]]) -> list[str]:
    """Rows of cells padded to their columns' widths (a short row's last cell runs on)."""
    n = max(len(r) for r in table)
    widths = [max(len(r[i]) for r in table if len(r) > i and len(r) == n) for i in range(n)]
    lines = []
    for r in table:
        if len(r) < n:
            lines.append("  " + r[0].ljust(widths[0]) + "  " + "  ".join(r[1:]))
            continue
        lines.append("  " + r[0].ljust(widths[0]) + "  " + "  ".join(c.rjust(w) for c, w in zip(r[1:], widths[1:])))
    return lines
