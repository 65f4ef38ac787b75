"""The control-step study of a model file (``harness.control_step``) as text, markdown and a
chart. It prints what it is given: the study's figures and the verdict's lines."""

from __future__ import annotations

import math
from pathlib import Path


def _g(x, fmt=".2g") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return format(x, fmt)


def _err(r) -> tuple[str, str]:
    if r.obs is None or math.isnan(r.obs.median):
        return "-", "-"
    med = _g(r.obs.median)
    return (med if r.resolved else f"< {med} (resolution)"), _g(r.obs.p95)


def header_lines(study) -> list[str]:
    s = study.setting
    ref = study.reference
    lines = [
        f"setting: {study.integrator}, timestep {study.timestep:g} s, frame skip {study.frame_skip}: control step "
        f"{study.control_step:g} s"
        + (f" ({s['environment']}: {s['source']})" if s.get("environment") else f" ({s['source']})"),
        f"controls: {s['controls']}",
        f"starts: {s['start']}, seeds {', '.join(map(str, s['seeds']))}; run {study.horizon_s:g} s each",
        f"observation: {s['observation']}; errors are RMS over its coordinates of the difference over each "
        f"coordinate's spread on the visited states",
        f"episodes: {s['termination']}",
        f"contact: {study.pairs} collidable geom pairs (MuJoCo's filters: contype/conaffinity, parent and weld, "
        f"<exclude>, <pair>)",
        f"reference: {ref.describe()}; stopped at {ref.why}; "
        + (
            "converged: at most a tenth of the baseline's error"
            if ref.converged
            else "NOT converged: more than a tenth of the baseline's error, so no candidate is judged"
        ),
        f"transitions: one control step from {study.nstates} states on the reference's runs, against the reference"
        + (
            ""
            if study.episodes is None
            else (
                ", inside each episode (ends: "
                + ", ".join("> run" if e is None else f"{e:.3g} s" for e in study.episodes)
                + "; Gymnasium's terminate_when_unhealthy)"
                if study.within_episode
                else f", {100 * study.past_termination:.0f}% of them after the episode's end (--past-termination)"
            )
        ),
    ]
    med, shortest = study.predictable()
    if med is None and shortest is None:
        lines.append(f"predictable horizon: beyond the run ({study.horizon_s:g} s) for every seed")
    else:
        per_seed = ", ".join("> run" if h is None else f"{h:.3g} s" for h in study.horizon)
        lines.append(
            f"predictable horizon: {per_seed} by seed (the references part by a tenth of the spread); "
            f"trajectory errors are judged before it only"
        )
    return lines


COLUMNS = (
    "candidate",
    "steps/ctrl",
    "evals/ctrl",
    "error median",
    "error p95",
    "qpos p95",
    "qvel p95",
    "traj. error in horizon",
    "run",
    "contacts/step",
    "in contact",
    "penetration median / max (mm)",
    "cost/ctrl (µs, fastest; next fastest +%)",
    "cost ratio",
)


def table_rows(study) -> list[list[str]]:
    base = study.baseline.cost_s
    rows = []
    for r in study.candidates:
        med, p95 = _err(r)
        c = r.contacts
        contact = (
            [
                f"{c.mean:.2f} (max {c.max})",
                f"{100 * c.share:.0f}%",
                f"{1e3 * c.penetration_median:.2f} / {1e3 * c.penetration_max:.1f}",
            ]
            if c
            else ["no pair", "-", "-"]
        )
        name = r.candidate.name + (" (yours)" if r.baseline else "")
        if r.same_bits_as:
            name += f" = {r.same_bits_as} bit for bit"
        if not study.reference.converged:
            med, p95 = "not judged", "not judged"
        rows.append(
            [
                name,
                str(r.physics_steps),
                str(r.evaluations),
                med,
                p95,
                _g(r.qpos.p95) if r.qpos else "-",
                _g(r.qvel.p95) if r.qvel else "-",
                _g(r.trajectory_error),
                r.run_status,
                *contact,
                f"{1e6 * r.cost_s:.1f}" + (f" (+{100 * r.cost_spread:.0f}%)" if math.isfinite(r.cost_spread) else ""),
                f"{r.cost_s / base:.2f}" if base > 0 else "-",
            ]
        )
    ref = study.contacts_reference
    if ref is not None:
        rows.append(
            [
                f"reference runs (rk4 h/{2**3})",
                "",
                "",
                "",
                "",
                "",
                "",
                "",
                "",
                f"{ref.mean:.2f} (max {ref.max})",
                f"{100 * ref.share:.0f}%",
                f"{1e3 * ref.penetration_median:.2f} / {1e3 * ref.penetration_max:.1f}",
                "",
                "",
            ]
        )
    return rows


