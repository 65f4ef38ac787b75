"""The finding a ``sweep`` cell draws (``harness.nightly.measures.sweep_cell``): the seed's claim that stiff
cloth wants implicit Euler "where explicit methods would demand absurdly tiny timesteps", held
against where the measured cheapest frames of the two families cross.

✓ where implicit solves take over from explicit substeps on the grid (``family_crossover``:
explicit cheaper at one value, implicit at the next): the crossover's value and h*omega at one
substep are stated, and how many substeps the cheapest explicit method needed just past it.
✗ where they do not (the explicit frame cheaper at every value, or the implicit one everywhere),
with the two families' frames at the stiffest value. Either way the line names the cheapest
family at the stiffest value where it is neither (a position-based solve) and where the overall
cheapest family changes. Nothing checked (None) where no method meets the tolerances at an end.
"""
from __future__ import annotations

from records.advice import family_name
from records.findings import MARK, Finding

#: The seed's claim, as the finding quotes it.
CLAIM = ("the seed sends stiff cloth to implicit Euler \"where explicit methods would demand absurdly tiny "
         "timesteps\"")
#: The families the claim counts as explicit substepping and as implicit solving.
EXPLICIT, IMPLICIT = "explicit", "implicit"


def sweep_finding(cell) -> Finding:
    f = cell.figures
    points = f.sweep_points()
    where = f"`{cell.scene}`{' ' + f.label if f.label else ''}"
    request = f.request or {}
    tol = f"energy ≤ {request['energy_tol']:g}" if request.get("energy_tol") else "the tolerances"
    head = (f"{MARK} {where}, {f.param} = {points[0].value:.3g}..{points[-1].value:.3g} at {f.hz:g} Hz "
            f"({tol} over {request.get('horizon', float('nan')):g} s): {CLAIM}")
    soft, stiff = points[0].cheapest, points[-1].cheapest
    if soft is None or stiff is None:
        return Finding(head.replace(f"{MARK} ", "") + "; not judged: no method meets the tolerances at "
                       f"{f.param} = {(points[0] if soft is None else points[-1]).value:.3g}", None, cell.scene,
                       cell.method)
    from harness.measures.sweep import family_costs, family_crossover

    x = family_crossover(points, EXPLICIT, IMPLICIT)
    if x is not None:
        past = [e for p in points if p.value >= x.above for e in p.met if e.family == EXPLICIT]
        need = past[0] if past else None
        text = (f"{head}: measured, explicit substeps (`{x.from_method}`) are cheaper up to {f.param} ≈ "
                f"{x.value:.3g}, implicit solves (`{x.to_method}`) beyond: the crossover at h·ω ≈ "
                f"{x.homega_one:.3g} at one substep")
        if need is not None:
            text += f"; just past it `{need.method}` still meets them at {need.substeps} substeps"
    else:
        last = family_costs(points[-1])
        frames = ", ".join(f"{family_name(k)} {_us(last[k].cost_per_frame_s)} (`{last[k].method}`)"
                           for k in (EXPLICIT, IMPLICIT) if k in last)
        text = (f"{head}: measured, implicit solves never take over from explicit substeps on the grid; at "
                f"{f.param} = {points[-1].value:.3g} (h·ω = {points[-1].homega_one:.3g} at one substep) "
                f"{frames or 'neither family meets them'}")
    if stiff.family not in (EXPLICIT, IMPLICIT):
        text += (f"; the cheapest frame at {f.param} = {points[-1].value:.3g} is {family_name(stiff.family)} "
                 f"(`{stiff.method}`, {_us(stiff.cost_per_frame_s)})")
    overall = [c for c in f.sweep_crossovers()]
    if overall and not (len(overall) == 1 and (overall[0].from_family, overall[0].to_family) == (EXPLICIT, IMPLICIT)):
        text += "; the cheapest family overall: " + ", ".join(
            f"{family_name(c.from_family)} → {family_name(c.to_family)} at h·ω ≈ {c.homega_one:.3g}" for c in overall)
    return Finding(text, x is not None, cell.scene, cell.method)


def _us(seconds) -> str:
    return "–" if seconds is None else f"{seconds * 1e6:.3g} µs"


def sweep_findings(scene: str, piv: dict) -> list[Finding]:
    """One finding per ok ``sweep`` cell on ``scene``, smallest sheet first."""
    cells = [ms["sweep"] for (s, _), ms in piv.items() if s == scene and "sweep" in ms]
    cells = [c for c in cells if c.status == "ok" and c.figures.points]
    params = lambda c: c.figures.params or {}  # noqa: E731
    cells.sort(key=lambda c: (float(params(c).get("n", 1)) * float(params(c).get("m", 1)), c.method))
    return [sweep_finding(c) for c in cells]
