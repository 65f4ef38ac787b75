"""Judging a nightly run, in one place: the tolerances, the rules that give a measured figure its
check or cross against the textbook, the verdict against the previous run, and the findings.

``judge(cells, ...)`` reads the run's cells (``records.cell.Cell``) and returns a
``records.findings.Judgement``: plain records the report prints (``reports/`` judges nothing).

A scene's own findings are declared as data: ``SCENE_CHECKS[scene]`` is a table of ``Check``
rows, each naming what is checked (its ``finding``, one of ``FINDINGS``), the cells it reads
(``measure``, ``methods``), what it is judged against (``expect``, ``against``) and with which
tolerance. Adding a check to a scene is a row, not a new function. A row names no engine mode:
where it checks what a method was measured to do, it names the field of the method's declared
behaviour (``Check.of``, ``records.method.Behaviour``) and applies to every method of the run
that declares it, with what the declaration says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from records import is_reference, scheme_name
from records.cell import Cell, Claims, MethodCells, pivot
from records.figures import limit_text
from records.findings import MARK, Change, ClaimChecks, Finding, Judgement, Verdict

from harness.engine_findings import blowups_at_nominal, engine_findings
from harness.measures.energy import claim_met
from harness.measures.workprecision import error_at_equal_cost as at_equal_cost

#: A measured order within this of the declared order gets a check mark (the order tests' tolerance).
ORDER_TOL = 0.15
#: A measured stability limit within this fraction of the textbook's gets a check mark.
STABILITY_TOL = 0.005
#: Counted force evaluations per step agree with the declared number to this (they are counts).
EVALS_TOL = 1e-9


# ----------------------------------------------------------------------------- the claims
def claims_of(cells: dict) -> Claims:
    """The claims a method's cells carry ({measure: cell}); none known: every field None."""
    return next((c.claims for c in cells.values() if c.claims is not None and c.claims.known), Claims())


def homega_ok(cell: Cell | None, claim) -> bool | None:
    """A stability cell against the claimed largest stable h*omega (None: no h is stable; inf:
    every h is) to STABILITY_TOL; None where there is nothing to judge. No stable step resolved
    (a growth below what the search tells from 1 at every step) is no stable h: it agrees with None."""
    if cell is None or cell.status != "ok":
        return None
    f = cell.figures
    if claim is None:
        return bool(f.unstable_everywhere or f.unresolved)
    if claim == math.inf:
        return bool(f.unbounded)
    return cell.value is not None and not f.unbounded and abs(cell.value / float(claim) - 1) <= STABILITY_TOL


def claim_checks(cells: dict) -> ClaimChecks:
    """One method's cells on one scene ({measure: cell}) against the claims they carry."""
    claims = claims_of(cells)
    cost, order, energy, stab = (cells.get(m) for m in ("cost", "order", "energy", "stability"))
    evals = order_ok = energy_ok = None
    if cost is not None and cost.status == "ok":
        n = cost.figures.force_evals_per_step
        if claims.evals_per_pass:  # whole Newton passes of the declared evaluations, at least one
            evals = n is not None and bool(claims.force_evals) and n >= claims.force_evals - EVALS_TOL
        else:
            evals = n is not None and claims.force_evals is not None and abs(n - claims.force_evals) < EVALS_TOL
    if order is not None and order.status == "ok" and order.value is not None:  # None: no order measurable
        order_ok = claims.order is not None and abs(order.value - claims.order) <= ORDER_TOL
    if energy is not None and energy.figures.energy_class:
        energy_ok = claim_met(claims.energy, energy.figures.energy_class)
    return ClaimChecks(
        claims=claims,
        evals=evals,
        order=order_ok,
        energy=energy_ok,
        homega=homega_ok(stab, claims.homega_max) if claims.known else None,
    )


def bound_ok(cell: Cell) -> bool:
    """A reviewed energy bound holds: the cell measured, at or below its bound."""
    bound = cell.figures.bound
    return cell.status == "ok" and bound is not None and cell.value <= bound


