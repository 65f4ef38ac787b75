"""``harness model PATH``: every measure on a model file (MJCF ``.xml`` or URDF ``.urdf``), in
every engine mode that loads it, as written and conservative (``scenarios.model``).

The file's variants run as the nightly runs a suite (``harness.nightly.models.model_suite``):
the same cells, tables and charts, written to ``--out`` (``report.md``, ``charts/``). The history
is a temporary file unless ``--db`` names one, so a model run stores nothing unless asked to.
Printed: what the model has that perturbs an integrator, what each variant switched off, its
initial state and reference, each variant's table, and the advice (``--hz``).

Without ``--full`` (or one of its flags) the command asks the question a robot's user brings
(``harness.control_step``): at the file's own timestep and integrator, the control step
(``--frame-skip`` or ``--env``'s), seeded controls and the environment's starts, how far each
control step is from the converged one, what another integrator or substeps would change, and at
what cost, with the predictable horizon and the contacts."""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from scenarios import FEATURES, VARIANTS

from harness import validate


def add_parser(sub):
    from scenarios.environments import ENVIRONMENTS

    p = sub.add_parser(
        "model",
        help="your own MJCF or URDF model at its control step (MuJoCo; about 4 s on 2 cores); --full: every "
        "measure in MuJoCo, pybullet, Drake and Newton (about a minute)",
    )
    p.add_argument(
        "path",
        nargs="?",
        default=None,
        help="the model file: MJCF (.xml) or URDF (.urdf); optional with --env (its packaged file)",
    )
    q = p.add_argument_group("the control-step question (the default; seconds to a minute on 2 cores)")
    q.add_argument(
        "--env",
        default=None,
        metavar="NAME",
        help=f"an environment's setting: its file, frame skip and reset ({', '.join(ENVIRONMENTS)})",
    )
    q.add_argument(
        "--frame-skip",
        default=None,
        metavar="N",
        help="physics steps per control step, the control held (default 1, or --env's)",
    )
    q.add_argument(
        "--controls",
        default="seeded",
        metavar="seeded|zero|FILE",
        help="seeded: U(ctrlrange) a control step (default); zero: passive; FILE: .npy/.csv, a row a control step",
    )
    q.add_argument("--seeds", default="3", metavar="N", help="starts (and control sequences) drawn, seeds 0..N-1")
    q.add_argument(
        "--reset-noise",
        default=None,
        metavar="SCALE",
        help="qpos0 + U(-SCALE, SCALE) on qpos and qvel (default 0.01, or --env's reset)",
    )
    q.add_argument("--horizon", default="2", metavar="SECONDS", help="each seed's run (default 2 s)")
    q.add_argument("--states", default="40", metavar="N", help="transition states per seed (default 40)")
    q.add_argument(
        "--past-termination",
        action="store_true",
        help="judge states after the environment would end the episode too (the robot fallen); by "
        "default an --env with a termination rule is judged inside its episodes",
    )
    p.add_argument(
        "--full",
        action="store_true",
        help="the full study instead: every measure, variants as written and conservative, every engine "
        "(minutes); implied by --variant, --keep, --off, --perturb, --hz, --energy-tol, --methods, --db",
    )
    p.add_argument(
        "--variant",
        action="append",
        metavar="NAME",
        help=f"which variants to measure (repeatable; default both: {', '.join(VARIANTS)})",
    )
    p.add_argument(
        "--keep",
        action="append",
        metavar="FEATURE",
        help=f"keep this feature on in the conservative variant (repeatable; one of {', '.join(FEATURES)})",
    )
    p.add_argument(
        "--off",
        action="append",
        metavar="FEATURE",
        help=f"switch this feature off in every variant, e.g. gravity or armature (repeatable; one of "
        f"{', '.join(FEATURES)})",
    )
    p.add_argument(
        "--seed",
        default="0",
        help="the first seed: the question's starts and controls use seeds SEED.."
        "SEED+N-1; --full: the seed of its initial perturbation",
    )
    p.add_argument("--perturb", default=None, help="its standard deviation (qpos and qvel; default 0.5)")
    p.add_argument(
        "--hz",
        action="append",
        metavar="HZ",
        help="frame rate of the advice on the conservative variant (repeatable; default 60; 0: none)",
    )
    p.add_argument("--energy-tol", default=None, help="the advice's energy tolerance (default 1e-3)")
    p.add_argument("--out", default=None, help="report directory (default results/model/<file name>)")
    p.add_argument("--db", default=None, help="SQLite history to store the run in (default: none kept)")
    p.add_argument("--jobs", default="2", help="worker processes")
    p.add_argument(
        "--methods",
        default=None,
        metavar="PATTERNS",
        help="comma-separated engine modes or patterns (drake:*); default every MuJoCo, pybullet and "
        "Newton mode and four of Drake's (harness/nightly/models.py MODEL_MODES)",
    )
    p.add_argument("--json", action="store_true", help="print the model, its variants and every cell as JSON")
    return p


