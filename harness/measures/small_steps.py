"""'Small steps' (Macklin, Storey, Lu, Terdiman, Chentanez, Jeschke and Mueller, SCA 2019), measured:
at a fixed frame rate and equal cost per frame, XPBD with n substeps of one Gauss-Seidel pass
against one step of n passes, against implicit Euler and its linearly implicit form at one step
a frame, and against semi-implicit Euler at the fewest substeps a frame it needs to stay bounded.

Every configuration runs ``t_end`` of simulated time (default 2) in frames of 1/``hz`` from the scene's initial state,
on the scheme's compiled loop where that computes the interpreted bits (``reference.RefMethod``,
``compiled_where_bitwise``), else interpreted. Rows
(``small_steps``), one per configuration:

* ``energy_retained`` = E(t_end) / E(0) (the scenes' exact energy is E(0): 1 is no damping);
* ``stretch`` = max over the frames of the scene's ``constraint_error`` (max |length - rest| / rest);
* ``error`` = max |q - q_ref| over the frames up to min(t_end, the reference's horizon);
* ``attrs["reference_stretch"]``: the reference solution's own stretch over the same frames: a
  spring of finite stiffness stretches, and a method that damps the motion stretches it less, so
  a stretch is judged as its distance from the reference's (``stretch_off``), never "less is
  better";
* ``cost_per_frame_s``: CPU seconds of the compiled loop per frame (``reference.time_per_step``
  on the process's CPU clock, the fastest of ``repeats`` calls of ``timing_frames`` frames, one
  loop call per repeat; steps per frame times seconds per step).

A scheme that does not run on the scene (implicit Euler on the rope, whose links are
constraints: no force to solve) is a row with its reason. ``claims(frame)`` judges the paper's
claims from the rows alone (✓/✗ with the figures), ``chart`` draws error and energy retained
against cost per frame; ``reports.position_based_section`` prints both tables.

**The paper's case.** Macklin et al. make their claims for stiff constraints: links of zero
compliance, or springs stiff enough that the true motion keeps them near their rest lengths. On
a cloth of soft shear and bending springs (the default's 50 and 5, whose reference stretches 0.36)
the stretch claims are not theirs to test: where the reference stretches more than PAPERS_CASE,
the stretch rows say "not the paper's case" (their figures still shown), and the nightly runs the
study again on the scene with every spring stiff (``STIFF``: k = k_shear = k_bend = 1e5 on the
4 x 4 sheet, whose reference stretches 0.29%).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pandas as pd

from reference import METHODS, RefMethod, time_per_step
from scenarios import make_scene

#: The configurations' passes: n substeps x 1 pass against 1 step x n passes.
PASSES = (1, 2, 4, 8, 16, 32)
#: The implicit schemes at one step a frame.
IMPLICIT = ("implicit_euler", "linearly_implicit_euler")
#: The explicit baseline, at the fewest substeps a frame (doubling from 1) that stay bounded.
EXPLICIT = "semi_implicit_euler"
#: Bounded: the run finished and its energy stayed within this factor of E(0).
BOUNDED_FACTOR = 2.0
#: The most substeps a frame the explicit baseline is tried at.
MAX_SUBSTEPS = 256
#: A claim that one configuration beats another needs it better by more than this share (the
#: figures are deterministic; the margin keeps a tie from reading as a win).
MARGIN = 0.01
#: The paper's case: the reference stretches its springs or links by at most this (relative).
PAPERS_CASE = 0.01
#: The cloth's springs made stiff, where its own are not the paper's case: the reference of the
#: 4 x 4 sheet then stretches 2.9e-3 (1.5e-2 at 1e4, 0.36 with the default soft shear and bending).
STIFF = {"k": 1e5, "k_shear": 1e5, "k_bend": 1e5}


def _runs(scene, scheme_id: str, dt: float, steps: int, options: dict):
    return RefMethod(METHODS[scheme_id], options, compiled_where_bitwise=True).simulate(scene, dt, steps, 1)


def _row(
    scene,
    label: str,
    scheme_id: str,
    options: dict,
    hz: float,
    steps_per_frame: int,
    t_end: float,
    timing: bool,
    timing_frames: int,
    repeats: int,
) -> dict:
    from harness.methods import RefMethod

    scheme = METHODS[scheme_id]
    row = {
        "scene": scene.id,
        "config": label,
        "method": f"ref:{scheme_id}",
        "substeps": options.get("substeps"),
        "iterations": options.get("iterations"),
        "steps_per_frame": steps_per_frame,
        "hz": hz,
        "status": "ok",
        "detail": "",
        "energy_retained": None,
        "stretch": None,
        "error": None,
        "cost_per_frame_s": None,
    }
    ok, why = RefMethod(scheme, options).supports(scene)
    if not ok:
        return {**row, "status": "not run", "detail": why}
    dt = 1.0 / (hz * steps_per_frame)
    frames = int(round(t_end * hz))
    tr = _runs(scene, scheme_id, dt, frames * steps_per_frame, options)
    keep = tr.step % steps_per_frame == 0
    q, t, energy = tr.q[keep, 0], tr.t[keep], tr.energy[keep, 0]
    e0 = float(scene.energy(*scene.initial_state()))
    row["status"], row["detail"] = tr.status, tr.detail
    if q.shape[0]:
        with np.errstate(all="ignore"):
            row["energy_retained"] = float(energy[-1] / e0)
            row["stretch"] = float(np.max(scene.constraint_error(q)))
            sel = t <= min(t_end, scene.reference_horizon) + 1e-12
            q_ref, _ = scene.reference_solution(t[sel])
            row["error"] = float(np.max(np.abs(q[sel] - q_ref)))
    if timing and tr.status == "ok":
        res = time_per_step(scheme, scene, dt, timing_frames * steps_per_frame, repeats=repeats, clock="cpu", **options)
        row["cost_per_frame_s"] = res["s_per_step"] * steps_per_frame
    return row


def explicit_substeps(scene, hz: float, t_end: float) -> tuple[int, str]:
    """The fewest substeps a frame (1, 2, 4, ...) at which semi-implicit Euler stays bounded over
    ``t_end`` (``BOUNDED_FACTOR``), and "" ; or (0, why) where none up to ``MAX_SUBSTEPS`` does."""
    from harness.methods import RefMethod

    ok, why = RefMethod(METHODS[EXPLICIT]).supports(scene)
    if not ok:
        return 0, why
    e0 = float(scene.energy(*scene.initial_state()))
    start = max(1, 2 ** math.ceil(math.log2(max(1.0, scene.omega / (2.0 * hz)))))
    s = start
    while s <= MAX_SUBSTEPS:
        tr = _runs(scene, EXPLICIT, 1.0 / (hz * s), int(round(t_end * hz)) * s, {})
        if tr.status == "ok" and np.all(np.abs(tr.energy[:, 0]) <= BOUNDED_FACTOR * abs(e0)):
            return s, ""
        s *= 2
    return 0, f"unbounded at every substep count up to {MAX_SUBSTEPS} a frame"


def stiff_text() -> str:
    """``STIFF`` as the report names it: k = k_shear = k_bend = 1e5."""
    values = set(STIFF.values())
    if len(values) == 1:
        return f"{' = '.join(STIFF)} = {values.pop():.0e}".replace("e+0", "e").replace("e+", "e")
    return ", ".join(f"{k} = {v:g}" for k, v in STIFF.items())


def stiff_params(scene_id: str, **scene_params) -> dict | None:
    """The scene's parameters with every spring stiff (``STIFF``), where it has those parameters
    (the cloth and the net); None elsewhere."""
    from scenarios import SCENES

    if not set(STIFF) <= set(SCENES[scene_id].params):
        return None
    return {**scene_params, **STIFF}


def small_steps(
    scene_id: str,
    hz: float = 60.0,
    t_end: float = 2.0,
    passes=PASSES,
    timing: bool = True,
    timing_frames: int = 60,
    repeats: int = 3,
    **scene_params,
) -> pd.DataFrame:
    """The study's rows on one scene (module docstring), ``attrs`` its settings."""
    scene = make_scene(scene_id, **scene_params)
    t0 = time.process_time()
    rows = []
    for n in passes:
        rows.append(
            _row(
                scene,
                f"xpbd {n} substeps x 1",
                "xpbd",
                {"substeps": int(n), "iterations": 1},
                hz,
                1,
                t_end,
                timing,
                timing_frames,
                repeats,
            )
        )
        if n > 1:
            rows.append(
                _row(
                    scene,
                    f"xpbd 1 step x {n}",
                    "xpbd",
                    {"substeps": 1, "iterations": int(n)},
                    hz,
                    1,
                    t_end,
                    timing,
                    timing_frames,
                    repeats,
                )
            )
    for sid in IMPLICIT:
        rows.append(_row(scene, sid.replace("_", " "), sid, {}, hz, 1, t_end, timing, timing_frames, repeats))
    s, why = explicit_substeps(scene, hz, t_end)
    if s:
        rows.append(
            _row(scene, f"semi-implicit Euler {s} substeps", EXPLICIT, {}, hz, s, t_end, timing, timing_frames, repeats)
        )
    else:
        rows.append(
            {
                "scene": scene.id,
                "config": "semi-implicit Euler",
                "method": f"ref:{EXPLICIT}",
                "status": "not run",
                "detail": why,
                "hz": hz,
                "steps_per_frame": None,
            }
        )
    frame = pd.DataFrame(rows).astype(object).where(lambda f: f.notna(), None)
    frames = int(round(t_end * hz))
    t = np.arange(frames + 1) / hz
    t = t[t <= min(t_end, scene.reference_horizon) + 1e-12]
    frame.attrs.update({"reference_stretch": float(np.max(scene.constraint_error(scene.reference_solution(t)[0])))})
    frame.attrs.update(
        {
            "scene": scene.id,
            "params": dict(scene.values),
            "hz": hz,
            "t_end": t_end,
            "passes": list(passes),
            "clock": "cpu",
            "timing_frames": timing_frames,
            "repeats": repeats,
            "cpu_s": time.process_time() - t0,
        }
    )
    return frame


