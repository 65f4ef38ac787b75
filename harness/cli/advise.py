"""``harness advise SCENE --hz 60 --energy-tol 1e-3``: the cheapest method, with the fewest
substeps, that keeps the scene stable and within the tolerances over the horizon, and why
each other method cannot (``harness.measures.advise``)."""
from __future__ import annotations

import os

from scenarios import make_scene, parse_overrides

from harness import validate
from harness.measures.advise import HORIZON, MAX_SUBSTEPS, Request, advise
from harness.cli.measure_args import emit


def add_parser(sub):
    p = sub.add_parser("advise", help="the cheapest method and substeps that meet tolerances at a frame rate")
    p.add_argument("scene")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    p.add_argument("--hz", required=True, help="frames per unit of simulated time (60 for 60 Hz)")
    p.add_argument("--horizon", default=str(HORIZON), help=f"simulated time to hold the tolerances over "
                                                            f"(default {HORIZON:g})")
    p.add_argument("--energy-tol", help="largest |E - E_exact| / max |E_exact| allowed over the horizon")
    p.add_argument("--error-tol", help="largest absolute position error allowed over the horizon")
    p.add_argument("--methods", action="append", metavar="PATTERNS",
                   help="comma-separated method ids or patterns (ref:*,mujoco:*); default: every method")
    p.add_argument("--max-substeps", default=str(MAX_SUBSTEPS), help=f"largest substep count tried "
                                                                     f"(1, 2, 4, ...; default {MAX_SUBSTEPS})")
    p.add_argument("--jobs", default=str(os.cpu_count() or 1), help="worker processes (default: the cores)")
    p.add_argument("--timeout", default="120", help="seconds one method's search may take")
    p.add_argument("--json", action="store_true", help="print the advice and every measured row as JSON")
    return p


def run(args) -> int:
    request = Request(hz=args.hz, horizon=args.horizon, energy_tol=args.energy_tol, error_tol=args.error_tol,
                      max_substeps=args.max_substeps).checked()
    jobs = validate.count("--jobs", args.jobs, 1, 1024)
    timeout = validate.positive_finite("--timeout", args.timeout)
    patterns = [p.strip() for item in args.methods or () for p in item.split(",") if p.strip()]
    scene = make_scene(args.scene, **parse_overrides(args.set))
    result = advise(scene, request, patterns or None, jobs=jobs, timeout=timeout)
    return emit(result.as_dict() if args.json else result, args.json, _lines, scene)


def _us(x) -> str:
    return "-" if x is None else f"{x * 1e6:.3g}"


def _g(x, spec=".2e") -> str:
    return "-" if x is None else format(x, spec)


def _lines(a):
    r = a.request
    params = ", ".join(f"{k}={v:g}" for k, v in a.params.items())
    yield (f"advise {a.scene} ({params}) at {r.hz:g} Hz over {r.horizon:g}: {r.tolerances_text()}; "
           f"substeps 1..{r.max_substeps}")
    yield a.verdict()
    yield ""
    yield "meets the tolerances (cheapest frame first; the fewest substeps that meet them):"
    w = max([len(m.method) for m in a.meeting + a.failing] + [len(x["method"]) for x in a.left_out] + [6])
    head = (f"  {'method':{w}s} {'substeps':>8s} {'h*omega':>8s} {'limit':>8s} {'energy err':>10s} {'class':>8s} "
            f"{'pos err':>9s} {'us/frame':>9s} {'evals/frame':>11s}")
    meeting = a.meeting
    notes: dict[str, int] = {}
    if meeting:
        yield head
        for m in meeting:
            b = m.best_row
            evals = _g(b.evals_per_frame, ".4g")
            if b.evals_per_frame is None and m.evals_reason:
                evals += f"[{notes.setdefault(m.evals_reason, len(notes) + 1)}]"
            yield (f"  {m.method:{w}s} {b.substeps:8d} {b.homega:8.3g} {_limit(m):>8s} {_g(b.energy_error):>10s} "
                   f"{b.energy_class or '-':>8s} {_g(b.position_error):>9s} {_us(b.cost_per_frame_s):>9s} "
                   f"{evals:>11s}")
        for reason, n in notes.items():
            yield f"  [{n}] evaluations not counted: {reason}"
    else:
        yield "  none"
    failing = a.failing
    if failing:
        yield ""
        yield "cannot meet them (at every substep count tried):"
        for m in failing:
            yield f"  {m.method:{w}s} {m.reason}"
    if a.left_out:
        yield ""
        yield "left out:"
        for x in a.left_out:
            yield f"  {x['method']:{w}s} {x['reason']}"


def _limit(m) -> str:
    if m.limit_verdict == "unbounded":
        return ">" + format(m.limit_searched, ".3g")
    if m.limit_verdict == "unstable":
        return "none"
    return "-" if m.homega_limit is None else format(m.homega_limit, ".4g")
