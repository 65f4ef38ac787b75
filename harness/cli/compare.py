"""``harness compare [RUN_A] [RUN_B]``: what got worse between two stored runs (default: the
last two complete runs, cost judged over the suite's history once it has three runs, and every
accuracy figure that changed with the latest run listed as a CHANGE). Exit 1 when anything
regressed."""

from __future__ import annotations

import json
from pathlib import Path

from records import InvalidInput

from harness import validate
from harness.history.compare import compare_runs, not_measured_runs, regression_lines
from harness.history.series import load as load_trend
from harness.nightly.run import DEFAULT_DB
from harness.history.storage import History


def add_parser(sub):
    p = sub.add_parser("compare", help="list regressions between two stored runs")
    p.add_argument("run_a", nargs="?", default=None)
    p.add_argument("run_b", nargs="?", default=None)
    p.add_argument("--db", default=str(DEFAULT_DB))
    p.add_argument("--bounds", default=None, help="energy bounds file (default: the reviewed one)")
    p.add_argument("--json", action="store_true")
    return p


def run(args) -> int:
    from harness.history import bounds as bounds_mod

    if not Path(args.db).exists():
        raise InvalidInput(f"--db={args.db}: no such history (run `harness nightly` first)")
    run_a = validate.count("RUN_A", args.run_a, 1) if args.run_a is not None else None
    run_b = validate.count("RUN_B", args.run_b, 1) if args.run_b is not None else None
    if run_a is not None and run_b is None:
        run_a, run_b = None, run_a  # one id: compare that run with the run before it
    history = History(args.db)
    trend = None
    if run_a is None:  # the default comparison: judged over the suite's history too
        runs = history.runs()
        if run_b is not None or not runs.empty:
            target = run_b if run_b is not None else int(runs.run_id.iloc[-1])
            trend = load_trend(
                history, run_id=target, measurement_version=int(history.run(target)["measurement_version"])
            )
    a, b, regs = compare_runs(
        history, run_a, run_b, Path(args.bounds) if args.bounds else bounds_mod.DEFAULT_PATH, trend=trend
    )
    changes = trend.latest_changes() if trend is not None and a is not None else []
    unmeasured = not_measured_runs(history, a, b)
    if args.json:
        print(
            json.dumps(
                {
                    "run_a": a,
                    "run_b": b,
                    "regressions": [r.as_dict() for r in regs],
                    "not_measured": [r.as_dict() for r in unmeasured],
                    "judged_by_history": bool(trend is not None and trend.judged),
                    "changes": [
                        {"scene": c.scene, "method": c.method, "measure": c.measure, "dt": c.dt, **ch.as_dict()}
                        for c, ch in changes
                    ],
                },
                indent=1,
                default=str,
            )
        )
    else:
        how = f" (cost over the last {len(trend.runs)} runs)" if trend is not None and trend.judged else ""
        print(f"run {b} against {'run ' + str(a) + how if a is not None else 'bounds only (no earlier run)'}:")
        for line in regression_lines(regs, unmeasured):
            print(f"  {line}")
        for c, ch in changes:
            print(
                f"  CHANGE {c.measure}: {c.method} on {c.scene}: {ch.before:.6g} -> {ch.after:.6g} "
                f"({'worse' if ch.worse else 'better'}); {ch.cause}"
            )
    return 1 if regs else 0