def _request(args) -> tuple[tuple[float, ...], dict | None]:
    hz = [validate.positive_finite("--hz", h) if str(h) not in ("0", "0.0") else 0.0 for h in (args.hz or ["60"])]
    hz = tuple(h for h in hz if h > 0.0)
    if not hz:
        return (), None
    tol = validate.positive_finite("--energy-tol", args.energy_tol if args.energy_tol is not None else "1e-3")
    return hz, {"energy_tol": tol, "horizon": 10.0, "max_substeps": 16}


FULL_FLAGS = ("variant", "keep", "off", "perturb", "hz", "methods", "db", "energy_tol")


def wants_full(args) -> bool:
    return bool(args.full or any(getattr(args, f) is not None for f in FULL_FLAGS))


def run(args) -> int:
    if args.path is None and args.env is None:
        from records import InvalidInput

        raise InvalidInput("path: a model file is needed (an .xml or .urdf), or --env NAME for an environment's own")
    if not wants_full(args):
        return run_question(args)
    if args.path is None:
        from scenarios.environments import environment

        args.path = environment(args.env).path()
    return run_full(args)


def question_setting(args):
    """(model file, ControlSetting, StudyConfig) from the arguments, every field checked."""
    from scenarios.control_setting import CONTROL_MODES, DEFAULT_RESET, ControlSetting
    from scenarios.environments import ResetNoise, environment
    from scenarios.model import read_model_file

    from harness.control_step import StudyConfig

    env = environment(args.env) if args.env else None
    path = args.path or env.path()
    mf = read_model_file(path)
    frame_skip = (
        validate.count("--frame-skip", args.frame_skip, 1, 10_000)
        if args.frame_skip is not None
        else (env.frame_skip if env else 1)
    )
    seeds = validate.count("--seeds", args.seeds, 1, 100)
    seed0 = validate.count("--seed", args.seed, 0, 2**32 - 1 - seeds)
    if args.controls not in CONTROL_MODES:
        ControlSetting.read_controls(args.controls)  # a bad file is refused before MuJoCo compiles the model
    if args.reset_noise is not None:
        scale = (
            float(args.reset_noise)
            if str(args.reset_noise) in ("0", "0.0")
            else validate.positive_finite("--reset-noise", args.reset_noise)
        )
        reset = ResetNoise(scale, scale, "uniform")
    else:
        reset = env.reset if env else DEFAULT_RESET
    horizon = validate.positive_finite("--horizon", args.horizon)
    if horizon > 60:
        from records import InvalidInput

        raise InvalidInput(f"--horizon={args.horizon} is out of range (allowed: > 0, at most 60 s)")
    states = validate.count("--states", args.states, 1, 10_000)
    jobs = validate.count("--jobs", args.jobs, 1, 64)
    source = env.source if env else "harness defaults (no --env)"
    if env and (args.frame_skip is not None or args.reset_noise is not None):
        source += "; changed by --frame-skip/--reset-noise"
    asked = {
        "frame_skip": frame_skip,
        "controls": args.controls,
        "reset": reset,
        "source": source,
        "seeds": tuple(seed0 + i for i in range(seeds)),
    }
    setting = ControlSetting.for_environment(env, **asked) if env else ControlSetting(**asked)
    return (
        mf,
        setting,
        StudyConfig(horizon_s=horizon, states_per_seed=states, threads=jobs, within_episode=not args.past_termination),
    )


def engines_note(m) -> list[str]:
    """Why the question runs MuJoCo alone, and what --full does with the other engines."""
    from scenarios import collidable_pairs

    if collidable_pairs(m):
        return [
            "Drake, Newton and pybullet are not in this question: Drake's parser builds no contact geometry "
            "for a model file (no SceneGraph) and Newton's loader runs with contacts off, so neither steps the "
            "robot this file describes, and pybullet builds its own masses and inertias from the geoms. "
            "`harness model --full` runs Drake and Newton on the file's contact-free (conservative) variant only, "
            "and pybullet on both, its built model compared with MuJoCo's."
        ]
    return [
        "The model has no collidable pair: `harness model --full` compares MuJoCo with Drake, Newton and "
        "pybullet on it, each engine's built model checked against MuJoCo's."
    ]