# ----------------------------------------------------------------------------- the claims
def _pick(frame: pd.DataFrame, substeps: int | None, iterations: int | None, method: str = "ref:xpbd"):
    rows = frame[
        (frame["method"] == method)
        & (frame["substeps"] == substeps)
        & (frame["iterations"] == iterations)
        & (frame["status"] == "ok")
    ]
    return None if rows.empty else rows.iloc[0]


def _value(row, key: str, reference_stretch: float | None):
    """A row's figure as the claims judge it: the stretch as its distance from the reference's."""
    if key != "stretch_off":
        return row[key]
    if row["stretch"] is None or reference_stretch is None:
        return None
    return abs(row["stretch"] - reference_stretch)


def papers_case(frame: pd.DataFrame) -> bool:
    """Whether the study's scene is the paper's case: its reference stretches at most PAPERS_CASE."""
    ref = frame.attrs.get("reference_stretch")
    return ref is not None and ref <= PAPERS_CASE


def _beats(a, b, key: str, higher: bool, reference_stretch=None) -> bool:
    va, vb = _value(a, key, reference_stretch), _value(b, key, reference_stretch)
    if va is None or vb is None or not (np.isfinite(va) and np.isfinite(vb)):
        return False
    return va > vb * (1 + MARGIN) if higher else va < vb * (1 - MARGIN)


