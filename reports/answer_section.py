"""The report's first section, "The answer": for every scene of the run, which method to use at the
frame rate it was asked about, why in a line, and the runner-up, with the tolerances and the
scene's parameters it was judged by. The detail behind each line is further down (the At-N-Hz
sections, the contact tables, the findings).

* A scene with ``advise`` cells (``harness.measures.advise``): at each frame rate, the method that
  meets the tolerances with the cheapest frame. Frames whose costs lie within their timing spread
  (``records.advice.tie``) are a tie: both named, and the pick among them goes to the more
  accurate (the smaller position error), then the fewer evaluations a frame, never to the clock.
* A contact scene (``contact`` cells): at each tolerance profile's own step (a game's 60 Hz, a
  robot's 1 kHz, ``records.contact.PROFILE_DT``), the engine mode within every tolerance of that
  profile at the least engine-loop CPU per simulated second, the same tie rule applied with the
  loop's measured cost.
* Any other scene says what the suite measured of it instead, in a line.
"""

from __future__ import annotations

import math

from records.cell import Cell

#: Frame costs within this fraction of each other are a tie where a cell stored no spread of its
#: own (a contact run's loop is timed once): policy, the process-to-process noise of one timing.
TIE_WITHOUT_SPREAD = 0.1


def _num(x) -> float:
    return math.inf if x is None else float(x)


def _us(s) -> str:
    return "–" if s is None else f"{s * 1e6:.3g} µs"


def _tied(first: tuple, other: tuple) -> bool:
    from records.advice import tie

    return tie(first[0], first[1], other[0], other[1])


#: Two position errors closer than this, relative, are one figure: schemes that compute the same
#: positions (leapfrog and velocity Verlet) differ in the last bits, which a compiler or a BLAS moves.
SAME_ERROR_REL = 1e-9


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return abs(float(a) - float(b)) <= SAME_ERROR_REL * max(abs(float(a)), abs(float(b)))


def _pick(candidates: list[dict]) -> tuple[dict, list[dict], dict | None, str]:
    """(the pick, the candidates tied with the cheapest (empty: no tie), the runner-up, why the pick
    among the tied). Each candidate: ``cost``, ``spread`` (relative; None: ``TIE_WITHOUT_SPREAD``),
    ``error`` (position error, None: not judged), ``energy`` (energy error, None: not judged),
    ``evals`` (a frame's, None: not counted), ``name``. A tie is decided by the position error,
    errors within ``SAME_ERROR_REL`` being one; then the energy error; then the evaluations; then
    the name (the phrase says which decided)."""
    ranked = sorted(candidates, key=lambda c: (_num(c["cost"]), c["name"]))
    first = ranked[0]

    def key(c):
        spread = c["spread"] if c["spread"] is not None else TIE_WITHOUT_SPREAD
        return (c["cost"], spread)

    tied = [c for c in ranked if c is first or _tied(key(first), key(c))]
    if len(tied) < 2:
        return first, [], ranked[1] if len(ranked) > 1 else None, ""
    pool, why = tied, ""
    for field, phrase in (
        ("error", "the more accurate"),
        ("energy", "the more accurate in energy (their positions alike)"),
        ("evals", "the cheaper in evaluations a frame (their errors alike)"),
    ):
        best = min(_num(c.get(field)) for c in pool)
        keep = [c for c in pool if _same(c.get(field), best if math.isfinite(best) else None)]
        if 0 < len(keep) < len(pool):
            pool = keep
            if len(pool) == 1:  # this figure decided: the phrase is true of the pick against every other
                why = phrase
                break
    pick = min(pool, key=lambda c: c["name"])
    if len(pool) > 1:
        why = "first by name among those alike in accuracy and evaluations"
    rest = [c for c in ranked if c is not pick]
    return pick, tied, rest[0] if rest else None, why


