"""``harness bench``: ns per step of each reference scheme, compiled, on the single unit
spring and on a batch of 1000 springs. Targets live here, not in timed unit tests.
``harness bench --engines``: each engine mode beside a bare loop of its step call
(:mod:`harness.engine_bench`)."""
from __future__ import annotations

import json

from reference import METHODS
from reference._compiled import time_per_step
from scenarios import make_scene

#: Targets from the design: explicit schemes <= 100 ns/step on one spring; the batch of
#: 1000 <= 1 ns per spring-step for semi-implicit Euler.
SINGLE_TARGET_NS = 100.0
BATCH_TARGET_NS = 1.0
EXPLICIT_TARGETED = ("explicit_euler", "semi_implicit_euler", "semi_implicit_euler_position_first")


#: The bench runs on the spring, which has no constraints: constrained schemes
#: (ref:verlet_constrained) are measured on the rope by ``harness.rope_study``.
UNCONSTRAINED = [sid for sid, s in METHODS.items() if not s.constrained]


def add_parser(sub):
    p = sub.add_parser("bench", help="ns per step of each reference scheme (compiled)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--methods", nargs="*", help="scheme ids, or engine mode ids with --engines (default: all)")
    p.add_argument("--engines", action="store_true",
                   help="engine modes: the engine's own loop beside a bare loop of its step call")
    return p


def measure(scheme_ids=None) -> list[dict]:
    spring = make_scene("spring")
    rows = []
    for sid in scheme_ids or UNCONSTRAINED:
        s = METHODS[sid]
        single = time_per_step(s, spring, 0.01, 200_000)
        batch = time_per_step(s, spring, 0.01, 2_000, batch=1000)
        row = {"method": f"ref:{sid}", "single_ns_per_step": single["s_per_step"] * 1e9,
               "batch1000_ns_per_spring_step": batch["s_per_step"] * 1e9 / 1000,
               "single_median_ns": single["median_s_per_step"] * 1e9,
               "batch1000_median_ns": batch["median_s_per_step"] * 1e9 / 1000}
        if sid in EXPLICIT_TARGETED:
            row["single_target_ns"] = SINGLE_TARGET_NS
            row["single_meets_target"] = row["single_ns_per_step"] <= SINGLE_TARGET_NS
        if sid == "semi_implicit_euler":
            row["batch_target_ns"] = BATCH_TARGET_NS
            row["batch_meets_target"] = row["batch1000_ns_per_spring_step"] <= BATCH_TARGET_NS
        rows.append(row)
    return rows


def run(args) -> int:
    from .. import validate

    if args.engines:
        return _run_engines(args)
    for sid in args.methods or ():
        validate.choice("method", sid, UNCONSTRAINED)
    rows = measure(args.methods)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"{'method':42s} {'1 spring ns/step':>17s} {'1000 springs ns/spring-step':>28s}  target")
    for r in rows:
        target = ""
        if "single_meets_target" in r:
            target += f"single <= {SINGLE_TARGET_NS:g} ns: {'met' if r['single_meets_target'] else 'MISSED'}"
        if "batch_meets_target" in r:
            target += f"; batch <= {BATCH_TARGET_NS:g} ns: {'met' if r['batch_meets_target'] else 'MISSED'}"
        print(f"{r['method']:42s} {r['single_ns_per_step']:17.1f} {r['batch1000_ns_per_spring_step']:28.3f}  {target}")
    return 0


def _run_engines(args) -> int:
    import adapters

    from .. import engine_bench, validate

    for mid in args.methods or ():
        validate.choice("method", mid, list(adapters.ENGINE_METHODS))
    rows = engine_bench.measure(args.methods)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    for line in engine_bench.lines(rows):
        print(line)
    return 0
