"""The work-precision Pareto front: the (cost, error) points no other point beats in both, as the
charts mark it and ``harness workprecision`` states it."""

from __future__ import annotations

import math


def pareto_front(curves: dict[str, tuple[list, list]]) -> list[tuple[float, float, str]]:
    """The work-precision Pareto front over every method's (cost, error) points ({method: (costs,
    errors)}): the points no other point beats in both cost and error, as (cost, error, method),
    cheapest first (so errors fall along it). Where two points tie in cost the smaller error
    stands; non-finite or non-positive figures take no part."""
    pts = sorted(
        (float(c), float(e), m)
        for m, (costs, errors) in curves.items()
        for c, e in zip(costs, errors)
        if c is not None and e is not None and math.isfinite(c) and math.isfinite(e) and c > 0 and e > 0
    )
    front, best = [], math.inf
    for c, e, m in pts:
        if e < best:
            front.append((c, e, m))
            best = e
    return front


def pareto_summary(front: list[tuple[float, float, str]]) -> list[str]:
    """The front in lines, one per stretch a method holds: from which cost to which, its errors."""
    out, run = [], []
    for point in front + [None]:
        if run and (point is None or point[2] != run[-1][2]):
            (c0, e0, m), (c1, e1, _) = run[0], run[-1]
            span = f"{c0:.3g}" if c0 == c1 else f"{c0:.3g} to {c1:.3g}"
            errs = f"{e0:.3g}" if e0 == e1 else f"{e0:.3g} down to {e1:.3g}"
            out.append(f"{m}: cost {span}, error {errs}")
            run = []
        if point is not None:
            run.append(point)
    return out
