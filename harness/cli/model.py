"""``harness model PATH``: every measure on a model file (MJCF ``.xml`` or URDF ``.urdf``), in
every engine mode that loads it, as written and conservative (``scenarios.model``).

The file's variants run as the nightly runs a suite (``harness.nightly.models.model_suite``):
the same cells, tables and charts, written to ``--out`` (``report.md``, ``charts/``). The history
is a temporary file unless ``--db`` names one, so a model run stores nothing unless asked to.
Printed: what the model has that perturbs an integrator, what each variant switched off, its
initial state and reference, each variant's table, and the advice (``--hz``)."""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from scenarios import FEATURES, VARIANTS

from harness import validate


def add_parser(sub):
    p = sub.add_parser("model", help="every measure on your own MJCF or URDF model, in MuJoCo, pybullet, Drake and Newton")
    p.add_argument("path", help="the model file: MJCF (.xml) or URDF (.urdf)")
    p.add_argument("--variant", action="append", metavar="NAME",
                   help=f"which variants to measure (repeatable; default both: {', '.join(VARIANTS)})")
    p.add_argument("--keep", action="append", metavar="FEATURE",
                   help=f"keep this feature on in the conservative variant (repeatable; one of {', '.join(FEATURES)})")
    p.add_argument("--off", action="append", metavar="FEATURE",
                   help=f"switch this feature off in every variant, e.g. gravity or armature (repeatable; one of "
                        f"{', '.join(FEATURES)})")
    p.add_argument("--seed", default="0", help="seed of the initial perturbation (a model with no keyframe)")
    p.add_argument("--perturb", default=None, help="its standard deviation (qpos and qvel; default 0.5)")
    p.add_argument("--hz", action="append", metavar="HZ",
                   help="frame rate of the advice on the conservative variant (repeatable; default 60; 0: none)")
    p.add_argument("--energy-tol", default="1e-3", help="the advice's energy tolerance")
    p.add_argument("--out", default=None, help="report directory (default results/model/<file name>)")
    p.add_argument("--db", default=None, help="SQLite history to store the run in (default: none kept)")
    p.add_argument("--jobs", default="2", help="worker processes")
    p.add_argument("--methods", default=None, metavar="PATTERNS",
                   help="comma-separated engine modes or patterns (drake:*); default every MuJoCo, pybullet and "
                        "Newton mode and four of Drake's (harness/nightly/models.py MODEL_MODES)")
    p.add_argument("--json", action="store_true", help="print the model, its variants and every cell as JSON")
    return p


def _request(args) -> tuple[tuple[float, ...], dict | None]:
    hz = [validate.positive_finite("--hz", h) if str(h) not in ("0", "0.0") else 0.0 for h in (args.hz or ["60"])]
    hz = tuple(h for h in hz if h > 0.0)
    if not hz:
        return (), None
    tol = validate.positive_finite("--energy-tol", args.energy_tol)
    return hz, {"energy_tol": tol, "horizon": 10.0, "max_substeps": 16}


