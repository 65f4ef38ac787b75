"""The advice over a grid of one scene parameter: where the cheapest way to meet a user's
tolerances changes family (``harness advise SCENE --sweep k=1e2..1e6:9``).

At each value of the grid (a log grid, LO to HI in ``points`` values, each checked against the
parameter's declared range before anything runs) every candidate method is searched over
substeps 1, 2, 4, ... up to ``max_substeps``, fewest first, each level measured and judged as
``harness.measures.advise`` judges it (``ascend``; where no position tolerance is asked nothing is
held against the scene's reference solution, which on a stiff 32 x 32 cloth costs more than the
whole search: a run that blows up fails the energy tolerance). A method
that meets the tolerances at none of them is searched on, doubling its substeps, until it meets
them, or until its next level's cost per frame (substeps x its cost per step, timed before the
run) would pass ``factor`` times the cheapest frame found at that value (the bound ``cost``), or
its substeps would pass ``cap`` (the bound ``cap``); which bound ended each search is recorded.
A chart then shows whether an explicit scheme takes 20 or 2000 substeps where it still can.

Cost per frame is substeps x the method's cost per step, as the advice times it: the compiled
kernel of a reference scheme, the engine mode's step, on the CPU clock, timed at the step of the
row that meets the tolerances (a method searched beyond ``max_substeps`` is timed first at its
first level there, to bound its search, and again where it meets them).

A method's **family** is what it declares: a reference scheme its kind (``reference.kinds``:
explicit, implicit, constrained, ..., any kind added later its own family), an engine mode
``explicit`` (the method protocol declares no kind for an engine mode). The **crossover** is
where the cheapest method's family changes from one value of the grid to the next; its value
and h*omega at one substep are estimated where the two families' cheapest frames cross, by
log-log interpolation between the two values (their geometric midpoint where one family has no
cost at one of them).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from records import InvalidInput
from records.advice import Crossover, MethodAdvice, SweepEntry, SweepPoint, family_name  # noqa: F401

from harness import validate
from harness.measures.advise import Request

#: Values in a grid unless the user asks for another number.
POINTS = 9
MAX_POINTS = 50
#: A search beyond ``max_substeps`` stops where the next level's frame would cost more than this
#: many times the cheapest frame found at that value ...
FACTOR = 10.0
#: ... or where its substeps would pass this many.
CAP = 4096
#: What the costs are timed on (``harness.measures.advise``).
CLOCK = "cpu"

_GRID = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^.:][^:]*?)\s*\.\.\s*([^:]+?)\s*(?::\s*(\S+))?\s*$")


def family_of(method) -> str:
    """The family a method declares: a reference scheme's kind, else ``explicit``."""
    scheme = method.scheme
    return scheme.kind.name if scheme is not None else "explicit"


@dataclass(frozen=True)
class Grid:
    """A log grid of one scene parameter."""

    param: str
    lo: float
    hi: float
    values: tuple[float, ...]

    @property
    def text(self) -> str:
        return f"{self.param}={self.lo:g}..{self.hi:g}:{len(self.values)}"


def parse_grid(text: str, scene, points=None) -> Grid:
    """``"k=1e2..1e6"`` (``points`` values, default POINTS) or ``"k=1e2..1e6:9"`` -> the log grid,
    checked against ``scene``'s declared parameters and their ranges (InvalidInput, one line,
    naming the field and what it may be)."""
    form = "NAME=LO..HI or NAME=LO..HI:POINTS, e.g. k=1e2..1e6:9"
    m = _GRID.match(str(text))
    if not m:
        raise InvalidInput(f"--sweep {text!r} is not a grid (allowed: {form})")
    name, lo_text, hi_text, n_text = m.groups()
    params = scene.params
    if name not in params:
        raise InvalidInput(f"--sweep parameter {name!r} is not a parameter of scene {scene.id} "
                           f"(valid: {', '.join(params) or 'none'})")
    if n_text is not None and points is not None and validate.count("--points", points, 2, MAX_POINTS) != \
            validate.count("--sweep points", n_text, 2, MAX_POINTS):
        raise InvalidInput(f"--sweep {text!r} and --points={points} give two numbers of points (allowed: one of them)")
    n = validate.count("--sweep points" if n_text is not None else "--points",
                       n_text if n_text is not None else (POINTS if points is None else points), 2, MAX_POINTS)
    ends = []
    for which, t in (("LO", lo_text), ("HI", hi_text)):
        try:
            ends.append(float(t))
        except ValueError:
            raise InvalidInput(f"--sweep {name} {which}={t!r} is not a number (allowed: {form})") from None
    lo, hi = ends
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo < hi):
        raise InvalidInput(f"--sweep {name}={lo:g}..{hi:g} is not a log grid (allowed: finite 0 < LO < HI)")
    spec = params[name]
    for v in (lo, hi):
        try:
            spec.check(name, v)
        except InvalidInput as exc:
            raise InvalidInput(f"--sweep: {exc}") from None
    values = np.geomspace(lo, hi, n)
    values[0], values[-1] = lo, hi  # the ends exactly as given
    if spec.integer:
        values = np.unique(np.round(values))
        if len(values) < 2:
            raise InvalidInput(f"--sweep {name}={lo:g}..{hi:g} holds fewer than 2 integers (allowed: integer "
                               f"parameter {name} over a range with at least 2)")
    for v in values:  # every value through the scene's own checks, its cross-parameter ones too
        scene.copy_with(**{**scene.values, name: float(v)})
    return Grid(name, lo, hi, tuple(float(v) for v in values))