def _fmt(x) -> str:
    return "–" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{x:.3g}"


#: The paper's claims: (name, the row key, whether higher is better).
PAIR_CLAIMS = (
    ("n substeps x 1 pass beat 1 step x n passes in error against the reference", "error", False),
    ("n substeps x 1 pass beat 1 step x n passes in damping (energy retained)", "energy_retained", True),
    (
        "n substeps x 1 pass beat 1 step x n passes in constraint error (stretch, as its distance from "
        "the reference's)",
        "stretch_off",
        False,
    ),
)
IMPLICIT_CLAIMS = (
    ("XPBD substeps beat {name} in damping at equal cost per frame", "energy_retained", True),
    (
        "XPBD substeps beat {name} in constraint error at equal cost per frame (stretch, as its "
        "distance from the reference's)",
        "stretch_off",
        False,
    ),
)


def _not_the_papers_case(reference_stretch: float) -> str:
    return (
        f"not the paper's case: the reference itself stretches {reference_stretch:.3g} (> {PAPERS_CASE:g}: "
        "soft springs, where a method that damps the motion stretches them less)"
    )


def claims(frame: pd.DataFrame) -> list[dict]:
    """One row per claim of the paper on the study's scene: ``{"scene", "claim", "verdict" (✓, ✗ or
    – where it could not be judged), "figures"}``, from the rows alone (timings included, as given).
    A stretch is judged as its distance from the reference's; where the scene is not the paper's
    case (``papers_case``) the stretch rows are "–", "not the paper's case", their figures after."""
    scene = frame.attrs.get("label") or frame.attrs.get("scene") or (frame["scene"].iloc[0] if len(frame) else "")
    passes = [n for n in frame.attrs.get("passes", sorted(set(frame["substeps"].dropna()))) if n > 1]
    ref = frame.attrs.get("reference_stretch")
    case = papers_case(frame)
    out = []

    def said(verdict, figures, key):
        if key == "stretch_off" and ref is None:
            return "–", "no reference stretch to judge a stretch against"
        if key == "stretch_off" and not case:
            return "–", f"{_not_the_papers_case(ref)}; " + figures
        return verdict, figures

    for claim, key, higher in PAIR_CLAIMS:
        wins, parts = 0, []
        judged = 0
        for n in passes:
            sub, it = _pick(frame, n, 1), _pick(frame, 1, n)
            if sub is None or it is None:
                continue
            judged += 1
            wins += _beats(sub, it, key, higher, ref)
            parts.append(f"n={n}: {_fmt(_value(sub, key, ref))} vs {_fmt(_value(it, key, ref))}")
        verdict = "–" if not judged else "✓" if wins == judged else "✗"
        verdict, figures = said(verdict, f"{wins} of {judged} n; " + "; ".join(parts) if judged else "no pair ran", key)
        out.append({"scene": scene, "claim": claim, "verdict": verdict, "figures": figures})
    subs = frame[(frame["method"] == "ref:xpbd") & (frame["iterations"] == 1) & (frame["status"] == "ok")]
    for sid in IMPLICIT:
        rows = frame[(frame["method"] == f"ref:{sid}")]
        name = sid.replace("_", " ")
        imp = None if rows.empty or rows.iloc[0]["status"] != "ok" else rows.iloc[0]
        for template, key, higher in IMPLICIT_CLAIMS:
            claim = template.format(name=name)
            if imp is None:
                why = rows.iloc[0]["detail"] if not rows.empty else "not in the rows"
                out.append({"scene": scene, "claim": claim, "verdict": "–", "figures": f"not run: {why}"})
                continue
            cost = imp["cost_per_frame_s"]
            within = subs[subs["cost_per_frame_s"].notna()]
            if cost is None or not np.isfinite(cost) or within.empty:
                out.append({"scene": scene, "claim": claim, "verdict": "–", "figures": "no cost per frame to match"})
                continue
            cheaper = within[within["cost_per_frame_s"] <= cost]
            pick = (
                cheaper.sort_values("cost_per_frame_s").iloc[-1]
                if not cheaper.empty
                else within.sort_values("cost_per_frame_s").iloc[0]
            )
            verdict = "✓" if _beats(pick, imp, key, higher, ref) else "✗"
            what = "|stretch - the reference's|" if key == "stretch_off" else key
            verdict, figures = said(
                verdict,
                (
                    f"xpbd {int(pick['substeps'])} substeps ({pick['cost_per_frame_s'] * 1e6:.3g} µs/frame"
                    f"{'' if not cheaper.empty else ', the cheapest, still costlier'}): {what} "
                    f"{_fmt(_value(pick, key, ref))} vs {_fmt(_value(imp, key, ref))} ({cost * 1e6:.3g} µs/frame)"
                ),
                key,
            )
            out.append({"scene": scene, "claim": claim, "verdict": verdict, "figures": figures})
    return out


