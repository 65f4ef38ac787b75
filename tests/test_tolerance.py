"""Error-controlled integration as a method with a tolerance (``drake:runge_kutta3@1e-6``,
``rebound:ias15@1e-9``) and the ``tolerance`` cell: work-precision over the tolerance, with the
steps taken and rejected counted (``harness.measures.tolerance``)."""

from __future__ import annotations

import pytest

from records import InvalidInput
from records.cell import Cell
from scenarios import make_scene

pytest.importorskip("pydrake")

from harness.measures.tolerance import tolerance_sweep  # noqa: E402
from harness.methods import get_method  # noqa: E402
from records.figures import ToleranceFigures  # noqa: E402
from records.measures import Comparison  # noqa: E402

from harness.nightly.measures.tolerance_cells import _findings, _regression, _section  # noqa: E402


def test_a_tolerance_hands_the_step_to_drakes_error_control():
    """The fixed-step mode stays fixed at h; with a tolerance the same integrator is adaptive,
    its settings read back from Drake: error control on, that target accuracy, steps taken and
    rejected counted."""
    spring = make_scene("spring")
    fixed = get_method("drake:runge_kutta3").simulate(spring, 0.125, 8)
    assert fixed.meta.settings["fixed_step_mode"] is True and fixed.meta.settings["steps_taken"] == 8
    m = get_method("drake:runge_kutta3@1e-6")
    assert m.adaptive and m.id == "drake:runge_kutta3@1e-6"
    run = m.simulate(spring, spring.period, 3)
    s = run.meta.settings
    assert s["fixed_step_mode"] is False and s["target_accuracy"] == 1e-6
    # Error control takes many steps per output (the output interval is a whole period).
    assert s["steps_taken"] > 100 and s["steps_rejected"] >= 0
    # Run at a tolerance, the error sits near it: the exact state at 3 periods is (1, 0).
    assert abs(run.q[-1, 0, 0] - 1.0) < 1e-4


def test_a_method_without_an_error_estimate_refuses_a_tolerance():
    for mid in ("drake:semi_explicit_euler@1e-6", "drake:discrete_sap@1e-6", "ref:rk4@1e-6"):
        with pytest.raises(InvalidInput, match="unknown option 'tolerance'"):
            get_method(mid)
    with pytest.raises(InvalidInput, match=r"option tolerance=0 is out of range"):
        get_method("drake:runge_kutta3@0")
    with pytest.raises(InvalidInput, match="takes no tolerance"):
        tolerance_sweep("ref:rk4", make_scene("spring"), timing=False)


def test_ias15s_tolerance_is_its_epsilon():
    kepler = make_scene("kepler")
    run = get_method("rebound:ias15@1e-6").simulate(kepler, kepler.period, 2)
    assert run.meta.settings["epsilon"] == 1e-6
    assert get_method("rebound:ias15").simulate(kepler, kepler.period, 2).meta.settings["epsilon"] == 1e-9


def test_the_sweeps_error_follows_the_tolerance_and_its_work_grows():
    """Drake's RK3 with its embedded error estimate: the error per unit step is held to the
    tolerance, so the global error scales with it (measured 5.7x the tolerance at 1e-6 and 1e-8
    on the spring over 5 periods); two decades of tolerance give two decades of error, to the
    factor 3 allowed here for the controller's rejections and step-size rounding. The steps grow
    as tolerance^(-1/3) for a third-order method (x4.6 per two decades)."""
    res = tolerance_sweep("drake:runge_kutta3", make_scene("spring"), tolerances=(1e-4, 1e-6, 1e-8), timing=False)
    rows = res["rows"]
    assert [r["tolerance"] for r in rows] == [1e-4, 1e-6, 1e-8] and all(r["status"] == "ok" for r in rows)
    for a, b in zip(rows, rows[1:]):
        assert 100 / 3 < a["error"] / b["error"] < 100 * 3
        assert 4.6 / 1.5 < b["steps_taken"] / a["steps_taken"] < 4.6 * 1.5
    assert res["ended"] == "the tightest tolerance, 1e-08"


def test_the_sweep_stops_before_a_run_past_its_budget_by_counts_not_a_clock():
    """Drake's implicit Euler is first order: its work grows about tenfold per two decades of
    tolerance (2,160 then 16,661 evaluations at 1e-2, 1e-4), so a 50,000-evaluation budget stops it
    before 1e-6, whatever the machine's load."""
    res = tolerance_sweep(
        "drake:implicit_euler",
        make_scene("spring"),
        tolerances=(1e-2, 1e-4, 1e-6, 1e-8),
        max_evals=50_000,
        timing=False,
    )
    assert [r["tolerance"] for r in res["rows"]] == [1e-2, 1e-4]
    assert res["ended"].startswith("before tolerance 1e-06") and "past 50000" in res["ended"]


