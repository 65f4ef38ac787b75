"""The nightly report: stored cells -> ``report.md`` and PNG charts. It never simulates.

Written atomically: charts carry the run id in their names (new files, the previous report's
charts untouched), the markdown goes to a temporary file that ``os.replace`` moves over
``report.md`` in one step, and only then are charts no longer referenced removed. A run
killed half-way leaves the previous report whole.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

import pandas as pd

from . import charts
from .damping_section import damping_stability_section
from .history_section import history_section
from .scene_findings import scene_findings

CHECK, CROSS = "✓", "✗"

#: A measured order within this of the declared order gets a check mark (the order tests' tolerance).
ORDER_TOL = 0.15
#: A measured stability limit within this fraction of the textbook's gets a check mark.
STABILITY_TOL = 0.005


def _fmt(x, spec=".3g", none="–"):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return none
    if isinstance(x, float) and math.isinf(x):
        return "unbounded"
    return format(x, spec)


def _pivot(cells: pd.DataFrame) -> dict:
    """{(scene, method): {measure: row}} for the scene x method cells (bounds excluded)."""
    out: dict = {}
    for _, r in cells[cells.measure != "bound"].iterrows():
        out.setdefault((r.scene, r.method), {})[r.measure] = r
    return out


def homega_text(row) -> str:
    if row is None:
        return "–"
    if row.status != "ok":
        return row.status
    d = row.data
    if d.get("unstable_everywhere"):
        return "none (ρ > 1 for every h)"
    if d.get("unbounded"):
        return f"unbounded (searched to {d.get('homega_searched', float('nan')):.3g})"
    return _fmt(row.value, ".4g")


def claim_homega_text(c) -> str:
    if c is None:
        return "none"
    if c == "?":  # no claims known: every cell of the scheme failed before measuring
        return c
    if c == math.inf or c == "inf":
        return "unbounded"
    return f"{float(c):.4g}"


def homega_ok(row, claim) -> bool | None:
    if row is None or row.status != "ok":
        return None
    d = row.data
    if claim is None:
        return bool(d.get("unstable_everywhere"))
    if claim == math.inf or claim == "inf":
        return bool(d.get("unbounded"))
    return row.value is not None and not d.get("unbounded") and abs(row.value / float(claim) - 1) <= STABILITY_TOL


def mark(ok) -> str:
    return "" if ok is None else (CHECK if ok else CROSS)


# ----------------------------------------------------------------------------- sections
def verdict(regressions, previous, cells: pd.DataFrame | None = None, trend=None) -> list[str]:
    lines = ["## Verdict", ""]
    against = f"run {previous}" if previous is not None else "no earlier run (bounds checked only)"
    if previous is not None and trend is not None and trend.judged:
        against += f" (cost judged over the last {len(trend.runs)} runs: see [History](#history))"
    if not regressions:
        lines.append(f"**No regressions** against {against}.")
    else:
        lines.append(f"**{len(regressions)} regression(s)** against {against}:")
        lines.append("")
        lines += [f"- {r.line()}" for r in regressions]
    changed = trend.latest_changes() if trend is not None else []
    if changed:
        lines += ["", f"{len(changed)} accuracy figure(s) changed in this run (deterministic: reported at once): "
                      + ", ".join(f"{c.measure} of `{c.method}` on `{c.scene}` {ch.before:.4g} -> {ch.after:.4g}"
                                  for c, ch in changed) + "; see [History](#history)."]
    failed = _failed(cells) if cells is not None else []
    if failed:
        lines += ["", f"{len(failed)} method(s) could not be measured in full in this run (crashed or timed out): "
                      + ", ".join(f"`{m}` on `{sc}`" for (sc, m), _ in failed) + "; see [Failures](#failures)."]
    return lines + [""]


def _failed(cells: pd.DataFrame) -> list[tuple[tuple[str, str], pd.DataFrame]]:
    """((scene, method), its crashed / timed-out cells), for every method with any."""
    bad = cells[cells.status.isin(["crashed", "timed_out"])]
    return [(key, grp) for key, grp in bad.groupby(["scene", "method"], sort=True)]


def failures(cells: pd.DataFrame) -> list[str]:
    """Where and why: every crashed or timed-out cell, grouped by scene x method and outcome."""
    lines = ["## Failures", ""]
    groups = _failed(cells)
    if not groups:
        return lines + ["No cell crashed or timed out.", ""]
    lines += ["A crash (the engine aborted or raised) or a hang (the worker was killed at the task's time "
              "limit) is recorded and the run goes on; the cells measured before it are kept.", "",
              "| method | scene | outcome | measures | why |", "|---|---|---|---|---|"]
    for (scene, method), grp in groups:
        subs = sorted(grp.groupby(["status", "detail"], sort=False), key=lambda kv: kv[0][1].startswith("not reached"))
        for (status, detail), sub in subs:
            why = " ".join(str(detail).split()).replace("|", "\\|") or "–"
            lines.append(f"| `{method}` | {scene} | **{status}** | {', '.join(sub.measure)} | {why} |")
    return lines + [""]


def tradeoff_table(piv: dict, scene: str = "spring") -> list[str]:
    lines = [f"## The trade-off, measured (reference schemes on `{scene}`)", "",
             "Each cell: measured value, the textbook's claim in brackets, and whether they agree. "
             "Cost: counted force evaluations per step, and CPU time per step as a ratio to explicit Euler's, "
             "timed beside it in the same worker.", "",
             "| scheme | evals/step | time ratio | observed order | energy | largest stable h·ω |",
             "|---|---|---|---|---|---|"]
    rows = [(m, ms) for (s, m), ms in piv.items() if s == scene and m.startswith("ref:")]
    if not rows:
        return lines + ["", f"_no reference cells on {scene} in this run_", ""]
    for method, ms in sorted(rows):
        claims = next((r.data.get("claims") for r in ms.values() if r.data.get("claims")), {}) or {}
        cost, order, energy, stab = ms.get("cost"), ms.get("order"), ms.get("energy"), ms.get("stability")
        if cost is not None and cost.status == "ok":
            evals = cost.data.get("force_evals_per_step")
            ev_ok = evals is not None and claims.get("force_evals") is not None and abs(evals - claims["force_evals"]) < 1e-9
            evals_txt = f"{_fmt(evals, '.3g')} [{claims.get('force_evals_text', claims.get('force_evals', '?'))}] {mark(ev_ok)}"
            ratio = cost.data.get("ratio_to_explicit_euler")
            ratio_txt = _fmt(ratio, ".2f")
        else:
            evals_txt = ratio_txt = cost.status if cost is not None else "–"
        if order is not None and order.status == "ok":
            o_ok = claims.get("order") is not None and abs(order.value - claims["order"]) <= ORDER_TOL
            order_txt = f"{order.value:.2f} [{claims.get('order', '?')}] {mark(o_ok)}"
        else:
            order_txt = order.status if order is not None else "–"
        if energy is not None:
            cls = energy.data.get("class") or energy.status
            e_ok = claims.get("energy") == cls if energy.data.get("class") else None
            energy_txt = f"{cls} [{claims.get('energy', '?')}] {mark(e_ok)}"
        else:
            energy_txt = "–"
        claim_h = claims.get("homega_max", "?")
        stab_txt = f"{homega_text(stab)} [{claim_homega_text(claim_h)}] {mark(homega_ok(stab, claim_h))}"
        lines.append(f"| `{method}` | {evals_txt} | {ratio_txt} | {order_txt} | {energy_txt} | {stab_txt} |")
    return lines + [""]


def identity_table(piv: dict) -> list[str]:
    lines = ["## Which scheme each engine mode is", "",
             "Each engine mode stepped beside every reference scheme on the same scene; the match is the scheme "
             "with the smallest max |difference| in the state.", "",
             "| engine mode | scene | matches | max deviation | runner-up (deviation) |", "|---|---|---|---|---|"]
    n = 0
    for (scene, method), ms in sorted(piv.items()):
        row = ms.get("identity")
        if row is None:
            continue
        n += 1
        if row.status != "ok":
            lines.append(f"| `{method}` | {scene} | {row.status}: {row.detail} | | |")
            continue
        d = row.data
        runner = f"`{d.get('runner_up')}` ({_fmt(d.get('runner_up_deviation'), '.2e')})" if d.get("runner_up") else "–"
        matches = _matches(d)
        said = " = ".join(f"`{m}`" for m in matches) if matches else f"none (closest `{d.get('closest')}`)"
        lines.append(f"| `{method}` | {scene} | {said} | {_fmt(row.value, '.2e')} | {runner} |")
    if not n:
        lines.append("| _no engine modes in this run_ | | | | |")
    return lines + [""]


def _energy_text(energy) -> str:
    if energy is None:
        return "–"
    if energy.status != "ok":
        return energy.status
    if energy.data.get("rel_error_defined") is False:
        return "undefined (exact E crosses 0)"
    return _fmt(energy.value, ".2e")


def _micro(seconds):
    return None if seconds is None else seconds * 1e6


#: What the cost columns of a scene's table are (said once above the scenes' tables).
COST_COLUMNS = ("CPU µs/step: a reference scheme's compiled loop, an engine mode's own loop (`engine s/step`: "
                "`mujoco.rollout`, REBOUND's `sim.steps(n)`, a Python loop calling only the step function for "
                "pybullet and pymunk); the time ratio to explicit Euler and the work-precision charts use it. "
                "As stepped µs/step: the same engine mode stepped one call at a time by the harness, its state "
                "read and checked and its forces applied from Python after every step.")


def scene_section(scene: str, piv: dict, chart_names: dict) -> list[str]:
    lines = [f"### `{scene}`", "",
             "| method | status | max \\|ΔE/E\\| | energy | max global error | order | largest stable h·ω | "
             "evals/step | CPU µs/step | as stepped µs/step | time ratio |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for (s, method), ms in sorted(piv.items()):
        if s != scene:
            continue
        energy, error, order = ms.get("energy"), ms.get("error"), ms.get("order")
        stab, cost = ms.get("stability"), ms.get("cost")
        statuses = sorted({r.status for r in ms.values() if r.status != "ok"})
        status = ", ".join(statuses) if statuses else "ok"
        if energy is not None and energy.status == "unstable" and energy.data.get("failed_step"):
            status += f" (energy run: step {energy.data['failed_step']})"
        cells = [
            f"`{method}`", status,
            _energy_text(energy),
            (energy.data.get("class") or "–") if energy is not None else "–",
            _fmt(error.value, ".2e") if error is not None and error.status == "ok" else (error.status if error is not None else "–"),
            _order_text(order),
            homega_text(stab),
            _fmt(cost.data.get("force_evals_per_step"), ".3g") if cost is not None and cost.status == "ok" else "–",
            _fmt(cost.value * 1e6, ".3g") if cost is not None and cost.status == "ok" else (cost.status if cost is not None else "–"),
            _fmt(_micro(cost.data.get("as_stepped_s_per_step")), ".3g") if cost is not None and cost.status == "ok" else "–",
            _fmt(cost.data.get("ratio_to_explicit_euler"), ".2f") if cost is not None and cost.status == "ok" else "–",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    for kind, title in (("energy", "Energy against time"), ("workprecision", "Work-precision: error against cost"),
                        ("stability", "Largest stable h·ω")):
        name = chart_names.get((scene, kind))
        if name:
            lines += [f"![{title} on {scene}]({name})", ""]
    return lines


def _order_text(order) -> str:
    """The measured order; where the scheme declares a lower order for this scene's
    velocity-dependent force, that declaration beside it, so a first-order result reads as
    the scheme's and not as a failure."""
    if order is None:
        return "–"
    if order.status != "ok":
        return order.status
    note = (order.data.get("claims") or {}).get("order_note")
    return _fmt(order.value, ".2f") + (f" [{note}]" if note else "")


