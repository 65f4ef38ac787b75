"""The findings a ``sweep`` cell draws (``harness.nightly.measures.sweep_cell``): the seed's claim that
stiff cloth wants implicit Euler "where explicit methods would demand absurdly tiny timesteps", as
the two claims it makes, each judged per sweep (per sheet size) from the measured entries at the
grid's stiffest value (``seed_claims``; ``harness advise --sweep`` prints the same two lines):

* **survives** (the energy tolerance alone): an implicit solve stays stable and within the energy
  tolerance with steps at least ``TINY`` times longer than the explicit schemes need for the same
  (``SweepEntry.energy_substeps``: the fewest substeps whose run did, whatever its position error;
  an explicit search that ended first, on its cost or substep bound, needs at least its next level).
  ✓ where it does; ✗ where no implicit solve stays within it up to the most substeps searched, or
  an explicit scheme does at fewer than ``TINY`` times the implicit solve's substeps; not judged
  where every implicit search ended on its cost bound before one did. The claim is about
  stability, not cost: where the searches leave it open, the stiffest value's implicit searches
  that the cost bound cut are run on for it alone (``harness.measures.sweep.probe_survival``), so
  that a machine's timings cannot turn it.
* **the cheaper usable frame** (the accuracy tolerance too): the implicit family's cheapest frame
  that meets every tolerance is cheaper than the explicit family's (an explicit family whose
  searches all ended on the cost or the substep bound counts as dearer). ✓ / ✗ at the stiffest
  value, with where implicit solves take over on the grid (``family_crossover``) where they do;
  not judged where the sweep asked no accuracy tolerance, or neither family meets the tolerances.

Each line names the methods behind its figures and their solves (``SweepEntry.solve``: a library's
with its settings, or the scene's own kernel), and the tolerances. Where a third family (a
position-based solve) is the cheapest frame at the stiffest value, the second line says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from records.advice import family_crossover, family_name, tie
from records.findings import MARK, Finding

#: The seed's claim, as the findings quote it.
CLAIM = 'the seed sends stiff cloth to implicit Euler "where explicit methods would demand absurdly tiny timesteps"'
#: The families the claims count as explicit substepping and as implicit solving.
EXPLICIT, IMPLICIT = "explicit", "implicit"
#: "Absurdly tiny": the explicit schemes' step at least this many times shorter than the implicit
#: solve's for the same energy tolerance (an order of magnitude; at the stiff end of the cloth's
#: grid their stability alone asks h·ω <= 2 against the frame's h·ω of 100 and more).
TINY = 10


@dataclass(frozen=True)
class Claim:
    """One of the seed's two claims on one sweep: whether it holds (None: not judged) and what was
    measured, in words (no mark)."""

    name: str
    ok: bool | None
    text: str


def seed_claims(points, param: str, energy_tol: float | None, accuracy: bool) -> tuple[Claim, Claim]:
    """The two claims (module docstring) judged at the stiffest value of ``points``
    (``SweepPoint``s in grid order); ``accuracy``: whether the sweep asked a position tolerance."""
    return survives(points, param, energy_tol, accuracy), cheaper_usable(points, param, accuracy)


def _at(p, param: str) -> str:
    return f"at {param} = {p.value:.3g} (h·ω = {p.homega_one:.3g} at one substep)"


def _solve(e, checked: bool = True) -> str:
    """The entry's solve, and where its win rests on that solve's own error, the run that says so
    (``checked``: the convergence check ran at the substeps the line names)."""
    rests = (
        f" (its win rests on the solve's own error: `{e.converged['method']}` misses the tolerances)"
        if checked and e.rests_on_solve
        else ""
    )
    return (f", solve: {e.solve}" if e.solve else "") + rests


def _energy_steps(e, accuracy: bool) -> int | None:
    """The fewest substeps within the energy tolerance an entry records; a sweep on the energy alone
    stored before entries recorded it gives its met substeps."""
    if e.energy_substeps is not None:
        return e.energy_substeps
    return e.substeps if e.ended == "met" and not accuracy else None


def _stands(e) -> bool:
    """Whether an entry's survival stands once its solve converges further (no knob, or the check
    passed: ``harness.measures.sweep.survived``)."""
    return e.survival_converged is None or bool(e.survival_converged.get("meets"))


def _moves(c: dict) -> str:
    """What a convergence check found the tightened run to change, in words."""
    parts = []
    if not c.get("energy_within", True):
        e = c.get("energy_error")
        parts.append("its energy error " + (f"{e:.3g}" if e is not None else "undefined") + " misses the tolerance")
    if c.get("moved") is not None and c.get("tol") is not None and c["moved"] > c["tol"]:
        until = f" within the predictable horizon ({c['until']:.3g} s)" if c.get("until") is not None else ""
        parts.append(f"its positions move {c['moved']:.3g} > {c['tol']:.3g}{until}")
    if c.get("com_moved") is not None and c.get("tol") is not None and c["com_moved"] > c["tol"]:
        parts.append(f"its centre of mass moves {c['com_moved']:.3g} past the horizon")
    return "; ".join(parts) or (c.get("why") or "it misses the tolerances")


def _rests(e) -> str:
    """An implicit survival that rests on its solve's own error, in words."""
    c = e.survival_converged
    s = e.energy_substeps
    return (
        f"`{e.method}` within it at {s} substep{'s' if s > 1 else ''} rests on its solve's own error "
        f"(`{c['method']}`: {_moves(c)})"
    )


