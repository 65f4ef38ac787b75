"""``harness order SCENE --method M``: observed order, the slope of log error against log dt,
with the points used and those left out (and why)."""

from __future__ import annotations

from records import InvalidInput

from harness import validate
from harness.measures.order import MIN_POINTS, observed_order
from harness.cli.measure_args import add_common, emit, fmt, method_for, progress, scene_of, timeout_of


def add_parser(sub):
    p = sub.add_parser("order", help="observed order of accuracy from a timestep sweep")
    add_common(p)
    p.add_argument("--points", default="8", help=f"number of timesteps (>= {MIN_POINTS})")
    p.add_argument("--span", default="8", help="ratio of the largest to the smallest dt")
    p.add_argument("--periods", default="0.5", help="horizon in scene periods")
    p.add_argument("--order-hint", default=None, help="order used to choose the dt range (default: declared)")
    p.add_argument("--dt", action="append", help="fix the timesteps instead (repeat)")
    return p


def run(args) -> int:
    points = validate.count("--points", args.points, MIN_POINTS, validate.MAX_POINTS)
    span = validate.positive_finite("--span", args.span)
    if span <= 1.0:
        raise InvalidInput(f"--span={args.span} is out of range (allowed: finite, > 1)")
    periods = validate.positive_finite("--periods", args.periods)
    hint = validate.count("--order-hint", args.order_hint, 1) if args.order_hint is not None else None
    dts = [validate.positive_finite("--dt", x) for x in args.dt] if args.dt else None
    if dts is not None and len(dts) < MIN_POINTS:
        raise InvalidInput(f"--dt given {len(dts)} times (allowed: at least {MIN_POINTS} timesteps)")
    timeout = timeout_of(args)
    scene = scene_of(args)
    method = method_for(args.method, scene)
    with progress() as say:
        res = observed_order(
            method, scene, points=points, span=span, periods=periods, order=hint, dts=dts, timeout=timeout, progress=say
        )
    return emit(res, args.json, _lines, scene)


def _lines(r):
    yield (
        f"{r['method']} on {r['scene']}: observed order {fmt(r['order'], '.3f')} "
        f"(stderr {fmt(r['stderr'], '.2g')}; declared {fmt(r['order_declared'])}) over {r['periods']:g} periods"
    )
    yield f"  {'dt':>12s} {'h*omega':>10s} {'steps':>7s} {'error':>11s}"
    for p in sorted(r["points"] + r["excluded"], key=lambda p: p["dt"]):
        mark = f"  left out: {p['reason']}" if "reason" in p else ""
        yield f"  {p['dt']:12.5g} {p['omega_dt']:10.4g} {p['steps']:7d} {fmt(p['error'], '11.3e')}{mark}"
    if r.get("reason"):
        yield f"  no order: {r['reason']}"
