"""The nightly report: a run's cells and what judging them found (``harness.judge``: a
``records.findings.Judgement``) -> ``report.md`` and PNG charts. It never simulates and judges
nothing: it prints records.

Written atomically: charts carry the run id in their names (new files, the previous report's
charts untouched), the markdown goes to a temporary file that ``os.replace`` moves over
``report.md`` in one step, and only then are charts no longer referenced removed. A run
killed half-way leaves the previous report whole.

The charts are listed (``report_charts``) and drawn, by ``jobs`` worker processes
(``reports.drawing``), before any markdown is written; the markdown links the charts drawn, so
it is the same however many processes drew them.
"""

from __future__ import annotations

import os
from pathlib import Path

from records.cell import Cell, Claims, pivot
from records.findings import MARK, ClaimChecks, Finding, Judgement, Verdict
from records.measures import columns, measures
from records.run import RunRecord, RunTiming

from . import charts
from .drawing import Chart, draw_charts
from .damping_section import damping_stability_section
from .history_section import history_charts, history_section
from .advice_section import frame_rates, advice_section
from .answer_section import answer_section
from .position_based_section import position_based_section
from .run_section import appendix, footer
from .text import Footnotes, fmt as _fmt, limit_text, of_measure as _of

CHECK, CROSS = "✓", "✗"


def homega_text(cell: Cell | None) -> str:
    if cell is None:
        return "–"
    if cell.status != "ok":
        return cell.status
    f = cell.figures
    if f.unstable_everywhere:
        return "none (ρ > 1 for every h)"
    if f.unresolved:
        return "no stable step resolved"
    if f.unbounded:
        searched = f.homega_searched if f.homega_searched is not None else float("nan")
        return f"unbounded (searched to {searched:.3g})" + _over(f)
    return limit_text(cell.value, none="–") + _over(f)


def _over(f) -> str:
    """The horizon a finite-horizon limit holds over (a longer run finds a smaller limit)."""
    steps = getattr(f, "horizon_steps", None)
    return f" over {steps} steps" if f.criterion == "finite_horizon" and steps else ""


def claim_homega_text(c) -> str:
    if c == "?":  # no claims known: every cell of the scheme failed before measuring
        return c
    return limit_text(None if c is None else float(c))


def mark(ok) -> str:
    return "" if ok is None else (CHECK if ok else CROSS)


# ----------------------------------------------------------------------------- sections
def verdict(v: Verdict) -> list[str]:
    lines = ["## Verdict", ""]
    against = f"run {v.previous}" if v.previous is not None else "no earlier run (bounds checked only)"
    if v.judged_runs is not None:
        against += f" (cost judged over the last {v.judged_runs} runs: see [History](#history))"
    if not v.regressions:
        lines.append(f"**No regressions** against {against}.")
    else:
        lines.append(f"**{len(v.regressions)} regression(s)** against {against}:")
        lines.append("")
        lines += [f"- {r}" for r in v.regressions]
    if v.not_measured:
        lines += [
            "",
            f"{len(v.not_measured)} cell(s) not measured this run: they timed out (a limit of CPU seconds, the "
            "task tried once more), which says they took too long here, not that they got worse; not regressions: "
            + "; ".join(v.not_measured)
            + ".",
        ]
    if v.changed:
        lines += [
            "",
            f"{len(v.changed)} accuracy figure(s) changed in this run (deterministic: reported at once): "
            + ", ".join(
                f"{c.measure} of `{c.method}` on `{c.scene}` {c.before:.4g} -> {c.after:.4g}" for c in v.changed
            )
            + "; see [History](#history).",
        ]
    if v.failed:
        lines += [
            "",
            f"{len(v.failed)} method(s) could not be measured in full in this run (crashed or timed out): "
            + ", ".join(f"`{m}` on `{sc}`" for sc, m in v.failed)
            + "; see [Failures](#failures).",
        ]
    return lines + [""]


def _failed(cells: list[Cell]) -> list[tuple[tuple[str, str], list[Cell]]]:
    """((scene, method), its crashed / timed-out cells), for every method with any."""
    out: dict = {}
    for c in cells:
        if c.status in ("crashed", "timed_out"):
            out.setdefault((c.scene, c.method), []).append(c)
    return sorted(out.items(), key=lambda kv: kv[0])