def run_question(args) -> int:
    from scenarios.model import compile_model

    from harness.control_step import run_study, verdict
    from reports import control_step_section as section

    mf, setting, config = question_setting(args)
    m = compile_model(mf)
    setting = setting.checked(m)
    out = Path(args.out) if args.out else Path("results/model") / mf.name
    study = run_study(m, setting, config, progress=sys.stderr, path=mf.path)
    words = verdict(study)
    note = engines_note(m)
    frame = study.frame()
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / "control_step.csv", index=False)
    drew = section.chart(study, out / "charts" / "control_step_error_cost.png")
    report = out / "report.md"
    report.write_text(section.markdown(study, words, "charts/control_step_error_cost.png" if drew else None, note))
    if args.json:
        from harness.measures.frames import jsonable

        print(
            json.dumps(
                jsonable(
                    {
                        "model": {"file": mf.path, "sha256": mf.sha256},
                        "setting": study.setting,
                        "reference": {
                            "h": study.reference.h,
                            "level": study.reference.level,
                            "error_median": study.reference.error.median,
                            "error_p95": study.reference.error.p95,
                            "converged": study.reference.converged,
                            "history": study.reference.history,
                            "why": study.reference.why,
                        },
                        "collidable_pairs": study.pairs,
                        "predictable_horizon_s": study.horizon,
                        "run_s": study.horizon_s,
                        "episodes_s": study.episodes,
                        "within_episode": study.within_episode,
                        "verdict": words,
                        "engines": note,
                        "candidates": frame.to_dict(orient="records"),
                        "report": str(report),
                        "wall_s": study.wall_s,
                    }
                ),
                indent=1,
                default=str,
            )
        )
        return 0
    print(f"model {mf.path} (sha256 {mf.sha256[:16]}...): {m.nv} dof, {m.nu} actuators")
    for line in section.header_lines(study):
        print(line)
    print()
    for line in words:
        print(line)
    print()
    for line in section.text_table(study):
        print(line)
    print()
    for line in note:
        print(line)
    print(f"report: {report} ({study.wall_s:.1f} s)")
    return 0


def run_full(args) -> int:
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

        print(
            json.dumps(
                jsonable(
                    {
                        "model": scenes[0].describe(),
                        "variants": [s.describe() for s in scenes],
                        "cannot_load": unloaded,
                        "cross_engine": [c.to_row() for c in compared],
                        "report": str(result["report"]),
                        "wall_s": result["timing"]["total_s"],
                        "cells": [c.to_row() for c in cells],
                    }
                ),
                indent=1,
                default=str,
            )
        )
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
    lines = [
        f"model {first.file.path} ({first.file.kind}, sha256 {first.file.sha256[:16]}...): "
        f"{first.nv} dof, own timestep {first.own_timestep:g} s",
        "perturbs an integrator: " + ("; ".join(f"{k} ({v})" for k, v in found.items()) or "nothing found"),
    ]
    lines += built_differently(first.file)
    for s in scenes:
        off = ", ".join(s.switched_off) or "nothing"
        kept = ", ".join(s.kept) or "nothing of armature or gravity (the model has neither)"
        # The reference's own error, as the error cells of this run recorded it (computed in the workers).
        # Never a figure of a cell measured against its own run (another engine's).
        ref = sorted(
            {
                c.figures.reference_error
                for c in cells
                if c.scene == s.id
                and c.measure == "error"
                and c.status == "ok"
                and c.figures.reference_error is not None
                and "own run" not in (c.figures.source or "")
            }
        )
        from scenarios import REFERENCE_JUDGES

        said = f"estimated error {ref[0]:.2g}" if ref else "not reached (no error cell against it finished)"
        if ref and ref[0] > REFERENCE_JUDGES:
            said += f": NOT converged (above {REFERENCE_JUDGES:g}), so no error or order is judged against it"
        lines += [
            f"{s.id}: switched off {off}; kept {kept}; omega {s.omega:.4g} rad/s (nominal h*omega "
            f"{s.own_timestep * s.omega:.3g}), slowest mode {s.slowest_omega:.4g} rad/s",
            f"  initial state: {s.describe_state()}",
        ]
        if s.own_run_reference:
            lines.append(
                f"  reference: none of another engine ({s.mujoco_refusal}); Bullet builds the scene, and "
                f"each of its modes is measured against its own run at half the step (Richardson)"
            )
            continue
        lines += [
            f"  reference: MuJoCo RK4 over one period ({s.reference_horizon:.3g} s), from the model's own step "
            f"{s.own_timestep:g} s down, halved until two halvings agree to 1e-11: {said}; another engine's modes, "
            "which build their own model of "
            f"the file, against their own run at half the step (Richardson)"
        ]
    return lines


def built_differently(mf) -> list[str]:
    """What of the file the other engines' loaders build differently, named before any figure of
    theirs: a total mass MuJoCo's compiler scales the bodies to (``settotalmass``), which neither
    Drake's parser nor Bullet's MJCF loader applies."""
    import xml.etree.ElementTree as ET

    if mf.kind != "MJCF":
        return []
    total = [c.get("settotalmass") for c in ET.parse(mf.path).getroot().iter("compiler") if c.get("settotalmass")]
    if not total:
        return []
    return [
        f"masses: the file sets settotalmass={total[-1]} (MuJoCo scales every body's mass and inertia to that "
        f"total); Drake's parser and Bullet's loader do not apply it, so their bodies have other masses and "
        f"their energy and error figures are on another model (the cross-engine lines name each quantity)"
    ]