# ----------------------------------------------------------------------------- one value
def _entry_from(advice: MethodAdvice, family: str) -> SweepEntry:
    """A method's entry from its search up to ``max_substeps``."""
    searched = max((r.substeps for r in advice.rows if r.status != "skipped"), default=0)
    if advice.status != "ok":
        return SweepEntry(advice.method, family, advice.status, searched=searched, why=advice.reason)
    best = advice.best_row
    if best is None:
        return SweepEntry(advice.method, family, "", searched=searched, why=advice.reason)
    return SweepEntry(advice.method, family, "met", best.substeps, best.h, best.homega, advice.cost_per_step_s,
                      best.cost_per_frame_s, best.energy_error, best.position_error, searched=searched)


def search_on(method, scene, request: Request, advice: MethodAdvice, substeps: int, cost_per_step: float | None,
              ceiling: float | None, *, timeout=None, injected=None) -> dict:
    """One level beyond ``max_substeps``: ``cost_per_step`` timed first where unknown; where
    ``ceiling`` (factor x the cheapest frame, seconds) is known and ``substeps`` x the cost per
    step passes it, nothing is run (``ended`` ``cost``); else the horizon run at ``substeps``,
    judged as the advice judges it, and the cost per step timed again at its step where it
    meets the tolerances. Runs in the caller's process."""
    from harness.measures.advise import _cost_per_step, _row
    from harness.measures.common import resolve

    method = resolve(method, scene)
    h = 1.0 / (request.hz * substeps)
    timing = ""
    if cost_per_step is None:
        cost_per_step, timing = _cost_per_step(method, scene, h, injected)
    if ceiling is not None and cost_per_step is not None and substeps * cost_per_step > ceiling:
        return {"ended": "cost", "cost_per_step_s": cost_per_step, "row": None}
    row = _row(method, scene, request, substeps, advice, timeout, reference=False)
    out = {"ended": "", "cost_per_step_s": cost_per_step, "row": row}
    if row.status in ("crashed", "timed_out"):
        out["ended"] = row.status
    elif row.meets:
        out["ended"] = "met"
        out["cost_per_step_s"], timing = _cost_per_step(method, scene, h, injected)
    out["timing"] = timing
    return out