def failures(cells: list[Cell]) -> list[str]:
    """Where and why: every crashed or timed-out cell, grouped by scene x method and outcome."""
    lines = ["## Failures", ""]
    groups = _failed(cells)
    if not groups:
        return lines + ["No cell crashed or timed out.", ""]
    lines += [
        "A crash (the engine aborted or raised) or a hang (the worker was killed at the task's time "
        "limit) is recorded and the run goes on; the cells measured before it are kept.",
        "",
        "| method | scene | outcome | measures | why |",
        "|---|---|---|---|---|",
    ]
    for (scene, method), grp in groups:
        by: dict = {}
        for c in grp:
            by.setdefault((c.status, c.detail), []).append(c.measure)
        for (status, detail), names in sorted(by.items(), key=lambda kv: kv[0][1].startswith("not reached")):
            why = " ".join(str(detail).split()).replace("|", "\\|") or "–"
            lines.append(f"| `{method}` | {scene} | **{status}** | {', '.join(names)} | {why} |")
    return lines + [""]


def tradeoff_table(piv: dict, judged: dict, scene: str = "spring") -> list[str]:
    lines = [
        f"## The trade-off, measured (reference schemes on `{scene}`)",
        "",
        "Each cell: measured value, the textbook's claim in brackets, and whether they agree. "
        "Cost: counted force evaluations per step, and CPU time per step as a ratio to explicit Euler's, "
        "timed beside it in the same worker.",
        "",
        "| scheme | evals/step | time ratio | observed order | energy | largest stable h·ω |",
        "|---|---|---|---|---|---|",
    ]
    rows = [(m, ms) for (s, m), ms in piv.items() if s == scene and m.startswith("ref:")]
    if not rows:
        return lines + ["", f"_no reference cells on {scene} in this run_", ""]
    for method, ms in sorted(rows):
        ok = judged.get((scene, method), ClaimChecks())
        claims = ok.claims
        cost, order, energy, stab = (ms.get(m) for m in ("cost", "order", "energy", "stability"))
        if cost is not None and cost.status == "ok":
            evals_txt = (
                f"{_fmt(cost.figures.force_evals_per_step, '.3g')} [{_claim(claims, 'force_evals_text')}] "
                f"{mark(ok.evals)}"
            )
            ratio_txt = _fmt(cost.figures.ratio_to_explicit_euler, ".2f")
        else:
            evals_txt = ratio_txt = cost.status if cost is not None else "–"
        if order is not None and order.status == "ok" and order.value is None:
            order_txt = f"no order (errors at the floor) [{_claim(claims, 'order')}]"
        elif order is not None and order.status == "ok":
            order_txt = f"{order.value:.2f} [{_claim(claims, 'order')}] {mark(ok.order)}"
        else:
            order_txt = order.status if order is not None else "–"
        if energy is not None:
            cls = energy.figures.energy_class or energy.status
            energy_txt = f"{cls} [{_claim(claims, 'energy')}] {mark(ok.energy)}"
        else:
            energy_txt = "–"
        stab_txt = f"{homega_text(stab)} [{claim_homega_text(_claim(claims, 'homega_max'))}] {mark(ok.homega)}"
        lines.append(f"| `{method}` | {evals_txt} | {ratio_txt} | {order_txt} | {energy_txt} | {stab_txt} |")
    return lines + [""]


def _claim(claims: Claims, name: str):
    """One claim as the table prints it: "?" where no claims are known."""
    return getattr(claims, name) if claims.known else "?"


def identity_table(piv: dict) -> list[str]:
    lines = [
        "## Which scheme each engine mode is",
        "",
        "Each engine mode stepped beside every reference scheme on the same scene; the match is the scheme "
        "with the smallest max |difference| in the state.",
        "",
        "| engine mode | scene | matches | max deviation | runner-up (deviation) |",
        "|---|---|---|---|---|",
    ]
    n = 0
    for (scene, method), ms in sorted(piv.items()):
        row = ms.get("identity")
        if row is None:
            continue
        n += 1
        if row.status != "ok":
            lines.append(f"| `{method}` | {scene} | {row.status}: {row.detail} | | |")
            continue
        f = row.figures
        runner = f"`{f.runner_up}` ({_fmt(f.runner_up_deviation, '.2e')})" if f.runner_up else "–"
        matches = f.all_matches
        said = " = ".join(f"`{m}`" for m in matches) if matches else f"none (closest `{f.closest}`)"
        dev = _fmt(row.value, ".2e") + (
            ""
            if f.precision != "float32"
            else " (float32: matched at float32 rounding)"
            if matches
            else " (float32: no scheme within float32 rounding)"
        )
        lines.append(f"| `{method}` | {scene} | {said} | {dev} | {runner} |")
    if not n:
        lines.append("| _no engine modes in this run_ | | | | |")
    return lines + [""]


