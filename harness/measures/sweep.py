"""The advice over a grid of one scene parameter: where the cheapest way to meet a user's
tolerances changes family (``harness advise SCENE --sweep k=1e2..1e6:9``).

At each value of the grid (a log grid, LO to HI in ``points`` values, each checked against the
parameter's declared range before anything runs) every candidate method is searched over
substeps 1, 2, 4, ..., each level measured and judged as ``harness.measures.advise`` judges its
rows: the energy and, by default, the position error against the scene's reference (5% of its
length scale); where the request asks no position tolerance nothing is held against the
reference, which on a stiff 32 x 32 cloth costs more than the whole search (a run that blows up
then fails the energy tolerance). A level that meets them is run again with its convergence knob
tightened (``advise.convergence``), and where that misses them the entry says its win rests on
the solve's own error (``SweepEntry.rests_on_solve``). The search does not stop at ``max_substeps``: a method's levels
go on doubling until one meets the tolerances, or until the next level's frame (substeps x its cost per
step, a pilot timed at that step before the run) would cost more than ``factor`` times the
cheapest frame found at that value (the bound ``cost``), or its substeps would pass ``cap`` (the
bound ``cap``); which bound ended each search is recorded. The levels of all the methods run
cheapest frame first, so the cheapest frame that meets the tolerances is found before any level
``factor`` times dearer is run (a large stiff cloth's backward Euler frame, whose Newton
iterations each solve by conjugate gradients, is then timed and not run). The chart then shows whether an explicit
scheme takes 20 or 2000 substeps where it still can.

Cost per frame is substeps x the method's cost per step, as the advice times it: the compiled
kernel of a reference scheme, the engine mode's step, on the CPU clock, at the step of the level
that meets the tolerances (each repeat TIME_BUDGET_S long where the cost measure's 100,000 steps
would take longer).

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
from records.advice import (
    Crossover,
    MethodAdvice,
    SweepEntry,
    SweepPoint,
    crossovers,  # noqa: F401
    family_crossover,  # noqa: F401 (re-exported)
    family_name,  # noqa: F401 (re-exported: harness.cli.advise)
)

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
#: Steps of a pilot timing (what orders and bounds the search; PILOT_S of steps where those few take
#: less), and the length of each timed repeat of a row that meets the tolerances, where the cost
#: measure's 100,000 steps would be longer.
PILOT_STEPS = 4
PILOT_S = 0.005
TIME_BUDGET_S = 0.05

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
        raise InvalidInput(
            f"--sweep parameter {name!r} is not a parameter of scene {scene.id} (valid: {', '.join(params) or 'none'})"
        )
    if (
        n_text is not None
        and points is not None
        and validate.count("--points", points, 2, MAX_POINTS) != validate.count("--sweep points", n_text, 2, MAX_POINTS)
    ):
        raise InvalidInput(f"--sweep {text!r} and --points={points} give two numbers of points (allowed: one of them)")
    n = validate.count(
        "--sweep points" if n_text is not None else "--points",
        n_text if n_text is not None else (POINTS if points is None else points),
        2,
        MAX_POINTS,
    )
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
            raise InvalidInput(
                f"--sweep {name}={lo:g}..{hi:g} holds fewer than 2 integers (allowed: integer "
                f"parameter {name} over a range with at least 2)"
            )
    for v in values:  # every value through the scene's own checks, its cross-parameter ones too
        scene.copy_with(**{**scene.values, name: float(v)})
    return Grid(name, lo, hi, tuple(float(v) for v in values))


# ----------------------------------------------------------------------------- one value
def pilot_cost(method, scene, h: float, injected=None) -> float | None:
    """Seconds per step of the method's compiled kernel (an engine mode's step) at ``h``, from
    PILOT_STEPS steps on the advice's clock (PILOT_S of steps where those few are too short to
    read): enough to order and bound the search. The cost measure's own pilot is 2,000 steps,
    then at least 5,000 a repeat, which a large stiff cloth's implicit step makes minutes."""
    from harness.measures.cost import wall_time_per_step

    res = wall_time_per_step(method, scene, h, steps=PILOT_STEPS, repeats=1, clock=CLOCK, injected=injected)
    per_step = res["s_per_step"]
    steps = int(PILOT_S / per_step) if per_step and per_step > 0 else PILOT_STEPS * 1000
    if steps > PILOT_STEPS:  # a fast kernel: a few steps are a few ticks of the CPU clock; time PILOT_S of them
        res = wall_time_per_step(method, scene, h, steps=min(steps, 100_000), repeats=1, clock=CLOCK, injected=injected)
        per_step = res["s_per_step"]
    return per_step


