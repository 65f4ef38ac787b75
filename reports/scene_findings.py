"""Findings particular to one scene: what the scene was built to show, read from this run's
stored cells (it never simulates). One function per scene, ``scene(piv, cells) -> [lines]``
(``piv`` is :func:`reports.markdown._pivot`'s ``{(scene, method): {measure: row}}``); a scene
absent from the run gives no lines.
"""
from __future__ import annotations

import math

import pandas as pd

from harness.workprecision import error_at_equal_cost

#: The schemes the outer solar system's energy finding calls symplectic.
SOLAR_SYMPLECTIC = ("ref:semi_implicit_euler", "ref:leapfrog", "ref:velocity_verlet", "ref:forest_ruth",
                    "rebound:leapfrog", "rebound:whfast", "rebound:saba")
#: The drift the issue allows IAS15 over the run.
IAS15_LIMIT = 1e-13


def _ok(row) -> bool:
    return row is not None and row.status == "ok"


def _value(row):
    if not _ok(row) or row.value is None or (isinstance(row.value, float) and math.isnan(row.value)):
        return None
    return float(row.value)


def _mark(ok: bool) -> str:
    return "✓" if ok else "✗"


def _sweep(piv: dict, scene: str, method: str) -> dict | None:
    """(cost per unit time, error) along a method's order sweep: the sweep's errors, the cost cell's
    seconds per step (a fixed-step method's cost per step does not depend on dt) over each dt."""
    ms = piv.get((scene, method), {})
    order, cost = ms.get("order"), ms.get("cost")
    sps = _value(cost)
    if not _ok(order) or not sps:
        return None
    pts = [p for p in order.data.get("points", []) if p.get("error") and p.get("dt")]
    if len(pts) < 2:
        return None
    return {"cost": [sps / p["dt"] for p in pts], "error": [p["error"] for p in pts]}


def solar_system(piv: dict, cells: pd.DataFrame) -> list[str]:
    """Issue 6's claims for the outer solar system, each with this run's numbers: symplectic
    energy bounded and RK4's drifting, REBOUND's leapfrog = ref:leapfrog, IAS15 <= 1e-13,
    WHFast ahead of leapfrog at equal cost, RK4's cost per step against leapfrog's."""
    scene = "solar_system"
    ms = {m: v for (s, m), v in piv.items() if s == scene}
    if not ms:
        return []
    out = []

    energy = {m: v["energy"] for m, v in ms.items() if v.get("energy") is not None}
    ran = [r for r in energy.values() if r.status in ("ok", "unstable")]
    if ran:
        dt, steps = ran[0]["dt"], ran[0]["steps"]
        span = f"{dt * steps:.3g} days at dt = {dt:g}"

        def text(m):
            r = energy[m]
            if r.status not in ("ok", "unstable"):
                return f"`{m}` {r.status}"
            val = _value(r)
            return f"`{m}` {val:.1e} {r.data.get('class')}" if val is not None else f"`{m}` {r.data.get('class')}"

        sym = [m for m in sorted(energy) if m in SOLAR_SYMPLECTIC]
        sym_ok = bool(sym) and all(energy[m].status == "ok" and energy[m].data.get("class") == "bounded" for m in sym)
        out.append(f"`solar_system`, energy over {span} (max |ΔE/E|, class): symplectic "
                   + ", ".join(text(m) for m in sym) + f": all bounded {_mark(sym_ok)}. Others: "
                   + ", ".join(text(m) for m in sorted(energy) if m not in SOLAR_SYMPLECTIC) + ".")
        rk4 = energy.get("ref:rk4")
        if rk4 is not None and rk4.status == "ok":
            n = rk4.data.get("numbers") or {}
            drifts = rk4.data.get("class") in ("decays", "grows", "drifts")
            out.append(f"`solar_system`: `ref:rk4`'s energy error is not bounded but {rk4.data.get('class')} "
                       f"{_mark(drifts)}: |ΔE/E| envelope {n.get('first_tenth_envelope', math.nan):.1e} over the "
                       f"first tenth of the run, {n.get('last_tenth_envelope', math.nan):.1e} over the last "
                       f"(secular rate {n.get('secular_rate', math.nan):.2e} per day).")

    ident = ms.get("rebound:leapfrog", {}).get("identity")
    if _ok(ident):
        match, dev = ident.data.get("match"), _value(ident)
        same = match == "ref:leapfrog"
        how = "bitwise" if dev == 0 else f"to {dev:.1e}"
        out.append(f"`solar_system`: `rebound:leapfrog` integrates as `{match}` ({how} over {int(ident['steps'])} "
                   f"steps of {ident['dt']:.4g} days) {_mark(same)}; runner-up `{ident.data.get('runner_up')}` at "
                   f"{ident.data.get('runner_up_deviation') or math.nan:.1e}.")

    ias = ms.get("rebound:ias15", {}).get("energy")
    if _ok(ias) and _value(ias) is not None:
        out.append(f"`solar_system`: `rebound:ias15` keeps max |ΔE/E| = {_value(ias):.1e} over the run "
                   f"(limit {IAS15_LIMIT:g}) {_mark(_value(ias) <= IAS15_LIMIT)}.")

    whfast = _sweep(piv, scene, "rebound:whfast")
    for other in ("rebound:leapfrog", "ref:leapfrog"):
        sweep = _sweep(piv, scene, other)
        if whfast is None or sweep is None:
            continue
        rows = error_at_equal_cost(whfast, sweep)
        if not rows:
            out.append(f"`solar_system`: `rebound:whfast` and `{other}` share no cost range in this run's sweeps.")
            continue
        ratios = [r["ratio"] for r in rows]
        span = f"{min(ratios):.1e}" if f"{min(ratios):.1e}" == f"{max(ratios):.1e}" else \
            f"{min(ratios):.1e} to {max(ratios):.1e}"
        points = f"{len(rows)} point{'s' if len(rows) > 1 else ''}"
        out.append(f"`solar_system`, work-precision: at equal cost per simulated day, `rebound:whfast`'s max "
                   f"global error is {span} times `{other}`'s ({points} of the order sweep) "
                   f"{_mark(max(ratios) < 1)}.")

    lf, rk = ms.get("ref:leapfrog", {}).get("cost"), ms.get("ref:rk4", {}).get("cost")
    if _value(lf) and _value(rk):
        ev_lf, ev_rk = lf.data.get("force_evals_per_step"), rk.data.get("force_evals_per_step")
        evals = f"{ev_rk:g} against {ev_lf:g} counted force evaluations" if ev_lf and ev_rk else "evaluations not counted"
        out.append(f"`solar_system`, cost: `ref:rk4` takes {_value(rk) / _value(lf):.2f}x `ref:leapfrog`'s time per "
                   f"step (compiled, {_value(rk) * 1e6:.3g} µs against {_value(lf) * 1e6:.3g} µs, min of repeats; "
                   f"spreads {rk.data.get('spread', 0):.0%} and {lf.data.get('spread', 0):.0%}) for {evals}.")
    return out
