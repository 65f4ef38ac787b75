"""records.cell: a Cell converted to its tidy DataFrame row and its SQLite row and back, for the
figures of every measure, through the history; a history written before the figures were typed
loads to the same records."""

from __future__ import annotations

import json
import math
from dataclasses import fields

import pytest

from records.cell import CELL_COLUMNS, FIGURES, Cell, Claims, EnergyFigures, IdentityFigures, NominalRun

from harness.history.storage import History


def _sample(kind: str, i: int):
    """A distinct value of the annotated type ``kind`` for the i-th field."""
    if kind.startswith("str"):
        return f"text {i}"
    if kind.startswith("bool"):
        return i % 2 == 0
    if kind.startswith("int"):
        return i + 1
    if kind.startswith("float"):
        return 0.25 + i
    if kind.startswith("list"):
        return [0.5 * i, {"row": i, "ok": True}]
    if kind.startswith("dict"):
        return {"key": i, "nested": [1.5, None]}
    if kind.startswith("Claims"):
        return CLAIMS
    if kind.startswith("NominalRun"):
        return NominalRun(
            dt=0.01 * i,
            homega=0.1,
            steps=10_000,
            status="unstable",
            failed_step=2434,
            detail="diverged",
            series={"t": [0.0, 1.0], "energy": [1.0, 2.0], "e0": 1.0},
        )
    return {"any": i}


CLAIMS = Claims(
    scheme="ref:leapfrog",
    order=2,
    order_note=None,
    force_evals=1,
    force_evals_text="1",
    energy="bounded",
    homega_max=2.0,
)


def full_figures(measure: str):
    """The figures of ``measure`` with every field set."""
    cls = FIGURES[measure]
    return cls(**{f.name: _sample(str(f.type), i) for i, f in enumerate(fields(cls))})


def full_cell(measure: str) -> Cell:
    return Cell(
        scene="chain",
        method="mujoco:discrete",
        family="mujoco",
        measure=measure,
        status="ok",
        params={"N": 8},
        dt=0.01,
        steps=1000,
        value=1.25e-3,
        wall_s=0.5,
        detail="measured",
        figures=full_figures(measure),
        claims=CLAIMS,
        kernels={"kernels_compiled": 1, "compile_s": 0.5},
        extra={"unlisted": [1, 2]},
    )


@pytest.mark.parametrize("measure", sorted(FIGURES))
def test_every_measures_cell_survives_its_rows(measure):
    cell = full_cell(measure)
    assert all(getattr(cell.figures, f.name) is not None for f in fields(cell.figures))
    assert Cell.from_row(cell.to_row()) == cell
    db = cell.to_db_row()
    assert list(db) == list(CELL_COLUMNS) and isinstance(db["data"], str)
    assert Cell.from_db_row(db) == cell
    # The stored data is one flat dict: the figures under their keys beside claims, kernels,
    # params and the extra keys.
    data = json.loads(db["data"])
    assert {"claims", "kernels", "params", "unlisted"} <= set(data)
    assert set(data) - {"claims", "kernels", "params", "unlisted"} == set(type(cell.figures).stored_keys())


@pytest.mark.parametrize("measure", sorted(FIGURES))
def test_every_measures_cell_survives_the_history(tmp_path, measure):
    h = History(tmp_path / "h.sqlite")
    run = h.start_run(started="now", suite="smoke", git_commit=None, versions={}, machine={}, settings={})
    cell = full_cell(measure)
    h.add_cell(run, cell)
    (back,) = h.cell_records(run)
    assert back == cell
    frame = h.cells(run)
    assert Cell.from_row(frame.iloc[0]) == cell
    assert list(frame.columns) == ["run_id", *CELL_COLUMNS]


def test_a_failed_cell_stores_no_figures_and_reads_back_empty(tmp_path):
    cell = Cell(
        scene="spring", method="faulty:abort", family="faulty", measure="energy", status="crashed", detail="SIGABRT"
    )
    assert cell.figures == EnergyFigures() and cell.data() == {}
    h = History(tmp_path / "h.sqlite")
    run = h.start_run(started="now", suite="smoke", git_commit=None, versions={}, machine={}, settings={})
    h.add_cell(run, cell)
    (back,) = h.cell_records(run)
    assert back == cell and back.dt is None and back.steps is None and back.value is None


def test_a_history_written_before_the_figures_were_typed_loads():
    """The row as the nightly stored it before: every figure written, None ones as null, the
    energy class under ``class``, claims beside them, an empty dict where no scheme is known."""
    old = {
        "scene": "spring",
        "method": "mujoco:euler",
        "family": "mujoco",
        "measure": "identity",
        "dt": 0.1,
        "steps": 200,
        "status": "ok",
        "detail": None,
        "value": 0.0,
        "wall_s": None,
        "data": json.dumps(
            {
                "match": "ref:semi_implicit_euler",
                "matches": ["ref:semi_implicit_euler"],
                "closest": "ref:semi_implicit_euler",
                "runner_up": "ref:leapfrog",
                "runner_up_deviation": 0.003,
                "name_suggests": None,
                "note": None,
                "match_claims": {
                    "order": 1,
                    "force_evals": 1,
                    "force_evals_text": "1",
                    "energy": "bounded",
                    "homega_max": 2.0,
                    "scheme": "ref:semi_implicit_euler",
                },
                "claims": {},
            }
        ),
    }
    cell = Cell.from_db_row(old)
    assert cell.figures == IdentityFigures(
        match="ref:semi_implicit_euler",
        matches=["ref:semi_implicit_euler"],
        closest="ref:semi_implicit_euler",
        runner_up="ref:leapfrog",
        runner_up_deviation=0.003,
        match_claims=Claims(
            scheme="ref:semi_implicit_euler",
            order=1,
            force_evals=1,
            force_evals_text="1",
            energy="bounded",
            homega_max=2.0,
        ),
    )
    assert cell.claims == Claims() and not cell.claims.known and cell.extra == {}
    assert cell.detail == "" and cell.wall_s == 0.0 and cell.steps == 200
    assert cell.figures.all_matches == ["ref:semi_implicit_euler"]
    energy = Cell.from_row(
        {
            "scene": "spring",
            "method": "ref:rk4",
            "family": "ref",
            "measure": "energy",
            "status": "ok",
            "value": 2.5e-6,
            "steps": 1000.0,
            "dt": float("nan"),
            "data": {"class": "decays", "rule": "trend", "failed_step": None, "settings": None},
        }
    )
    assert energy.figures.energy_class == "decays" and energy.figures.failed_step is None
    assert energy.dt is None and energy.steps == 1000 and energy.claims is None
    assert energy.data() == {"class": "decays", "rule": "trend"}


def test_claims_store_none_as_a_claim():
    """Explicit Euler claims no stable h*omega: a None that is stored, unlike a missing figure."""
    claims = Claims(
        scheme="ref:explicit_euler", order=1, force_evals=1, force_evals_text="1", energy="grows", homega_max=None
    )
    assert claims.to_data()["homega_max"] is None and "order_note" not in claims.to_data()
    assert Claims.from_data(claims.to_data())[0] == claims
    inf = Claims(scheme="ref:implicit_euler", homega_max=math.inf)
    assert Cell.from_db_row(Cell("s", "m", "ref", "cost", claims=inf).to_db_row()).claims.homega_max == math.inf