# ----------------------------------------------------------------------------- the verdict
def failed_methods(cells: list[Cell]) -> list[tuple[str, str]]:
    """(scene, method) of every method with a crashed or timed-out cell, sorted."""
    return sorted({(c.scene, c.method) for c in cells if c.status in ("crashed", "timed_out")})


def verdict(cells: list[Cell], regressions=(), previous=None, trend=None) -> Verdict:
    """The run against ``previous`` (``regressions`` from ``harness.history.compare``; ``trend``:
    the suite's judged history, whose latest accuracy changes are reported at once). The cells
    that timed out are not measured this run, listed apart and never regressions."""
    changed = trend.latest_changes() if trend is not None else []
    judged = len(trend.runs) if previous is not None and trend is not None and trend.judged else None
    return Verdict(
        previous=previous,
        regressions=tuple(r.line() for r in regressions),
        judged_runs=judged,
        changed=tuple(Change(c.scene, c.method, c.measure, ch.before, ch.after) for c, ch in changed),
        failed=tuple(failed_methods(cells)),
        not_measured=tuple(
            f"{c.measure} of {c.method} on {c.scene}" + (f" at dt={c.dt:g}" if c.dt is not None else "")
            for c in cells
            if c.status == "timed_out"
        ),
    )


# ----------------------------------------------------------------------------- the findings
@dataclass(frozen=True)
class Check:
    """One row of a scene's findings table: the ``finding`` (a key of ``FINDINGS``), the
    ``measure`` whose cells it reads, of ``methods`` (empty: every method with that measure),
    what they are judged ``against`` (methods) or ``expect``ed to be, with ``tolerance``;
    ``note``: what the line says of why, where the measurement cannot say it. ``of``: a field of
    ``records.method.Behaviour`` (a key of ``DECLARED``): the row also applies to every method of
    the run that declares it on the scene, with what it declares (``declared_checks``)."""

    finding: str
    measure: str
    methods: tuple[str, ...] = ()
    against: tuple[str, ...] = ()
    expect: object = None
    tolerance: float | None = None
    note: str = ""
    of: str | None = None


def _g(x, spec=".3g") -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def _names(methods) -> str:
    return ", ".join(f"`{m}`" for m in methods)


def _rows(piv: dict, scene: str, check: Check, statuses=("ok",)) -> dict:
    """{method: cell} of the check's measure on ``scene`` (of its methods, if it names any)."""
    return {
        m: ms[check.measure]
        for (s, m), ms in sorted(piv.items())
        if s == scene
        and check.measure in ms
        and (not check.methods or m in check.methods)
        and ms[check.measure].status in statuses
    }


def _value(cell: Cell | None):
    if cell is None or cell.status != "ok" or cell.value is None or math.isnan(cell.value):
        return None
    return float(cell.value)


def stability_limits(check: Check, scene: str, piv: dict) -> list[Finding]:
    """Every method's largest stable h*omega on the scene, grouped by limit."""
    stab = _rows(piv, scene, check)
    if not stab:
        return []
    by_limit: dict = {}
    for m, r in stab.items():
        if r.figures.verdict == "limited":
            by_limit.setdefault(float(limit_text(r.value)), []).append(m)
    parts = [f"h·ω_max = {limit_text(v)}: {_names(ms)}" for v, ms in sorted(by_limit.items())]
    never = [m for m, r in stab.items() if r.figures.unstable_everywhere]
    unresolved = [m for m, r in stab.items() if r.figures.unresolved]
    free = [m for m, r in stab.items() if r.figures.unbounded]
    if never:
        parts.append(f"unstable at every h: {_names(never)}")
    if unresolved:
        parts.append(
            f"no stable step resolved (growing at every step, by less than the search tells from 1): "
            f"{_names(unresolved)}"
        )
    if free:
        searched = max(stab[m].figures.homega_searched or 0 for m in free)
        parts.append(f"stable at every h searched (to h·ω = {searched:.3g}): {_names(free)}")
    return [
        Finding(f"`{scene}`: largest stable h·ω on the stiffest mode, measured: " + "; ".join(parts) + ".", scene=scene)
    ]


