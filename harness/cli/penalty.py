"""``harness contact --penalty``: the reference schemes on a penalty ground, printed or as
``--json`` (the table of ``harness.contact.penalty``), with the seed's claim judged on it."""

from __future__ import annotations

import json
import sys

from records import InvalidInput
from scenarios import parse_overrides

from harness.measures.frames import jsonable

from .contact import _numbers


def run_penalty(args) -> int:
    from scenarios import make_scene

    from harness.contact.penalty import GRID, SCHEMES, penalty_table, seed_claim
    from harness.methods import get_method

    methods = [m.strip() for m in args.methods.split(",")] if args.methods else list(SCHEMES)
    for m in methods:
        if not m.startswith("ref:"):
            raise InvalidInput(
                f"--methods: {m!r} is not a reference scheme (the penalty ground is stepped by ref:NAME)"
            )
        get_method(m)
    grid = _numbers("--grid", args.grid) if args.grid else list(GRID)
    overrides = parse_overrides(args.set)
    unknown = sorted(set(overrides) - {"omega_c"})
    if unknown:
        raise InvalidInput(
            f"--set {unknown[0]}: the penalty table takes omega_c only (e is 1 and 0.8, the rest the scene's defaults)"
        )
    omega_c = make_scene("penalty_ball", **overrides).values["omega_c"]
    df = penalty_table(methods, grid=grid, omega_c=omega_c)
    if args.json:
        json.dump(
            jsonable(
                {
                    "rows": df.to_dict(orient="records"),
                    "seed_claim": seed_claim(df)
                    if {"ref:implicit_euler", "ref:semi_implicit_euler"} <= set(methods)
                    else None,
                }
            ),
            sys.stdout,
            indent=1,
        )
        print()
        return 0
    for e, rows in df.groupby("e", sort=False):
        print(
            f"e = {e:g} (omega_c = {omega_c:g} rad/s): mean restitution of five bounces; "
            "+ gains energy, - loses it, x blows up, ~ scatters, ! unconverged solve; no mark: within"
        )
        print(f"  {'scheme':26} " + " ".join(f"{g:>9g}" for g in grid))
        for m, r in rows.groupby("method", sort=False):
            by = {x.homega: x for _, x in r.iterrows()}
            print(f"  {m:26} " + " ".join(f"{_penalty_cell(by[g]):>9}" for g in grid))
        print()
    if {"ref:implicit_euler", "ref:semi_implicit_euler"} <= set(methods):
        claim = seed_claim(df)
        where = ", ".join(
            f"h*omega_c {hw:g}: {claim['symplectic'][hw]:.3f} vs {claim['implicit'][hw]:.3f}" for hw in claim["where"]
        )
        print(
            "the seed's claim, implicit Euler makes lively bounces go dead: "
            + (f"holds ({where}: semi-implicit vs implicit Euler, e = 1)" if claim["holds"] else "not seen")
        )
    return 0


def _penalty_cell(r) -> str:
    if r.verdict == "blows up":
        return "x"
    mark = {"within": "", "gains energy": "+", "scatters": "~", "dead": "dead", "loses energy": "-"}[r.verdict]
    unconverged = r.unconverged is not None and r.unconverged == r.unconverged and r.unconverged > 0  # NaN: not solved
    return f"{r.mean_restitution:.3f}{mark}{'!' if unconverged else ''}"
