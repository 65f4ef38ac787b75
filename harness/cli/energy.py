"""``harness energy SCENE --method M --dt DT --steps N``: relative energy error against the
exact energy and its classification (grows / bounded / decays / drifts)."""

from __future__ import annotations

from harness import validate
from harness.measures.energy import energy_behaviour
from harness.cli.measure_args import add_common, emit, fmt, method_for, progress, scene_of, timeout_of


def add_parser(sub):
    p = sub.add_parser("energy", help="energy error series and its classification")
    add_common(p)
    p.add_argument("--dt", required=True)
    p.add_argument("--steps", required=True)
    p.add_argument("--every", default="1", help="record every K-th step")
    p.add_argument("--series", action="store_true", help="include t and dE/E at every recorded step (JSON)")
    return p


def run(args) -> int:
    dt = validate.positive_finite("--dt", args.dt)
    steps = validate.count("--steps", args.steps, 1)
    every = validate.count("--every", args.every, 1)
    timeout = timeout_of(args)
    scene = scene_of(args)
    method = method_for(args.method, scene)
    with progress() as say:
        res = energy_behaviour(method, scene, dt, steps, every=every, timeout=timeout, series=args.series, progress=say)
    return emit(res, args.json, _lines, scene)


def _lines(r):
    yield (
        f"{r['method']} on {r['scene']}, dt={r['dt']:g} (h*omega={r['omega_dt']:.4g}), {r['steps']} steps "
        f"({r['periods']:.3g} periods): {r['status']}"
    )
    yield f"  max |dE/E| {fmt(r.get('max_rel_error'), '.3e')}   final |dE/E| {fmt(r.get('final_rel_error'), '.3e')}"
    yield f"  classification: {r.get('classification') or 'none'} ({r.get('rule')})"
    for ev in r.get("events") or ():
        yield f"  event: {ev['text']}"
    if r.get("state_error_max") is not None:
        yield (
            f"  state error (phase and amplitude, against the {r['state_error_source']} solution): max "
            f"{fmt(r['state_error_max'], '.3e')}   final {fmt(r['state_error_final'], '.3e')}"
            f" (compared to t = {r['state_error_t_compared']:g})"
        )
    if "first_tenth_envelope" in r:
        yield (
            f"  envelope first tenth {r['first_tenth_envelope']:.3e}, last tenth {r['last_tenth_envelope']:.3e}, "
            f"secular rate {r['secular_rate']:.3e} per unit time"
        )
    if r.get("short_horizon"):
        yield "  note: fewer than 10 periods; the classification wants a longer run"