def _cell(rows, ended="the tightest tolerance, 1e-06", method="drake:runge_kutta3"):
    return Cell(
        scene="spring",
        method=method,
        family="drake",
        measure="tolerance",
        status="ok",
        value=max(r["error"] / r["tolerance"] for r in rows),
        figures=ToleranceFigures(rows=rows, ended=ended),
    )


ROWS = [
    {
        "tolerance": 1e-3,
        "error": 2e-3,
        "steps_taken": 81,
        "steps_rejected": 0,
        "force_evals": 243,
        "s_per_unit_time": 1e-4,
        "clock": "injected",
        "status": "ok",
    },
    {
        "tolerance": 1e-6,
        "error": 2.3e-6,
        "steps_taken": 780,
        "steps_rejected": 1,
        "force_evals": 2343,
        "s_per_unit_time": 1e-3,
        "clock": "injected",
        "status": "ok",
    },
]


def test_the_report_and_the_judge_read_the_sweep(tmp_path):
    from reports import charts

    cell = _cell(ROWS)
    piv = {("spring", cell.method): {"tolerance": cell}}
    (finding,) = _findings("spring", piv)
    assert (
        "global error / tolerance 2 to 2.3" in finding.text and "780 steps taken, 1 rejected at 1e-06" in finding.text
    )
    section = "\n".join(_section("spring", piv))
    assert "| `drake:runge_kutta3` | 1e-06 | 2.3e-06 | 780 | 1 | 2343 | 0.001 |" in section
    assert charts.tolerance_chart([cell], "spring", tmp_path / "t.png") and (tmp_path / "t.png").stat().st_size > 1000


def test_a_worse_error_at_the_same_tolerance_is_a_regression():
    worse = _regression(_cell(ROWS), _cell([dict(ROWS[0]), dict(ROWS[1], error=4e-6)]), Comparison())
    assert worse.kind == "tolerance" and (worse.before, worse.after) == (2.3e-6, 4e-6)
    assert "tolerance 1e-06" in worse.detail
    assert _regression(_cell(ROWS), _cell([dict(ROWS[1], error=3e-6)]), Comparison()) is None  # within half again


def test_harness_workprecision_sweeps_an_error_controlled_method_over_its_tolerances():
    import json

    from tests.test_cli import cli

    code, out, _ = cli(
        "workprecision",
        "spring",
        "--method",
        "drake:runge_kutta5",
        "--method",
        "ref:rk4",
        "--points",
        "2",
        "--repeats",
        "1",
        "--tolerances",
        "1e-3,1e-6",
        "--json",
    )
    doc = json.loads(out)
    assert code == 0 and {r["method"] for r in doc["rows"]} == {"ref:rk4"}
    (sweep,) = doc["error_controlled"]
    assert [r["method"] for r in sweep["rows"]] == ["drake:runge_kutta5@1e-3", "drake:runge_kutta5@1e-6"]
    assert all(r["steps_taken"] > 0 and r["s_per_unit_time"] > 0 for r in sweep["rows"])
    code, _, err = cli("workprecision", "spring", "--method", "ref:rk4", "--tolerances", "1e-3,0")
    assert code == 2 and "--tolerances=0 is out of range" in err


def test_a_stored_cell_is_read_back_with_its_measures_figures_in_a_fresh_process():
    """A reader that imports only the records gets a built-in measure's own figures type
    (``records.cell.FIGURES``), with no measure's declaration loaded, as the tolerance cell once
    did not (its findings met bare ``Figures``)."""
    import subprocess
    import sys

    code = (
        "from records.cell import Cell, CELL_COLUMNS\n"
        "row = {c: None for c in CELL_COLUMNS}\n"
        "row.update(scene='spring', method='drake:runge_kutta3', family='drake', measure='tolerance', "
        "status='ok', detail='', wall_s=0.0, data='{\"rows\": [], \"ended\": \"e\"}')\n"
        "print(type(Cell.from_db_row(row).figures).__name__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "ToleranceFigures"


def test_the_nightlys_tolerance_cell_times_on_the_cpu_clock_as_its_cost_cells_do():
    """One work-precision chart puts the cost cells (CPU clock) and the tolerance rows on one axis:
    the nightly's tolerance cell times its runs on the CPU clock too; the command keeps the wall."""
    from types import SimpleNamespace

    from records.measures import TaskContext

    from harness.nightly.measures.tolerance_cells import _run

    scene = make_scene("kepler")
    method = get_method("rebound:ias15")
    spec = SimpleNamespace(extras=SimpleNamespace(tolerances={"tolerances": [1e-6], "periods": 1.0, "repeats": 1}))
    task = SimpleNamespace(scene="kepler", method=method.id, family="rebound", params={}, timings=None)
    ctx = TaskContext(task, SimpleNamespace(cell_timeout=120.0), spec, scene, method)
    (cell,) = _run(ctx)
    assert [r["clock"] for r in cell.figures.rows] == ["cpu"]
    wall = tolerance_sweep(method, scene, tolerances=[1e-6], periods=1.0, repeats=1)
    assert [r["clock"] for r in wall["rows"]] == ["wall"]
