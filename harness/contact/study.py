"""The engines on the contact scenes: each mode at each step of a ladder, measured against the
scene's truth, and what follows from the ladder: for each figure the largest step at which it
holds (at that step and every shorter one), and at a frame rate the cheapest mode that bounces,
slides and rests within the tolerances.

Rows travel as a tidy DataFrame, one per (scene, mode, dt).
"""

from __future__ import annotations

from dataclasses import asdict

from records.contact import ContactFigures
from scenarios.contact import TOLERANCES, Tolerances, make_contact_scene

from .figures import contact_figures, within
from .run import LADDER, REPORT_DTS, contact_modes, run_contact


def measure_mode(
    mode_id: str,
    scene_id: str,
    params: dict | None = None,
    dts=LADDER,
    isolated: bool = True,
    timeout: float | None = None,
    tol: Tolerances | None = TOLERANCES,
) -> list[ContactFigures]:
    """The mode's figures at every step of ``dts``, judged under the profile ``tol`` (None: each
    step under its own, ``scenarios.contact.profile_at``; each run validated, then stepped; a failed
    run is its figures' ``detail``)."""
    from scenarios.contact import profile_at

    from .run import TIMEOUT_S

    scene = make_contact_scene(scene_id, **(params or {}))
    return [
        contact_figures(
            scene,
            run_contact(mode_id, scene_id, params, dt, timeout=timeout or TIMEOUT_S, isolated=isolated),
            tol or profile_at(dt),
        )
        for dt in dts
    ]


def largest(runs: list[ContactFigures]) -> dict:
    """For each judged figure, and for all of them ("all"), the largest step at which it is ✓ at
    that step and at every shorter one of the runs (None where not at the shortest)."""
    ordered = sorted(runs, key=lambda f: f.dt)
    names = sorted({k for f in ordered for k in f.passes})
    out = {}
    for name in [*names, "all"]:
        best = None
        for f in ordered:
            ok = within(f) if name == "all" else f.passes.get(name)
            if not ok:
                break
            best = f.dt
        out[name] = best
    return out


def study(
    scenes: dict[str, dict],
    modes=None,
    dts=REPORT_DTS,
    isolated: bool = True,
    tol: Tolerances | None = TOLERANCES,
    progress=None,
):
    """Every available mode that poses each scene, at each step: a tidy DataFrame, one row per
    (scene, mode, dt), with every figure the scene declares, its ✓/✗ and the mode's contact
    settings, judged under the profile ``tol`` (None: each step under its own). A mode asked for by
    name (``modes``) that does not pose a scene, or is not installed, is a row of its own (status
    ``unsupported``, ``detail`` saying why), never dropped. ``progress``: told a line before each
    mode's runs on a scene (a command's progress)."""
    import pandas as pd

    rows = []
    for scene_id, params in scenes.items():
        for mode_id, mode in contact_modes().items():
            if modes is not None and mode_id not in modes:
                continue
            ok, why = mode.available()
            installed = ok
            if ok:
                ok, why = mode.supports(make_contact_scene(scene_id, **params))
            if not ok:
                # Named by the user, or a pose of the scene's kind that refuses this scene's state:
                # a row saying why. (A mode not installed, or of an engine without the kind, is
                # left out of a run that named no modes.)
                refused = installed and mode.supports(scene_id)[0]
                if modes is not None or refused:
                    rows.append(unsupported_row(scene_id, params, mode_id, why))
                continue
            if progress is not None:
                steps = ", ".join(f"1/{1 / dt:.0f}" for dt in dts)
                progress(f"contact: {scene_id}, {mode_id} at dt {steps}")
            for f in measure_mode(mode_id, scene_id, params, dts, isolated=isolated, tol=tol):
                rows.append(row_of(mode_id, f))
    df = pd.DataFrame(rows)
    # The columns in one order whatever the scenes: the run, every scene's figures, what it was judged by.
    figures = [c for c in df.columns if c not in (*HEAD, *TAIL)]
    return df[[c for c in (*HEAD, *figures, *TAIL) if c in df.columns]]


#: A row's columns before and after its scene's figures.
HEAD = ("scene", "method", "dt", "status", "within")
TAIL = ("cpu_per_s", "detail", "passes", "profile", "by_profile", "settings", "params", "truth")


def row_of(mode_id: str, f: ContactFigures) -> dict:
    """One run's row: the scene, the mode, the step, its status and verdict, then each figure its
    scene declares (``scenarios.contact.Figure``; those shown in the tables), the engine loop's
    cost, and what it was judged by."""
    scene = make_contact_scene(f.scene, **f.params)
    return {
        "scene": f.scene,
        "method": mode_id,
        "dt": f.dt,
        "status": f.status,
        "within": within(f),
        **{d.name: f.values.get(d.name) for d in scene.FIGURES if d.shown},
        "cpu_per_s": f.cpu_per_s,
        "detail": f.detail,
        "passes": f.passes,
        "profile": f.profile,
        "by_profile": f.by_profile,
        "settings": f.settings,
        "params": f.params,
        "truth": f.truth,
    }


