"""What the judge says of the contact cells: the seed's "lively bounces go dead" on the penalty
ground (``penalty`` cells), and per contact scene which engine modes keep every figure within its
tolerance at the frame rate a game steps at, with the cheapest of those that bounce, slide and
rest (``contact`` cells)."""

from __future__ import annotations

from records.findings import MARK, Finding

#: The frame rate the first advice answers for (a game's, judged by the game profile); the
#: second answers at a robot's control step by the robotics profile (``scenarios.contact.PROFILE_DT``).
ADVICE_DT = 1 / 60
#: The seed's claim, quoted.
SEED_CLAIM = "lively bounces go dead"


def _rows(piv, scene, measure):
    return {m: ms[measure] for (s, m), ms in piv.items() if s == scene and measure in ms and ms[measure].status == "ok"}


def contact_findings(scene: str, piv: dict) -> list[Finding]:
    """Per contact scene: the modes that gain energy at a bounce (a ✗ whatever the tolerance), and
    at each profile's step (a game's 60 Hz, a robot's 1 kHz) the modes within every tolerance of
    that profile. On the first ball scene, the advice across scenes at each: the cheapest mode
    that bounces, slides and rests within the profile's tolerances."""
    from scenarios.contact import PROFILE_DT

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
    for name, dt in PROFILE_DT.items():
        at = {m: _at(c.figures.runs, dt) for m, c in cells.items()}
        judged = {m: _passes(r, name) for m, r in at.items() if r is not None}
        if not judged:
            continue
        ok = sorted(m for m, passes in judged.items() if passes and all(passes.values()))
        out.append(
            Finding(
                f"`{scene}` at {_hz(dt)}, {name} profile: "
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
        out += [_advice(piv, name, dt) for name, dt in PROFILE_DT.items()]
    return [f for f in out if f is not None]


def _hz(dt: float) -> str:
    return f"{1 / dt:.0f} Hz"


def _passes(run: dict, profile: str) -> dict | None:
    """A stored run's ✓/✗ under ``profile``: its own where it was judged under each profile, else
    (a run stored before profiles) its ``passes`` where those were judged by that profile's
    tolerances, else None (not judged by it)."""
    by = run.get("by_profile") or {}
    if profile in by:
        return by[profile]
    if (run.get("tolerances") or {}).get("name", "robotics") == profile:
        return run.get("passes")
    return None


def _at(runs, dt):
    return next((r for r in runs if abs(r["dt"] - dt) <= 1e-9 * dt), None)


def _first_ball(piv) -> str | None:
    balls = sorted({s for (s, _), ms in piv.items() if "contact" in ms and ms["contact"].figures.scene == "ball"})
    return balls[0] if balls else None


def _omega(settings: dict) -> str:
    """The contact's natural frequency a mode's settings state (its stiffness as a rate), if any."""
    for k, v in (settings or {}).items():
        if "omega_c" in k and isinstance(v, int | float):
            return f", ω_c {v:g} rad/s"
    return ""


def _advice(piv, profile: str, dt: float) -> Finding | None:
    """A frame of ``dt``: the modes within every tolerance of ``profile`` on a ball, the slide and the
    stack at their fewest substeps a frame among the ladder's steps that divide it, cheapest first
    (the sum of the engine loop's CPU per simulated second over the three), each with its contact's
    ω_c where it states one; the others named with the figures that fail at the most substeps run."""
    from scenarios.contact import PROFILES

    from .study import ADVICE_SCENES, SUBSTEPS, frame_pick

    by_n: dict[int, dict[str, dict[str, dict]]] = {}
    settings: dict[str, dict] = {}
    for (s, m), ms in piv.items():
        c = ms.get("contact")
        if c is None or c.status != "ok" or c.figures.scene not in ADVICE_SCENES:
            continue
        for n in SUBSTEPS:  # the ladder's steps that divide the frame: n substeps a frame
            r = _at(c.figures.runs, dt / n)
            if r is not None:
                passes = _passes(r, profile)
                if passes is None:
                    continue
                by_n.setdefault(n, {}).setdefault(m, {})[s] = {**r, "passes": passes}
                settings.setdefault(m, r.get("settings") or {})
    by_mode = by_n.get(1, {})
    if not by_mode:
        return None
    kinds_needed = sorted(
        {s for (s, _), ms in piv.items() if "contact" in ms and ms["contact"].figures.scene in ADVICE_SCENES}
    )
    picked, failing = frame_pick(by_n, kinds_needed)
    fine = [(c, m) for c, m, _ in picked]
    substeps = {m: n for _, m, n in picked}
    source = PROFILES[profile].source
    scenes = ", ".join(kinds_needed)
    why_not = "; ".join(
        f"`{m}`{_omega(settings.get(m, {}))}: "
        + ", ".join(f"{s} ({', '.join(figs)})" for s, figs in sorted(bad.items()))
        for m, bad in sorted(failing.items())
    )
    ran = f"of the {len(by_mode)} engine modes this suite ran at {_hz(dt)}"
    if not fine:
        return Finding(
            f"{MARK} Advice at {_hz(dt)}, {profile} profile ({source}): no engine mode {ran} bounces, slides and "
            f"rests within every tolerance ({scenes}). What fails: {why_not}.",
            False,
        )
    best = ", ".join(
        f"`{m}` at {substeps[m]} substep{'s' if substeps[m] > 1 else ''} a frame ({c:.3g} CPU s per simulated s "
        f"over the {len(kinds_needed)} scenes{_omega(settings.get(m, {}))})"
        for c, m in sorted(fine)
    )
    rest = f" Not within: {why_not}." if why_not else ""
    return Finding(
        f"{MARK} Advice at {_hz(dt)}, {profile} profile ({source}), {ran}: within every tolerance on {scenes}, "
        f"cheapest first: {best}.{rest}",
        True,
    )
