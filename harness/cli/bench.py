"""``harness bench``: ns per step of each reference scheme, compiled, on the single unit
spring and on a batch of 1000 springs, each beside its floor (the same scheme as one
hand-written loop of scalars) timed in the same run (:mod:`harness.bench.kernels`).
``harness bench --engines``: each engine mode beside a bare loop of its step call
(:mod:`harness.bench.engines`). Targets live there, not in timed unit tests."""

from __future__ import annotations

import json

from harness.bench.kernels import on_the_spring


def add_parser(sub):
    p = sub.add_parser("bench", help="ns per step of each reference scheme (compiled) beside its floor")
    p.add_argument("--json", action="store_true")
    p.add_argument("--methods", nargs="*", help="scheme ids, or engine mode ids with --engines (default: all)")
    p.add_argument(
        "--engines", action="store_true", help="engine modes: the engine's own loop beside a bare loop of its step call"
    )
    return p


def run(args) -> int:
    """The reference kernels beside their floors, or (``--engines``) the engine modes beside their
    bare loops: the same steps, validate the ids, measure, print JSON or lines."""
    from harness import validate

    if args.engines:
        import adapters

        from harness.bench import engines as bench

        valid = list(adapters.ENGINE_METHODS)
    else:
        from harness.bench import kernels as bench

        valid = on_the_spring()
    for mid in args.methods or ():
        validate.choice("method", mid, valid)
    result = bench.measure(args.methods)
    if args.json:
        print(json.dumps(result, indent=1))
        return 0
    for line in bench.lines(result):
        print(line)
    return 0
