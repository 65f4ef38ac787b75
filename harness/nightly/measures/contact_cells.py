"""The nightly's contact cells (issue: the bounce, the slide and the stack in every engine).

* ``contact``: one engine mode on one contact scene (``scenarios.contact``) at every step of the
  suite's ladder, measured against the scene's truth by the scene's own judge (``harness.contact``);
  the value is the largest step at which every figure holds (and at every shorter step). The cell
  carries what the scene declares of its figures (``ContactCellFigures.declared``), which the
  report and the charts read: a new contact scene needs no table here or there.
* ``penalty``: one reference scheme on the penalty ball (``scenarios.penalty_ball``) over the grid of
  h*omega_c at e = 1 and 0.8; the value is the largest h*omega_c up to which a perfectly elastic
  bounce stays within the tolerance.

A suite asks for them in ``Suite.contact``: ``scenes`` ((contact scene, params), ...), ``modes``
(None: every available mode that poses a scene), ``ladder`` (the steps), ``penalty`` (the
schemes) and ``grid``. Their tasks (``harness.nightly.run.contact_tasks``) are cell tasks that name
their one measure (``Task.only``) and carry their scene's id and parameters; each measure runs
where its task names it, as every measure runs: from the registry.
"""

from __future__ import annotations

from records.contact import ContactCellFigures, PenaltyFigures
from records.findings import Finding
from records.measures import Measure, Worse

from harness.nightly.cell_kit import make_cell, plain

#: The penalty grid of the standard suite: the issue's log grid.
PENALTY_RESTITUTIONS = (1.0, 0.8)


def cell_scene(scene_id: str, params: dict) -> str:
    """A cell's scene name: the contact scene, with each parameter that differs from its default
    (``ball`` at e = 1 -> ``ball_e1``). A name only: the task carries the id and parameters."""
    from scenarios.contact import make_contact_scene

    defaults = type(make_contact_scene(scene_id)).params
    return scene_id + "".join(f"_{k}{_value(v)}" for k, v in sorted(params.items()) if v != defaults[k].default)


def _value(v) -> str:
    """A parameter's value in a name: as ``g`` prints it where that is the value, else every digit
    (two values a ``g`` format rounds alike name two cells)."""
    short = f"{v:g}"
    return short if float(short) == v else repr(float(v))


def _named(name: str):
    """A measure that runs where its task names it (``Task.only``): a suite's contact table."""
    return lambda ctx: name in getattr(ctx.task, "only", ())


def contact_run(ctx) -> list:
    """The ``contact`` cell of an engine mode on a contact scene (``ctx.scene``, built from the
    task's scene id and parameters)."""
    from harness.contact.run import LADDER, contact_modes
    from harness.contact.study import largest, measure_mode

    from scenarios.contact import profile

    task, scene = ctx.task, ctx.scene
    settings = ctx.suite.contact
    ladder = tuple(settings.get("ladder", LADDER))
    tol = profile(settings.get("profile", "robotics"))
    mode = contact_modes()[task.method]
    runs = measure_mode(
        task.method, scene.id, task.params, ladder, isolated=False, timeout=ctx.suite.cell_timeout, tol=tol
    )
    best = largest(runs)
    ok = [f for f in runs if f.passes]
    status = "ok" if ok else "crashed"
    detail = "" if ok else "; ".join(sorted({f"{f.status}: {f.detail}" for f in runs}))[:500]
    version = next((f.engine_version for f in runs if f.engine_version), None)
    figures = ContactCellFigures(
        scene=scene.id,
        scene_params=dict(task.params),
        runs=[plain(f.to_data()) for f in runs],
        largest=best,
        settings=plain(dict(mode.settings)),
        doc=mode.doc or None,
        engine_version=version,
        declared=plain(scene.declared()),
        truth_text=scene.truth_text(),
        tolerance_text=f"{tol.name} profile ({tol.source}): " + scene.tolerance_text(scene.tolerances(tol)),
        profile=tol.name,
    )
    return [make_cell(task, "contact", status, best.get("all"), None, detail=detail, figures=figures)]


def penalty_run(ctx) -> list:
    """The ``penalty`` cell of a reference scheme on the penalty ground: a row per (e, h*omega_c)
    (``harness.contact.penalty.row``: one impact's restitution over the phases, the bounces of a
    drop to rest); the value is the largest h*omega_c of the grid up to which a perfectly elastic
    impact stays within the tolerance at every phase."""
    from harness.contact.penalty import GAIN, GRID, OMEGA_C, TOLERANCE, row

    task = ctx.task
    settings = ctx.suite.contact
    grid = tuple(settings.get("grid", GRID))
    omega_c = settings.get("omega_c", OMEGA_C)
    rows = [row(task.method, e, hw, omega_c) for e in PENALTY_RESTITUTIONS for hw in grid]
    figures = PenaltyFigures(rows=plain(rows), grid=list(grid), omega_c=omega_c, tolerance=TOLERANCE, gain=GAIN)
    return [make_cell(task, "penalty", "ok", _penalty_value(rows), None, figures=figures)]


