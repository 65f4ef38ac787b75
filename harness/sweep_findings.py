"""The finding a ``sweep`` cell draws (``harness.nightly.sweep_cell``): the seed's claim that stiff
cloth wants implicit Euler "where explicit methods would demand absurdly tiny timesteps", held
against where the cheapest family measured changes.

✓ where the trade-off flips the way the claim says: explicit substeps are the cheapest frame at
the softest value of the grid, an implicit family at the stiffest, and the crossover between is
named (its value and h*omega at one substep, with how many substeps the cheapest explicit method
needed at the stiffest value where it still met the tolerances). ✗ where it does not (implicit
cheapest everywhere, explicit cheapest everywhere, or another family at the stiff end), with
what was measured instead. Nothing checked (None) where no method meets the tolerances at an end.
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
    cross = f.sweep_crossovers()
    flips = [x for x in cross if x.from_family == EXPLICIT and x.to_family == IMPLICIT]
    ok = soft.family == EXPLICIT and stiff.family == IMPLICIT and bool(flips)
    if ok:
        x = flips[-1]
        explicit = [e for p in points if p.value >= x.above for e in p.met if e.family == EXPLICIT]
        need = max(explicit, key=lambda e: e.substeps) if explicit else None
        text = (f"{head}: measured, explicit substeps (`{x.from_method}`) are cheapest up to {f.param} ≈ "
                f"{x.value:.3g}, implicit solves (`{x.to_method}`) beyond: the crossover at h·ω ≈ "
                f"{x.homega_one:.3g} at one substep")
        if need is not None:
            text += (f"; past it the cheapest explicit frame still met them with `{need.method}` at "
                     f"{need.substeps} substeps")
        return Finding(text, True, cell.scene, cell.method)
    measured = ", ".join(f"{family_name(p.cheapest.family)} at {f.param} = {p.value:.3g}" for p in (points[0], points[-1]))
    if cross:
        measured += "; crossovers: " + ", ".join(f"{family_name(x.from_family)} → {family_name(x.to_family)} at "
                                                 f"h·ω ≈ {x.homega_one:.3g}" for x in cross)
    return Finding(f"{head}: measured, the cheapest frame is {measured}", False, cell.scene, cell.method)


def sweep_findings(scene: str, piv: dict) -> list[Finding]:
    """One finding per ok ``sweep`` cell on ``scene``, smallest sheet first."""
    cells = [ms["sweep"] for (s, _), ms in piv.items() if s == scene and "sweep" in ms]
    cells = [c for c in cells if c.status == "ok" and c.figures.points]
    params = lambda c: c.figures.params or {}  # noqa: E731
    cells.sort(key=lambda c: (float(params(c).get("n", 1)) * float(params(c).get("m", 1)), c.method))
    return [sweep_finding(c) for c in cells]