def survives(points, param: str, energy_tol: float | None, accuracy: bool = True) -> Claim:
    name = "implicit Euler survives where explicit steps must be tiny (energy tolerance)"
    p = points[-1]
    if energy_tol is None:
        return Claim(name, None, "not judged: the sweep asked no energy tolerance")
    steps = {
        fam: sorted(
            (s, e.method)
            for e in p.entries
            if e.family == fam and (fam != IMPLICIT or _stands(e))
            for s in [_energy_steps(e, accuracy)]
            if s is not None
        )
        for fam in (EXPLICIT, IMPLICIT)
    }
    implicit = [e for e in p.entries if e.family == IMPLICIT]
    if not implicit:
        return Claim(name, None, f"not judged: no implicit solve was searched {_at(p, param)}")
    # A survival whose solve, converged further, loses the energy or moves the sheet is its solve's,
    # not implicit Euler's: it does not count, and the line says so.
    resting = [e for e in implicit if e.energy_substeps is not None and not _stands(e)]
    rest = f"; {'; '.join(_rests(e) for e in resting)}" if resting else ""
    if not steps[IMPLICIT]:
        tried = ", ".join(f"`{e.method}` to {e.searched} substeps" for e in implicit)
        if all(e.ended == "cost" for e in implicit if e not in resting) and len(resting) < len(implicit):
            return Claim(
                name,
                None,
                f"not judged: every implicit search ended on its cost bound {_at(p, param)} "
                f"before one stayed within the energy tolerance ({tried}){rest}",
            )
        return Claim(
            name,
            False,
            f"no implicit solve stays stable within energy error ≤ {energy_tol:g} {_at(p, param)} with its solve "
            f"converged ({tried}){rest}",
        )
    s_i, m_i = steps[IMPLICIT][0]
    e_i = next(e for e in implicit if e.method == m_i)
    probed = " (run past its search's cost bound for this claim alone)" if s_i in tuple(e_i.probed or ()) else ""
    said = (
        f"`{m_i}` stays within energy error ≤ {energy_tol:g} at {s_i} substep{'s' if s_i > 1 else ''}"
        f"{probed}{_solve(e_i, e_i.substeps == s_i)}"
    )
    tried = [e for e in p.entries if e.family == EXPLICIT]
    if not tried:
        return Claim(name, None, f"not judged: no explicit scheme was searched {_at(p, param)}; {said}")
    # An explicit search that ended before a level within the energy tolerance (on its cost or
    # substep bound) needs at least its next level: the fewest the family needs is bounded below.
    bounds = sorted(
        (e.next_substeps or 2 * max(e.searched, 1), e.method) for e in tried if _energy_steps(e, accuracy) is None
    )
    need, m_e = min(steps[EXPLICIT][:1] + bounds[:1])
    exact = bool(steps[EXPLICIT]) and (not bounds or steps[EXPLICIT][0][0] < bounds[0][0])
    if exact:
        explicit = f"explicit substeps need {need} (`{m_e}`)"
    elif steps[EXPLICIT]:
        s_e, m_met = steps[EXPLICIT][0]
        explicit = (
            f"explicit substeps need at least {need} (`{m_e}` not within it below {need}, its search ended "
            f"there; `{m_met}` within it at {s_e})"
        )
    else:
        explicit = f"no explicit scheme is within it below {need} substeps (`{m_e}` the first to stop)"
    ratio = need / s_i
    ok = ratio >= TINY
    checked = (
        f" (`{e_i.survival_converged['method']}` within it too, its motion where this run's is)"
        if e_i.survival_converged is not None
        else ""
    )
    return Claim(
        name,
        ok,
        f"{_at(p, param)}: {said}{checked}; {explicit}: steps {'' if exact else 'at least '}"
        f"{ratio:.3g} x shorter ({'≥' if ok else '<'} the {TINY} x the claim asks){rest}",
    )