def _penalty_value(rows) -> float | None:
    """The largest h*omega_c up to which every elastic row of the grid is within the tolerance."""
    best = None
    for r in sorted((r for r in rows if r["e"] == 1.0), key=lambda r: r["homega"]):
        if r.get("verdict") != "within":
            break
        best = r["homega"]
    return best


def _contact_worse(before, after, comparison) -> Worse | None:
    """A figure that held at a step now fails there (an energy gained at a bounce among them), or
    the largest step at which everything holds got shorter."""
    was = {round(r["dt"], 12): r for r in before.figures.runs}
    for r in after.figures.runs:
        old = was.get(round(r["dt"], 12))
        if old is None:
            continue
        lost = sorted(k for k, v in (old.get("passes") or {}).items() if v and not (r.get("passes") or {}).get(k))
        if lost:
            return Worse(
                "contact", before.value, after.value, f"at dt = {r['dt']:.4g} s {', '.join(lost)} held and now fails"
            )
    if before.value is not None and (after.value is None or after.value < before.value * (1 - 1e-9)):
        return Worse(
            "contact",
            before.value,
            after.value,
            f"largest step within every tolerance {before.value:.4g} s -> "
            f"{'none' if after.value is None else f'{after.value:.4g} s'}",
        )
    return None


def _penalty_worse(before, after, comparison) -> Worse | None:
    """The largest h*omega_c with an elastic impact within the tolerance got smaller, or a solve
    that held now fails. A cell stored before the per-impact table (its rows have no
    ``impact_mean``) measured five bounces, another figure: it is not compared."""
    rows_before = getattr(before.figures, "rows", None) or []
    rows_after = getattr(after.figures, "rows", None) or []
    if not all("impact_mean" in r for r in rows_before + rows_after):
        return None
    if before.value is not None and (after.value is None or after.value < before.value):
        return Worse(
            "penalty",
            before.value,
            after.value,
            f"an elastic impact stays within the tolerance up to h*omega_c {before.value:g} -> "
            f"{'none' if after.value is None else f'{after.value:g}'}",
        )
    was = {(r["e"], r["homega"]): r for r in rows_before}
    for r in rows_after:
        old = was.get((r["e"], r["homega"]))
        if old is not None and old.get("verdict") != "unsolved" and r.get("verdict") == "unsolved":
            return Worse(
                "penalty",
                before.value,
                after.value,
                f"at e = {r['e']:g}, h*omega_c = {r['homega']:g} the implicit solve failed at {r['unsolved']} steps",
            )
    return None


def _contact_findings(scene, piv) -> list:
    from harness.contact.findings import contact_findings

    return contact_findings(scene, piv)


def _contact_section(scene, piv):
    from reports.contact_section import contact_lines

    return contact_lines(scene, piv)


def _contact_chart(cells, scene, path):
    from reports.contact_section import contact_chart

    return contact_chart(cells, scene, path)


def _penalty_section(scene, piv):
    from reports.penalty_section import penalty_lines

    return penalty_lines(scene, piv)


def _penalty_findings(scene, piv) -> list[Finding]:
    from harness.contact.penalty_findings import penalty_findings

    return penalty_findings(scene, piv)


def _penalty_chart(cells, scene, path):
    from reports.penalty_section import penalty_chart

    return penalty_chart(cells, scene, path)


MEASURES = [
    Measure(
        "contact",
        ContactCellFigures,
        "an engine mode on a contact scene at every step of a ladder, against "
        "the analytic truth: the figures the scene declares (restitution per bounce, stop distance, penetration, "
        "drift, kinetic energy, ...), cost per simulated second, and the largest step within every tolerance",
        run=contact_run,
        applies=_named("contact"),
        regression=_contact_worse,
        findings=_contact_findings,
        section=_contact_section,
        chart=_contact_chart,
        higher_is_worse=False,
    ),
    Measure(
        "penalty",
        PenaltyFigures,
        "a reference scheme on a penalty ground: one impact's restitution against h*omega_c beside the "
        "closed form and the exact one, and the bounces a drop makes before it rests",
        run=penalty_run,
        applies=_named("penalty"),
        regression=_penalty_worse,
        findings=_penalty_findings,
        section=_penalty_section,
        chart=_penalty_chart,
        higher_is_worse=False,
    ),
]