def unsupported_row(scene_id: str, params: dict, mode_id: str, why: str) -> dict:
    """The row of a mode asked for that does not pose the scene (or is not installed): why not."""
    scene = make_contact_scene(scene_id, **params)
    return {
        "scene": scene_id,
        "method": mode_id,
        "dt": None,
        "status": "unsupported",
        "within": None,
        "cpu_per_s": None,
        "detail": why,
        "passes": {},
        "settings": {},
        "params": dict(scene.values),
        "truth": scene.truth(),
    }


#: What "bounces, slides and rests" asks of a mode: the ball at e = 0.8, the slide and the stack
#: (the box at rest is the stack's bottom box alone).
ADVICE_SCENES = ("ball", "slide", "stack")


def rank(by_mode: dict[str, dict[str, dict]], needed) -> tuple[list[tuple[float, str]], dict]:
    """The advice's rule, on each mode's run at one step per scene ({mode: {scene: run}}, a run
    with its ``passes``, ``status`` and ``cpu_per_s``): the modes that pose every scene of
    ``needed`` and are within every tolerance on each, as (the sum of their CPU per simulated
    second over those scenes, mode), cheapest first; and the others, with the scenes and figures
    that fail ({mode: {scene: [figures]}}; a failed run's status in place of its figures)."""
    fine, failing = [], {}
    for mode, runs in by_mode.items():
        if not set(needed) <= set(runs):
            continue
        bad = {
            s: (sorted(k for k, v in r["passes"].items() if not v) if r["passes"] else [r["status"]])
            for s, r in runs.items()
            if s in needed and not (r["passes"] and all(r["passes"].values()))
        }
        if bad:
            failing[mode] = bad
        else:
            fine.append((sum(runs[s]["cpu_per_s"] or 0.0 for s in needed), mode))
    return sorted(fine), failing


#: The substeps a frame's advice tries (each engine step 1/(hz n)): a game steps its physics more
#: than once a frame where one step cannot hold it (a ball falls u h into the floor before any
#: contact without continuous collision acts).
SUBSTEPS = (1, 2, 4, 8, 16)


def frame_pick(by_n: dict[int, dict[str, dict[str, dict]]], needed) -> tuple[list[tuple[float, str, int]], dict]:
    """A frame's advice over substeps ({n: {mode: {scene: run}}}, a run as ``rank`` reads it): for
    each mode the fewest substeps at which it is within every tolerance on ``needed``, as (its CPU
    per simulated second over them, mode, n), cheapest first; and the modes within at no n, with
    what fails at the most substeps tried ({mode: {scene: [figures]}})."""
    best: dict[str, tuple[float, int]] = {}
    failing: dict[str, dict] = {}
    for n in sorted(by_n):
        fine, bad = rank(by_n[n], needed)
        for cost, mode in fine:
            best.setdefault(mode, (cost, n))
        failing.update({m: b for m, b in bad.items()})
    failing = {m: b for m, b in failing.items() if m not in best}
    return sorted((c, m, n) for m, (c, n) in best.items()), failing


def advise(df, dt: float, tol: Tolerances = TOLERANCES) -> dict:
    """At one step: ``rank`` over ``ADVICE_SCENES`` (``df``: ``study``'s rows, judged under the
    profile ``tol``); a mode asked for that does not pose a scene is named in ``unposed`` with why
    ({mode: {scene: why}})."""
    unposed: dict[str, dict[str, str]] = {}
    if len(df):
        for r in df[df.status == "unsupported"].itertuples():
            unposed.setdefault(r.method, {})[r.scene] = r.detail
        df = df[df.status != "unsupported"]
    by_n = {}
    for n in SUBSTEPS:
        step = dt / n
        at = df[(df.dt - step).abs() <= 1e-12 * step] if len(df) else df
        if len(at):
            by_n[n] = {
                mode: {
                    r.scene: {"passes": r.passes, "status": r.status, "cpu_per_s": r.cpu_per_s}
                    for r in rows.itertuples()
                }
                for mode, rows in at.groupby("method")
            }
    fine, failing = frame_pick(by_n, ADVICE_SCENES)
    return {
        "dt": dt,
        "within": [m for _, m, _ in fine],
        "cost": {m: c for c, m, _ in fine},
        "substeps": {m: n for _, m, n in fine},
        "failing": failing,
        "unposed": unposed,
        "profile": tol.name,
        "tolerances": asdict(tol),
    }


def advise_frame(
    scenes: dict, hz: float, modes, tol: Tolerances, substeps=SUBSTEPS, isolated: bool = True, progress=None
):
    """``study`` at 1/(hz n) for n of ``substeps``, each mode stepped at more substeps only while it
    is not yet within every tolerance on every scene (its fewest that are is its frame), then
    ``advise`` over those rows. ``progress``: as ``study`` takes it."""
    import pandas as pd

    from .run import contact_modes

    frames = []
    pending = [m for m in (modes if modes is not None else contact_modes())]
    for n in substeps:
        if not pending:
            break
        df = study(scenes, pending, [1.0 / (hz * n)], isolated=isolated, tol=tol, progress=progress)
        frames.append(df)
        ok = df[df.status != "unsupported"]
        done = {
            m
            for m, rows in ok.groupby("method")
            if set(rows.scene) >= set(scenes) and bool((rows.within == True).all())  # noqa: E712
        }
        refused = set(df[df.status == "unsupported"].method)
        pending = [m for m in pending if m not in done and m not in refused]
    df = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    return advise(df, 1.0 / hz, tol)
