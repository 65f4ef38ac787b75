"""``harness history``: a cell's stored series across the complete runs of a suite, and the steps
found in it (``harness.history.series``). Exit 1 when the latest run's cost regressed by the history's
judgement, as ``harness compare`` would say."""

from __future__ import annotations

import json
from pathlib import Path

from records import InvalidInput

from harness import validate
from records.measures import trended

from harness.history.series import WINDOW, load
from harness.nightly.run import DEFAULT_DB
from harness.history.storage import MEASUREMENT_VERSION, History


def add_parser(sub):
    p = sub.add_parser("history", help="a cell's series across stored runs, and the steps detected in it")
    p.add_argument("--scene", default=None)
    p.add_argument("--method", default=None)
    p.add_argument("--measure", default=None, help="one of the trended measures (harness list)")
    p.add_argument("--last", default=None, help=f"the last N complete runs (default: {WINDOW})")
    p.add_argument("--suite", default=None, help="the suite (default: the latest complete run's)")
    p.add_argument(
        "--measurement-version",
        default=None,
        help=f"read runs of another measurement version (default: this harness's, {MEASUREMENT_VERSION})",
    )
    p.add_argument("--db", default=str(DEFAULT_DB))
    p.add_argument("--json", action="store_true")
    return p


def _fmt(x) -> str:
    if x is None:
        return "–"
    return format(x, ".4g")


def run(args) -> int:
    last = validate.count("--last", args.last, 1) if args.last is not None else None
    version = (
        validate.count("--measurement-version", args.measurement_version, 1)
        if args.measurement_version is not None
        else MEASUREMENT_VERSION
    )
    if args.measure is not None:
        validate.choice("--measure", args.measure, list(trended()))
    if not Path(args.db).exists():
        raise InvalidInput(f"--db={args.db}: no such history (run `harness nightly` first)")
    trend = load(
        History(args.db),
        suite=args.suite,
        measurement_version=version,
        last=last,
        scene=args.scene,
        method=args.method,
        measure=args.measure,
    )
    if args.json:
        print(json.dumps(trend.as_dict(), indent=1, default=str))
        return 1 if trend.regressions() else 0
    ids = trend.run_ids
    print(
        f"{trend.suite} suite, measurement version {trend.measurement_version}: {len(ids)} complete run(s), "
        f"{ids[0]}..{ids[-1]}; cost judged {'over the history' if trend.judged else 'by the last two runs'}"
    )
    if trend.left_out:
        print(trend.left_out)
    if not trend.cells:
        print("no stored cell matches")
    for cell in trend.cells:
        dt = f" dt={cell.dt:g}" if cell.dt is not None else ""
        noise = f", noise {cell.fit.noise:.1%}" if cell.fit is not None else ""
        print(f"{cell.method} on {cell.scene}{dt}: {cell.measure} [{cell.unit}{noise}]")
        print(
            "  "
            + "  ".join(
                f"r{p.run_id}={_fmt(p.value) if p.value is not None else p.status}"
                + (f"±{p.spread:.0%}" if p.spread else "")
                for p in cell.points
            )
        )
        for ch in cell.changes:
            conf = f", confidence {ch.confidence:.3f}" if ch.confidence is not None else ""
            size = f" ({ch.size:+.1%})" if ch.size is not None else ""
            print(
                f"  {'worse' if ch.worse else 'better'} at run {ch.run_id}: {_fmt(ch.before)} -> {_fmt(ch.after)}"
                f"{size}{conf}; {ch.cause}"
            )
        for ch in cell.machine_steps:
            conf = f", confidence left {ch.confidence:.3f}" if ch.confidence is not None else ""
            print(
                f"  machine noise at run {ch.run_id}: {_fmt(ch.before)} -> {_fmt(ch.after)} ({ch.size:+.1%}{conf}); "
                f"{ch.cause}"
            )
        if cell.regression is not None:
            print(f"  REGRESSION {cell.regression.line()}")
    return 1 if trend.regressions() else 0
