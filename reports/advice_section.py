"""The report's "At N Hz" section: per scene, the method that meets the suite's tolerances with
the cheapest frame, its runners-up, and why the others cannot (``advise`` cells)."""

from __future__ import annotations

import math

from records.cell import Cell

from .text import Footnotes, fmt as _fmt, of_measure as _of

#: What the At-Hz section says of a request no advice cell carried.
REQUEST_UNKNOWN = {
    "energy_tol": None,
    "error_tol": None,
    "error_rel": None,
    "horizon": float("nan"),
    "max_substeps": "?",
}


def frame_rates(cells: list[Cell]) -> list[float]:
    return sorted({float(c.figures.hz) for c in _of(cells, "advise", "ok") if c.figures.hz})


def _per_frame(row: dict) -> str:
    c = row["cost_per_frame_s"]
    return "–" if c is None else f"{c * 1e6:.3g} µs"


def _converged(row: dict) -> str:
    c = row.get("converged")
    if c is None:
        return "–"
    return "yes" if c["meets"] else f"no: `{c['method']}` {c['why']}"


def advice_section(cells: list[Cell], hz: float, chart_names: dict) -> list[str]:
    """ "At 60 Hz": per scene, the method that meets the suite's tolerances with the cheapest
    frame (its fewest substeps), the runners-up, and how many methods meet none; from this
    run's ``advise`` cells (``harness.measures.advise``), cost per frame = substeps x the cost cell's
    CPU time per step."""
    rows = [c for c in cells if c.measure == "advise" and c.figures.hz == hz]
    if not rows:
        return []
    request = next((c.figures.request for c in rows if c.figures.request), None)
    request = {**REQUEST_UNKNOWN, **(request or {})}
    tol = []
    if request["energy_tol"] is not None:
        tol.append(f"energy error ≤ {request['energy_tol']:g}")
    if request["error_tol"] is not None:
        tol.append(f"position error ≤ {request['error_tol']:g}")
    elif request["error_rel"] is not None:
        tol.append(f"position error ≤ {100 * request['error_rel']:g}% of the scene's length scale")
    accuracy = request["error_tol"] is not None or request["error_rel"] is not None
    lines = [
        f"## At {hz:g} Hz",
        "",
        *([] if accuracy else ["**No accuracy tolerance: the energy alone judged, not where the positions end.**", ""]),
        f"Which method, with how many substeps a frame, keeps each scene stable and within "
        f"{' and '.join(tol) or 'the tolerances'} over {request['horizon']:g} s at {hz:g} "
        f"frames a second, for the least cost per frame (`harness advise`; substeps 1 to "
        f"{request['max_substeps']}, cost = substeps × the cost cell's CPU time per step). An iterative "
        "method that meets them is run again with its convergence knob tightened (ten times the passes, a "
        "tolerance a hundred times tighter): *converged* no where that misses them, its win resting on the "
        "solve's own error.",
        "",
    ]
    by_scene: dict = {}
    for c in rows:
        by_scene.setdefault(c.scene, []).append(c)
    for scene, grp in by_scene.items():
        meeting, failing, broken = [], [], []
        for r in grp:
            if r.status != "ok":
                broken.append(f"`{r.method}` {r.status}")
                continue
            best = r.figures.best
            if best is None:
                failing.append((r.method, r.figures.reason or "–"))
            else:
                row = r.figures.rows[best]
                meeting.append((row["cost_per_frame_s"] or math.inf, r.method, row))
        meeting.sort(key=lambda m: (m[0], m[1]))
        lines += [f"### `{scene}` at {hz:g} Hz", ""]
        position_tol = next((r.figures.position_tol for r in grp if r.figures.position_tol is not None), None)
        scale = next((r.figures.length_scale for r in grp if r.figures.length_scale is not None), None)
        if position_tol is not None:
            lines += [
                f"Position tolerance here: {position_tol:.3g}"
                + (
                    f" ({100 * request['error_rel']:g}% of the scene's length scale {scale:.3g})"
                    if request["error_tol"] is None and scale is not None
                    else ""
                )
                + ".",
                "",
            ]
        elif accuracy:
            lines += [
                "No accuracy tolerance here: the scene has no reference solution to hold the positions "
                "against; the energy alone judged.",
                "",
            ]
        if meeting:
            _, method, row = meeting[0]
            rests = row.get("converged") is not None and not row["converged"]["meets"]
            lines.append(
                f"**Advised: `{method}`, {row['substeps']} substep{'s' if row['substeps'] > 1 else ''}, "
                f"{_per_frame(row)} per frame"
                + (
                    f"; its win rests on the solve's own error (`{row['converged']['method']}` misses them)"
                    if rests
                    else ""
                )
                + ".**"
            )
        else:
            lines.append("**No method meets the tolerances here.**")
        lines += [
            "",
            "| rank | method | substeps | h·ω | energy error | class | position error | per frame | "
            "evals/frame | converged |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        notes = Footnotes()
        reasons = {r.method: r.figures.evals_reason for r in grp if r.status == "ok"}
        for i, (_, method, row) in enumerate(meeting[:5], start=1):
            evals = _fmt(
                row["evals_per_frame"],
                ".3g",
                notes.mark(reasons.get(method) and f"`{method}` counts no force evaluations: {reasons[method]}"),
            )
            lines.append(
                f"| {i} | `{method}` | {row['substeps']} | {row['homega']:.3g} | {_fmt(row['energy_error'], '.2e')} | "
                f"{row['energy_class'] or '–'} | {_fmt(row['position_error'], '.2e')} | "
                f"{_per_frame(row)} | {evals} | {_converged(row)} |"
            )
        if len(meeting) > 5:
            lines.append(f"| | {len(meeting) - 5} more meet them | | | | | | | | |")
        lines.append("")
        lines += notes.lines()
        if failing:
            lines.append("Cannot meet them: " + "; ".join(f"`{m}`: {why}" for m, why in sorted(failing)) + ".")
            lines.append("")
        if broken:
            lines += ["Not advised (see Failures): " + ", ".join(broken) + ".", ""]
        name = chart_names.get((scene, f"advise{hz:g}"))
        if name:
            lines += [f"![Error against cost per frame on {scene} at {hz:g} Hz]({name})", ""]
    return lines
