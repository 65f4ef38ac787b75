"""What the judge says of the contact cells: the seed's "lively bounces go dead" on the penalty
ground (``penalty`` cells), and per contact scene which engine modes keep every figure within its
tolerance at the frame rate a game steps at, with the cheapest of those that bounce, slide and
rest (``contact`` cells)."""

from __future__ import annotations

from records.findings import MARK, Finding

#: The frame rate the advice answers for.
ADVICE_DT = 1 / 60
#: The seed's claim, quoted.
SEED_CLAIM = "lively bounces go dead"


def _rows(piv, scene, measure):
    return {m: ms[measure] for (s, m), ms in piv.items() if s == scene and measure in ms and ms[measure].status == "ok"}


def contact_findings(scene: str, piv: dict) -> list[Finding]:
    """Per contact scene: the modes that gain energy at a bounce (a ✗ whatever the tolerance), and
    at 60 Hz the modes within every tolerance. On the first ball scene, the advice across scenes:
    the cheapest mode that bounces, slides and rests within tolerance at 60 Hz."""
    cells = _rows(piv, scene, "contact")
    if not cells:
        return []
    out = []
    gained = {m: sorted({r["dt"] for r in c.figures.runs if r.get("gained")}) for m, c in cells.items()}
    for m, dts in gained.items():
        if dts:
            out.append(
                Finding(
                    f"{MARK} `{m}` on `{scene}` gains energy at a bounce at dt = "
                    + ", ".join(f"1/{1 / d:.0f} s" for d in dts)
                    + ".",
                    False,
                    scene,
                    m,
                )
            )
    at60 = {m: _at(c.figures.runs, ADVICE_DT) for m, c in cells.items()}
    ok = sorted(m for m, r in at60.items() if r is not None and r.get("passes") and all(r["passes"].values()))
    out.append(
        Finding(
            f"`{scene}` at 60 Hz: "
            + (
                f"within every tolerance: {', '.join(f'`{m}`' for m in ok)}"
                if ok
                else "no engine mode is within every tolerance"
            )
            + ".",
            None,
            scene,
        )
    )
    if scene == _first_ball(piv):
        out.append(_advice(piv))
    return out


def _at(runs, dt):
    return next((r for r in runs if abs(r["dt"] - dt) <= 1e-9 * dt), None)


def _first_ball(piv) -> str | None:
    balls = sorted({s for (s, _), ms in piv.items() if "contact" in ms and ms["contact"].figures.scene == "ball"})
    return balls[0] if balls else None


def _advice(piv) -> Finding:
    """At 60 Hz, the modes within every tolerance on a ball, the slide and the stack, cheapest first
    (the sum of the engine loop's CPU per simulated second over the three)."""
    from .study import ADVICE_SCENES, rank

    by_mode: dict[str, dict[str, dict]] = {}
    for (s, m), ms in piv.items():
        c = ms.get("contact")
        if c is None or c.status != "ok" or c.figures.scene not in ADVICE_SCENES:
            continue
        r = _at(c.figures.runs, ADVICE_DT)
        if r is not None:
            by_mode.setdefault(m, {})[s] = r
    kinds_needed = sorted(
        {s for (s, _), ms in piv.items() if "contact" in ms and ms["contact"].figures.scene in ADVICE_SCENES}
    )
    fine, _ = rank(by_mode, kinds_needed)
    if not fine:
        return Finding(
            f"{MARK} Advice at 60 Hz: no engine mode bounces, slides and rests within every tolerance "
            f"({', '.join(sorted(kinds_needed))}).",
            False,
        )
    fine.sort()
    best = ", ".join(f"`{m}` ({c:.3g} CPU s per simulated s over the {len(kinds_needed)} scenes)" for c, m in fine)
    return Finding(
        f"{MARK} Advice at 60 Hz: within every tolerance on {', '.join(sorted(kinds_needed))}, cheapest first: {best}.",
        True,
    )