def _matches(d: dict) -> list[str]:
    """Every scheme an identity cell matched (several where the scene cannot tell them apart:
    under a constant force, explicit and position-first Euler are one update)."""
    return list(d.get("matches") or ([d["match"]] if d.get("match") else []))


def findings(piv: dict, cells: pd.DataFrame) -> list[str]:
    """Engine behaviour a user would not expect, derived from this run's measurements."""
    out = []
    for (scene, method), ms in sorted(piv.items()):
        if method.startswith("ref:"):
            continue
        ident, energy = ms.get("identity"), ms.get("energy")
        if ident is not None and ident.status == "ok":
            d = ident.data
            matches, dev = _matches(d), ident.value
            expected = d.get("name_suggests")
            if expected and matches and f"ref:{expected}" not in matches:
                said = " = ".join(f"`{m}`" for m in matches)
                out.append(f"`{method}` on `{scene}` integrates as **{said}** (max deviation {dev:.1e}), "
                           f"not the {expected.replace('_', ' ')} its name suggests.")
            elif matches == ["ref:explicit_euler"]:
                out.append(f"`{method}` on `{scene}` is **explicit Euler** (max deviation {dev:.1e}).")
            elif not matches and d.get("note"):
                out.append(f"`{method}` on `{scene}`: {d['note']}")
        if energy is not None and energy.status == "unstable" and energy.data.get("failed_step"):
            out.append(f"`{method}` blows up on `{scene}` at the nominal timestep (step {energy.data['failed_step']}).")
        elif energy is not None and energy.status == "ok" and energy.data.get("class") == "grows":
            out.append(f"`{method}` gains energy on `{scene}` at the nominal timestep "
                       f"(max |ΔE/E| {energy.value:.2e}).")
    out += scene_findings(piv, cells)
    lines = ["## Findings", ""]
    lines += [f"- {f}" for f in dict.fromkeys(out)] or ["- nothing unexpected in this run"]
    return lines + [""]


