"""``harness cost SCENE --method M --dt DT``: counted force evaluations and wall time per
step, and the ratio to (compiled) explicit Euler on the same scene and dt. An engine mode
shows two figures: ``engine s/step`` (its own loop; the ratio uses it) and ``as stepped by
the harness`` (one step at a time from Python)."""

from __future__ import annotations

from harness import validate
from harness.measures.cost import COUNT_STEPS, REPEATS, cost_per_step
from harness.cli.measure_args import add_common, emit, fmt, method_for, progress, scene_of, timeout_of


def add_parser(sub):
    p = sub.add_parser("cost", help="force evaluations and wall time per step")
    add_common(p)
    p.add_argument("--dt", required=True)
    p.add_argument("--repeats", default=str(REPEATS), help="timed repeats (the minimum is reported)")
    p.add_argument("--time-steps", default=None, help="steps per timed repeat (default: by method kind)")
    p.add_argument("--count-steps", default=str(COUNT_STEPS), help="steps of the counted run")
    return p


def run(args) -> int:
    dt = validate.positive_finite("--dt", args.dt)
    repeats = validate.count("--repeats", args.repeats, 1, 1000)
    time_steps = validate.count("--time-steps", args.time_steps, 1) if args.time_steps is not None else None
    count_steps = validate.count("--count-steps", args.count_steps, 1)
    timeout = timeout_of(args)
    scene = scene_of(args)
    method = method_for(args.method, scene)
    with progress() as say:
        res = cost_per_step(
            method,
            scene,
            dt,
            time_steps=time_steps,
            repeats=repeats,
            count_steps=count_steps,
            timeout=timeout,
            progress=say,
        )
    return emit(res, args.json, _lines, scene)


def _lines(r):
    yield f"{r.method} on {r.scene}, dt={r.dt:g}"
    evals = (
        fmt(r.force_evals_per_step, ".4g")
        if r.force_evals_per_step is not None
        else f"not counted ({r.force_evals_reason})"
    )
    yield f"  force evaluations per step: {evals}; solves per step: {fmt(r.solves_per_step, '.4g')}"
    if r.solver is not None:
        yield (
            f"  its solve's iterations per step: {fmt(r.solver_iterations_per_step, '.4g')}; solves stopped short "
            f"of their tolerance: {r.unconverged_solves} over {r.count_steps} steps"
        )
    label = "engine s/step" if r.as_stepped is not None else "wall time per step"
    yield (
        f"  {label}: {r.s_per_step * 1e9:.1f} ns (median {r.median_s_per_step * 1e9:.1f}, "
        f"spread {fmt(r.rel_spread, '.1%')}; {r.timing})"
    )
    if r.engine_loop:
        yield f"    the engine's loop: {r.engine_loop}"
    if r.as_stepped is not None:
        a = r.as_stepped
        yield (
            f"  as stepped by the harness: {a['s_per_step'] * 1e9:.1f} ns (median {a['median_s_per_step'] * 1e9:.1f}, "
            f"spread {fmt(a['rel_spread'], '.1%')}; {a['time_steps']} steps; state read and forces applied every "
            f"step), {a['s_per_step'] / r.s_per_step:.3g}x the engine's own loop"
        )
    if r.ratio_to_explicit_euler is None:
        yield f"  no ratio to {r.baseline['method']}: {r.baseline['unsupported']}"
    else:
        yield (
            f"  ratio to {r.baseline['method']} ({r.baseline['s_per_step'] * 1e9:.1f} ns/step): "
            f"{r.ratio_to_explicit_euler:.3g}"
        )