def sweep_value(scene, value: float, request: Request, methods: list, *, factor: float = FACTOR, cap: int = CAP,
                call=None, timeout=None, injected=None) -> SweepPoint:
    """Every method of ``methods`` (ids) at one value (``scene`` built at it): the advice's
    search, then the search on beyond ``max_substeps`` (module docstring). ``call(fn, args)``
    runs one method's step of the search (default: in this process); the methods' searches of
    one round run side by side where ``call`` does."""
    from harness.methods import active_plugins

    call = call or _in_process
    plugins = active_plugins()
    point = SweepPoint(float(value), float(scene.omega), float(scene.omega / request.hz))
    advices = dict(zip(methods, call_all(call, [(_advise_one, (m, scene, request, timeout, injected, plugins))
                                                for m in methods])))
    entries: dict[str, SweepEntry] = {}
    for mid, res in advices.items():
        if isinstance(res, tuple):  # (MethodAdvice, family)
            entries[mid] = _entry_from(*res)
        else:  # the worker failed: its status and why
            entries[mid] = SweepEntry(mid, _family_by_id(mid), getattr(res, "status", "crashed"),
                                      why=f"{getattr(res, 'status', 'crashed')}: {getattr(res, 'detail', res)}")
    level = request.substeps[-1] * 2
    open_ = [m for m, e in entries.items() if e.ended == ""]
    costs: dict[str, float | None] = {m: None for m in open_}
    while open_:
        met = [e.cost_per_frame_s for e in entries.values() if e.ended == "met" and e.cost_per_frame_s]
        ceiling = factor * min(met) if met else None
        if level > cap:
            for m in open_:
                entries[m].ended = "cap"
                entries[m].why = f"no level up to {cap} substeps meets them" + (
                    f" ({entries[m].why})" if entries[m].why else "")
            break
        jobs = [(_search_on_one, (m, scene, request, advices[m][0], level, costs[m], ceiling, timeout, injected,
                                   plugins))
                for m in open_]
        for m, res in zip(list(open_), call_all(call, jobs)):
            e = entries[m]
            if not isinstance(res, dict):
                e.ended, e.why = getattr(res, "status", "crashed"), str(getattr(res, "detail", res))
                open_.remove(m)
                continue
            costs[m] = e.cost_per_step_s = res["cost_per_step_s"]
            row = res["row"]
            if res["ended"] == "cost":
                e.ended = "cost"
                e.why = (f"{level} substeps would cost {_us(level * costs[m])} a frame, past {factor:g} x the "
                         f"cheapest ({_us(ceiling / factor)})")
            elif row is not None:
                e.searched = level
                if res["ended"] == "met":
                    e.ended, e.substeps, e.h, e.homega = "met", level, row.h, row.homega
                    e.cost_per_frame_s = level * e.cost_per_step_s
                    e.energy_error, e.position_error = row.energy_error, row.position_error
                    e.why = ""
                elif res["ended"]:
                    e.ended, e.why = res["ended"], row.why
                else:
                    e.why = f"{row.why} at {level} substeps"
            if e.ended:
                open_.remove(m)
        level *= 2
    point.entries = [entries[m] for m in methods]
    return point


def _us(seconds: float | None) -> str:
    return "?" if seconds is None else f"{seconds * 1e6:.3g} µs"


def _in_process(fn, args):
    return fn(*args)


def call_all(call, jobs: list) -> list:
    """``call(fn, args)`` of every job, side by side where ``call`` has threads to spare
    (``call.jobs``), in order."""
    width = getattr(call, "jobs", 1)
    if width <= 1 or len(jobs) <= 1:
        return [call(fn, args) for fn, args in jobs]
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(width) as threads:
        return list(threads.map(lambda job: call(*job), jobs))


def _family_by_id(method_id: str) -> str:
    from harness.methods import get_method

    try:
        return family_of(get_method(method_id))
    except Exception:  # noqa: BLE001 - a method that cannot be looked up still gets its row
        return "explicit"


def _method(method_id: str):
    from reference import Exact

    from harness.methods import get_method

    # A reference scheme runs on its exact compiled path, as ``harness advise`` runs it.
    return get_method(method_id, exact=Exact())


def ascend(method, scene, request: Request, *, timeout=None, injected=None) -> MethodAdvice:
    """One method's search up to ``max_substeps``, fewest substeps first: 1, 2, 4, ... until a level
    meets the tolerances (the fewest that do, for a convergent method), each row measured and
    judged as ``harness.measures.advise`` measures it (with its stability limit on a linear scene),
    nothing held against the scene's reference solution unless a position tolerance is asked.
    The advice bisects from the most substeps down; a sweep mostly meets stiff scenes' implicit
    solves at one or two substeps, where that order would first pay for sixteen."""
    from harness.measures.advise import _cost_per_step, _limit, _reason, _row
    from harness.measures.common import resolve

    method = resolve(method, scene)
    out = MethodAdvice(method.id)
    try:
        out.homega_limit, out.limit_verdict, out.limit_searched = _limit(method, scene, request, timeout)
    except InvalidInput as exc:  # the one-step map cannot be measured: each step is judged by its run
        out.limit_verdict = f"not measured ({exc})"
    for s in request.substeps:
        row = _row(method, scene, request, s, out, timeout, reference=False)
        out.rows.append(row)
        if row.status in ("crashed", "timed_out"):
            break
        if row.meets:
            out.best = len(out.rows) - 1
            out.cost_per_step_s, out.cost_timing = _cost_per_step(method, scene, row.h, injected)
            row.cost_per_frame_s = s * out.cost_per_step_s
            break
    if out.best is None:
        out.reason = _reason(out, request)
    return out


def _advise_one(method_id, scene, request, timeout, injected, plugins=()):
    from harness.methods import use_plugins

    use_plugins(plugins)
    method = _method(method_id)
    return ascend(method, scene, request, timeout=timeout, injected=injected), family_of(method)


def _search_on_one(method_id, scene, request, advice, level, cost, ceiling, timeout, injected, plugins=()):
    from harness.methods import use_plugins

    use_plugins(plugins)
    return search_on(_method(method_id), scene, request, advice, level, cost, ceiling, timeout=timeout,
                     injected=injected)