def _frame_rates(cells: pd.DataFrame) -> list[float]:
    rows = cells[(cells.measure == "advise") & (cells.status == "ok")]
    return sorted({float(r.data["hz"]) for _, r in rows.iterrows() if r.data.get("hz")})


def _per_frame(row: dict) -> str:
    c = row.get("cost_per_frame_s")
    return "–" if c is None else f"{c * 1e6:.3g} µs"


def advice_section(cells: pd.DataFrame, hz: float, chart_names: dict) -> list[str]:
    """"At 60 Hz": per scene, the method that meets the suite's tolerances with the cheapest
    frame (its fewest substeps), the runners-up, and how many methods meet none; from this
    run's ``advise`` cells (``harness.measures.advise``), cost per frame = substeps x the cost cell's
    CPU time per step."""
    rows = cells[(cells.measure == "advise") & (cells.data.map(lambda d: d.get("hz") == hz))]
    if rows.empty:
        return []
    request = next((r.data["request"] for _, r in rows.iterrows() if r.data.get("request")), {})
    tol = []
    if request.get("energy_tol") is not None:
        tol.append(f"energy error ≤ {request['energy_tol']:g}")
    if request.get("error_tol") is not None:
        tol.append(f"position error ≤ {request['error_tol']:g}")
    lines = [f"## At {hz:g} Hz", "",
             f"Which method, with how many substeps a frame, keeps each scene stable and within "
             f"{' and '.join(tol) or 'the tolerances'} over {request.get('horizon', float('nan')):g} s at {hz:g} "
             f"frames a second, for the least cost per frame (`harness advise`; substeps 1 to "
             f"{request.get('max_substeps', '?')}, cost = substeps × the cost cell's CPU time per step).", ""]
    for scene, grp in rows.groupby("scene", sort=False):
        meeting, failing, broken = [], [], []
        for _, r in grp.iterrows():
            if r.status != "ok":
                broken.append(f"`{r.method}` {r.status}")
                continue
            best = r.data.get("best")
            if best is None:
                failing.append((r.method, r.data.get("reason") or "–"))
            else:
                meeting.append((r.data["rows"][best].get("cost_per_frame_s") or math.inf, r.method,
                                r.data["rows"][best]))
        meeting.sort(key=lambda m: (m[0], m[1]))
        lines += [f"### `{scene}` at {hz:g} Hz", ""]
        if meeting:
            _, method, row = meeting[0]
            lines.append(f"**Advised: `{method}`, {row['substeps']} substep{'s' if row['substeps'] > 1 else ''}, "
                         f"{_per_frame(row)} per frame.**")
        else:
            lines.append("**No method meets the tolerances here.**")
        lines += ["", "| rank | method | substeps | h·ω | energy error | class | position error | per frame | "
                      "evals/frame |", "|---|---|---|---|---|---|---|---|---|"]
        for i, (_, method, row) in enumerate(meeting[:5], start=1):
            lines.append(f"| {i} | `{method}` | {row['substeps']} | {row['homega']:.3g} | {_fmt(row.get('energy_error'), '.2e')} | "
                         f"{row.get('energy_class') or '–'} | {_fmt(row.get('position_error'), '.2e')} | "
                         f"{_per_frame(row)} | {_fmt(row.get('evals_per_frame'), '.3g')} |")
        if len(meeting) > 5:
            lines.append(f"| | {len(meeting) - 5} more meet them | | | | | | | |")
        lines.append("")
        if failing:
            lines.append("Cannot meet them: " + "; ".join(f"`{m}`: {why}" for m, why in sorted(failing)) + ".")
            lines.append("")
        if broken:
            lines += ["Not advised (see Failures): " + ", ".join(broken) + ".", ""]
        name = chart_names.get((scene, f"advise{hz:g}"))
        if name:
            lines += [f"![Error against cost per frame on {scene} at {hz:g} Hz]({name})", ""]
    return lines