def frame_cost(method, scene, h: float, pilot: float | None, injected=None) -> tuple[float | None, str, float | None]:
    """(seconds per step, how timed, the repeats' relative spread) of a row that meets the
    tolerances, as the advice times it (``harness.measures.advise``: COST_REPEATS repeats on the CPU
    clock), each repeat TIME_BUDGET_S long by the pilot's figure (the cost measure's 100,000 steps
    where they fit)."""
    from harness.measures.advise import COST_REPEATS
    from harness.measures.cost import REF_TIME_STEPS, wall_time_per_step

    steps = None
    if pilot and pilot * REF_TIME_STEPS > TIME_BUDGET_S:
        steps = max(PILOT_STEPS, int(TIME_BUDGET_S / pilot))
    res = wall_time_per_step(method, scene, h, steps=steps, repeats=COST_REPEATS, clock=CLOCK, injected=injected)
    timing = f"{res['timing']}; {res['clock']} clock, {res['time_steps']} steps a repeat"
    return res["s_per_step"], timing, res.get("rel_spread")


def start(
    method, scene, request: Request, *, timeout=None, injected=None
) -> tuple[MethodAdvice, str, float | None, str]:
    """A method's search before its first level: its stability limit on a linear scene (which
    skips the runs of levels known unstable, as the advice does), its family, its pilot cost
    per step at one substep a frame and, for an implicit method, its solve in words."""
    from harness.measures.advise import _limit
    from harness.measures.common import resolve

    method = resolve(method, scene)
    out = MethodAdvice(method.id)
    try:
        out.homega_limit, out.limit_verdict, out.limit_searched = _limit(method, scene, request, timeout)
    except InvalidInput as exc:  # the one-step map cannot be measured: each step is judged by its run
        out.limit_verdict = f"not measured ({exc})"
    family = family_of(method)
    return out, family, pilot_cost(method, scene, 1.0 / request.hz, injected), solve_of(method, scene, family)


def solve_of(method, scene, family: str) -> str:
    """An implicit method's linear solve in words: a library solve's (``reference.solvers``, with
    its settings), else its scene's own kernel's (``Scene.solve_text``); "" for another family."""
    if family != "implicit":
        return ""
    return method.describe().get("solver") or scene.solve_text


def level(
    method,
    scene,
    request: Request,
    advice: MethodAdvice,
    substeps: int,
    ceiling: float | None,
    *,
    timeout=None,
    injected=None,
    survival: bool = False,
) -> dict:
    """One level of a method's search: its pilot cost per step at this step first; where
    ``ceiling`` (factor x the cheapest frame found, seconds) is known and ``substeps`` x that cost
    passes it, nothing is run (``ended`` ``cost``); else the horizon run, measured and judged as
    the advice's rows (``harness.measures.advise._row``; nothing held against the scene's reference
    solution unless a position tolerance is asked), and where it meets the tolerances its cost
    per step timed as the advice times it and, for a method with a convergence knob, the same level
    with the knob tightened (``harness.measures.advise.convergence``: its figures and its positions).
    ``survival``: the level may be the first claim's (the stiffest value, an implicit solve not yet
    within the energy tolerance): where it is within it, the same check (``survival_converged``)."""
    from harness.measures.advise import _row, convergence, release

    from harness.measures.common import resolve

    method = resolve(method, scene)
    h = 1.0 / (request.hz * substeps)
    pilot = pilot_cost(method, scene, h, injected)
    out = {
        "ended": "",
        "pilot_s": pilot,
        "row": None,
        "cost_per_step_s": None,
        "timing": "",
        "cost_rel_spread": None,
        "survival_converged": None,
    }
    if ceiling is not None and pilot is not None and substeps * pilot > ceiling:
        out["ended"] = "cost"
        return out
    row = _row(method, scene, request, substeps, advice, timeout, reference=False, count=False)
    out["row"] = row
    if row.status in ("crashed", "timed_out"):
        out["ended"] = row.status
    elif row.meets:
        out["ended"] = "met"
        out["cost_per_step_s"], out["timing"], out["cost_rel_spread"] = frame_cost(method, scene, h, pilot, injected)
        row.converged = convergence(method, scene, request, row, advice, timeout, reference=False, count=False)
    if survival and within_energy(row, request):
        # The first claim rests on the energy and the motion: the tightened run within the energy
        # tolerance, its positions where the row's are (its accuracy is the second claim's).
        check = (
            row.converged
            if row.meets
            else convergence(method, scene, request, row, advice, timeout, reference=False, count=False)
        )
        if check is not None:
            check = {**check, "meets": bool(check.get("energy_within") and check.get("motion"))}
        out["survival_converged"] = check
    release(row)
    return out


