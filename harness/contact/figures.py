"""A contact run measured against its scene's analytic truth: the scene's own judge
(``scenarios.contact``: each scene's ``measure`` gives the figures it declares in ``FIGURES`` and
their ✓/✗), with what every run states beside them (the step, the status, the truth, the
tolerances, the engine's settings and the engine loop's cost per simulated second)."""

from __future__ import annotations

from records.contact import ContactFigures, ContactTrajectory
from records.trajectory import OK

# apexes, STOPPED: the judges' own (scenarios.contact), read here by those who read them here before.
from scenarios.contact import PROFILES, STOPPED, TOLERANCES, ContactScene, Tolerances, apexes  # noqa: F401


def contact_figures(scene: ContactScene, run: ContactTrajectory, tol: Tolerances = TOLERANCES) -> ContactFigures:
    """The run's figures against the scene's truth (all None but the settings where it failed),
    judged under the profile ``tol`` and, beside it, under every profile of ``PROFILES``."""
    common = dict(
        scene=scene.id,
        params=dict(scene.values),
        dt=run.dt,
        status=run.status,
        truth=scene.truth(),
        tolerances=scene.tolerances(tol),
        settings=dict(run.settings),
        loop=run.loop or None,
        engine_version=run.engine_version,
        profile=tol.name,
    )
    if run.status != OK:
        return ContactFigures(**common, detail=run.detail)
    got = dict(scene.measure(run, tol))
    passes, detail = got.pop("passes", {}), got.pop("detail", None)
    named = [f.truth for f in scene.FIGURES if f.truth] + [f.chart_truth[0] for f in scene.FIGURES if f.chart_truth]
    no_truth = sorted({key for key in named if key not in common["truth"]})
    if no_truth:  # a declaration the tables would print beside a truth that is not there
        raise ValueError(
            f"contact scene {scene.id}: FIGURES compares with truth {no_truth}, which truth() does not give"
        )
    values = {f.name: got.get(f.name) for f in scene.FIGURES}
    values.update({k: v for k, v in got.items() if k not in values})
    steps = run.steps_recorded
    cpu = run.loop_cpu_s / (steps * run.dt) if run.loop_cpu_s is not None and steps else None
    by_profile = {name: dict(scene.measure(run, other).get("passes", {})) for name, other in PROFILES.items()}
    by_profile[tol.name] = passes
    return ContactFigures(**common, values=values, passes=passes, detail=detail, cpu_per_s=cpu, by_profile=by_profile)


def within(figures: ContactFigures) -> bool | None:
    """Every judged figure ✓ (None where the run failed: nothing was judged)."""
    if not figures.passes:
        return None
    return all(figures.passes.values())