def bounds_section(cells: pd.DataFrame) -> list[str]:
    b = cells[cells.measure == "bound"]
    if b.empty:
        return []
    lines = ["## Energy bounds (reviewed file)", "", "| method | scene | dt | steps | max \\|ΔE/E\\| | bound | |",
             "|---|---|---|---|---|---|---|"]
    for _, r in b.sort_values(["scene", "method", "dt"]).iterrows():
        bound = r.data.get("bound")
        ok = r.status == "ok" and bound is not None and r.value <= bound
        val = _fmt(r.value, ".2e") if r.status == "ok" else r.status
        lines.append(f"| `{r.method}` | {r.scene} | {r['dt']:g} | {int(r.steps)} | {val} | {_fmt(bound, '.2g')} | {mark(ok)} |")
    return lines + [""]


def appendix(run: dict, cells: pd.DataFrame) -> list[str]:
    lines = ["## Appendix: versions and settings", "", "| package | version |", "|---|---|"]
    for pkg, ver in sorted((run.get("versions") or {}).items()):
        lines.append(f"| {pkg} | {ver or 'not installed'} |")
    lines += ["", "Settings each engine adapter used (as the adapter recorded them):", ""]
    seen = set()
    for _, r in cells[(cells.family != "ref") & (cells.measure == "energy")].sort_values(["method", "scene"]).iterrows():
        settings = r.data.get("settings")
        key = (r.method, r.scene)
        if settings is None or key in seen:
            continue
        seen.add(key)
        items = "; ".join(f"{k}={v}" for k, v in settings.items()) if isinstance(settings, dict) else str(settings)
        lines.append(f"- `{r.method}` on `{r.scene}` ({r.data.get('engine_version', '?')}): {items}")
    if not seen:
        lines.append("- none recorded: no engine run finished in this run")
    settings = run.get("settings") or {}
    suite = settings.get("suite") or {}
    if suite:
        lines += ["", "The suite's settings:", ""]
        for scene, spec in (suite.get("scenes") or {}).items():
            lines.append(f"- `{scene}`: " + "; ".join(f"{k}={v}" for k, v in spec.items()))
        rest = {k: v for k, v in suite.items() if k not in ("name", "scenes")}
        rest["cell_timeout"] = settings.get("cell_timeout", rest.get("cell_timeout"))
        if settings.get("plugins"):
            rest["plugins"] = ",".join(settings["plugins"])
        lines.append("- " + "; ".join(f"{k}={v}" for k, v in rest.items()))
    skipped = settings.get("skipped") or []
    if skipped:
        lines += ["", "Left out of the matrix:", ""]
        lines += [f"- `{s['method']}` on `{s['scene']}`: {s['reason']}" for s in skipped]
    return lines + [""]


