"""``harness identify SCENE --method M``: which reference scheme an engine mode integrates.

Exit status: 0 when a reference scheme matches within roundoff, 1 when none does (or the
run failed), 2 on bad input; so a new engine version can be checked in one command.
"""

from __future__ import annotations

import json
import math

from scenarios import make_scene, parse_overrides

from harness import validate
from harness.cli.measure_args import method_for, progress
from harness.measures.identify import format_report, identify


def add_parser(sub):
    p = sub.add_parser("identify", help="which reference scheme a method matches, and how closely")
    p.add_argument("scene")
    p.add_argument("--method", required=True, help="ENGINE:MODE or ref:NAME (see `harness list`)")
    p.add_argument("--dt", help="timestep (default: the scene's period / 100)")
    p.add_argument("--steps", help="number of steps (default: 1000, ten periods)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    p.add_argument("--timeout", default="60", help="seconds an engine run may take")
    p.add_argument("--json", action="store_true")
    return p


def run(args) -> int:
    # Everything is validated before anything is stepped.
    dt = None if args.dt is None else validate.positive_finite("--dt", args.dt)
    steps = None if args.steps is None else validate.count("--steps", args.steps, 1)
    timeout = validate.positive_finite("--timeout", args.timeout)
    scene = make_scene(args.scene, **parse_overrides(args.set))
    method = method_for(args.method, scene)
    with progress() as say:  # the candidates step on the nightly's compiled path, as the method does
        result = identify(method, scene, dt, steps, timeout=timeout, compiled_where_bitwise=True, progress=say)
    if args.json:
        out = result.as_dict()
        print(json.dumps(_finite({"model_note": scene.model_note, **out} if scene.model_note else out), indent=1))
    else:
        if scene.model_note:
            print(f"{scene.id}: {scene.model_note}")
        print(format_report(result))
    return 0 if result.matches else 1


def _finite(x):
    """JSON has no inf: a deviation that is not finite (runs of different length) becomes null."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x
