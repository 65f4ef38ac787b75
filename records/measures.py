"""The measure contract: each measure is one declared object (``Measure``), and everything that
handles measures iterates the registry instead of naming them: the nightly's task loop (which run,
in what order, and with what), storage (a cell's figures type), the history's comparison (the
regression rule), the judge (the findings a measure draws), the report (a scene table's columns,
the lines under it, a chart) and ``harness list``.

Every hook is given typed records: ``run`` and ``applies`` a ``TaskContext``; ``regression`` the
two runs' ``Cell`` and a ``Comparison``, and it answers ``Worse`` or None; ``findings`` and
``section`` a scene and its cells by (scene, method) (``records.cell.pivot``); ``chart`` the
scene's cells.

The registry is filled from above and read from anywhere: the built-in measures are registered by
the harness (``harness.nightly.cells``, when it is imported: the task's own measures, then those
of every module of ``harness.nightly.measures``), a plugin's by ``harness.methods.load_plugins``.
It lives here, at the bottom of the house, so that the report (which reads records only) can
iterate it; the functions a measure carries are called, never imported, by the layers below the
one that declared them. Nothing here loads a module.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any
from collections.abc import Callable

from records.cell import FIGURES, Cell, Claims, MethodCells
from records.figures import Figures
from records.findings import Finding
from records.method import Method
from records.trajectory import Trajectory

#: A scene's cells as the judge and the report hand them to a measure: {(scene, method): its cells}.
Pivot = dict[tuple[str, str], MethodCells]


@dataclass
class TaskContext:
    """What a measure's ``run`` and ``applies`` see of one scene x method task: the task, its
    suite and scene spec (``harness.nightly``'s ``Task``, ``Suite``, ``SceneSpec``), the scene (a
    ``scenarios.Scene``) and the method (``run_method``: the compiled twin where the scene's long
    runs take it), the nominal dt, the claims
    the cells are judged by (an identity run may replace them), the cells measured so far by
    measure, and the runs stepped so far that a later measure reads as they are, by name
    (``energy``: the energy run's trajectory; the constraint cell's stretch is measured on it,
    not on a run of its own)."""

    task: Any
    suite: Any
    spec: Any
    scene: Any
    method: Method | None = None
    run_method: Method | None = None
    dt: float | None = None
    claims: Claims = field(default_factory=Claims)
    cells: dict[str, Cell] = field(default_factory=dict)
    runs: dict[str, Trajectory] = field(default_factory=dict)


@dataclass(frozen=True)
class Comparison:
    """What a regression rule knows of the two runs beyond their cells: ``machine_only``, that
    nothing the cell depends on differs between them (code, package versions, platform:
    ``harness.history.series.what_differs``), so a figure that is not deterministic moved with
    the machine alone."""

    machine_only: bool = False


@dataclass(frozen=True)
class Worse:
    """What a regression rule found worse in a cell from the earlier run to the later: its kind
    (``order``, ``stability``, ``slowdown``, a plugin's own), the figure before and after, and a
    line saying so."""

    kind: str
    before: object
    after: object
    detail: str


@dataclass(frozen=True)
class Column:
    """One column of a scene's table: its header, its text for a row (given the row's cells by
    measure and a footnote marker ``mark(text) -> str``), and its place among the columns (lower
    first; equal ranks keep registry order)."""

    header: str
    text: Callable[[MethodCells, Callable[[str | None], str]], str]
    rank: float = 100.0


@dataclass(frozen=True)
class Measure:
    """A measure, declared once.

    * ``name``: the cell's ``measure``; ``figures``: its typed figures (``records.figures``).
    * ``run(ctx: TaskContext) -> list[Cell]``: the cells of one scene x method task; None where
      another measure's run makes this one's cell (``made_by``: the energy run makes the error
      cell).
    * ``applies(ctx: TaskContext) -> bool``: which scenes, methods and suites it runs on (default:
      every task).
    * ``makes``: the measures its run returns cells of, in order (default: its own name).
    * ``regression(before: Cell, after: Cell, comparison: Comparison) -> Worse | None``: the
      history's rule, given the two runs' cells of the same (scene, method, measure, dt), both
      ``ok``; None: no regression rule.
    * ``findings(scene, piv: Pivot) -> list[Finding]``: what the judge draws from its cells on a
      scene.
    * ``columns``: its columns in a scene's table; ``section(scene, piv: Pivot) -> list[str]``:
      lines the report prints under the scene's table; ``chart(cells, scene, path) -> bool``:
      draws its chart of a scene (the scene's cells) to ``path`` (True where it drew), shown
      under the table.
    * ``trend``: the unit its value is trended in over the history (None: not trended);
      ``higher_is_worse``: which way a change is worse; ``deterministic``: the same code and
      versions give the same value (every change is one), else judged against its noise.
    * ``doc``: one line for ``harness list``.
    """

    name: str
    figures: type[Figures] = Figures
    doc: str = ""
    run: Callable[[TaskContext], list[Cell]] | None = None
    applies: Callable[[TaskContext], bool] | None = None
    made_by: str | None = None
    makes: tuple[str, ...] = ()
    regression: Callable[[Cell, Cell, Comparison], Worse | None] | None = None
    findings: Callable[[str, Pivot], list[Finding]] | None = None
    columns: tuple[Column, ...] = ()
    section: Callable[[str, Pivot], list[str]] | None = None
    chart: Callable[[list[Cell], str, Any], bool] | None = None
    trend: str | None = None
    higher_is_worse: bool = True
    deterministic: bool = True

    @property
    def cells(self) -> tuple[str, ...]:
        """The measures whose cells its run makes."""
        return self.makes or (self.name,)


#: Every measure, in the order a task runs them: the built-in ones first, then the plugins'.
REGISTRY: dict[str, Measure] = {}
_BUILTIN: set[str] = set()


def register(measure: Measure, builtin: bool = False) -> Measure:
    """Add ``measure``; its figures type is then the one storage reads its cells with. The
    built-in measures (``builtin``: registered by the harness) come before every plugin's, in the
    order they are registered, whenever a plugin was registered. Registering the same measure
    again changes nothing; another measure of the same name is an error."""
    have = REGISTRY.get(measure.name)
    if have is not None:
        if have is measure or have == measure:
            return have
        raise ValueError(f"measure {measure.name!r} is already registered")
    if builtin:
        _BUILTIN.add(measure.name)
        items = list(REGISTRY.items())
        at = next((i for i, (name, _) in enumerate(items) if name not in _BUILTIN), len(items))
        items.insert(at, (measure.name, measure))
        REGISTRY.clear()
        REGISTRY.update(items)
    else:
        REGISTRY[measure.name] = measure
    FIGURES.setdefault(measure.name, measure.figures)
    return measure


def unregister(name: str) -> None:
    """Remove the measure ``name`` (a plugin's, once its module is no longer in effect)."""
    if REGISTRY.pop(name, None) is not None:
        FIGURES.pop(name, None)
        _BUILTIN.discard(name)


def get(name: str) -> Measure | None:
    """The measure ``name``, or None where none is registered."""
    return REGISTRY.get(name)


def measures() -> list[Measure]:
    """The registered measures, in run order."""
    return list(REGISTRY.values())


def trended() -> tuple[str, ...]:
    """The measures the history trends, in the order of their columns in a scene's table."""
    ranked = sorted(
        (min((c.rank for c in m.columns), default=1e9), i, m.name) for i, m in enumerate(REGISTRY.values()) if m.trend
    )
    return tuple(name for _, _, name in ranked)


def columns() -> list[Column]:
    """A scene table's columns after the method and status, by rank."""
    return sorted((c for m in REGISTRY.values() for c in m.columns), key=lambda c: c.rank)