def energy_text(energy) -> str:
    if energy is None:
        return "–"
    if energy.status != "ok":
        return energy.status
    if energy.figures.rel_error_defined is False:
        return "undefined (exact E crosses 0)"
    return _fmt(energy.value, ".2e")


def error_text(error) -> str:
    if error is None:
        return "–"
    if error.status != "ok":
        return error.status
    if error.figures.below_reference:
        return f"< {_fmt(error.figures.reference_error, '.1e')} (below the reference's accuracy)"
    return _fmt(error.value, ".2e")


def _micro(seconds):
    return None if seconds is None else seconds * 1e6


#: What the cost columns of a scene's table are (said once above the scenes' tables).
COST_COLUMNS = (
    "CPU µs/step: a reference scheme's compiled loop, an engine mode's own loop (`engine s/step`: "
    "`mujoco.rollout`, REBOUND's `sim.steps(n)`, a Python loop calling only the step function for "
    "pybullet and pymunk); the time ratio to explicit Euler and the work-precision charts use it. "
    "As stepped µs/step: the same engine mode stepped one call at a time by the harness, its state "
    "read and checked and its forces applied from Python after every step."
)


def evals_text(cost, mark) -> str:
    if cost is None or cost.status != "ok":
        return "–"
    f = cost.figures
    return _fmt(
        f.force_evals_per_step,
        ".3g",
        mark(f.force_evals_reason and f"`{cost.method}` counts no force evaluations: {f.force_evals_reason}"),
    )


def cpu_text(cost, mark) -> str:
    if cost is None:
        return "–"
    return _fmt(cost.value * 1e6, ".3g") if cost.status == "ok" else cost.status


def as_stepped_text(cost, mark) -> str:
    return _fmt(_micro(cost.figures.as_stepped_s_per_step), ".3g") if cost is not None and cost.status == "ok" else "–"


def ratio_text(cost, mark) -> str:
    return _fmt(cost.figures.ratio_to_explicit_euler, ".2f") if cost is not None and cost.status == "ok" else "–"


def scene_section(scene: str, piv: dict, chart_names: dict) -> list[str]:
    """A scene's table (a row per method: its status, then every registered measure's columns,
    ``records.measures``), the lines each measure prints under it, and its charts."""
    notes_of_model = sorted(
        {c.model_note for (s, _), ms in piv.items() if s == scene for c in ms.values() if c.model_note}
    )
    cols = columns()
    lines = [f"### `{scene}`", "", *(f"**{note}.**" for note in notes_of_model), *([""] if notes_of_model else [])]
    # A measure without columns whose section is its table gives a method no row of its own: a suite's
    # own tables (contact, penalty) show their sections alone; a scene task's (sweep) sit beside its energy row.
    tabled = {m.name for m in measures() if m.columns or m.made_by or (m.run is not None and m.section is None)}
    rows = [(method, ms) for (s, method), ms in sorted(piv.items()) if s == scene and set(ms) & tabled]
    if rows:  # a scene whose cells are all of measures with no columns (contact) shows their sections alone
        lines += ["| method | status | " + " | ".join(c.header for c in cols) + " |", "|---|---|" + "---|" * len(cols)]
    notes = Footnotes()
    for method, ms in rows:
        energy = ms.get("energy")
        statuses = sorted({r.status for r in ms.values() if r.status != "ok"})
        status = ", ".join(statuses) if statuses else "ok"
        if energy is not None and energy.status == "unstable" and energy.figures.failed_step:
            status += f" (energy run: step {energy.figures.failed_step})"
        cells = [f"`{method}`", status, *(c.text(ms, notes.mark) for c in cols)]
        lines.append("| " + " | ".join(cells) + " |")
    if rows:
        lines.append("")
    lines += notes.lines()
    for m in measures():
        if m.section is not None:
            lines += m.section(scene, piv)
    for kind, title in (
        ("energy", "Energy against time"),
        ("workprecision", "Work-precision: error against cost"),
        ("stability", "Largest stable h·ω"),
    ):
        name = chart_names.get((scene, kind))
        if name:
            lines += [f"![{title} on {scene}]({name})", ""]
    for m in measures():
        name = chart_names.get((scene, f"measure:{m.name}"))
        if name:
            lines += [f"![{m.name} on {scene}]({name})", ""]
    return lines


