"""``harness compare [RUN_A] [RUN_B]``: what got worse between two stored runs (default: the
last two complete runs). Exit 1 when anything regressed."""
from __future__ import annotations

import json
from pathlib import Path

from scenarios import InvalidInput

from .. import validate
from ..compare import compare_runs, regression_lines
from ..nightly import DEFAULT_DB
from ..storage import History


def add_parser(sub):
    p = sub.add_parser("compare", help="list regressions between two stored runs")
    p.add_argument("run_a", nargs="?", default=None)
    p.add_argument("run_b", nargs="?", default=None)
    p.add_argument("--db", default=str(DEFAULT_DB))
    p.add_argument("--bounds", default=None, help="energy bounds file (default: the reviewed one)")
    p.add_argument("--json", action="store_true")
    return p


def run(args) -> int:
    from .. import bounds as bounds_mod

    if not Path(args.db).exists():
        raise InvalidInput(f"--db={args.db}: no such history (run `harness nightly` first)")
    run_a = validate.count("RUN_A", args.run_a, 1) if args.run_a is not None else None
    run_b = validate.count("RUN_B", args.run_b, 1) if args.run_b is not None else None
    if run_a is not None and run_b is None:
        run_a, run_b = None, run_a  # one id: compare that run with the run before it
    a, b, regs = compare_runs(History(args.db), run_a, run_b, Path(args.bounds) if args.bounds else bounds_mod.DEFAULT_PATH)
    if args.json:
        print(json.dumps({"run_a": a, "run_b": b, "regressions": [r.as_dict() for r in regs]}, indent=1, default=str))
    else:
        print(f"run {b} against {'run ' + str(a) if a is not None else 'bounds only (no earlier run)'}:")
        for line in regression_lines(regs):
            print(f"  {line}")
    return 1 if regs else 0
