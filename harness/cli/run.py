"""``harness run SCENE --method M --dt DT --steps N``: print the trajectory."""

from __future__ import annotations

import json
import sys

import numpy as np

from scenarios import make_scene, parse_overrides

from harness import validate
from harness.cli.measure_args import method_for, progress
from harness.methods import parse_options
from harness.execution.simulate import simulate

FORMATS = ("table", "csv", "json")


def add_parser(sub):
    p = sub.add_parser("run", help="step a method on a scene and print the trajectory")
    p.add_argument("scene")
    p.add_argument("--method", required=True, help="ref:NAME or ENGINE:MODE (see `harness list`)")
    p.add_argument("--dt", required=True)
    p.add_argument("--steps", required=True)
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter")
    p.add_argument(
        "--opt",
        action="append",
        metavar="KEY=VALUE",
        help="set a method option (ref:verlet_constrained: iterations=K projection passes per step)",
    )
    p.add_argument("--every", default="1", help="print every K-th step (the last is always printed)")
    p.add_argument("--format", default="table", help="table, csv or json")
    p.add_argument("--timeout", default="60", help="seconds an engine run may take")
    return p


def run(args) -> int:
    # Everything is validated before anything is stepped.
    fmt = validate.choice("--format", args.format, FORMATS)
    dt = validate.positive_finite("--dt", args.dt)
    steps = validate.count("--steps", args.steps, 0)
    every = validate.count("--every", args.every, 1)
    timeout = validate.positive_finite("--timeout", args.timeout)
    scene = make_scene(args.scene, **parse_overrides(args.set))
    method = method_for(args.method, scene, parse_options(args.opt))
    with progress() as say:
        say(f"run: stepping {method.id}, {steps} steps at dt {dt:g}")
        traj = simulate(method, scene, dt, steps, every, timeout=timeout)
    frame = traj.to_frame()
    out = sys.stdout
    if fmt == "csv":
        frame.to_csv(out, index=False, float_format="%.17g", lineterminator="\n")
    elif fmt == "json":
        json.dump(
            {**_jsonable(traj.summary()), "columns": list(frame.columns), "rows": frame.to_dict(orient="records")},
            out,
            indent=1,
            default=_default,
        )
        out.write("\n")
    else:
        out.write(frame.to_string(index=False, float_format=lambda x: f"{x:.6g}") + "\n")
    if not traj.ok:
        print(f"harness: {traj.method} on {traj.scene}: {traj.status}: {traj.detail}", file=sys.stderr)
    return 0 if traj.ok or traj.status == "unstable" else 1


def _default(x):
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)


def _jsonable(d):
    return json.loads(json.dumps(d, default=_default))