def survives_one_frame(check: Check, scene: str, piv: dict) -> list[Finding]:
    """At ``expect`` frames a second, which methods are stable at one step a frame (their measured
    largest stable dt at least the frame), and how many substeps each other one needs
    (ceil(frame / dt_max)): the reference schemes that survive are implicit ones only."""
    from reference import METHODS

    frame = 1.0 / float(check.expect)
    survive, need = [], []
    for m, r in _rows(piv, scene, check).items():
        f = r.figures
        if f.unbounded or (f.dt_max is not None and f.dt_max >= frame):
            survive.append(m)
        elif f.unstable_everywhere:
            need.append(f"`{m}` unstable at every h")
        elif f.unresolved:
            need.append(f"`{m}` no stable step resolved")
        elif f.dt_max:
            need.append(f"`{m}` {math.ceil(frame / f.dt_max)} (h·ω_max {r.value:.3g})")
    if not survive and not need:
        return []
    explicit = [m for m in survive if is_reference(m) and not METHODS[scheme_name(m)].implicit]
    return [
        Finding(
            f"`{scene}` at {check.expect:g} Hz: stable at one step a frame: {_names(survive) or 'none'} "
            f"{MARK}; substeps a frame each other method needs to be stable (measured limit): " + ", ".join(need) + ".",
            not explicit,
            scene,
        )
    ]


def damping_beyond_the_limit(check: Check, scene: str, piv: dict) -> list[Finding]:
    """What each method stable far beyond the explicit limit keeps of the energy, per mode; which grow."""
    damp = _rows(piv, scene, check)
    if not damp:
        return []
    first = next(iter(damp.values())).figures
    homega, factor = first.omega_dt, first.factor if first.factor is not None else 100
    out = []
    for m, r in damp.items():
        if not r.figures.stable:
            continue
        hi, lo = r.figures.highest or {}, r.figures.lowest or {}
        out.append(
            Finding(
                f"`{m}` on `{scene}` at {factor:g}x the explicit limit (h·ω_max = {_g(homega, '.4g')}): keeps "
                f"{_g(r.value, '.3g')} of the energy after one step from the scene's state; per step its highest mode "
                f"keeps {_g(hi.get('energy_factor'), '.3g')} of its energy (damping ratio ζ = "
                f"{_g(hi.get('zeta'), '.3f')}), its lowest {_g(lo.get('energy_factor'), '.3g')} (ζ = "
                f"{_g(lo.get('zeta'), '.3f')}); the exact motion keeps all of it (ζ = 0).",
                scene=scene,
                method=m,
            )
        )
    growing = [m for m, r in damp.items() if r.figures.stable is False]
    if growing:
        rhos = [damp[m].figures.rho for m in growing if damp[m].figures.rho is not None]
        out.append(
            Finding(
                f"`{scene}` at h·ω_max = {_g(homega, '.4g')}: {len(growing)} methods grow there (spectral "
                f"radius {_g(min(rhos), '.3g')} to {_g(max(rhos), '.3g')} per step): {_names(growing)}.",
                scene=scene,
            )
        )
    return out