def _advise_lines(scene: str, cells: list[Cell]) -> list[str]:
    out = []
    for hz in sorted({float(c.figures.hz) for c in cells if c.figures.hz}):
        at = [c for c in cells if c.figures.hz and float(c.figures.hz) == hz and c.status == "ok"]
        meeting = []
        for c in at:
            f = c.figures
            if f.best is None or not f.rows:
                continue
            row = f.rows[f.best]
            meeting.append(
                {
                    "name": c.method,
                    "cost": row.get("cost_per_frame_s"),
                    "spread": (c.extra or {}).get("cost_rel_spread", getattr(f, "cost_rel_spread", None)),
                    "error": row.get("position_error"),
                    "energy": row.get("energy_error"),
                    "evals": row.get("evals_per_frame"),
                    "substeps": row.get("substeps"),
                }
            )
        request = next((c.figures.request for c in at if c.figures.request), None) or {}
        tol = []
        if request.get("energy_tol") is not None:
            tol.append(f"energy error ≤ {request['energy_tol']:g}")
        pos = next((c.figures.position_tol for c in at if c.figures.position_tol is not None), None)
        if pos is not None:
            tol.append(f"position error ≤ {pos:.3g}")
        over = f" over {request['horizon']:g} s" if request.get("horizon") is not None else ""
        judged = f"{' and '.join(tol) or 'stability alone'}{over}"
        if not meeting:
            out.append(f"- `{scene}` at {hz:g} Hz: no method meets {judged} (the At {hz:g} Hz section says why).")
            continue
        pick, tied, runner, why = _pick(meeting)
        line = (
            f"- `{scene}` at {hz:g} Hz: **`{pick['name']}`**, {pick['substeps']} substep"
            f"{'s' if (pick['substeps'] or 0) > 1 else ''} a frame, {_us(pick['cost'])} per frame: "
        )
        if tied:
            others = ", ".join(f"`{c['name']}` ({_us(c['cost'])})" for c in tied if c is not pick)
            line += f"its frame costs the same as {others} within their timing spread (a tie), and it is {why}"
        else:
            line += "the cheapest frame that meets the tolerances"
        line += f" ({judged}; {len(meeting)} of {len(at)} methods meet them)"
        if runner is not None:
            line += f"; runner-up `{runner['name']}`, {_us(runner['cost'])} per frame"
        out.append(line + ".")
    return out


def _contact_lines(scene: str, cells: list[Cell]) -> list[str]:
    from records.contact import PROFILE_DT

    out = []
    params = cells[0].figures.scene_params or {}
    shown = ", ".join(f"{k} = {v:g}" for k, v in params.items())
    for profile, dt in PROFILE_DT.items():
        fine, judged = [], 0
        for c in cells:
            run = next((r for r in c.figures.runs if r.get("dt") and abs(r["dt"] - dt) <= 1e-9 * dt), None)
            if run is None or run.get("status") != "ok":
                continue
            passes = (run.get("by_profile") or {}).get(profile)
            if passes is None:
                continue
            judged += 1
            if passes and all(passes.values()):
                cost = run.get("cpu_per_s")
                fine.append({"name": c.method, "cost": cost, "spread": None, "error": None, "evals": None})
        if not judged:
            continue
        where = f"`{scene}`{f' ({shown})' if shown else ''} at {1 / dt:.0f} Hz, {profile} profile"
        if not fine:
            out.append(
                f"- {where}: no engine mode is within every tolerance ({judged} judged; the contact table says "
                "which figure fails)."
            )
            continue
        pick, tied, runner, why = _pick(fine)
        line = f"- {where}: **`{pick['name']}`**, {pick['cost']:.3g} CPU s per simulated s"
        if tied:
            others = ", ".join(f"`{c['name']}` ({c['cost']:.3g})" for c in tied if c is not pick)
            line += (
                f", within every tolerance and as cheap as {others} within timing noise (a tie; named {why})"
                f" ({len(fine)} of {judged} modes are within every tolerance)"
            )
        else:
            line += f", the cheapest within every tolerance ({len(fine)} of {judged} modes are)"
        if runner is not None:
            line += f"; runner-up `{runner['name']}`, {runner['cost']:.3g}"
        out.append(line + ".")
    return out


def answer_section(cells: list[Cell]) -> list[str]:
    """ "The answer": a line per scene and frame rate (module docstring)."""
    scenes = list(dict.fromkeys(c.scene for c in cells if c.measure != "bound"))
    if not scenes:
        return []
    lines = [
        "## The answer",
        "",
        "Which method to use, scene by scene, at the frame rate each was asked about, and why in a line; "
        "the runner-up beside it. Costs are CPU time (the engine's or the compiled kernel's own loop); a "
        "pick between frames whose costs lie within their timing spread is a tie, both named, decided by "
        "accuracy, then evaluations.",
        "",
    ]
    for scene in scenes:
        mine = [c for c in cells if c.scene == scene]
        advise = [c for c in mine if c.measure == "advise"]
        contact = [c for c in mine if c.measure == "contact" and c.status == "ok"]
        said = _advise_lines(scene, advise) if advise else _contact_lines(scene, contact) if contact else None
        if said:
            lines += said
        elif advise or contact:
            statuses = ", ".join(sorted({c.status for c in advise or contact}))
            lines.append(f"- `{scene}`: its advice was asked but not measured ({statuses}; see Failures).")
        else:
            measured = ", ".join(sorted({c.measure for c in mine}))
            lines.append(f"- `{scene}`: no advice asked of it in this suite (measured: {measured}).")
    return lines + [""]