def sweep_value(
    scene,
    value: float,
    request: Request,
    methods: list,
    *,
    factor: float = FACTOR,
    cap: int = CAP,
    call=None,
    timeout=None,
    injected=None,
    survival: bool = False,
) -> SweepPoint:
    """Every method of ``methods`` (ids) at one value (``scene`` built at it), cheapest first:
    each method's levels 1, 2, 4, ... are run in the order of their frames' cost (substeps x the
    method's last pilot cost per step), so that the cheapest frame that meets the tolerances is
    found before any costlier level runs, and a level whose frame would pass ``factor`` times it
    is not run (``cost``); past ``cap`` substeps a search ends (``cap``). ``call(fn, args)`` runs
    one step of the search (default: in this process); where it has ``jobs`` > 1, that many of
    the cheapest pending levels run side by side. ``survival``: the stiffest value's, where the
    seed's first claim is judged: ``probe_survival`` runs after the search."""
    from harness.methods import active_plugins

    call = call or _in_process
    plugins = active_plugins()
    point = SweepPoint(
        float(value),
        float(scene.omega),
        float(scene.omega / request.hz),
        position_tol=request.position_tolerance(scene),
    )
    horizon = predictable(scene, request)
    point.horizon = horizon.as_dict() if horizon is not None else None
    entries: dict[str, SweepEntry] = {}
    advices: dict[str, MethodAdvice] = {}
    pilot: dict[str, float | None] = {}
    pending: dict[str, int] = {}
    for m, res in zip(
        methods, call_all(call, [(_start_one, (m, scene, request, timeout, injected, plugins)) for m in methods])
    ):
        if isinstance(res, tuple):
            advices[m], family, pilot[m], solve = res
            entries[m] = SweepEntry(m, family, "", cost_per_step_s=pilot[m], solve=solve)
            pending[m] = 1
        else:  # the worker failed: its status and why
            status = getattr(res, "status", "crashed")
            entries[m] = SweepEntry(m, _family_by_id(m), status, why=f"{status}: {getattr(res, 'detail', res)}")
    width = max(1, getattr(call, "jobs", 1))
    while pending:
        met = [e.cost_per_frame_s for e in entries.values() if e.ended == "met" and e.cost_per_frame_s]
        ceiling = factor * min(met) if met else None
        for m, s in list(pending.items()):
            e = entries[m]
            if s > cap:
                e.ended, e.next_substeps = "cap", s
                e.why = f"no level up to {cap} substeps meets them ({e.why})" if e.why else f"past {cap} substeps"
                del pending[m]
            elif ceiling is not None and pilot[m] is not None and s * pilot[m] > ceiling:
                _cut(e, s, pilot[m], ceiling, factor)
                del pending[m]
        order = sorted(pending, key=lambda m: (pending[m] * (pilot[m] or 0.0), m))[:width]
        jobs = [
            (
                _level_one,
                (
                    m,
                    scene,
                    request,
                    advices[m],
                    pending[m],
                    ceiling,
                    timeout,
                    injected,
                    plugins,
                    survival and entries[m].family == "implicit" and entries[m].energy_substeps is None,
                ),
            )
            for m in order
        ]
        for m, res in zip(order, call_all(call, jobs)):
            e, s = entries[m], pending[m]
            if not isinstance(res, dict):
                e.ended, e.why = getattr(res, "status", "crashed"), str(getattr(res, "detail", res))
                del pending[m]
                continue
            pilot[m] = res["pilot_s"]
            row = res["row"]
            if res["ended"] == "cost":
                _cut(e, s, pilot[m], ceiling, factor)
            elif row is not None:
                e.searched = s
                if e.energy_substeps is None and within_energy(row, request):
                    e.energy_substeps = s  # the levels run in order 1, 2, 4, ...: the first is the fewest
                    e.survival_converged = res.get("survival_converged")
                if res["ended"] == "met":
                    e.ended, e.substeps, e.h, e.homega = "met", s, row.h, row.homega
                    e.cost_per_step_s = res["cost_per_step_s"]
                    e.cost_per_frame_s = s * e.cost_per_step_s
                    e.cost_rel_spread = res.get("cost_rel_spread")
                    e.energy_error, e.position_error, e.why = row.energy_error, row.position_error, ""
                    e.judged_until, e.com_error, e.strain_excess = row.judged_until, row.com_error, row.strain_excess
                    e.converged = row.converged
                elif res["ended"]:
                    e.ended, e.why = res["ended"], row.why
                else:
                    e.why = f"{row.why} at {s} substep{'s' if s > 1 else ''}"
            if e.ended:
                del pending[m]
            else:
                pending[m] = 2 * s
    point.entries = [entries[m] for m in methods]
    if survival:
        probe_survival(point, scene, request, advices, call, timeout, injected, plugins)
    return point