def brouwer_lines(scene: str, piv: dict) -> list[str]:
    """Brouwer's law on the scene, where measured (``brouwer`` cells): each method's energy-error
    growth over its ensemble, slope and 95% interval, and its position error's where there is one."""
    rows = [(m, ms["brouwer"]) for (s, m), ms in sorted(piv.items()) if s == scene and "brouwer" in ms]
    if not rows:
        return []
    parts = []
    for method, c in rows:
        f = c.figures
        if c.status != "ok" or c.value is None or not f.ci95:
            parts.append(f"`{method}`: {c.status}{': ' + (f.reason or c.detail) if (f.reason or c.detail) else ''}")
            continue
        text = (
            f"`{method}`: RMS |ΔE/E| over {f.realizations} realizations scales as t^{c.value:.2f} "
            f"(95% interval {f.ci95[0]:.2f}–{f.ci95[1]:.2f}) over {f.periods:.3g} periods"
        )
        if f.error_slope is not None and f.error_ci95:
            text += (
                f"; its position error as t^{f.error_slope:.2f} ({f.error_ci95[0]:.2f}–{f.error_ci95[1]:.2f}, "
                f"fitted to t = {f.error_fit_until:.3g}, below 0.1)"
            )
        parts.append(text)
    return [
        "Brouwer's law (roundoff walks the energy error as t^0.5, the phase error as t^1.5; the initial "
        "state perturbed at 1e-15 per realization, the slope of the ensemble's RMS with a bootstrap "
        "interval): " + "; ".join(parts) + ".",
        "",
    ]


def cross_engine_lines(c) -> list[str]:
    """A ``cross_engine`` cell in words: its verdict with the figures behind it, then one line per
    quantity that differs in the models the engines built, then how an engine came by a quantity
    the harness supplies."""
    f = c.figures
    a, b = f.methods or ("?", "?")
    if c.status != "ok":
        return [f"{a} and {b} on {c.scene}: not compared ({c.status}: {c.detail})"]
    if f.verdict is None:  # a cell stored before the verdict was recorded
        return [f"{a} and {b} on {c.scene}: {c.detail}"]
    head = c.detail
    differences, notes = list(f.differences or []), list(f.notes or [])
    if differences:
        head += ". What each engine built differs:"
    return [head] + differences + notes


def class_text(energy) -> str:
    """The energy class, with what the bodies did where a class alone misleads (an orbit that
    spirals in and is thrown out "grows"): the run's events (``Scene.events``)."""
    if energy is None:
        return "–"
    cls = energy.figures.energy_class or "–"
    events = energy.figures.events or []
    return cls + (f" ({'; '.join(ev['text'] for ev in events)})" if events else "")


def order_text(order) -> str:
    """The measured order; where the scheme declares a lower order for this scene's
    velocity-dependent force, that declaration beside it, so a first-order result reads as
    the scheme's and not as a failure."""
    if order is None:
        return "–"
    if order.status != "ok":
        return order.status
    note = order.claims.order_note if order.claims is not None else None
    return _fmt(order.value, ".2f") + (f" [{note}]" if note else "")


def finding_line(f: Finding) -> str:
    """A finding as its line: its verdict mark where its text carries one."""
    return f.text.replace(MARK, CHECK if f.ok else CROSS)


def findings(found, chart_names: dict | None = None) -> list[str]:
    """What judging the run found (``Judgement.findings``), one line each; then the evidence of
    a blow-up at the nominal timestep (energy over the stability measure's horizon), per scene."""
    lines = ["## Findings", ""]
    lines += [f"- {finding_line(f)}" for f in found] or ["- nothing unexpected in this run"]
    lines.append("")
    nominal = sorted(
        (key[0], name) for key, name in (chart_names or {}).items() if isinstance(key, tuple) and key[1] == "nominal"
    )
    for scene, name in nominal:
        lines += [f"![Energy at the nominal timestep over the stability horizon on {scene}]({name})", ""]
    return lines