def chart(frames: list[pd.DataFrame], path) -> bool:
    """Error and energy retained against CPU cost per frame, one column per scene, one series per
    family (substeps, passes), the implicit and explicit schemes as points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    frames = [f for f in frames if len(f) and f["cost_per_frame_s"].notna().any()]
    if not frames:
        return False
    fig, axes = plt.subplots(2, len(frames), figsize=(5 * len(frames), 6.5), squeeze=False)
    for col, f in enumerate(frames):
        ok = f[(f["status"] == "ok") & f["cost_per_frame_s"].notna()]
        sub = ok[(ok["method"] == "ref:xpbd") & (ok["iterations"] == 1)].sort_values("cost_per_frame_s")
        its = ok[(ok["method"] == "ref:xpbd") & (ok["substeps"] == 1)].sort_values("cost_per_frame_s")
        others = ok[ok["method"] != "ref:xpbd"]
        for row, key, label in ((0, "error", "max |q - q_ref|"), (1, "energy_retained", "E(t_end) / E(0)")):
            ax = axes[row, col]
            ax.plot(sub["cost_per_frame_s"] * 1e6, sub[key], "o-", label="XPBD n substeps x 1 pass")
            ax.plot(its["cost_per_frame_s"] * 1e6, its[key], "s--", label="XPBD 1 step x n passes")
            for _, r in others.iterrows():
                ax.plot(r["cost_per_frame_s"] * 1e6, r[key], "^", label=r["config"])
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())  # the minor labels overlap over a decade
            if key == "error":
                ax.set_yscale("log")
            ax.set_xlabel("CPU µs per frame (compiled loop, process CPU clock)")
            ax.set_ylabel(label)
            ax.grid(True, which="both", alpha=0.3)
            if row == 0:
                ax.set_title(
                    f"{f.attrs.get('scene', '')} at {f.attrs.get('hz', 60):g} Hz, {f.attrs.get('t_end', 2):g} s"
                )
            ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return True
