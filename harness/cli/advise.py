"""``harness advise SCENE --hz 60 --energy-tol 1e-3``: the cheapest method, with the fewest
substeps, that keeps the scene stable and within the tolerances over the horizon, and why
each other method cannot (``harness.measures.advise``)."""

from __future__ import annotations

import sys

import os

from records import InvalidInput
from records.figures import limit_text
from scenarios import make_scene, parse_overrides

from harness import validate
from harness.measures.advise import ERROR_REL, HORIZON, MAX_SUBSTEPS, Request, advise, solve_note
from harness.measures.sweep import CAP, CLOCK, FACTOR, POINTS, family_name, parse_grid, run_sweep
from harness.cli.measure_args import emit, progress
from harness.sweep_findings import seed_claims


def add_parser(sub):
    p = sub.add_parser("advise", help="the cheapest method and substeps that meet tolerances at a frame rate")
    p.add_argument("scene", help="a scene, or contact: the engines' ball, slide and stack (harness contact)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    p.add_argument("--hz", required=True, help="frames per unit of simulated time (60 for 60 Hz)")
    p.add_argument(
        "--horizon", default=str(HORIZON), help=f"simulated time to hold the tolerances over (default {HORIZON:g})"
    )
    p.add_argument("--energy-tol", help="largest |E - E_exact| / max |E_exact| allowed over the horizon")
    p.add_argument(
        "--error-tol",
        default=f"{100 * ERROR_REL:g}%",
        help="largest position error allowed over the horizon: ABS in the scene's units, P%% of the "
        f"scene's length scale, or none (default {100 * ERROR_REL:g}%%)",
    )
    p.add_argument(
        "--methods",
        action="append",
        metavar="PATTERNS",
        help="comma-separated method ids or patterns (ref:*,mujoco:*); default: every method",
    )
    p.add_argument(
        "--max-substeps",
        default=str(MAX_SUBSTEPS),
        help=f"largest substep count tried (1, 2, 4, ...; default {MAX_SUBSTEPS})",
    )
    p.add_argument("--jobs", default=str(os.cpu_count() or 1), help="worker processes (default: the cores)")
    p.add_argument("--timeout", default="120", help="seconds one method's search may take")
    p.add_argument(
        "--sweep",
        metavar="NAME=LO..HI[:POINTS]",
        help="the advice at each value of a log grid of one scene parameter (k=1e2..1e6:9), each "
        "method searched past --max-substeps, and where the cheapest family changes",
    )
    p.add_argument("--points", help=f"values in the --sweep grid (default {POINTS})")
    p.add_argument(
        "--factor",
        default=str(FACTOR),
        help=f"a sweep searches a method on until its frame costs this many times the cheapest (default {FACTOR:g})",
    )
    p.add_argument("--sweep-max-substeps", default=str(CAP), help=f"... or its substeps pass this many (default {CAP})")
    p.add_argument("--json", action="store_true", help="print the advice and every measured row as JSON")
    return p


def position_tolerance(text) -> tuple[float | str | None, float | None]:
    """``--error-tol``: (absolute, relative) from ``ABS``, ``P%`` or ``none`` (InvalidInput, one line)."""
    t = str(text).strip()
    if t.lower() == "none":
        return None, None
    if t.endswith("%"):
        return None, validate.positive_finite("--error-tol", t[:-1]) / 100.0
    try:
        float(t)
    except ValueError:
        raise InvalidInput(
            f"--error-tol={text!r} is not a tolerance (allowed: ABS > 0 in the scene's units, "
            "P% of the scene's length scale, or none)"
        ) from None
    return t, None


def run(args) -> int:
    if args.scene == "contact":  # the contact scenes: which engine mode bounces, slides and rests, cheapest first
        from harness.cli.contact import advise_contact, contact_modes_matching

        hz = validate.positive_finite("--hz", args.hz)
        patterns = [p.strip() for item in args.methods or () for p in item.split(",") if p.strip()]
        return advise_contact(1.0 / hz, contact_modes_matching(patterns), as_json=args.json)  # profile by the step
    error_tol, error_rel = position_tolerance(args.error_tol)
    request = Request(
        hz=args.hz,
        horizon=args.horizon,
        energy_tol=args.energy_tol,
        error_tol=error_tol,
        max_substeps=args.max_substeps,
        error_rel=error_rel,
    ).checked()
    jobs = validate.count("--jobs", args.jobs, 1, 1024)
    timeout = validate.positive_finite("--timeout", args.timeout)
    patterns = [p.strip() for item in args.methods or () for p in item.split(",") if p.strip()]
    overrides = parse_overrides(args.set)
    scene = make_scene(args.scene, **overrides)
    if args.sweep is not None:
        grid = parse_grid(args.sweep, scene, args.points)
        if grid.param in overrides:
            raise InvalidInput(
                f"--sweep {grid.param} and --set {grid.param} name the same parameter (allowed: one of them)"
            )
        with progress() as say:
            result = run_sweep(
                scene,
                grid,
                request,
                patterns or None,
                factor=args.factor,
                cap=args.sweep_max_substeps,
                jobs=jobs,
                timeout=timeout,
                progress=say,
            )
        return emit(result.as_dict() if args.json else result, args.json, sweep_lines, scene)
    if args.points is not None:
        raise InvalidInput("--points is for a --sweep (allowed: with --sweep NAME=LO..HI)")
    if not patterns:
        patterns = default_patterns()
        print(
            "advise: "
            + "; ".join(
                f"{engine}'s modes left out ({why}; --methods '{engine}:*' adds them)"
                for engine, why in ON_REQUEST.items()
            )
            + " [--methods '*' runs every method]",
            file=sys.stderr,
        )
    with progress() as say:
        result = advise(scene, request, patterns, jobs=jobs, timeout=timeout, progress=say)
    return emit(result.as_dict() if args.json else result, args.json, _lines, scene)


#: Engines a single-scene advice runs only when asked (``--methods``): where their start-up, not the
#: scene, is the cost, so that a question on a built-in scene is answered in seconds. Warp compiles
#: and launches Newton's kernels; Drake builds a plant for every run of its fourteen modes (the
#: advice's limit search alone runs dozens). docs/performance.md has the durations.
ON_REQUEST = {
    "newton": "Warp's kernel start-up dominates a small scene",
    "drake": "a plant built for every run of fourteen modes",
}


def default_patterns() -> list[str]:
    """Every method but those of the engines run on request."""
    from harness.methods import all_methods

    return [m for m in all_methods() if m.split(":")[0] not in ON_REQUEST]


def _us(x) -> str:
    return "-" if x is None else f"{x * 1e6:.3g}"


def _g(x, spec=".2e") -> str:
    return "-" if x is None else format(x, spec)


def _converged(b, notes: dict) -> str:
    """The converged column: - (no convergence knob), yes, or no with the note saying why."""
    if b.converged is None:
        return "-"
    if b.converged["meets"]:
        return "yes"
    return f"no[{notes.setdefault(solve_note(b), len(notes) + 1)}]"


def _lines(a):
    from harness.measures.energy import MIN_PERIODS

    r = a.request
    params = ", ".join(f"{k}={v:g}" for k, v in a.params.items())
    yield (
        f"advise {a.scene} ({params}) at {r.hz:g} Hz over {r.horizon:g}: "
        f"{r.tolerances_text(a.length_scale, a.position_tol is not None)}; substeps 1..{r.max_substeps}"
    )
    yield a.verdict()
    yield ""
    yield "meets the tolerances (cheapest frame first; the fewest substeps that meet them):"
    w = max([len(m.method) for m in a.meeting + a.failing] + [len(x["method"]) for x in a.left_out] + [6])
    head = (
        f"  {'method':{w}s} {'substeps':>8s} {'h*omega':>8s} {'limit':>8s} {'energy err':>10s} {'class':>8s} "
        f"{'pos err':>9s} {'us/frame':>9s} {'evals/frame':>11s} {'converged':>9s}"
    )
    meeting = a.meeting
    notes: dict[str, int] = {}
    solves: dict[str, int] = {}
    if meeting:
        yield head
        for m in meeting:
            b = m.best_row
            evals = _g(b.evals_per_frame, ".4g")
            if b.evals_per_frame is None and m.evals_reason:
                evals += f"[{notes.setdefault(m.evals_reason, len(notes) + 1)}]"
            yield (
                f"  {m.method:{w}s} {b.substeps:8d} {b.homega:8.3g} {_limit(m):>8s} {_g(b.energy_error):>10s} "
                f"{b.energy_class or '-':>8s} {_g(b.position_error):>9s} {_us(b.cost_per_frame_s):>9s} "
                f"{evals:>11s} {_converged(b, solves):>9s}"
            )
        for reason, n in notes.items():
            yield f"  [{n}] evaluations not counted: {reason}"
        for why, n in solves.items():
            yield f"  no[{n}] {why}"
        if a.periods is not None and a.periods < MIN_PERIODS and any(m.best_row.energy_class is None for m in meeting):
            yield (
                f"  class -: the horizon holds {a.periods:.3g} periods of the scene's omega, fewer than the "
                f"{MIN_PERIODS:g} that tell a bounded band from a drift"
            )
        if any(m.best_row.converged is not None for m in meeting):
            yield (
                "  converged: each iterative method again at its substeps with its convergence knob tightened "
                "(ten times the passes, a tolerance a hundred times tighter): yes, it still meets them"
            )
    else:
        yield "  none"
    failing = a.failing
    if failing:
        yield ""
        yield "not advised (at every substep count tried: misses the tolerances, or its step is unstable):"
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
    if m.limit_verdict in ("unstable", "unresolved"):
        return "none"
    return "-" if m.homega_limit is None else limit_text(m.homega_limit)


#: What a method's cell in the sweep's table says of each way its search ended.
ENDED = {"cost": "cost", "cap": "cap", "crashed": "crash", "timed_out": "t/o"}


def _cell(e) -> str:
    if e.ended == "met":
        return f"{e.substeps}: {_us(e.cost_per_frame_s)}"
    said = ENDED.get(e.ended, e.ended or "-")
    return f"{said}@{e.next_substeps}" if e.next_substeps else said


def _pick(e, point=None) -> str:
    """A family's pick at one value: method, substeps x us per frame, its errors, * where its win
    rests on the solve's own error; ``~`` and the family's methods tied with it (``tied_with``)."""
    tied = [t for t in point.tied_with(e) if t.family == e.family] if point is not None else []
    return (
        f"{e.method} {e.substeps} x {_us(e.cost_per_frame_s)} (E {_g(e.energy_error, '.2g')}, "
        f"x {_g(e.position_error, '.2g')}){'*' if e.rests_on_solve else ''}"
        + "".join(f" ~ {t.method} {t.substeps} x {_us(t.cost_per_frame_s)}" for t in tied)
    )


def sweep_lines(sw):
    """The sweep as text: per value, each family's cheapest frame; the crossovers; then every
    method at every value (substeps: µs a frame, or the bound that ended its search)."""
    r = sw.request
    params = ", ".join(f"{k}={v:g}" for k, v in sw.params.items())
    g = sw.grid
    yield (
        f"sweep {sw.scene} ({params}) over {g.param} = {g.lo:g} .. {g.hi:g} ({len(g.values)} values, log) "
        f"at {r.hz:g} Hz over {r.horizon:g}: {r.tolerances_text(sw.length_scale)}"
    )
    yield (
        f"each method: substeps 1..{r.max_substeps}, then doubled until it meets them, its frame would cost "
        f"> {sw.factor:g} x the cheapest, or > {sw.cap} substeps; cost = substeps x compiled kernel / engine "
        f"step (a library solve, ?solver=: the Python loop that runs it), {CLOCK.upper()} clock"
    )
    yield ""
    families = list(dict.fromkeys(e.family for p in sw.points for e in p.entries))
    cells = []
    for p in sw.points:
        costs = p.family_costs()
        cells.append([_pick(e, p) if e else "-" for e in (costs.get(f) for f in families)])
    w = [max([len(family_name(f))] + [len(row[i]) for row in cells]) for i, f in enumerate(families)]
    yield (
        f"  {g.param:>9s} {'h*omega@1':>9s}  "
        + "  ".join(f"{family_name(f):{w[i]}s}" for i, f in enumerate(families))
        + "  cheapest (us per frame)"
    )
    for p, row in zip(sw.points, cells):
        best = p.cheapest
        rivals = sorted({e.family for e in p.tied_with(best)} - {best.family}) if best else []
        named = (
            "a tie: " + " / ".join(family_name(f) for f in [best.family, *rivals])
            if rivals
            else family_name(best.family)
            if best
            else "none"
        )
        shown = "  ".join(f"{c:{w[i]}s}" for i, c in enumerate(row))
        yield f"  {p.value:9.3g} {p.homega_one:9.3g}  {shown}  {named}"
    any_tie = any(p.cheapest is not None and p.tied_with(p.cheapest) for p in sw.points) or any(
        " ~ " in c for row in cells for c in row
    )
    yield (
        "  each pick: method, substeps x us per frame (E its energy error, x its position error)"
        + ("; ~ a method whose frame costs the same within the timing spread (a tie)" if any_tie else "")
        + (
            "; *: its win rests on the solve's own error (it misses the tolerances with its convergence knob tightened)"
            if any(e.rests_on_solve for p in sw.points for e in p.entries)
            else ""
        )
    )
    yield ""
    cross = sw.crossovers
    if not cross:
        fam = {p.cheapest.family for p in sw.points if p.cheapest}
        yield (
            "no crossover: the cheapest family is " + ", ".join(family_name(f) for f in sorted(fam)) + " at every value"
            if fam
            else "no crossover: no method meets the tolerances at any value"
        )
    for c in cross:
        above = next((e for p in sw.points if p.value == c.above for e in p.entries if e.method == c.to_method), None)
        rests = (
            f" ({c.to_method}'s win there rests on the solve's own error)"
            if above is not None and above.rests_on_solve
            else ""
        )
        yield (
            f"crossover: {family_name(c.from_family)} ({c.from_method}) -> {family_name(c.to_family)} "
            f"({c.to_method}) between {g.param}={c.below:.3g} and {c.above:.3g}: "
            f"{'about' if c.interpolated else 'midway,'} {g.param} = {c.value:.3g}, h*omega = {c.homega_one:.3g} "
            f"at one substep{rests}"
        )
    searched = {e.family for p in sw.points for e in p.entries}
    if {"explicit", "implicit"} <= searched:  # the seed's claims set the two families against each other
        yield ""
        yield "the seed's claims (stiff cloth to implicit Euler), judged at the stiffest value:"
        for claim in seed_claims(sw.points, g.param, r.energy_tol, r.accuracy):
            verdict = {True: "holds", False: "does not hold", None: "-"}[claim.ok]
            yield f"  {claim.name}: {verdict}; {claim.text.replace('`', '')}"
    yield ""
    yield (
        "every method (substeps: us per frame; cost@S: S substeps would pass the factor, not run; cap@S: past "
        "the most substeps):"
    )
    mw = max([len(e.method) for p in sw.points for e in p.entries] + [6])
    yield f"  {'method':{mw}s} " + " ".join(f"{p.value:>12.3g}" for p in sw.points)
    for i, e0 in enumerate(sw.points[0].entries if sw.points else []):
        yield f"  {e0.method:{mw}s} " + " ".join(f"{_cell(p.entries[i]):>12s}" for p in sw.points)
    if sw.left_out:
        yield ""
        yield "left out: " + ", ".join(x["method"] for x in sw.left_out)
