"""The measure registry: each measure is one declared object (``Measure``), and everything that
handles measures iterates ``REGISTRY`` instead of naming them: the nightly's cells (which run, in
what order, and with what), storage (a cell's figures type), the history's comparison (the
regression rule), the judge (the findings a measure draws), the report (a scene table's columns,
the lines under it, a chart) and ``harness list``.

A measure is declared where its run function lives (the built-in ones in
``harness.nightly.cells`` and ``harness.nightly.scene_cells``) and registered with ``register``;
a plugin module named in ``$HARNESS_PLUGINS`` declares ``MEASURES = [Measure(...), ...]``, and
``harness.methods.load_plugins`` registers them, in the main process and in every worker.

The registry lives here, at the bottom of the house, so that the report (which reads records
only) can iterate it; the functions a measure carries are called, never imported, by the layers
below the one that declared them.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any, Callable

from records.figures import FIGURES, Figures


@dataclass(frozen=True)
class Column:
    """One column of a scene's table: its header, its text for a row (given the row's cells by
    measure and a footnote marker ``mark(text) -> str``), and its place among the columns (lower
    first; equal ranks keep registry order)."""

    header: str
    text: Callable[[dict, Callable[[str | None], str]], str]
    rank: float = 100.0


@dataclass(frozen=True)
class Measure:
    """A measure, declared once.

    * ``name``: the cell's ``measure``; ``figures``: its typed figures (``records.figures``).
    * ``run(ctx) -> list[Cell]``: the cells of one scene x method task (``ctx``: the nightly's
      ``TaskContext``: task, suite, spec, scene, method, dt, the cells measured so far, claims);
      None where another measure's run makes this one's cell (``made_by``: the energy run makes
      the error cell).
    * ``applies(ctx) -> bool``: which scenes, methods and suites it runs on (default: every task).
    * ``makes``: the measures its run returns cells of, in order (default: its own name).
    * ``regression(a, b) -> (kind, detail) | None``: the history's rule, given the two runs' rows
      of the same cell (dicts with ``value``, ``status``, ``data``); None: no regression rule.
    * ``findings(scene, piv) -> list[Finding]``: what the judge draws from its cells on a scene.
    * ``columns``: its columns in a scene's table; ``section(scene, piv) -> list[str]``: lines the
      report prints under the scene's table; ``chart(cells, scene, path) -> bool``: draws its
      chart of a scene (the scene's cells) to ``path`` (True where it drew), shown under the table.
    * ``trend``: the unit its value is trended in over the history (None: not trended);
      ``higher_is_worse``: which way a change is worse; ``deterministic``: the same code and
      versions give the same value (every change is one), else judged against its noise.
    * ``doc``: one line for ``harness list``.
    """

    name: str
    figures: type[Figures] = Figures
    doc: str = ""
    run: Callable[[Any], list] | None = None
    applies: Callable[[Any], bool] | None = None
    made_by: str | None = None
    makes: tuple[str, ...] = ()
    regression: Callable[[dict, dict], tuple[str, str] | None] | None = None
    findings: Callable[[str, dict], list] | None = None
    columns: tuple[Column, ...] = ()
    section: Callable[[str, dict], list[str]] | None = None
    chart: Callable[[list, str, Any], bool] | None = None
    trend: str | None = None
    higher_is_worse: bool = True
    deterministic: bool = True
    extra: dict = field(default_factory=dict)

    @property
    def cells(self) -> tuple[str, ...]:
        """The measures whose cells its run makes."""
        return self.makes or (self.name,)


#: Every measure, in the order a task runs them.
REGISTRY: dict[str, Measure] = {}

#: The modules that declare the built-in measures: imported by name the first time the registry
#: is read, as a plugin module is, so that every reader (the history's comparison, the report)
#: sees them without importing the layer that runs them.
BUILTIN = ("harness.nightly.cells", "harness.nightly.scene_cells", "harness.nightly.tolerance_cells",
           "harness.nightly.sweep_cell")
_loaded = False


def _builtin() -> None:
    global _loaded
    if not _loaded:
        _loaded = True
        for name in BUILTIN:
            importlib.import_module(name)


def unregister(name: str) -> None:
    """Remove the measure ``name`` (a plugin's, once its module is no longer in effect)."""
    if REGISTRY.pop(name, None) is not None:
        FIGURES.pop(name, None)


def get(name: str) -> Measure | None:
    """The measure ``name``, or None where none is registered."""
    _builtin()
    return REGISTRY.get(name)


def figures_of(name: str) -> type[Figures]:
    """The figures type of the measure ``name`` (the built-in measures' declarations loaded first,
    so a cell read from storage by any reader gets its own type), ``Figures`` for an unknown one."""
    _builtin()
    return FIGURES.get(name, Figures)


def register(measure: Measure, before: str | None = None, builtin: bool = False) -> Measure:
    """Add ``measure`` (at the end, or just before the measure ``before``); its figures type is
    then the one storage reads its cells with. Registering the same object again changes nothing;
    another measure of the same name is an error. The built-in measures (``builtin``: declared by a
    ``BUILTIN`` module) come first: any other registration loads them before it."""
    if not builtin:
        _builtin()
    have = REGISTRY.get(measure.name)
    if have is not None:
        if have is measure or have == measure:
            return have
        raise ValueError(f"measure {measure.name!r} is already registered")
    if before is None or before not in REGISTRY:
        REGISTRY[measure.name] = measure
    else:
        items = list(REGISTRY.items())
        at = [k for k, _ in items].index(before)
        items.insert(at, (measure.name, measure))
        REGISTRY.clear()
        REGISTRY.update(items)
    FIGURES.setdefault(measure.name, measure.figures)
    return measure


def measures() -> list[Measure]:
    """The registered measures, in run order."""
    _builtin()
    return list(REGISTRY.values())


def trended() -> tuple[str, ...]:
    """The measures the history trends, in the order of their columns in a scene's table."""
    _builtin()
    ranked = sorted((min((c.rank for c in m.columns), default=1e9), i, m.name)
                    for i, m in enumerate(REGISTRY.values()) if m.trend)
    return tuple(name for _, _, name in ranked)


def columns() -> list[Column]:
    """A scene table's columns after the method and status, by rank."""
    _builtin()
    return sorted((c for m in REGISTRY.values() for c in m.columns), key=lambda c: c.rank)