def footer(run: dict, timing: dict | None) -> list[str]:
    timing = timing or {}
    lines = ["---", ""]
    total = timing.get("total_s")
    lines.append(f"Run {run['run_id']} ({run['suite']} suite), started {run['started']}, commit "
                 f"`{run.get('git_commit') or 'unknown'}`, measurement version {run['measurement_version']}. "
                 f"Cells ran on: {timing.get('executor', (run.get('settings') or {}).get('executor', '?'))}.")
    if total is not None:
        lines += [""] + where_the_time_went(timing)
    return lines + [""]


def _by(d: dict, n: int = 8) -> str:
    return ", ".join(f"{k} {v:.1f}s" for k, v in sorted(d.items(), key=lambda kv: -kv[1])[:n]) or "–"


def _kernels_phrase(timing: dict) -> str:
    """How much of the workers' CPU compiled kernels, and how many came from the disk cache."""
    compiled, loaded = timing.get("kernels_compiled"), timing.get("kernels_loaded")
    if compiled is None:  # a run stored before kernels were cached
        return (f", {timing['numba_compile_s']:.1f}s of it numba compiling the timing kernels"
                if timing.get("numba_compile_s") else "")
    if not compiled and not loaded:
        return ""
    return (f", {timing.get('numba_compile_s', 0.0):.1f}s of it numba compiling {compiled} (scheme, scene) "
            f"kernels, {loaded} more loaded from the disk cache in {timing.get('kernel_load_s', 0.0):.1f}s")


