"""A measured cell: one measure of one method on one scene, as the nightly stores and reports it.

``Cell`` holds what every cell has (scene, params, method, family, measure, status, dt, steps,
value, wall_s, detail), the measure's figures as a typed record (``FIGURES[measure]``: a
frozen dataclass per measure, one attribute per figure the reports read), the textbook claims
the cell is judged against (``Claims``), and whatever else the measure recorded in ``extra``.

The conversions live here and nowhere else: ``Cell.to_row`` / ``Cell.from_row`` for the tidy
DataFrame row (``data`` as a dict), ``Cell.to_db_row`` / ``Cell.from_db_row`` for the SQLite row
(``data`` as JSON). The stored ``data`` is one flat dict, as it always was: the figures under
their keys (``EnergyFigures.energy_class`` is stored as ``class``), ``claims``, ``kernels``,
``params`` and the extra keys beside them; a figure that is None is not written, and a key
that is not written reads back as None. A history written before the figures were typed
therefore loads unchanged.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

from records.advice import SweepFigures
from records.figures import (  # noqa: F401 (the cell's records, re-exported: ``from records.cell import ...``)
    AdviceFigures,
    BoundFigures,
    BrouwerFigures,
    Claims,
    ConstraintFigures,
    CostFigures,
    CrossEngineFigures,
    DampingFigures,
    EnergyFigures,
    ErrorFigures,
    Figures,
    IdentityFigures,
    NominalRun,
    OrderFigures,
    Record,
    ScalingFigures,
    SmallStepsFigures,
    StabilityFigures,
    StabilityVsDampingFigures,
    ToleranceFigures,
)

#: Each measure's figures type, as storage reads its cells: those declared in records here, so that
#: a reader with nothing of the harness loaded gets them; a type declared in a measure's own module
#: (a plugin's) is added when the measure is registered (``records.measures.register``). An
#: unknown measure's cells read as bare ``Figures``.
FIGURES: dict[str, type[Figures]] = {
    "energy": EnergyFigures,
    "error": ErrorFigures,
    "order": OrderFigures,
    "stability": StabilityFigures,
    "cost": CostFigures,
    "identity": IdentityFigures,
    "advise": AdviceFigures,
    "bound": BoundFigures,
    "constraint": ConstraintFigures,
    "damping": DampingFigures,
    "stability_vs_damping": StabilityVsDampingFigures,
    "scaling": ScalingFigures,
    "brouwer": BrouwerFigures,
    "cross_engine": CrossEngineFigures,
    "small_steps": SmallStepsFigures,
    "tolerance": ToleranceFigures,
    "sweep": SweepFigures,
}


def _figures_type(measure: str) -> type[Figures]:
    return FIGURES.get(measure, Figures)


#: The columns of a cell, in the tidy DataFrame and in the SQLite ``cells`` table.
CELL_COLUMNS = ("scene", "method", "family", "measure", "dt", "steps", "status", "detail", "value", "wall_s", "data")


def _number(x):
    """A stored number: None for missing or NaN (SQL NULL reads back as NaN in a DataFrame)."""
    if x is None:
        return None
    x = float(x)
    return None if math.isnan(x) else x


def _json_default(x):
    import numpy as np

    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.bool_):
        return bool(x)
    return str(x)


def to_json(obj) -> str:
    """JSON as the history stores it (numpy values as Python ones, NaN and inf allowed)."""
    return json.dumps(obj, default=_json_default, allow_nan=True)


@dataclass
class Cell:
    """One measured cell. ``figures`` is ``FIGURES[measure]`` (all None where the measure failed)."""

    scene: str
    method: str
    family: str
    measure: str
    status: str = "ok"
    params: dict = field(default_factory=dict)
    dt: float | None = None
    steps: int | None = None
    value: float | None = None
    wall_s: float = 0.0
    detail: str = ""
    figures: Figures | None = None
    claims: Claims | None = None
    kernels: dict | None = None  # compiled kernels this cell's measure compiled or loaded
    extra: dict = field(default_factory=dict)
    model_note: str | None = None  # the scene is another force model on a built-in grid (Scene.model_note)

    def __post_init__(self):
        if self.figures is None:
            self.figures = _figures_type(self.measure)()

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    # ------------------------------------------------------------------ the stored data dict
    def data(self) -> dict:
        """The flat dict stored in the ``data`` column."""
        out = dict(self.extra)
        out.update(self.figures.to_data())
        if self.claims is not None:
            out["claims"] = self.claims.to_data()
        if self.kernels:
            out["kernels"] = dict(self.kernels)
        if self.params:
            out["params"] = dict(self.params)
        if self.model_note:
            out["model_note"] = self.model_note
        return out

    @staticmethod
    def _split(measure: str, data: dict | None) -> dict:
        data = dict(data or {})
        claims = data.pop("claims", None)
        kernels = data.pop("kernels", None)
        params = data.pop("params", None) or {}
        note = data.pop("model_note", None)
        figures, extra = _figures_type(measure).from_data(data)
        return {
            "figures": figures,
            "extra": extra,
            "kernels": kernels,
            "params": dict(params),
            "model_note": note,
            "claims": Claims.from_data(claims)[0] if isinstance(claims, dict) else None,
        }

    # ------------------------------------------------------------------ the tidy DataFrame row
    def to_row(self) -> dict:
        """The tidy row: every column of ``CELL_COLUMNS``, ``data`` as a dict."""
        return {
            "scene": self.scene,
            "method": self.method,
            "family": self.family,
            "measure": self.measure,
            "dt": self.dt,
            "steps": self.steps,
            "status": self.status,
            "detail": self.detail,
            "value": self.value,
            "wall_s": self.wall_s,
            "data": self.data(),
        }

    @classmethod
    def from_row(cls, row) -> Cell:
        """From a tidy row (a dict, or a DataFrame row: missing numbers may read as NaN)."""
        get = row.get
        steps = _number(get("steps"))
        detail = get("detail")
        return cls(
            scene=row["scene"],
            method=row["method"],
            family=row["family"],
            measure=row["measure"],
            status=row["status"],
            dt=_number(get("dt")),
            steps=None if steps is None else int(steps),
            value=_number(get("value")),
            wall_s=_number(get("wall_s")) or 0.0,
            detail=detail if isinstance(detail, str) else "",
            **cls._split(row["measure"], get("data")),
        )

    # ------------------------------------------------------------------ the SQLite row
    def to_db_row(self) -> dict:
        """The ``cells`` table's columns (less ``run_id``): ``data`` as JSON, a NaN value as NULL."""
        row = self.to_row()
        row["value"] = _number(row["value"])
        row["data"] = to_json(row["data"])
        return row

    @classmethod
    def from_db_row(cls, row) -> Cell:
        """From a ``cells`` row (a mapping of its columns, ``data`` as JSON text)."""
        data = row["data"]
        return cls.from_row(
            {
                **{c: row[c] for c in CELL_COLUMNS if c != "data"},
                "data": json.loads(data) if isinstance(data, str) and data else {},
            }
        )


def figures_of(row) -> Figures:
    """The typed figures of a stored row (a tidy row or a DataFrame row: ``measure``, ``data``)."""
    figures, _ = _figures_type(row["measure"]).from_data(dict(row["data"] or {}))
    return figures


class MethodCells(dict):
    """{measure: cell} of one scene x method; the measures the findings read by name are
    attributes (None where the method has no such cell)."""

    def cell(self, measure: str) -> Cell | None:
        return self[measure] if measure in self else None

    energy = property(lambda self: self.cell("energy"))
    order = property(lambda self: self.cell("order"))
    stability = property(lambda self: self.cell("stability"))
    cost = property(lambda self: self.cell("cost"))
    identity = property(lambda self: self.cell("identity"))
    damping = property(lambda self: self.cell("damping"))


def pivot(cells: list[Cell]) -> dict[tuple[str, str], MethodCells]:
    """{(scene, method): MethodCells} for the scene x method cells (bounds excluded)."""
    out: dict = {}
    for c in cells:
        if c.measure != "bound":
            out.setdefault((c.scene, c.method), MethodCells())[c.measure] = c
    return out