def text_table(study) -> list[str]:
    rows = [list(COLUMNS), *table_rows(study)]
    widths = [max(len(r[i]) for r in rows) for i in range(len(COLUMNS))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]


def markdown(study, verdict: list[str], chart: str | None, engines_note: list[str]) -> str:
    out = [
        f"# {Path(study.file).name} at its control step",
        "",
        "## The answer",
        "",
        *[f"- {v}" for v in verdict],
        "",
        "## Setting",
        "",
        *[f"- {h}" for h in header_lines(study)],
        "",
        "## Each integrator and substep level",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "|" + "---|" * len(COLUMNS),
    ]
    out += ["| " + " | ".join(r) + " |" for r in table_rows(study)]
    out += [
        "",
        "Errors are relative to the observation's spread (module `harness/control_step.py`); cost is MuJoCo's "
        "own loop, `mj_step(m, d, nstep=steps/ctrl)` once a control step, wall clock (`time.perf_counter`), "
        "over every seed's judged control steps, the fastest of its repeats (the next fastest's excess beside it); "
        "the cost ratio is to your setting's, measured in the "
        "same run.",
    ]
    if chart:
        out += ["", f"![error against cost]({chart})"]
    if engines_note:
        out += ["", "## Other engines", "", *[f"- {n}" for n in engines_note]]
    out += ["", f"Measured in {study.wall_s:.1f} s."]
    return "\n".join(out) + "\n"


def chart(study, path: Path) -> bool:
    """Transition error (median) against cost per control step, one series per integrator, a point
    per substep level; your setting circled."""
    if not study.reference.converged:
        return False
    from reports.charts import _save, plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    series: dict[str, list] = {}
    for r in study.candidates:
        if r.obs is None or not math.isfinite(r.obs.median) or r.obs.median <= 0 or r.same_bits_as:
            continue
        series.setdefault(r.candidate.integrator, []).append((1e6 * r.cost_s, r.obs.median, r))
    for name, pts in series.items():
        pts.sort(key=lambda p: p[2].candidate.substeps)
        line = ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=name)[0]
        for x, y, r in pts:
            ax.annotate(
                f"x{r.candidate.substeps}",
                (x, y),
                textcoords="offset points",
                xytext=(4, 3),
                fontsize=7,
                color=line.get_color(),
            )
            if not r.resolved:
                ax.plot([x], [y], marker="v", color=line.get_color())
    b = study.baseline
    if b.obs and math.isfinite(b.obs.median) and b.obs.median > 0:
        ax.plot(
            [1e6 * b.cost_s],
            [b.obs.median],
            marker="o",
            markersize=14,
            markerfacecolor="none",
            color="black",
            label="your setting",
        )
    ax.axhline(study.reference.error.median, color="grey", linestyle=":", label="reference's own error")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost per control step (µs, wall clock: MuJoCo's mj_step loop, fastest of repeats)")
    ax.set_ylabel("transition error, median (of the observation's spread)")
    twins = sorted(
        {
            f"{r.candidate.integrator} = {study.by_name(r.same_bits_as).candidate.integrator}"
            for r in study.candidates
            if r.same_bits_as and study.by_name(r.same_bits_as)
        }
    )
    ax.set_title(
        f"{Path(study.file).name}: one control step ({study.control_step:g} s) against the reference"
        + (f"\nnot drawn, the same bits: {', '.join(twins)}" if twins else ""),
        fontsize=9,
    )
    ax.legend(fontsize=7)
    return _save(fig, path)