def bounds_section(cells: list[Cell], judged: dict) -> list[str]:
    b = _of(cells, "bound")
    if not b:
        return []
    lines = [
        "## Energy bounds (reviewed file)",
        "",
        "| method | scene | dt | steps | max \\|ΔE/E\\| | bound | |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in sorted(b, key=lambda c: (c.scene, c.method, c.dt)):
        bound = r.figures.bound
        ok = judged.get((r.scene, r.method, r.dt))
        val = _fmt(r.value, ".2e") if r.status == "ok" else r.status
        lines.append(
            f"| `{r.method}` | {r.scene} | {r.dt:g} | {int(r.steps)} | {val} | {_fmt(bound, '.2g')} | {mark(ok)} |"
        )
    return lines + [""]


def report_charts(run_id: int, cells: list[Cell], trend=None) -> tuple[list[Chart], dict]:
    """(every chart the report can show, to be drawn: ``reports.drawing``; {(scene, kind): chart
    name} of the per-scene ones, for the sections that show them)."""
    scenes = list(dict.fromkeys(c.scene for c in cells if c.measure != "bound"))
    styles = {"styles": charts.method_styles(c.method for c in cells)}  # one colour and marker a method
    todo, names = [], {}
    for scene in scenes:
        of_scene = [c for c in cells if c.scene == scene]
        for kind, fn in (
            ("energy", charts.energy_chart),
            ("workprecision", charts.workprecision_chart),
            ("stability", charts.stability_chart),
        ):
            names[(scene, kind)] = name = f"charts/run{run_id}-{scene}-{kind}.png"
            todo.append(Chart(name, fn, (of_scene, scene), styles))
        names[(scene, "nominal")] = name = f"charts/run{run_id}-{scene}-nominal.png"
        todo.append(Chart(name, charts.nominal_chart, (of_scene, scene), styles))
        for hz in frame_rates(cells):
            names[(scene, f"advise{hz:g}")] = name = f"charts/run{run_id}-{scene}-advise{hz:g}hz.png"
            todo.append(Chart(name, charts.advice_chart, (of_scene, scene, hz), styles))
        for m in measures():  # a registered measure's own chart, where its cells are on the scene
            if m.chart is not None and any(c.measure == m.name for c in of_scene):
                names[(scene, f"measure:{m.name}")] = name = f"charts/run{run_id}-{scene}-{m.name}.png"
                todo.append(Chart(name, m.chart, (of_scene, scene)))
    names["damping"] = name = f"charts/run{run_id}-damping-stability.png"
    todo.append(Chart(name, charts.damping_stability_chart, (cells,), styles))
    return todo + history_charts(trend, run_id), names


def render(
    run, cells: list[Cell], judged: Judgement, out_dir: Path, timing=None, trend=None, jobs: int = 1, extra=()
) -> tuple[str, list[str]]:
    """(the report's markdown, the chart files written, relative to ``out_dir``) of ``run`` (its
    stored metadata, a ``RunRecord`` or the history's row), its ``cells``, what judging them
    found, ``timing`` (where the run's time went, a ``RunTiming`` or the nightly's dict) and
    ``trend`` (the suite's judged history, ``harness.history.series.Trend``: the History section).
    ``jobs``: processes drawing the charts (``reports.drawing``; 1: this one)."""
    run, timing = RunRecord.of(run), RunTiming.of(timing)
    run_id = run.run_id
    piv = pivot(cells)
    scenes = list(dict.fromkeys(c.scene for c in cells if c.measure != "bound"))
    (out_dir / "charts").mkdir(parents=True, exist_ok=True)
    todo, names = report_charts(run_id, cells, trend)
    written = draw_charts(todo, out_dir, jobs)
    drawn = set(written)
    chart_names = {key: name for key, name in names.items() if name in drawn}
    lines = [f"# Integrator comparison: run {run_id} ({run.suite})", ""]
    lines += answer_section(cells)
    lines += verdict(judged.verdict)
    lines += list(extra)  # sections the caller adds after the verdict (an engine version change)
    lines += history_section(trend, run_id, drawn)
    lines += tradeoff_table(piv, judged.claims)
    lines += position_based_section(piv, chart_names)
    lines += identity_table(piv)
    lines += damping_stability_section(cells, chart_names.get("damping"))
    lines += ["## Per scene", "", COST_COLUMNS, ""]
    for scene in scenes:
        lines += scene_section(scene, piv, chart_names)
    for hz in frame_rates(cells):
        lines += advice_section(cells, hz, chart_names)
    lines += findings(judged.findings, chart_names)
    lines += failures(cells)
    lines += bounds_section(cells, judged.bounds)
    lines += appendix(run, cells)
    lines += footer(run, timing)
    return "\n".join(lines), written


def write_report(
    run: dict,
    cells: list[Cell],
    judged: Judgement,
    out_dir,
    timing=None,
    trend=None,
    jobs: int = 1,
    before_write=None,
    extra=(),
) -> Path:
    """``render`` written to ``out_dir/report.md`` (atomically, see above); ``jobs`` processes
    draw its charts; ``before_write`` is called between the two (the nightly's kill point)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    text, charts_written = render(run, cells, judged, out_dir, timing, trend, jobs, extra)
    if before_write is not None:
        before_write()
    target = out_dir / "report.md"
    tmp = out_dir / f".report.md.{os.getpid()}.tmp"
    with open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, target)  # the one step where the old report becomes the new one
    keep = {Path(c).name for c in charts_written}
    for old in (out_dir / "charts").glob("run*.png"):
        if old.name not in keep:
            old.unlink(missing_ok=True)
    return target