def where_the_time_went(timing: dict) -> list[str]:
    """The footer's account of the run's time: wall against the CPU the workers spent, and
    where the worker seconds went (by measure, by family, numba compilation, slowest tasks)."""
    total, cells_s = timing.get("total_s", 0.0), timing.get("cells_s", 0.0)
    jobs = timing.get("jobs")
    lines = [f"Wall time {total:.1f}s to this report, {cells_s:.1f}s of it running {timing.get('tasks', '?')} tasks"
             + (f" in {jobs} worker processes on {timing.get('cpus', '?')} cores" if jobs else "") + "."]
    cpu = timing.get("worker_cpu_s")
    if cpu is not None:
        busy = f" (on average {cpu / cells_s:.2f} workers busy)" if cells_s > 0 else ""
        lost = timing.get("tasks_without_cpu") or 0
        lines[-1] += (f" CPU time in the workers {cpu:.1f}s{busy}"
                      + (f", not counting {lost} task(s) whose worker was lost" if lost else "")
                      + _kernels_phrase(timing)
                      + f"; in the main process {timing.get('main_cpu_s', 0.0):.1f}s.")
    lines += ["", f"Worker seconds by measure: {_by(timing.get('worker_seconds_by_measure', {}))}.",
              "", f"By family: {_by(timing.get('worker_seconds_by_family', {}))}."]
    slowest = timing.get("slowest_tasks") or []
    if slowest:
        lines += ["", "Slowest tasks: " + ", ".join(f"{label} {sec:.1f}s" for label, sec in slowest) + "."]
    return lines


# ----------------------------------------------------------------------------- the report
def render(history, run_id: int, out_dir: Path, regressions, previous, timing, trend=None) -> tuple[str, list[str]]:
    run = history.run(run_id)
    cells = history.cells(run_id)
    piv = _pivot(cells)
    scenes = list(dict.fromkeys(cells[cells.measure != "bound"].scene))
    chart_dir = out_dir / "charts"
    chart_dir.mkdir(parents=True, exist_ok=True)
    chart_names, written = {}, []
    for scene in scenes:
        for kind, fn in (("energy", charts.energy_chart), ("workprecision", charts.workprecision_chart),
                         ("stability", charts.stability_chart)):
            name = f"charts/run{run_id}-{scene}-{kind}.png"
            if fn(cells[cells.scene == scene], scene, out_dir / name):
                chart_names[(scene, kind)] = name
                written.append(name)
        for hz in _frame_rates(cells):
            name = f"charts/run{run_id}-{scene}-advise{hz:g}hz.png"
            if charts.advice_chart(cells[cells.scene == scene], scene, hz, out_dir / name):
                chart_names[(scene, f"advise{hz:g}")] = name
                written.append(name)
    damping_chart = f"charts/run{run_id}-damping-stability.png"
    if charts.damping_stability_chart(cells, out_dir / damping_chart):
        written.append(damping_chart)
    else:
        damping_chart = None
    lines = [f"# Integrator comparison: run {run_id} ({run['suite']})", ""]
    lines += verdict(regressions, previous, cells, trend)
    section, trend_charts = history_section(trend, run_id, out_dir)
    lines += section
    written += trend_charts
    lines += tradeoff_table(piv)
    lines += identity_table(piv)
    lines += damping_stability_section(cells, damping_chart)
    lines += ["## Per scene", "", COST_COLUMNS, ""]
    for scene in scenes:
        lines += scene_section(scene, piv, chart_names)
    for hz in _frame_rates(cells):
        lines += advice_section(cells, hz, chart_names)
    lines += findings(piv, cells)
    lines += failures(cells)
    lines += bounds_section(cells)
    lines += appendix(run, cells)
    lines += footer(run, timing)
    return "\n".join(lines), written


def write_report(history, run_id: int, out_dir, regressions=(), previous=None, timing=None, trend=None) -> Path:
    """``trend``: the suite's judged history (``harness.history.series.Trend``) for the History section."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    text, charts_written = render(history, run_id, out_dir, list(regressions), previous, timing, trend)
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
