"""The advice's records: one (method, substeps) row measured, and one method's search over
substeps (``harness.measures.advise`` measures them; the nightly stores them in its advice cells,
the report and ``harness advise`` print them)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import ClassVar

from records.figures import Figures, Record


@dataclass
class Row:
    """One (method, substeps) measured. ``meets`` the tolerances, else ``why`` not."""

    substeps: int
    h: float
    homega: float
    stable: bool
    status: str  # ok, unstable, crashed, timed_out (of the horizon run, or "skipped")
    rho: float | None = None  # spectral radius of the one-step map at h (linear scenes)
    energy_error: float | None = None
    energy_gained: bool | None = None
    #: The energy error's way: grows / falls, or on a dissipating scene grows (above its start),
    #: damps less / damps more than the exact motion.
    energy_way: str | None = None
    energy_class: str | None = None
    position_error: float | None = None
    evals_per_frame: float | None = None
    cost_per_frame_s: float | None = None
    meets: bool = False
    why: str = ""
    detail: str = ""
    #: Where the row meets the tolerances and its method has a convergence knob: the same substeps
    #: with the knob tightened (``harness.measures.advise.convergence``): {"method", "meets", "why",
    #: "energy_error", "position_error", ..., "moved": how far its positions move}; its "meets"
    #: False: the win rests on the solve's own error.
    converged: dict | None = None
    #: Past a predictable horizon shorter than the asked one (``harness.measures.horizon``): the
    #: time the position error is judged to, the centre of mass's error past it, and the run's
    #: largest strain less the reference's (None where not measured).
    judged_until: float | None = None
    com_error: float | None = None
    strain_excess: float | None = None


@dataclass
class MethodAdvice:
    """One method's search: its rows (in the order measured), the row that meets the
    tolerances with the fewest substeps (``best``, an index into ``rows``), or ``reason``."""

    method: str
    status: str = "ok"  # ok, or crashed / timed_out where the search itself died
    homega_limit: float | None = None
    limit_verdict: str = "not measured"  # limited, unbounded (stable at every h*omega searched), unstable,
    #                                       unresolved (no stable step resolved: harness.measures.stability)
    limit_searched: float | None = None  # the largest h*omega the limit search tried
    cost_per_step_s: float | None = None
    cost_timing: str = ""
    cost_rel_spread: float | None = None  # the timing's repeats, (slowest - fastest) / fastest
    evals_reason: str = ""
    rows: list[Row] = field(default_factory=list)
    best: int | None = None
    reason: str = ""

    @property
    def best_row(self) -> Row | None:
        return None if self.best is None else self.rows[self.best]

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> MethodAdvice:
        d = dict(d)
        rows = [Row(**r) for r in d.pop("rows", [])]
        return cls(rows=rows, **d)


# ----------------------------------------------------------------------------- the sweep
#: How a family (a method's declared kind, ``harness.measures.sweep``) is named in the tables and
#: charts; a kind not listed is named by itself.
FAMILY_NAMES = {
    "explicit": "explicit substeps",
    "implicit": "implicit solves",
    "constrained": "constraint projections",
    "decay": "explicit substeps with exact decay",
    "position_based": "position-based solves",
}


def family_name(kind: str) -> str:
    return FAMILY_NAMES.get(kind, kind)


@dataclass
class SweepEntry:
    """One method at one value of a swept parameter (``harness.measures.sweep``): the fewest
    substeps that meet the tolerances and their cost per frame, or the bound that ended the search
    (``ended``: ``met``; ``cost``, its next level's frame past the stated factor times the cheapest
    method's; ``cap``, past the sweep's most substeps; ``crashed`` / ``timed_out``)."""

    method: str
    family: str  # what the method declares: a reference scheme's kind, an engine mode's
    ended: str = ""
    substeps: int | None = None
    h: float | None = None
    homega: float | None = None
    cost_per_step_s: float | None = None
    cost_per_frame_s: float | None = None
    cost_rel_spread: float | None = None  # the timing's repeats, (slowest - fastest) / fastest
    energy_error: float | None = None
    position_error: float | None = None
    searched: int = 0  # the most substeps run
    next_substeps: int | None = None  # the level not run where the cost or the cap bound ended the search
    why: str = ""
    converged: dict | None = None  # where met: its convergence knob tightened (``records.advice.Row.converged``)
    #: The fewest substeps, of the levels run, whose run was stable and within the energy tolerance
    #: (whatever its position error): the seed's first claim reads it (``harness.sweep_findings``).
    energy_substeps: int | None = None
    solve: str = ""  # an implicit method's linear solve, in words (its library's and settings)
    #: The levels run past the cost bound to find ``energy_substeps`` alone (the survival probe,
    #: ``harness.measures.sweep.probe_survival``): the first claim is about stability, not cost.
    probed: tuple = ()
    #: As ``Row``'s: the position error judged to the predictable horizon, the centre of mass and the
    #: largest strain past it (``harness.measures.horizon``).
    judged_until: float | None = None
    com_error: float | None = None
    strain_excess: float | None = None
    #: The convergence check at ``energy_substeps`` (the first claim's level), as ``converged``.
    survival_converged: dict | None = None

    @property
    def rests_on_solve(self) -> bool:
        """Met, but missed once its solve converges further: the win rests on the solve's own error."""
        return self.converged is not None and not self.converged["meets"]