#: The seed's first claim asks an implicit solve to survive with steps this many times longer than
#: the explicit schemes need (``harness.sweep_findings.TINY``).
SURVIVAL_RATIO = 10


def probe_survival(
    point: SweepPoint, scene, request: Request, advices: dict, call, timeout, injected, plugins=()
) -> None:
    """The seed's first claim is about stability, not cost: where no implicit solve is yet known
    to stay within the energy tolerance at ``SURVIVAL_RATIO`` times fewer substeps than the explicit
    schemes need, run the levels the cost bound cut of each implicit search that met nothing,
    from its cut level up to that many fewer substeps, for ``energy_substeps`` alone (recorded in
    ``probed``; the entry's frame, cost and verdict are the search's). Nothing runs where the claim
    is settled either way by what was measured (a solve already survives there, or the explicit
    need is too few for any)."""
    explicit = [e for e in point.entries if e.family == "explicit"]
    implicit = [e for e in point.entries if e.family == "implicit"]
    if not explicit or not implicit or request.energy_tol is None:
        return
    needs = [
        e.energy_substeps if e.energy_substeps is not None else (e.next_substeps or 2 * max(e.searched, 1))
        for e in explicit
    ]
    most = min(needs) // SURVIVAL_RATIO
    if any(e.energy_substeps is not None and e.energy_substeps <= most and survived(e) for e in implicit) or most < 1:
        return
    for e in implicit:
        if e.ended != "cost" or e.energy_substeps is not None or e.method not in advices:
            continue
        s = e.next_substeps or 1
        while s <= most:
            job = (e.method, scene, request, advices[e.method], s, None, timeout, injected, plugins, True)
            res = call_all(call, [(_level_one, job)])[0]
            if not isinstance(res, dict) or res["row"] is None:
                break
            e.probed = (*e.probed, s)
            if within_energy(res["row"], request):
                e.energy_substeps = s
                e.survival_converged = res.get("survival_converged")
                break
            s *= 2


def survived(e: SweepEntry) -> bool:
    """Whether an entry's survival (``energy_substeps``) stands once its solve converges further:
    no convergence knob, or the tightened run within the energy tolerance and its motion where the
    entry's run's is (``survival_converged``)."""
    return e.energy_substeps is not None and (e.survival_converged is None or bool(e.survival_converged["meets"]))


def within_energy(row, request: Request) -> bool:
    """Whether a level's run was stable and within the energy tolerance, whatever its position error."""
    return (
        row.stable
        and request.energy_tol is not None
        and row.energy_error is not None
        and row.energy_error <= request.energy_tol
    )


def _cut(e: SweepEntry, s: int, per_step: float, ceiling: float, factor: float) -> None:
    """End ``e``'s search on the cost bound: ``s`` substeps would cost more than ``ceiling``."""
    e.ended, e.next_substeps, e.cost_per_step_s = "cost", s, per_step
    e.why = (
        f"{s} substep{'s' if s > 1 else ''} would cost {_us(s * per_step)} a frame, past {factor:g} x the "
        f"cheapest ({_us(ceiling / factor)})" + (f"; {e.why}" if e.why else "")
    )


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


def _method(method_id: str, plugins=()):
    from harness.methods import get_method, use_plugins

    use_plugins(plugins)
    # A reference scheme runs on its compiled loop where that computes the interpreted bits, as
    # ``harness advise`` runs it.
    return get_method(method_id, compiled_where_bitwise=True)


def _start_one(method_id, scene, request, timeout, injected, plugins=()):
    return start(_method(method_id, plugins), scene, request, timeout=timeout, injected=injected)