def cheaper_usable(points, param: str, accuracy: bool = True) -> Claim:
    name = "implicit Euler is the cheaper usable frame (accuracy tolerance too)"
    if not accuracy:
        return Claim(name, None, "not judged: the sweep asked no accuracy tolerance (the energy alone)")
    p = points[-1]
    if not any(e.family == IMPLICIT for e in p.entries):
        return Claim(name, None, f"not judged: no implicit solve was searched {_at(p, param)}")
    # Each family's cheapest frame that meets the tolerances with its solve converged (a win that
    # rests on the solve's own error is the solve's: said, not counted).
    costs = {
        fam: next((e for e in p.met if e.family == fam and not e.rests_on_solve), None) for fam in (IMPLICIT, EXPLICIT)
    }
    imp, exp = costs.get(IMPLICIT), costs.get(EXPLICIT)
    resting = [e for e in p.met if e.rests_on_solve and e.family in (IMPLICIT, EXPLICIT)]
    bounded = [e for e in p.entries if e.family == EXPLICIT and e.ended in ("cost", "cap")]
    if imp is None and exp is None:
        return Claim(name, None, f"not judged: neither family meets the tolerances {_at(p, param)}")

    def frame(e) -> str:
        return f"`{e.method}` {e.substeps} × = {_us(e.cost_per_frame_s)} a frame{_solve(e)}"

    tried = [e for e in p.entries if e.family == IMPLICIT]
    if imp is None:
        unconverged = any(e.rests_on_solve for e in tried)
        searched = [e for e in tried if not e.rests_on_solve] or tried
        far = max(searched, key=lambda e: (e.searched, e.method))
        ended = sorted({"met, resting on its solve" if e.rests_on_solve else e.ended for e in tried})
        text = (
            f"{_at(p, param)} no implicit solve meets them{' with its solve converged' if unconverged else ''} "
            f"({len(tried)} searched, ended on {' / '.join(ended)}; the furthest, `{far.method}` to {far.searched} "
            f"substeps: {far.why.split('; ')[-1] if far.why else far.ended}); explicit substeps do: {frame(exp)}"
        )
        ok = False
    elif exp is None:
        if not bounded:
            return Claim(
                name,
                None,
                f"not judged: no explicit scheme was searched {_at(p, param)}; implicit solves: {frame(imp)}",
            )
        text, ok = (
            (f"{_at(p, param)} implicit solves meet them, {frame(imp)}; no explicit scheme does within its cost bound"),
            True,
        )
    else:
        tied = tie(imp.cost_per_frame_s, imp.cost_rel_spread, exp.cost_per_frame_s, exp.cost_rel_spread)
        ok = imp.cost_per_frame_s < exp.cost_per_frame_s and not tied
        ratio = exp.cost_per_frame_s / imp.cost_per_frame_s
        text = f"{_at(p, param)} implicit solves' cheapest frame that meets them, {frame(imp)}, against explicit " + (
            f"substeps' {frame(exp)}: a tie (their costs lie within the timing spread: neither is the cheaper)"
            if tied
            else f"substeps' {frame(exp)}: "
            + (f"implicit {ratio:.3g} x cheaper" if ok else f"explicit {1 / ratio:.3g} x cheaper")
        )
    x = family_crossover(points, EXPLICIT, IMPLICIT)
    if x is not None:
        text += (
            f"; implicit solves take over from explicit substeps at {param} ≈ {x.value:.3g} "
            f"(h·ω ≈ {x.homega_one:.3g} at one substep)"
        )
    stiff = p.cheapest
    if stiff is not None and stiff.family not in (EXPLICIT, IMPLICIT):
        text += (
            f"; the cheapest frame there is {family_name(stiff.family)} (`{stiff.method}`, "
            f"{_us(stiff.cost_per_frame_s)})"
        )
    cheaper_resting = [
        e for e in resting if costs.get(e.family) is None or e.cost_per_frame_s < costs[e.family].cost_per_frame_s
    ]
    if cheaper_resting:
        text += "; not counted, their wins resting on the solve's own error: " + ", ".join(
            f"`{e.method}` {e.substeps} × = {_us(e.cost_per_frame_s)} "
            f"(`{e.converged['method']}`: {_moves(e.converged)})"
            for e in cheaper_resting
        )
    text += horizon_text(p)
    return Claim(name, ok, text)


