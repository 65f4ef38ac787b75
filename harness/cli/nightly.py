"""``harness nightly``: run the matrix, store it, compare with the last run, write the report.
Exit 1 when anything regressed (the list also heads the report), 2 on bad input (an unreachable
scheduler included), 3 when the Dask cluster was lost mid-run."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from harness import validate
from harness.history.compare import regression_lines
from harness.nightly.run import DEFAULT_DB, DEFAULT_OUT, run_nightly
from harness.nightly.suites import SUITES


def add_parser(sub):
    p = sub.add_parser(
        "nightly",
        help="run the comparison matrix, store it, report, flag regressions (the standard suite on 2 cores: "
        "about 4½ minutes with its kernels cached, 6 on an empty cache)",
    )
    p.add_argument("--suite", default="standard", help=f"one of: {', '.join(SUITES)}")
    p.add_argument("--out", default=str(DEFAULT_OUT), help="report directory (report.md + charts/)")
    p.add_argument("--db", default=str(DEFAULT_DB), help="SQLite history")
    p.add_argument("--jobs", default=None, help="worker processes (default: all cores)")
    p.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address [tcp://]HOST:PORT, or local:N for a LocalCluster of N worker "
        "processes (default: $HARNESS_SCHEDULER unless --jobs is given, else local worker processes)",
    )
    p.add_argument(
        "--bounds", default=None, help="energy bounds file (default: the reviewed harness/energy_bounds.csv)"
    )
    p.add_argument(
        "--cell-timeout",
        default=None,
        help="seconds one task (a scene x method, all its measures) may take before its worker is "
        "killed and the rest of it recorded timed_out (default: the suite's)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue the suite's latest run, left incomplete by a kill (SIGKILL, OOM, a lost machine), "
        "from the tasks it stored; refused when that run is complete or was measured otherwise "
        "(another commit, versions, platform or settings)",
    )
    p.add_argument(
        "--model",
        action="append",
        metavar="PATH",
        help="a model file (MJCF .xml or URDF .urdf) whose variants join the suite as scenes (repeatable; "
        "beside those [tool.harness] models lists in ./pyproject.toml)",
    )
    p.add_argument(
        "--engine",
        action="append",
        metavar="ENGINE==VERSION",
        help="run the suite once per engine release, each on an environment of its own kept in the "
        "harness cache, and report what changed between releases (repeatable; beside those "
        "[tool.harness] engines lists in ./pyproject.toml)",
    )
    p.add_argument(
        "--model-env",
        action="append",
        metavar="NAME",
        help="an environment's model file at its own control step, frame skip and reset (harness model "
        "--env NAME's question; repeatable): its verdict and table join the report",
    )
    p.add_argument("--json", action="store_true", help="print the run summary as JSON")
    return p


def run(args) -> int:
    from harness.history import bounds as bounds_mod

    from harness.nightly.models import configured_models, with_models

    suite = validate.choice("--suite", args.suite, list(SUITES))
    from harness.nightly.matrix import configured_engines

    engines = configured_engines() + list(args.engine or [])
    if engines:
        return _matrix(args, suite, engines)
    import adapters

    outside = sorted({m.version_problem() for m in adapters.ENGINE_METHODS.values()} - {None})
    if outside:  # an engine release its adapter does not support: one line, before anything runs
        from records import InvalidInput

        raise InvalidInput(outside[0])
    from scenarios.environments import environment

    envs = [environment(name) for name in (args.model_env or [])]  # an unknown name: one line, before anything runs
    for env in envs:
        env.path()  # its package installed
    models = configured_models() + list(args.model or [])
    if models:  # every file read and checked (and each engine's loader tried) before the history is opened
        suite = with_models(SUITES[suite], models)
    jobs = validate.count("--jobs", args.jobs, 1, 1024) if args.jobs is not None else None
    cell_timeout = (
        validate.positive_finite("--cell-timeout", args.cell_timeout) if args.cell_timeout is not None else None
    )
    bounds_path = Path(args.bounds) if args.bounds else bounds_mod.DEFAULT_PATH
    bounds_mod.load(bounds_path)  # a broken bounds file fails before anything runs
    from harness.execution.distributed import ClusterLost, resolve_scheduler

    resolve_scheduler(args.scheduler, jobs is not None)  # a bad address fails before anything runs
    from harness.measures.injected import load_injected

    load_injected()  # a broken $HARNESS_INJECT_TIMINGS file fails before anything runs
    try:
        result = run_nightly(
            suite,
            Path(args.out),
            Path(args.db),
            jobs,
            args.scheduler,
            bounds_path,
            cell_timeout=cell_timeout,
            resume=args.resume,
        )
    except ClusterLost as exc:
        print(
            f"harness: error: {exc}; the run is left incomplete (never compared, the previous report kept)",
            file=sys.stderr,
        )
        return 3
    if envs:
        control_step_sections(envs, Path(result["report"]))
    regs = result["regressions"]
    if args.json:
        print(
            json.dumps(
                {
                    "run_id": result["run_id"],
                    "previous": result["previous"],
                    "report": str(result["report"]),
                    "regressions": [r.as_dict() for r in regs],
                    "not_measured": [r.as_dict() for r in result.get("not_measured", ())],
                    "timing": result["timing"],
                },
                indent=1,
                default=str,
            )
        )
    else:
        print(f"run {result['run_id']}: report {result['report']} ({result['timing']['total_s']:.1f}s)")
        for line in regression_lines(regs, result.get("not_measured", ())):
            print(line)
    if regs:
        print(f"harness: {len(regs)} regression(s)", file=sys.stderr)
    return 1 if regs else 0


def _matrix(args, suite: str, engines: list[str]) -> int:
    """One run per engine release (``harness.nightly.matrix``); every spec checked first."""
    from harness.nightly.matrix import plan, run_matrix

    plan(engines)  # unknown engine, no such release, offline: one line before anything runs
    extra = [a for m in (args.model or []) for a in ("--model", m)]
    for name, value in (("--jobs", args.jobs), ("--bounds", args.bounds), ("--cell-timeout", args.cell_timeout)):
        if value is not None:
            extra += [name, str(value)]
    result = run_matrix(engines, suite, Path(args.out), Path(args.db), extra, resume=args.resume)
    regs = [r for run in result["runs"] for r in run["regressions"]]
    if args.json:
        runs = [{k: v for k, v in r.items() if k != "skipped"} for r in result["runs"]]
        print(json.dumps({"runs": runs, "report": str(result["report"])}, indent=1, default=str))
    else:
        for run in result["runs"]:
            print(f"{run['engine']} {run['version']}: run {run['run_id']}, report {run['report']}")
        print(f"matrix report: {result['report']}")
    return 1 if regs else 0


def control_step_sections(envs, report: Path, config=None) -> None:
    """Each environment's control-step question (``harness.control_step``) appended to the
    report, its table beside it as CSV; a study that fails is a line saying how, never a dead run."""
    import traceback

    from scenarios.control_setting import ControlSetting
    from scenarios.model import compile_model, read_model_file

    from harness.control_step import run_study, verdict
    from reports import control_step_section as section

    lines = ["", "## Model files at their control step", ""]
    for env in envs:
        try:
            mf = read_model_file(env.path())
            m = compile_model(mf)
            setting = ControlSetting.for_environment(env)
            study = run_study(m, setting, config, progress=sys.stderr, path=mf.path)
        except Exception as exc:  # recorded, never a dead report
            lines += [f"### {env.name}", "", f"crashed: {type(exc).__name__}: {' '.join(str(exc).split())}", ""]
            traceback.print_exc(file=sys.stderr)
            continue
        slug = env.name.replace("/", "_")
        study.frame().to_csv(report.parent / f"control_step_{slug}.csv", index=False)
        drew = section.chart(study, report.parent / "charts" / f"control_step_{slug}.png")
        body = section.markdown(study, verdict(study), f"charts/control_step_{slug}.png" if drew else None, [])
        lines += [
            f"### {env.name}",
            "",
            *(("#### " + ln[3:]) if ln.startswith("## ") else ln for ln in body.split("\n")[1:]),
        ]
    with open(report, "a") as fh:
        fh.write("\n".join(lines) + "\n")