def run(args) -> int:
    from harness.nightly.models import engine_modes, model_scenes, model_suite
    from harness.nightly.run import run_nightly

    variants = [validate.choice("--variant", v, list(VARIANTS)) for v in (args.variant or list(VARIANTS))]
    keep = [validate.choice("--keep", k, list(FEATURES)) for k in (args.keep or [])]
    off = [validate.choice("--off", k, list(FEATURES)) for k in (args.off or [])]
    params = {"seed": validate.count("--seed", args.seed, 0, 2**32 - 1)}
    if args.perturb is not None:
        params["perturb"] = args.perturb
    jobs = validate.count("--jobs", args.jobs, 1, 64)
    hz, request = _request(args)
    variants = tuple(dict.fromkeys(variants))
    patterns = [m.strip() for m in args.methods.split(",") if m.strip()] if args.methods else None
    modes = engine_modes(patterns)  # a bad --methods pattern is refused before any engine loads the file
    from harness.execution.isolation import engine_modules, preload_engines

    preload_engines(engine_modules(modes))
    scenes = model_scenes(args.path, variants, keep=keep, off=off, **params)  # the file checked first: InvalidInput
    out = Path(args.out) if args.out else Path("results/model") / scenes[0].file.name
    suite = model_suite([args.path], variants, request, hz, keep=keep, off=off, methods=patterns, **params)
    with tempfile.TemporaryDirectory() as tmp:
        db = Path(args.db) if args.db else Path(tmp) / "model.sqlite"
        result = run_nightly(suite, out, db, jobs, progress_stream=sys.stderr)
        from harness.history.storage import History

        cells = History(db).cell_records(result["run_id"])
    unloaded = {s.id: suite.scenes[s.id].cannot_load for s in scenes}
    compared = [c for c in cells if c.measure == "cross_engine"]
    extra = [f"- {engine} cannot load `{s.id}`: {why}" for s in scenes for engine, why in unloaded[s.id].items()]
    if extra:  # the report gains what the nightly's cells do not hold: the loaders' refusals
        with open(result["report"], "a") as fh:
            fh.write("\n## Model: the engines\n\n" + "\n".join(extra) + "\n")
    if args.json:
        from harness.measures.frames import jsonable

        print(json.dumps(jsonable({"model": scenes[0].describe(), "variants": [s.describe() for s in scenes],
                                   "cannot_load": unloaded, "cross_engine": [c.to_row() for c in compared],
                                   "report": str(result["report"]), "wall_s": result["timing"]["total_s"],
                                   "cells": [c.to_row() for c in cells]}), indent=1, default=str))
        return 0
    for line in header_lines(scenes, cells):
        print(line)
    for engine, why in next(iter(unloaded.values())).items():
        print(f"{engine} cannot load it: {why}")
    from records.cell import pivot
    from reports.markdown import scene_section
    from reports.advice_section import advice_section

    from harness.judge import judge
    from reports.markdown import finding_line

    piv = pivot(cells)
    found = judge(cells).findings
    for scene in scenes:
        print("\n".join(line for line in scene_section(scene.id, piv, {}) if line != ""))
        print("\n".join(f"- {finding_line(f)}" for f in found if f.scene == scene.id))
        print()
    for h in hz:
        print("\n".join(advice_section(cells, h, {})))
    failed = [c for c in cells if c.status in ("crashed", "timed_out")]
    for c in failed:
        print(f"{c.method} on {c.scene}: {c.measure} {c.status}: {c.detail}")
    print(f"report: {result['report']} ({result['timing']['total_s']:.1f} s)")
    return 0


def header_lines(scenes, cells) -> list[str]:
    first = scenes[0]
    found = first.found
    lines = [f"model {first.file.path} ({first.file.kind}, sha256 {first.file.sha256[:16]}...): "
             f"{first.nv} dof, own timestep {first.own_timestep:g} s",
             "perturbs an integrator: " + ("; ".join(f"{k} ({v})" for k, v in found.items()) or "nothing found")]
    for s in scenes:
        off = ", ".join(s.switched_off) or "nothing"
        kept = ", ".join(s.kept) or "nothing of armature or gravity (the model has neither)"
        # The reference's own error, as the error cells of this run recorded it (computed in the workers).
        ref = sorted({c.figures.reference_error for c in cells if c.scene == s.id and c.measure == "error"
                      and c.status == "ok" and c.figures.reference_error is not None})
        said = f"estimated error {ref[0]:.2g}" if ref else "not reached (no error cell finished)"
        lines += [f"{s.id}: switched off {off}; kept {kept}; omega {s.omega:.4g} rad/s (nominal h*omega "
                  f"{s.own_timestep * s.omega:.3g}), slowest mode {s.slowest_omega:.4g} rad/s",
                  f"  initial state: {s.describe_state()}"]
        if s.own_run_reference:
            lines.append(f"  reference: none of another engine ({s.mujoco_refusal}); Bullet builds the scene, and "
                         f"each of its modes is measured against its own run at half the step (Richardson)")
            continue
        lines += [
                  f"  reference: MuJoCo RK4 over one period ({s.reference_horizon:.3g} s), its step halved until two "
                  f"halvings agree to 1e-11: {said}; another engine's modes, which build their own model of "
                  f"the file, against their own run at half the step (Richardson)"]
    return lines