def _level_one(method_id, scene, request, advice, substeps, ceiling, timeout, injected, plugins=(), survival=False):
    return level(
        _method(method_id, plugins),
        scene,
        request,
        advice,
        substeps,
        ceiling,
        timeout=timeout,
        injected=injected,
        survival=survival,
    )


def predictable(scene, request: Request):
    """The scene's predictable horizon (``harness.measures.horizon``) at one value of the grid, where
    positions are judged: measured here, once, before any level runs (the scene carries both
    references to the workers); None where the sweep judges the energy alone (a convergence check
    that needs it measures it then), or the scene has no second reference."""
    from harness.measures.horizon import measure, supported

    tol = request.position_tolerance(scene)
    if tol is None or not supported(scene):
        return None
    return measure(scene, request.hz, request.horizon, tol)


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
    length_scale: float | None = None  # the scene's where it is the same at every value, else None

    @property
    def crossovers(self) -> list[Crossover]:
        return crossovers(self.points)

    def as_dict(self) -> dict:
        from dataclasses import asdict

        return {
            "scene": self.scene,
            "params": self.params,
            "param": self.grid.param,
            "grid": list(self.grid.values),
            "request": asdict(self.request),
            "length_scale": self.length_scale,
            "factor": self.factor,
            "cap": self.cap,
            "clock": CLOCK,
            "points": [p.as_dict() for p in self.points],
            "crossovers": [c.as_dict() for c in self.crossovers],
            "left_out": self.left_out,
            "claims": [asdict(c) for c in self.claims],
        }

    @property
    def claims(self) -> list:
        """The seed's two claims judged on this sweep (``harness.sweep_findings.seed_claims``)."""
        from harness.sweep_findings import seed_claims

        return list(
            seed_claims(self.points, self.grid.param, self.request.energy_tol, self.request.accuracy)
            if self.points
            else ()
        )


def run_sweep(
    scene,
    grid: Grid,
    request: Request,
    patterns=None,
    *,
    factor: float = FACTOR,
    cap: int = CAP,
    jobs: int = 1,
    timeout: float = 120.0,
    pool: bool = True,
    progress=None,
) -> Sweep:
    """The sweep of ``scene`` (its other parameters as given) over ``grid``: every candidate
    method (``patterns``, as ``harness advise`` takes them) at every value. ``pool``: each
    method's search in ``jobs`` reused worker processes (an engine that aborts or hangs costs its
    entry a ``crashed`` / ``timed_out``), else in this process (a nightly task's worker).
    ``progress``: told a line before each value (a command's progress)."""
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
        from harness.execution.isolation import engine_modules, preload_engines
        from harness.execution.pool import WorkerPool

        preload_engines(engine_modules(ids))  # the server imports these methods' engines alone

        with WorkerPool(max(1, min(jobs, len(ids) or 1))) as workers:
            call = _PoolCall(workers, timeout, jobs)
            for i, (v, s) in enumerate(zip(grid.values, scenes)):
                if progress is not None:
                    progress(f"sweep: {grid.param} = {v:g}, value {i + 1} of {len(scenes)}, {len(ids)} methods")
                points.append(
                    sweep_value(
                        s,
                        v,
                        request,
                        ids,
                        factor=factor,
                        cap=cap,
                        call=call,
                        timeout=timeout,
                        injected=injected,
                        survival=i == len(scenes) - 1,
                    )
                )
    else:
        for i, (v, s) in enumerate(zip(grid.values, scenes)):
            points.append(
                sweep_value(
                    s,
                    v,
                    request,
                    ids,
                    factor=factor,
                    cap=cap,
                    timeout=timeout,
                    injected=injected,
                    survival=i == len(scenes) - 1,
                )
            )
    scales = {s.length_scale for s in scenes}
    return Sweep(
        scene.id,
        {k: v for k, v in scene.values.items() if k != grid.param},
        grid,
        request,
        factor,
        cap,
        points,
        left,
        scales.pop() if len(scales) == 1 else None,
    )


class _PoolCall:
    """``call(fn, args)`` in a pool worker, within ``timeout``; a failure comes back as the
    pool's ``WorkerFailure``."""

    def __init__(self, pool, timeout, jobs):
        self.pool, self.timeout, self.jobs = pool, timeout, max(1, int(jobs))

    def __call__(self, fn, args):
        return self.pool.call(fn, args, timeout=self.timeout)
