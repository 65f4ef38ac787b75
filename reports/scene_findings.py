"""Findings particular to one scene, one function per scene, each reading only the stored cells
of this run (``piv``: {(scene, method): {measure: row}}) and returning finding lines (markdown,
no leading dash). ``scene_findings`` calls the function of every scene present. It never
simulates: every number comes from a cell.
"""
from __future__ import annotations

import math

import pandas as pd

from harness.measures.workprecision import error_at_equal_cost


def _rows(piv: dict, scene: str, measure: str) -> dict:
    """{method: row} of one measure on one scene."""
    return {m: ms[measure] for (s, m), ms in sorted(piv.items()) if s == scene and measure in ms}


def _names(methods) -> str:
    return ", ".join(f"`{m}`" for m in methods)


def _g(x, spec=".3g") -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def chain(piv: dict, cells: pd.DataFrame) -> list[str]:
    """Stability limits, damping far beyond them, MuJoCo's discrete step and backward Euler's
    cost against N on the spring chain."""
    out = []
    stab = {m: r for m, r in _rows(piv, "chain", "stability").items() if r.status == "ok"}
    if stab:
        limited = {m: r.value for m, r in stab.items() if r.data.get("verdict") == "limited"}
        by_limit: dict = {}
        for m, v in limited.items():
            by_limit.setdefault(round(v, 3), []).append(m)
        parts = [f"h·ω_max = {v:.4g}: {_names(ms)}" for v, ms in sorted(by_limit.items())]
        never = [m for m, r in stab.items() if r.data.get("unstable_everywhere")]
        free = [m for m, r in stab.items() if r.data.get("unbounded")]
        if never:
            parts.append(f"unstable at every h: {_names(never)}")
        if free:
            parts.append(f"stable at every h searched (to h·ω = {max(stab[m].data.get('homega_searched') or 0 for m in free):.3g}): "
                         f"{_names(free)}")
        out.append("`chain`: largest stable h·ω on the stiffest mode, measured: " + "; ".join(parts) + ".")

    damp = {m: r for m, r in _rows(piv, "chain", "damping").items() if r.status == "ok"}
    if damp:
        any_row = next(iter(damp.values()))
        homega = any_row.data.get("omega_dt")
        stable = {m: r for m, r in damp.items() if r.data.get("stable")}
        growing = {m: r for m, r in damp.items() if r.data.get("stable") is False}
        for m, r in stable.items():
            hi, lo = r.data.get("highest") or {}, r.data.get("lowest") or {}
            out.append(f"`{m}` on `chain` at {any_row.data.get('factor', 100):g}x the explicit limit (h·ω_max = {_g(homega, '.4g')}): "
                       f"keeps {_g(r.value, '.3g')} of the energy after one step from the scene's state; per step its "
                       f"highest mode keeps {_g(hi.get('energy_factor'), '.3g')} of its energy (damping ratio ζ = "
                       f"{_g(hi.get('zeta'), '.3f')}), its lowest {_g(lo.get('energy_factor'), '.3g')} (ζ = "
                       f"{_g(lo.get('zeta'), '.3f')}); the exact motion keeps all of it (ζ = 0).")
        if growing:
            rhos = [r.data.get("rho") for r in growing.values() if r.data.get("rho") is not None]
            out.append(f"`chain` at h·ω_max = {_g(homega, '.4g')}: {len(growing)} methods grow there (spectral radius "
                       f"{_g(min(rhos), '.3g')} to {_g(max(rhos), '.3g')} per step): {_names(growing)}.")

    discrete = piv.get(("chain", "mujoco:discrete"), {})
    ident, dd = discrete.get("identity"), discrete.get("damping")
    be = piv.get(("chain", "ref:implicit_euler"), {}).get("damping")
    if (ident is not None and ident.status == "ok" and ident.data.get("match") is None and dd is not None
            and dd.status == "ok" and be is not None and be.status == "ok"):
        rho_d, rho_b = (dd.data.get("highest") or {}).get("rho"), (be.data.get("highest") or {}).get("rho")
        apart = abs(rho_d / rho_b - 1.0) if rho_d is not None and rho_b else None
        out.append(f"`mujoco:discrete` on `chain` is backward Euler only where every tendon is stretched: from a generic "
                   f"state its one-step map is backward Euler's (highest mode's spectral radius within {_g(apart, '.1e')} "
                   f"relative), but from the scene's state, where every spring but the two beside the displaced mass "
                   f"sits exactly at its rest length, "
                   f"MuJoCo leaves those tendons out of its implicit step: it matches no scheme (closest "
                   f"`ref:implicit_euler`, max deviation {_g(ident.value, '.2e')}) and keeps {_g(dd.value, '.3g')} of the "
                   f"energy after that first step at 100x the limit, where backward Euler keeps {_g(be.value, '.3g')}.")

    for m, r in _rows(piv, "chain", "scaling").items():
        if r.status != "ok":
            continue
        rows = r.data.get("rows") or []
        ns = [row["N"] for row in rows]
        per_dof = rows[-1].get("ns_per_dof_step") if rows else None
        out.append(f"`{m}` on `chain`: cost per step grows as N^{r.value:.2f} over N = {min(ns)}…{max(ns)} "
                   f"(log-log fit, r = {_g(r.data.get('rvalue'), '.4f')}; {_g(per_dof, '.3g')} ns per mass-step at "
                   f"N = {max(ns)}): the tridiagonal solve is sparse.")
    return out


def rope(piv: dict, cells: pd.DataFrame) -> list[str]:
    """Constraint drift and energy change of every method on the rope."""
    rows = {m: r for m, r in _rows(piv, "rope", "constraint").items() if r.status in ("ok", "unstable")}
    if not rows:
        return []
    any_row = next(iter(rows.values()))
    parts = []
    for m, r in rows.items():
        d = r.data
        k = f", {d['iterations']} passes" if d.get("iterations") else ""
        parts.append(f"`{m}`{k}: {_g(r.value, '.2e')} stretch, energy {_g(d.get('energy_change'), '+.2%')}")
    out = [f"`rope` over t = {_g(any_row.data.get('t_final'), '.3g')} at the nominal dt = {_g(any_row['dt'], '.3g')}, "
           f"largest relative link stretch and energy change at the end: " + "; ".join(parts) + "."]
    for m, r in rows.items():
        by = r.data.get("by_iterations")
        if by:
            out.append(f"`{m}` on `rope` against projection passes: " + "; ".join(
                f"{b['iterations']}: stretch {_g(b.get('max_stretch'), '.2e')}, energy {_g(b.get('energy_change'), '+.2%')}"
                for b in by) + ".")
    return out


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


SCENES = {"chain": chain, "rope": rope, "solar_system": solar_system}


def scene_findings(piv: dict, cells: pd.DataFrame) -> list[str]:
    present = {s for s, _ in piv}
    out = []
    for scene, fn in SCENES.items():
        if scene in present:
            out += fn(piv, cells)
    return out
