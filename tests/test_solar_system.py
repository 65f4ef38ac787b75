"""The outer solar system against REBOUND (issue 6): the engine models, what the scene must show
measured through the harness's measures, and the scene in the nightly. Every tolerance says
where it comes from; the measured values quoted are rebound 5.2.2 on x86-64.

The issue's horizon is 2e5 days at dt = 10 days. The engine runs here use it; the reference
schemes' energy runs use 5e4 days (11.5 Jupiter orbits, the energy rule's minimum of ten
periods with room): interpreted, 2e5 days would cost ~25 s, and every class measured at 5e4
days is the one measured at 2e5 days (bounded for the symplectic schemes, RK4 decays,
explicit Euler grows). The nightly's standard suite runs the full 2e5 days.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import adapters
from harness.nightly.cells import failed_cells, run_task
from harness.execution.isolation import WorkerFailure
from harness.measures.energy import energy_behaviour
from harness.measures.error import trajectory_error
from harness.methods import get_method
from harness.nightly.run import Task, build_tasks, report_run
from harness.history.storage import History
from harness.nightly.suites import SOLAR_MODES, SOLAR_STABILITY_HI, SUITES, SceneSpec, Suite
from harness.measures.workprecision import chart_ready, error_at_equal_cost, work_precision
from reference import METHODS, integrate
from records import Trajectory
from scenarios import make_scene
from tests.shared_fixture import built_once

pytest.importorskip("rebound")

DT = 10.0
STEPS = 20_000  # 2e5 days, the issue's study
SHORT_STEPS = 5_000  # 5e4 days
#: The issue's limit on IAS15's |dE/E| over the run.
IAS15_LIMIT = 1e-13


@pytest.fixture(scope="module")
def solar():
    return make_scene("solar_system")


def engine(method_id, scene, dt, steps, every=1):
    return adapters.ENGINE_METHODS[method_id].simulate(scene, dt, steps, every)


# ------------------------------------------------------------------------ the models
@pytest.mark.parametrize("mode", ["leapfrog", "whfast", "ias15", "saba"])
def test_rebound_poses_the_scene_itself(solar, mode):
    """Same bodies, masses, G and heliocentric start as the scene, nothing moved to the centre of
    mass, every perturbing default off and read back."""
    run = engine(f"rebound:{mode}", solar, DT, 3)
    q0, v0 = solar.initial_state()
    np.testing.assert_array_equal(run.q[0, 0], q0)  # step 0 read back from the engine, bitwise
    np.testing.assert_array_equal(run.v[0, 0], v0)
    s = run.meta.settings
    assert s["G"] == solar.pvec[0] == 2.95912208286e-4
    assert s["masses"] == solar.masses.tolist() and s["N"] == 6 and s["N_active"] == "all"
    assert s["move_to_com"] is False and s["additional_forces"] == "none"
    assert (s["gravity"], s["collision"], s["boundary"], s["softening"]) == ("basic", "none", "none", 0.0)
    assert s["exit_max_distance"] == s["exit_min_distance"] == 0.0
    assert s["integrator"] == mode
    assert s["advance"] == adapters.rebound.ADVANCE["adaptive" if mode == "ias15" else "fixed"]
    for name, value in adapters.rebound.MODES[mode].items():
        assert s[name] == value, name
    assert adapters.ENGINE_METHODS[f"rebound:{mode}"].describe()["adaptive"] is (mode == "ias15")


def test_rebound_leapfrog_is_ref_leapfrog_over_the_whole_study(solar):
    """Bitwise over 2e5 days: the scene's pair sum is spelled as REBOUND's gravity="basic", and
    both are drift-kick-drift. Measured max |difference| exactly 0 in every coordinate."""
    run = engine("rebound:leapfrog", solar, DT, STEPS, every=100)
    ref = integrate(METHODS["leapfrog"], solar, DT, STEPS, every=100)
    assert run.ok and ref.ok and np.array_equal(run.step, ref.step)
    np.testing.assert_array_equal(run.q, ref.q)
    np.testing.assert_array_equal(run.v, ref.v)


# ------------------------------------------------------------------------ energy
@pytest.mark.parametrize("method_id", ["rebound:leapfrog", "rebound:whfast", "rebound:saba", "rebound:ias15"])
def test_engine_energy_over_the_study(solar, method_id):
    """Every REBOUND mode keeps |dE/E| bounded over 2e5 days (harness.measures.energy's rule). Measured
    max |dE/E|: leapfrog 4.08e-6, whfast 5.31e-9, saba 5.0e-14, ias15 2.06e-15."""
    res = energy_behaviour(method_id, solar, DT, STEPS, every=20)
    assert res["status"] == "ok" and res["classification"] == "bounded", res["rule"]
    if method_id == "rebound:ias15":
        # The issue's bound; measured 2.06e-15, fifty times below it.
        assert res["max_rel_error"] <= IAS15_LIMIT


@pytest.mark.parametrize(
    "scheme_id, expected",
    [
        ("explicit_euler", "grows"),
        ("semi_implicit_euler", "bounded"),
        ("velocity_verlet", "bounded"),
        ("forest_ruth", "bounded"),
    ],
)
def test_reference_energy_classes(solar, scheme_id, expected):
    """Over 5e4 days at dt = 10 (leapfrog and RK4: in the nightly test below). Measured max
    |dE/E| (first-tenth / last-tenth envelopes): explicit Euler 0.47 (0.14 / 0.63), semi-implicit
    Euler 1.12e-3 (1.06e-3 / 1.07e-3), velocity Verlet 8.3e-6 (8.3e-6 / 8.3e-6), Forest-Ruth
    2.53e-9 (2.51e-9 / 2.53e-9)."""
    res = energy_behaviour(f"ref:{scheme_id}", solar, DT, SHORT_STEPS, every=10)
    assert res["status"] == "ok" and res["classification"] == expected, res["rule"]


@pytest.mark.slow
def test_reference_energy_classes_over_the_whole_study(solar):
    """The issue's 2e5 days for every reference scheme it names (compiled: 6 compiles, ~40 s).
    Measured max |dE/E| (first-tenth / last-tenth envelopes): leapfrog 4.08e-6, velocity Verlet
    8.42e-6, Forest-Ruth 2.56e-9, semi-implicit Euler 1.14e-3, all bounded; RK4 4.7e-9 decays
    (4.4e-10 / 4.7e-9, secular rate -2.4e-14 per day); explicit Euler 0.66 grows."""
    from reference import RefMethod

    expected = {
        "leapfrog": "bounded",
        "velocity_verlet": "bounded",
        "forest_ruth": "bounded",
        "semi_implicit_euler": "bounded",
        "rk4": "decays",
        "explicit_euler": "grows",
    }
    for scheme_id, cls in expected.items():
        res = energy_behaviour(RefMethod(METHODS[scheme_id], compiled=True), solar, DT, STEPS, every=20)
        assert res["status"] == "ok" and res["classification"] == cls, (scheme_id, res["rule"])


# ------------------------------------------------------------------------ work-precision
def test_whfast_is_ahead_of_leapfrog_at_equal_cost(solar, tmp_path, monkeypatch):
    """harness.measures.workprecision over one Jupiter orbit at h*omega = 0.2 .. 0.00625 (dt 140 .. 4.3
    days), each mode's timing run on REBOUND's own loop (sim.steps(n)) but its figure injected
    (``HARNESS_INJECT_TIMINGS``: a verdict drawn from timings must not depend on the machine's load):
    a WHFast step costs ~4.3x a leapfrog step (measured 1.4 us and 0.33 us, injected with a 3%
    jitter), so the two sweeps overlap in cost only where leapfrog's dt is a few times smaller than
    WHFast's; six points give three overlapping ones. At equal cost per simulated day WHFast's max
    global error is measured 3.2e-4 to 4.0e-4 of leapfrog's. Bound 1e-2: a factor 25 of room over
    the worst point (a 2x error in a cost moves a second-order method's interpolated error by 4x)."""
    timings = tmp_path / "timings.json"
    timings.write_text(
        json.dumps({"s_per_step": {"rebound:whfast": 1.4e-6, "rebound:leapfrog": 3.3e-7}, "jitter": [1.0, 1.03, 0.98]})
    )
    monkeypatch.setenv("HARNESS_INJECT_TIMINGS", str(timings))
    rows = work_precision(
        ["rebound:whfast", "rebound:leapfrog"], solar, points=6, homega_max=0.2, periods=1.0, repeats=3, time_steps=1000
    )
    assert all(r["status"] == "ok" for r in rows)
    chart = chart_ready(rows)
    whfast = {"cost": chart["rebound:whfast"]["s_per_unit_time"], "error": chart["rebound:whfast"]["error"]}
    leapfrog = {"cost": chart["rebound:leapfrog"]["s_per_unit_time"], "error": chart["rebound:leapfrog"]["error"]}
    compared = error_at_equal_cost(whfast, leapfrog)
    assert len(compared) >= 2, (whfast, leapfrog)  # the two sweeps overlap in cost
    assert max(r["ratio"] for r in compared) < 1e-2, compared


def test_error_at_equal_cost_interpolates_and_never_extrapolates():
    curve = {"cost": [1.0, 10.0, 100.0], "error": [1e-2, 1e-4, 1e-6]}
    at = {"cost": [0.5, 10.0**1.5, 1000.0], "error": [1.0, 1e-3, 1.0]}
    (row,) = error_at_equal_cost(curve, at)
    assert row["curve_error"] == pytest.approx(1e-5, rel=1e-12) and row["ratio"] == pytest.approx(1e-2, rel=1e-12)


# ------------------------------------------------------------------------ error horizon
def test_error_is_measured_within_the_reference_horizon(solar):
    """Past reference_horizon (2e5 days) the reference solve is not trusted: the error stops
    there and says so. Here the states are the reference itself up to 2e5 days and nonsense after."""
    t = np.array([0.0, 1e5, 2e5, 3e5])
    q, v = solar.reference_solution(t[:3])
    q = np.vstack([q, q[-1:] + 1e3])
    v = np.vstack([v, np.zeros((1, 18))])
    traj = Trajectory(
        "solar_system", "test", 1e5, 3, 1, np.arange(4), t, q[:, None], v[:, None], solar.energy(q, v)[:, None]
    )
    err = trajectory_error(traj, solar)
    assert err["error_max"] == 0.0 and err["horizon"] == 2e5 and err["t_compared"] == 2e5 and err["t_final"] == 3e5
    assert err["compared_all"] is False and err["source"] == "solar_system reference_solution"


# ------------------------------------------------------------------------ the nightly
def test_standard_suite_runs_the_issues_methods(solar):
    """REBOUND's modes (the suite's selection for the scene) and the six schemes the issue names against
    them (each declares the scene in its own file)."""
    standard = dataclasses.replace(SUITES["standard"], bounds=False)
    tasks, skipped = build_tasks(standard)
    issue_schemes = {
        "ref:explicit_euler",
        "ref:semi_implicit_euler",
        "ref:velocity_verlet",
        "ref:leapfrog",
        "ref:forest_ruth",
        "ref:rk4",
    }
    assert {t.method for t in tasks if t.scene == "solar_system"} == set(SOLAR_MODES) | issue_schemes
    left_out = {s["method"]: s["reason"] for s in skipped if s["scene"] == "solar_system"}
    assert "does not declare solar_system among the scenes it joins" in left_out["ref:implicit_midpoint"]
    assert "has no model of scene solar_system" in left_out["mujoco:euler"]
    full, _ = build_tasks(dataclasses.replace(SUITES["full"], bounds=False))
    supported = {m for m in (t.method for t in full if t.scene == "solar_system")}
    assert supported >= set(SOLAR_MODES) | issue_schemes | {"ref:implicit_midpoint", "ref:verlet"}


#: The nightly's solar-system cells at a test's size: 5e4 days, a short sweep; no identity (the
#: bitwise test above is the identity that matters). Stability separately, below.
STUDY = Suite(
    "solar_test",
    scenes={
        "solar_system": SceneSpec(
            dt=DT,
            horizon=DT * SHORT_STEPS,
            order_points=6,
            order_span=4.0,
            order_periods=0.5,
            stability=False,
            compiled=True,
        )
    },
    cost_repeats=3,
    cost_steps=2000,
    series_points=200,
    stability_steps=100,
    cell_timeout=120.0,
    bounds=False,
    identify=False,
)
NIGHTLY_METHODS = ("ref:leapfrog", "ref:rk4", "rebound:leapfrog", "rebound:whfast", "rebound:ias15")
#: The seconds per step the module's cost cells record instead of the clock's (``HARNESS_INJECT_TIMINGS``):
#: the work-precision and cost-ratio findings are verdicts drawn from timings, so they read these, not
#: a machine's load. The figures are the ones measured on this project's quiet 2-core machine (REBOUND's
#: from docs/engines.md, the compiled reference kernels' from a standard nightly).
INJECTED = {
    "s_per_step": {
        "ref:explicit_euler": 1.3e-7,
        "ref:leapfrog": 4.6e-7,
        "ref:rk4": 1.72e-6,
        "rebound:leapfrog": 1.9e-7,
        "rebound:whfast": 1.08e-6,
        "rebound:ias15": 3.3e-5,
    }
}


def _solar_nightly(tmp):
    history = History(tmp / "h.sqlite")
    run_id = history.start_run(started="now", suite="solar_test", git_commit=None, versions={}, machine={}, settings={})
    timings = tmp / "timings.json"
    timings.write_text(json.dumps(INJECTED))
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(SUITES, "solar_test", STUDY)
        mp.setenv("HARNESS_INJECT_TIMINGS", str(timings))
        cells = {
            m: run_task(Task("cell", "solar_system", m, get_method(m).family, {}, "solar_test"))
            for m in NIGHTLY_METHODS
        }
        for rows in cells.values():
            for c in rows:
                history.add_cell(run_id, c)
        report = report_run(history, run_id, tmp / "out").read_text()
        # The same run with one more task that timed out: the findings still render, and say so.
        failure = WorkerFailure("timed_out", "worker killed after 120 s")
        for c in failed_cells(Task("cell", "solar_system", "rebound:saba", "rebound", {}, "solar_test"), failure):
            history.add_cell(run_id, c)
        with_failure = report_run(history, run_id, tmp / "out2").read_text()
    return cells, report, with_failure


@pytest.fixture(scope="module")
def nightly_cells(tmp_path_factory):
    """The nightly's tasks on the solar system and their report, built once a test run."""
    return built_once(tmp_path_factory, "solar-nightly", _solar_nightly)


def test_every_nightly_measure_runs_on_the_solar_system(nightly_cells):
    cells, _, _ = nightly_cells
    for method, rows in cells.items():
        measures = {c.measure: c for c in rows}
        assert all(c.status == "ok" for c in rows), [(c.measure, c.status, c.detail) for c in rows]
        if method == "rebound:ias15":
            # Adaptive: dt is its output interval, so no order (and no stability limit) in dt.
            assert set(measures) == {"energy", "error", "cost"}
        else:
            assert set(measures) == {"energy", "error", "order", "cost"}
            # Second order for the leapfrogs and WHFast, fourth for RK4, within the order tests' 0.15
            # (measured 1.994, 2.003, 4.093 over half an orbit).
            assert measures["order"].value == pytest.approx(4 if method == "ref:rk4" else 2, abs=0.15)
        assert measures["error"].figures.source == "solar_system reference_solution"
    ref = {c.measure: c for c in cells["ref:leapfrog"]}
    assert ref["energy"].figures.backend == "compiled" and ref["cost"].figures.force_evals_per_step == 1


def test_stability_cells_on_the_solar_system(nightly_cells):
    """The full suite's stability measure at a test's size (100 steps, search capped as the full
    suite caps it). ref:leapfrog is limited at h*omega = 2.20 (1.94 over 1000 steps): near 2, the
    limit on a harmonic mode of Jupiter's frequency. WHFast, exact on each Kepler orbit, is still
    bounded at the cap."""
    spec = dataclasses.replace(STUDY.scenes["solar_system"], stability=True, stability_hi=SOLAR_STABILITY_HI)
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(SUITES, "solar_test", dataclasses.replace(STUDY, scenes={"solar_system": spec}))
        cells = {
            m: {c.measure: c for c in run_task(Task("cell", "solar_system", m, get_method(m).family, {}, "solar_test"))}
            for m in ("ref:leapfrog", "rebound:whfast")
        }
    leapfrog, whfast = cells["ref:leapfrog"]["stability"], cells["rebound:whfast"]["stability"]
    assert leapfrog.status == "ok" and leapfrog.figures.verdict == "limited"
    assert 1.5 < leapfrog.value < 2.5
    assert whfast.status == "ok" and whfast.figures.verdict == "unbounded"
    assert whfast.figures.homega_searched == pytest.approx(SOLAR_STABILITY_HI, rel=1e-12)


def test_nightly_report_states_the_solar_findings(nightly_cells):
    """The findings module's lines, each with its verdict mark: all pass on this run."""
    cells, report, with_failure = nightly_cells
    lines = [ln for ln in report.splitlines() if ln.startswith("- `solar_system`")]
    assert any("all bounded ✓" in ln for ln in lines), lines
    assert any("`ref:rk4`'s energy error is not bounded but decays ✓" in ln for ln in lines), lines
    assert any("`rebound:ias15` keeps max |ΔE/E|" in ln and ln.endswith("✓.") for ln in lines), lines
    assert any("times `rebound:leapfrog`'s" in ln and ln.endswith("✓.") for ln in lines), lines
    assert not any("✗" in ln for ln in lines), lines
    cost = {m: next(c for c in rows if c.measure == "cost") for m, rows in cells.items()}
    # The cost cells record the injected seconds per step, and say so.
    assert {c.figures.clock for c in cost.values()} == {"injected"}
    assert cost["ref:rk4"].value == pytest.approx(INJECTED["s_per_step"]["ref:rk4"], rel=1e-12)
    assert any("`ref:rk4` takes" in ln for ln in lines)
    assert "`rebound:saba` timed_out" in with_failure
    assert (
        "| `rebound:saba` | solar_system | **timed_out** |" in with_failure
        and "worker killed after 120 s" in with_failure
    )