@dataclass
class SweepPoint:
    """Every method at one value of the swept parameter; ``homega_one`` is h*omega at one substep
    a frame (omega / hz)."""

    value: float
    omega: float
    homega_one: float
    entries: list[SweepEntry] = field(default_factory=list)
    position_tol: float | None = None  # the position tolerance at this value, absolute (None: not judged)
    horizon: dict | None = None  # its predictable horizon (``harness.measures.horizon.Horizon.as_dict``)

    @property
    def met(self) -> list[SweepEntry]:
        """The entries that meet the tolerances, cheapest frame first (then by id)."""
        ok = [e for e in self.entries if e.ended == "met" and e.cost_per_frame_s is not None]
        return sorted(ok, key=lambda e: (e.cost_per_frame_s, e.method))

    def tied_with(self, entry: SweepEntry) -> list[SweepEntry]:
        """The other entries that meet the tolerances at a frame cost within ``entry``'s timing
        spread (``tie``): which of them is the cheaper is the machine's noise."""
        return [
            e
            for e in self.met
            if e is not entry
            and tie(entry.cost_per_frame_s, entry.cost_rel_spread, e.cost_per_frame_s, e.cost_rel_spread)
        ]

    def family_costs(self) -> dict[str, SweepEntry]:
        """Each family's cheapest entry that meets the tolerances at this value."""
        out: dict[str, SweepEntry] = {}
        for e in self.met:
            out.setdefault(e.family, e)
        return out

    @property
    def cheapest(self) -> SweepEntry | None:
        met = self.met
        return met[0] if met else None

    def as_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> SweepPoint:
        d = dict(d)
        return cls(entries=[SweepEntry(**e) for e in d.pop("entries", [])], **d)


@dataclass
class Crossover:
    """Where the cheapest family changes between two neighbouring values of the grid: ``value``
    and ``homega_one`` estimated where the two families' cheapest frames cross (log-log
    interpolation; ``interpolated`` False: the grid's geometric midpoint, where one family has no
    cost at one end)."""

    below: float
    above: float
    from_family: str
    to_family: str
    from_method: str
    to_method: str
    value: float
    homega_one: float
    interpolated: bool

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Request(Record):
    """What an advice or a sweep was asked, as its cell stores it (``harness.measures.advise.Request``,
    which validates it): ``hz`` frames per unit time over ``horizon``, within ``energy_tol``
    (relative) and/or ``error_tol`` (absolute position error) or ``error_rel`` (a share of the
    scene's length scale), searched up to ``max_substeps``."""

    hz: float | None = None
    horizon: float | None = None
    energy_tol: float | None = None
    error_tol: float | None = None
    max_substeps: int | None = None
    error_rel: float | None = None