def horizon_text(p) -> str:
    """The point's predictable horizon and what was judged past it (``harness.measures.horizon``),
    where one was measured."""
    from harness.measures.horizon import Horizon

    h = Horizon.from_dict(p.horizon)
    if h is None:
        return ""
    past = h.past_text()
    return f"; the sheet is {h.text()}" + (f": {past}" if past else "")


def _us(seconds) -> str:
    return "–" if seconds is None or not math.isfinite(seconds) else f"{seconds * 1e6:.3g} µs"


def sweep_finding(cell) -> list[Finding]:
    """The two claims on one sweep cell, each a finding that names the sheet and the tolerances."""
    f = cell.figures
    points = f.sweep_points()
    where = f"`{cell.scene}`{' ' + f.label if f.label else ''}"
    r = f.sweep_request()
    tols = []
    if r.energy_tol:
        tols.append(f"energy error ≤ {r.energy_tol:g}")
    pos = points[-1].position_tol
    if r.error_tol:
        tols.append(f"position error ≤ {r.error_tol:g}")
    elif r.error_rel:
        tols.append(
            f"position error ≤ {100 * r.error_rel:g}% of the scene's length scale"
            + (f" ({pos:.3g})" if pos is not None else "")
        )
    head = (
        f"{where}, {f.param} = {points[0].value:.3g}..{points[-1].value:.3g} at {f.hz:g} Hz over "
        f"{r.horizon:g} s ({' and '.join(tols) or 'the tolerances'}): {CLAIM}"
    )
    out = []
    for claim in seed_claims(points, f.param, r.energy_tol, bool(r.error_tol or r.error_rel)):
        mark = f"{MARK} " if claim.ok is not None else ""
        out.append(Finding(f"{mark}{head}; {claim.name}: {claim.text}", claim.ok, cell.scene, cell.method))
    return out


def sweep_findings(scene: str, piv: dict) -> list[Finding]:
    """Two findings per ok ``sweep`` cell on ``scene``, smallest sheet first."""
    cells = [ms["sweep"] for (s, _), ms in piv.items() if s == scene and "sweep" in ms]
    cells = [c for c in cells if c.status == "ok" and c.figures.points]
    params = lambda c: c.figures.params or {}  # noqa: E731
    cells.sort(key=lambda c: (float(params(c).get("n", 1)) * float(params(c).get("m", 1)), c.method))
    return [finding for c in cells for finding in sweep_finding(c)]