# ----------------------------------------------------------------------------- the crossover
def family_costs(point: SweepPoint) -> dict[str, SweepEntry]:
    """Each family's cheapest entry that meets the tolerances at one value."""
    out: dict[str, SweepEntry] = {}
    for e in point.met:
        out.setdefault(e.family, e)
    return out


def crossovers(points: list[SweepPoint]) -> list[Crossover]:
    """Where the cheapest method's family changes between neighbouring values of the grid
    (module docstring): one ``Crossover`` per change, in grid order. A value where no method
    meets the tolerances breaks the chain (no change is read across it)."""
    out = []
    for a, b in zip(points, points[1:]):
        ca, cb = a.cheapest, b.cheapest
        if ca is None or cb is None or ca.family == cb.family:
            continue
        fa, fb = family_costs(a), family_costs(b)
        t, interpolated = 0.5, False
        old, new = ca.family, cb.family
        if all(f in costs for f in (old, new) for costs in (fa, fb)):
            d0 = math.log(fa[old].cost_per_frame_s / fa[new].cost_per_frame_s)  # < 0: the old family cheaper
            d1 = math.log(fb[old].cost_per_frame_s / fb[new].cost_per_frame_s)  # > 0: the new one
            if d0 < 0.0 < d1:
                t, interpolated = d0 / (d0 - d1), True
        value = math.exp(math.log(a.value) + t * (math.log(b.value) - math.log(a.value)))
        homega = math.exp(math.log(a.homega_one) + t * (math.log(b.homega_one) - math.log(a.homega_one)))
        out.append(Crossover(a.value, b.value, old, new, ca.method, cb.method, value, homega, interpolated))
    return out


# ----------------------------------------------------------------------------- the sweep
@dataclass
class Sweep:
    scene: str
    params: dict
    grid: Grid
    request: Request
    factor: float
    cap: int
    points: list
    left_out: list

    @property
    def crossovers(self) -> list[Crossover]:
        return crossovers(self.points)

    def as_dict(self) -> dict:
        from dataclasses import asdict

        return {"scene": self.scene, "params": self.params, "param": self.grid.param, "grid": list(self.grid.values),
                "request": asdict(self.request), "factor": self.factor, "cap": self.cap, "clock": CLOCK,
                "points": [p.as_dict() for p in self.points],
                "crossovers": [c.as_dict() for c in self.crossovers], "left_out": self.left_out}


def run_sweep(scene, grid: Grid, request: Request, patterns=None, *, factor: float = FACTOR, cap: int = CAP,
              jobs: int = 1, timeout: float = 120.0, pool: bool = True) -> Sweep:
    """The sweep of ``scene`` (its other parameters as given) over ``grid``: every candidate
    method (``patterns``, as ``harness advise`` takes them) at every value. ``pool``: each
    method's search in ``jobs`` reused worker processes (an engine that aborts or hangs costs its
    entry a ``crashed`` / ``timed_out``), else in this process (a nightly task's worker)."""
    from harness.measures.advise import candidates
    from harness.measures.injected import load_injected

    request = request.checked()
    factor = validate.positive_finite("--factor", factor)
    if factor < 1.0:
        raise InvalidInput(f"--factor={factor:g} is out of range (allowed: >= 1)")
    cap = validate.count("--sweep-max-substeps", cap, request.substeps[-1])
    injected = load_injected()
    scenes = [scene.copy_with(**{**scene.values, grid.param: v}) for v in grid.values]
    for s in scenes:
        validate.scene_values(s)
    ids, left = candidates(scenes[0], patterns)
    points = []
    if pool:
        from harness.execution.pool import WorkerPool

        with WorkerPool(max(1, min(jobs, len(ids) or 1))) as workers:
            call = _PoolCall(workers, timeout, jobs)
            for v, s in zip(grid.values, scenes):
                points.append(sweep_value(s, v, request, ids, factor=factor, cap=cap, call=call, timeout=timeout,
                                          injected=injected))
    else:
        for v, s in zip(grid.values, scenes):
            points.append(sweep_value(s, v, request, ids, factor=factor, cap=cap, timeout=timeout, injected=injected))
    return Sweep(scene.id, {k: v for k, v in scene.values.items() if k != grid.param}, grid, request, factor, cap,
                 points, left)


class _PoolCall:
    """``call(fn, args)`` in a pool worker, within ``timeout``; a failure comes back as the
    pool's ``WorkerFailure``."""

    def __init__(self, pool, timeout, jobs):
        self.pool, self.timeout, self.jobs = pool, timeout, max(1, int(jobs))

    def __call__(self, fn, args):
        return self.pool.call(fn, args, timeout=self.timeout)