@dataclass(frozen=True)
class SweepFigures(Figures):
    """``sweep``: the advice over a grid of one scene parameter (value: the first crossover's
    h*omega at one substep; None where the cheapest family never changes). ``points`` are
    ``SweepPoint`` dicts, ``crossovers`` ``Crossover`` dicts; ``params`` the scene's other values,
    ``label`` the sweep's name in the report (its size), ``clock`` what the costs were timed on.
    ``params`` is stored as ``scene_params``: a cell's ``params`` are its task's (``records.cell``),
    and the two under one key lost the sweep's on the way through the history."""

    KEYS: ClassVar[dict[str, str]] = {"params": "scene_params"}
    label: str | None = None
    param: str | None = None
    params: dict | None = None
    hz: float | None = None
    request: dict | None = None
    factor: float | None = None
    cap: int | None = None
    clock: str | None = None
    points: list | None = None
    crossovers: list | None = None

    def sweep_request(self) -> Request:
        return Request.from_data(self.request or {})[0]

    def sweep_points(self) -> list[SweepPoint]:
        return [SweepPoint.from_dict(p) for p in self.points or []]

    def sweep_crossovers(self) -> list[Crossover]:
        return [Crossover(**c) for c in self.crossovers or []]


# ----------------------------------------------------------------------------- the crossover
def crossovers(points: list[SweepPoint]) -> list[Crossover]:
    """Where the cheapest method's family changes between neighbouring values of the grid
    (``harness.measures.sweep``'s docstring): one ``Crossover`` per change, in grid order. No change
    is read across a value where no method meets the tolerances."""
    out = []
    for a, b in zip(points, points[1:]):
        ca, cb = a.cheapest, b.cheapest
        if ca is None or cb is None or ca.family == cb.family:
            continue
        fa, fb = a.family_costs(), b.family_costs()
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


def family_crossover(points: list[SweepPoint], a: str, b: str) -> Crossover | None:
    """Where family ``b``'s cheapest frame first becomes cheaper than family ``a``'s, ``a`` cheaper
    at the value before (whatever a third family does): interpolated log-log as ``crossovers``.
    A family with no frame that meets the tolerances at a value but whose search ended on the
    cost or the cap bound there counts as dearer than every frame met; None where ``b`` never
    takes over from ``a`` on the grid."""

    def cost(p, fam):
        e = p.family_costs().get(fam)
        if e is not None:
            return e.cost_per_frame_s, e.method
        bounded = any(x.family == fam and x.ended in ("cost", "cap") for x in p.entries)
        return (math.inf, None) if bounded else (None, None)

    for p, q in zip(points, points[1:]):
        (a0, ma), (b0, _), (a1, _), (b1, mb) = cost(p, a), cost(p, b), cost(q, a), cost(q, b)
        if None in (a0, b0, a1, b1) or not (a0 < b0 and b1 < a1):
            continue
        t, interpolated = 0.5, False
        if all(math.isfinite(x) for x in (a0, b0, a1, b1)):
            d0, d1 = math.log(a0 / b0), math.log(a1 / b1)
            t, interpolated = d0 / (d0 - d1), True
        value = math.exp(math.log(p.value) + t * (math.log(q.value) - math.log(p.value)))
        homega = math.exp(math.log(p.homega_one) + t * (math.log(q.homega_one) - math.log(p.homega_one)))
        return Crossover(p.value, q.value, a, b, ma, mb, value, homega, interpolated)
    return None


def tie(cost_a: float | None, spread_a: float | None, cost_b: float | None, spread_b: float | None) -> bool:
    """Whether two frames' costs lie within their timing spread: each a fastest repeat and the
    repeats' relative spread, the two ranges [fastest, slowest] overlapping. Which of two such frames
    is the cheaper is the machine's noise, not a finding: a pick between them is a tie."""
    if cost_a is None or cost_b is None or not (math.isfinite(cost_a) and math.isfinite(cost_b)):
        return False
    lo, hi = sorted(((cost_a, spread_a or 0.0), (cost_b, spread_b or 0.0)))
    return hi[0] <= lo[0] * (1.0 + lo[1])