def matches_only_from_a_generic_state(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A mode that is its ``against`` scheme from a generic state but matches none from the
    scene's (``note``: why not): its one-step map's highest mode beside the scheme's, and the
    energy each keeps."""
    (method,), (scheme,) = check.methods, check.against
    mine, theirs = piv.get((scene, method), MethodCells()), piv.get((scene, scheme), MethodCells())
    ident, dd, be = mine.identity, mine.cell(check.measure), theirs.cell(check.measure)
    if not (
        ident is not None
        and ident.status == "ok"
        and ident.figures.match is None
        and dd is not None
        and dd.status == "ok"
        and be is not None
        and be.status == "ok"
    ):
        return []
    rho_d = dd.figures.highest["rho"] if dd.figures.highest else None
    rho_b = be.figures.highest["rho"] if be.figures.highest else None
    apart = abs(rho_d / rho_b - 1.0) if rho_d is not None and rho_b else None
    return [
        Finding(
            f"`{method}` on `{scene}` is `{scheme}` only from a generic state: there its one-step map is `{scheme}`'s "
            f"(highest mode's spectral radius within {_g(apart, '.1e')} relative), but from the scene's state it "
            "matches "
            f"no scheme, since {check.note} (closest `{scheme}`, max deviation {_g(ident.value, '.2e')}), and keeps "
            f"{_g(dd.value, '.3g')} of the energy after that first step at 100x the limit, where `{scheme}` keeps "
            f"{_g(be.value, '.3g')}.",
            scene=scene,
            method=method,
        )
    ]


def cost_against_size(check: Check, scene: str, piv: dict) -> list[Finding]:
    """The log-log slope of cost per step against N, the number of unknowns."""
    out = []
    for m, r in _rows(piv, scene, check).items():
        rows = r.figures.rows or []
        ns = [row["ndof"] for row in rows]
        per_dof = rows[-1]["ns_per_dof_step"] if rows else None
        out.append(
            Finding(
                f"`{m}` on `{scene}`: cost per step grows as N^{r.value:.2f} over N = {min(ns)}…{max(ns)} "
                f"unknowns (log-log fit, r = {_g(r.figures.rvalue, '.4f')}; {_g(per_dof, '.3g')} ns per "
                f"unknown-step at N = {max(ns)}): {check.note}.",
                scene=scene,
                method=m,
            )
        )
    return out


def constraint_drift(check: Check, scene: str, piv: dict) -> list[Finding]:
    """Every method's largest link stretch and energy change; a projecting scheme's against its passes."""
    rows = _rows(piv, scene, check, ("ok", "unstable"))
    if not rows:
        return []
    first = next(iter(rows.values()))
    parts = []
    for m, r in rows.items():
        f = r.figures
        k = f", {f.iterations} passes" if f.iterations else ""
        parts.append(f"`{m}`{k}: {_g(r.value, '.2e')} stretch, energy {_g(f.energy_change, '+.2%')}")
    out = [
        Finding(
            f"`{scene}` over t = {_g(first.figures.t_final, '.3g')} at the nominal dt = {_g(first.dt, '.3g')}, "
            f"largest relative link stretch and energy change at the end: " + "; ".join(parts) + ".",
            scene=scene,
        )
    ]
    for m, r in rows.items():
        by = r.figures.by_iterations
        if by:
            out.append(
                Finding(
                    f"`{m}` on `{scene}` against projection passes: "
                    + "; ".join(
                        f"{b['iterations']}: stretch {_g(b['max_stretch'], '.2e')}, energy "
                        f"{_g(b['energy_change'], '+.2%')}"
                        for b in by
                    )
                    + ".",
                    scene=scene,
                    method=m,
                )
            )
    return out


def energy_classes(check: Check, scene: str, piv: dict) -> list[Finding]:
    """Every method's energy class over the run: those of ``methods`` expected ``expect``."""
    energy = {m: ms["energy"] for (s, m), ms in sorted(piv.items()) if s == scene and "energy" in ms}
    ran = [r for r in energy.values() if r.status in ("ok", "unstable")]
    if not ran:
        return []
    dt, steps = ran[0].dt, ran[0].steps

    def text(m):
        r = energy[m]
        if r.status not in ("ok", "unstable"):
            return f"`{m}` {r.status}"
        val = _value(r)
        return f"`{m}` {val:.1e} {r.figures.energy_class}" if val is not None else f"`{m}` {r.figures.energy_class}"

    named = [m for m in energy if m in check.methods]
    ok = bool(named) and all(energy[m].status == "ok" and energy[m].figures.energy_class == check.expect for m in named)
    return [
        Finding(
            f"`{scene}`, energy over {dt * steps:.3g} days at dt = {dt:g} (max |ΔE/E|, class): symplectic "
            + ", ".join(text(m) for m in named)
            + f": all {check.expect} {MARK}. Others: "
            + ", ".join(text(m) for m in energy if m not in check.methods)
            + ".",
            ok,
            scene,
        )
    ]


def energy_not_bounded(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A method whose energy error is expected to drift (a class in ``expect``), with its envelopes."""
    out = []
    for m, r in _rows(piv, scene, check).items():
        n = r.figures.numbers or {}
        nan = math.nan
        out.append(
            Finding(
                f"`{scene}`: `{m}`'s energy error is not bounded but {r.figures.energy_class} {MARK}: |ΔE/E| envelope "
                f"{n.get('first_tenth_envelope', nan):.1e} over the first tenth of the run, "
                f"{n.get('last_tenth_envelope', nan):.1e} over the last (secular rate {n.get('secular_rate', nan):.2e} "
                f"per day).",
                r.figures.energy_class in check.expect,
                scene,
                m,
            )
        )
    return out


def not_symplectic_where_mass_varies(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A mode that is semi-implicit Euler in the generalized velocity (``methods``) whose energy
    class is not the one its scheme (``against``) claims, on a scene whose mass matrix varies over
    the run's configurations by more than ``tolerance`` (the energy cell's recorded
    ``mass_matrix_varies``): why. v+ = v + h M(q)^-1 f, q+ = q + h v+ is symplectic Euler in
    (q, p = M v) only where M is constant; where M(q) varies its Jacobian in (q, p) has a
    determinant other than 1 and the energy drifts at a rate proportional to h (docs/findings.md)."""
    from reference import METHODS

    (scheme,) = check.against
    claim = METHODS[scheme_name(scheme)].energy_claim
    out = []
    for m, r in _rows(piv, scene, check).items():
        cls, varies = r.figures.energy_class, (r.figures.numbers or {}).get("mass_matrix_varies")
        if cls is None or cls == claim or varies is None or varies <= check.tolerance:
            continue
        out.append(
            Finding(
                f"`{m}` on `{scene}`: energy {cls} (max |ΔE/E| {_g(_value(r), '.2g')}), not {claim} as `{scheme}` "
                f"claims: semi-implicit in generalized velocity, not momentum (v+ = v + h M(q)⁻¹f, q+ = q + h v+): not "
                f"symplectic where M(q) varies; M varies by {varies:.1%} over the run's configurations (largest "
                f"relative change of v'Mv).",
                None,
                scene,
                m,
            )
        )
    return out


def integrates_as(check: Check, scene: str, piv: dict) -> list[Finding]:
    """An engine mode identified as the ``expect``ed reference scheme."""
    out = []
    for m, ident in _rows(piv, scene, check).items():
        match, dev = ident.figures.match, _value(ident)
        how = "bitwise" if dev == 0 else f"to {dev:.1e}"
        out.append(
            Finding(
                f"`{scene}`: `{m}` integrates as `{match}` ({how} over {int(ident.steps)} steps of dt = "
                f"{ident.dt:.4g}) "
                f"{MARK}; runner-up `{ident.figures.runner_up}` at "
                f"{ident.figures.runner_up_deviation or math.nan:.1e}.",
                match == check.expect,
                scene,
                m,
            )
        )
    return out


def advances_by_half_steps(check: Check, scene: str, piv: dict) -> list[Finding]:
    """An engine mode named for a scheme that is identified as that scheme taken as two half
    steps (``expect``): what it keeps beside the scheme it is named for (``against``), from the
    run's own cells."""
    out = []
    plain = next((m for m in check.against if (scene, m) in piv), None)
    for m, ident in _rows(piv, scene, check).items():
        if ident.figures.match != check.expect or plain is None:
            continue
        mine, theirs = piv[(scene, m)].get("energy"), piv[(scene, plain)].get("energy")
        if _value(mine) is None or _value(theirs) is None or mine.dt != theirs.dt or mine.steps != theirs.steps:
            continue
        sa, sb = mine.figures.series or {}, theirs.figures.series or {}
        if not sa.get("t") or sa.get("t") != sb.get("t"):
            continue
        # The first recorded time at or past 1000 steps (the run keeps too little energy after
        # its whole horizon for a ratio to say anything).
        t = list(sa["t"])
        i = next((k for k, tk in enumerate(t) if tk >= 1000 * mine.dt * (1 - 1e-9)), len(t) - 1)
        kept_mine, kept_theirs = sa["energy"][i] / sa["energy"][0], sb["energy"][i] / sb["energy"][0]
        out.append(
            Finding(
                f"`{scene}`: `{m}` is not `{plain}` at the step asked for but two of its half steps (identified as "
                f"`{check.expect}`, to {_value(ident) or 0.0:.1e}) {MARK}: at t = {t[i]:.4g} (steps of dt = "
                f"{mine.dt:.4g}) it keeps {kept_mine:.3g} of the energy where `{plain}` keeps {kept_theirs:.3g}, "
                f"for twice its solves.",
                True,
                scene,
                m,
            )
        )
    return out


def energy_within(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A method's max |dE/E| over the run at most ``tolerance``."""
    out = []
    for m, r in _rows(piv, scene, check).items():
        if _value(r) is not None:
            out.append(
                Finding(
                    f"`{scene}`: `{m}` keeps max |ΔE/E| = {_value(r):.1e} over the run "
                    f"(limit {check.tolerance:g}) {MARK}.",
                    _value(r) <= check.tolerance,
                    scene,
                    m,
                )
            )
    return out


def _sweep(piv: dict, scene: str, method: str) -> dict | None:
    """(cost per unit time, error) along a method's order sweep: the sweep's errors, the cost cell's
    seconds per step (a fixed-step method's cost per step does not depend on dt) over each dt."""
    ms = piv.get((scene, method), MethodCells())
    order, sps = ms.order, _value(ms.cost)
    if order is None or order.status != "ok" or not sps:
        return None
    pts = [p for p in order.figures.points or [] if p["error"] and p["dt"]]
    if len(pts) < 2:
        return None
    return {"cost": [sps / p["dt"] for p in pts], "error": [p["error"] for p in pts]}


def error_at_equal_cost(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A method's max global error at equal cost per simulated day, as a ratio to each of
    ``against``'s: below ``tolerance`` at every shared point."""
    out = []
    for method in check.methods:
        mine = _sweep(piv, scene, method)
        for other in check.against:
            theirs = _sweep(piv, scene, other)
            if mine is None or theirs is None:
                continue
            rows = at_equal_cost(mine, theirs)
            if not rows:
                out.append(
                    Finding(
                        f"`{scene}`: `{method}` and `{other}` share no cost range in this run's sweeps.",
                        None,
                        scene,
                        method,
                    )
                )
                continue
            ratios = [r["ratio"] for r in rows]
            lo, hi = f"{min(ratios):.1e}", f"{max(ratios):.1e}"
            span = lo if lo == hi else f"{lo} to {hi}"
            points = f"{len(rows)} point{'s' if len(rows) > 1 else ''}"
            out.append(
                Finding(
                    f"`{scene}`, work-precision: at equal cost per simulated day, `{method}`'s max global "
                    f"error is {span} times `{other}`'s ({points} of the order sweep) {MARK}.",
                    max(ratios) < check.tolerance,
                    scene,
                    method,
                )
            )
    return out


def cost_ratio(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A method's time per step as a ratio to ``against``'s, beside their counted evaluations."""
    out = []
    for method in check.methods:
        for other in check.against:
            rk, lf = piv.get((scene, method), MethodCells()).cost, piv.get((scene, other), MethodCells()).cost
            if not (_value(lf) and _value(rk)):
                continue
            ev_lf, ev_rk = lf.figures.force_evals_per_step, rk.figures.force_evals_per_step
            evals = (
                f"{ev_rk:g} against {ev_lf:g} counted force evaluations"
                if ev_lf and ev_rk
                else "evaluations not counted"
            )
            out.append(
                Finding(
                    f"`{scene}`, cost: `{method}` takes {_value(rk) / _value(lf):.2f}x `{other}`'s time per step "
                    f"(compiled, {_value(rk) * 1e6:.3g} µs against {_value(lf) * 1e6:.3g} µs, min of repeats; spreads "
                    f"{rk.figures.spread or 0:.0%} and {lf.figures.spread or 0:.0%}) for {evals}.",
                    None,
                    scene,
                    method,
                )
            )
    return out


def brouwer_law(check: Check, scene: str, piv: dict) -> list[Finding]:
    """A method's ensemble energy-error slope (``brouwer`` cells) against Brouwer's 0.5: its 95%
    interval contains it."""
    out = []
    for m, r in _rows(piv, scene, check).items():
        f = r.figures
        if r.value is None or not f.ci95:
            continue
        lo, hi = f.ci95
        out.append(
            Finding(
                f"`{scene}`: `{m}`'s energy error over {f.realizations} realizations and "
                f"{f.periods:.3g} periods grows as t^{r.value:.2f} (95% interval {lo:.2f}–{hi:.2f}), "
                f"Brouwer's law t^{check.expect:g} {MARK}.",
                bool(lo <= check.expect <= hi),
                scene,
                m,
            )
        )
    return out


#: The findings a scene's table may name.
FINDINGS = {
    f.__name__: f
    for f in (
        stability_limits,
        damping_beyond_the_limit,
        matches_only_from_a_generic_state,
        cost_against_size,
        constraint_drift,
        survives_one_frame,
        energy_classes,
        energy_not_bounded,
        integrates_as,
        energy_within,
        error_at_equal_cost,
        cost_ratio,
        brouwer_law,
        not_symplectic_where_mass_varies,
        advances_by_half_steps,
    )
}

#: The reference schemes the outer solar system's energy finding calls symplectic, beside every
#: method that declares itself so (``Behaviour.symplectic``).
SOLAR_SYMPLECTIC = ("ref:semi_implicit_euler", "ref:leapfrog", "ref:velocity_verlet", "ref:forest_ruth")
#: The energy drift over the run allowed a method whose error is roundoff alone (``Behaviour.roundoff``).
ROUNDOFF_DRIFT = 1e-13
#: A mass matrix that changes by less than this (relative, over a run's configurations) is
#: constant: MuJoCo's mass matrix at two configurations of a constant-M model differs by roundoff
#: (0 measured on slide joints), and a relative change of 1e-9 moves no energy class.
MASS_MATRIX_TOL = 1e-9

#: What a method's declared behaviour puts into a row that names its field (``Check.of``) on a
#: scene: the row's fields it sets, or None where it declares nothing there. A method that sets
#: none joins the row's own methods; one that sets some is a row of its own.
DECLARED = {
    "integrates_as": lambda m, scene: (
        {"expect": m.behaviour.integrates_as[scene]} if scene in m.behaviour.integrates_as else None
    ),
    "half_steps_of": lambda m, scene: (
        {"against": (m.behaviour.half_steps_of,), "expect": m.behaviour.integrates_as[scene]}
        if m.behaviour.half_steps_of and scene in m.behaviour.integrates_as
        else None
    ),
    "from_a_generic_state": lambda m, scene: (
        {
            "against": (m.behaviour.from_a_generic_state[scene],),
            "note": m.no_match.get(scene) or "the method gives no reason",
        }
        if scene in m.behaviour.from_a_generic_state
        else None
    ),
    "in_velocity": lambda m, scene: {"against": (m.behaviour.in_velocity,)} if m.behaviour.in_velocity else None,
    "symplectic": lambda m, scene: {} if m.behaviour.symplectic else None,
    "roundoff": lambda m, scene: {} if m.behaviour.roundoff else None,
    "beats_at_equal_cost": lambda m, scene: (
        {"against": m.behaviour.beats_at_equal_cost} if m.behaviour.beats_at_equal_cost else None
    ),
}

#: Each scene's findings, in the order the report lists them. A key that ends in ":" holds the
#: checks of every scene whose id starts with it (``model:``: every model file).
SCENE_CHECKS: dict[str, tuple[Check, ...]] = {
    "spring": (Check("advances_by_half_steps", "identity", of="half_steps_of"),),
    "chain": (
        Check("stability_limits", "stability"),
        Check("damping_beyond_the_limit", "damping"),
        Check("matches_only_from_a_generic_state", "damping", of="from_a_generic_state"),
        Check("cost_against_size", "scaling", note="the tridiagonal solve is sparse"),
    ),
    "rope": (Check("constraint_drift", "constraint"),),
    "cloth": (
        Check("stability_limits", "stability"),
        Check("survives_one_frame", "stability", expect=60.0),
        Check("integrates_as", "identity", of="integrates_as"),
        Check(
            "cost_against_size",
            "scaling",
            note="the sheet's sparse system, factorised in bands up to 600 unknowns and by conjugate gradients above",
        ),
    ),
    "net": (
        Check("stability_limits", "stability"),
        Check("integrates_as", "identity", of="integrates_as"),
    ),
    "kepler": (Check("brouwer_law", "brouwer", expect=0.5, of="roundoff"),),
    "solar_system": (
        Check("energy_classes", "energy", methods=SOLAR_SYMPLECTIC, expect="bounded", of="symplectic"),
        Check(
            "energy_not_bounded",
            "energy",
            methods=("ref:rk4",),
            expect=("decays", "grows", "drifts", "damps less", "damps more"),
        ),
        Check("integrates_as", "identity", of="integrates_as"),
        Check("energy_within", "energy", tolerance=ROUNDOFF_DRIFT, of="roundoff"),
        Check("brouwer_law", "brouwer", expect=0.5, of="roundoff"),
        Check("error_at_equal_cost", "order", tolerance=1.0, of="beats_at_equal_cost"),
        Check("cost_ratio", "cost", methods=("ref:rk4",), against=("ref:leapfrog",)),
    ),
    "model:": (Check("not_symplectic_where_mass_varies", "energy", tolerance=MASS_MATRIX_TOL, of="in_velocity"),),
}


def checks_of(scene: str) -> tuple[Check, ...]:
    """A scene's findings table: its own, then those of every id prefix it starts with."""
    return SCENE_CHECKS.get(scene, ()) + tuple(
        check for key, checks in SCENE_CHECKS.items() if key.endswith(":") and scene.startswith(key) for check in checks
    )


def declared_checks(check: Check, scene: str, piv: dict, methods: dict) -> list[Check]:
    """``check`` on ``scene`` with what the run's methods declare of its ``of``: the row with the
    methods that declare it and set nothing joined to its own (none left: no row), then a row per
    method that sets some of its fields, in the order of the method ids. ``methods``: the method
    registry by id; a method id it lacks (a plugin not loaded now) declares nothing."""
    if check.of is None:
        return [check]
    joined, own = list(check.methods), []
    for mid in sorted({m for s, m in piv if s == scene}):
        said = DECLARED[check.of](methods[mid], scene) if mid in methods else None
        if said == {}:
            joined.append(mid)
        elif said:
            own.append(replace(check, of=None, methods=(mid,), **said))
    return ([replace(check, of=None, methods=tuple(joined))] if joined else []) + own


def scene_findings(piv: dict) -> list[Finding]:
    """The checks of every scene present in this run, each table row in turn: the scenes in
    ``SCENE_CHECKS``'s order, then the scenes matched by an id prefix, sorted."""
    from harness.methods import all_methods
    from records.measures import measures

    present = {s for s, _ in piv}
    order = [s for s in SCENE_CHECKS if s in present] + sorted(s for s in present if s not in SCENE_CHECKS)
    methods = all_methods()
    out = [
        f
        for scene in order
        for row in checks_of(scene)
        for check in declared_checks(row, scene, piv, methods)
        for f in FINDINGS[check.finding](check, scene, piv)
    ]
    # What a registered measure draws from its own cells (records.measures.Measure.findings).
    return out + [f for scene in order for m in measures() if m.findings is not None for f in m.findings(scene, piv)]


# ----------------------------------------------------------------------------- the run
def judge(cells: list[Cell], regressions=(), previous=None, trend=None) -> Judgement:
    """Everything the report prints that is judged rather than measured."""
    piv = pivot(cells)
    seen, findings = set(), []
    for f in engine_findings(piv) + blowups_at_nominal(piv) + scene_findings(piv):
        if f.text not in seen:  # a line said twice is printed once
            seen.add(f.text)
            findings.append(f)
    return Judgement(
        verdict=verdict(cells, regressions, previous, trend),
        claims={key: claim_checks(ms) for key, ms in piv.items() if key[1].startswith("ref:")},
        bounds={(c.scene, c.method, c.dt): bound_ok(c) for c in cells if c.measure == "bound"},
        findings=tuple(findings),
    )
