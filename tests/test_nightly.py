"""The nightly run: smoke suite end to end, regressions, a killed run, failing cells.

The smoke nightly costs 10-15 s on an idle 2-core machine (most of it numba compiling the
reference schemes' timing kernels), so the module runs it three times in all: ``first_run``,
the rerun after a killed run (``killed_then_rerun``, which is also the unchanged rerun) and
the rerun with a tightened bound. Each test that needs a history of its own works on a copy.
"""

import contextlib
import io
import json
import math
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import matplotlib.colors
from matplotlib.image import imread

from harness.history import bounds as bounds_mod
from harness.cli import main
from harness.history.compare import compare_cells
from harness.nightly.run import Task, run_nightly, schedule
from harness.history.storage import History
from harness.nightly.suites import SUITES, SceneSpec, Suite
from harness.judge import judge
from reports import charts
from reports.drawing import ChartNotDrawn
from reports.markdown import write_report

SECTIONS = [
    "## Verdict",
    "## The trade-off, measured",
    "## Which scheme each engine mode is",
    "## Per scene",
    "## At 60 Hz",
    "## Findings",
    "## Failures",
    "## Appendix: versions and settings",
]
ROOT = Path(__file__).resolve().parents[1]
#: The one reviewed bound the module's runs measure: semi-implicit Euler's band on the unit
#: spring, max |dE/E| = h/2 = 0.05 at h = 0.1 (tests/theory.py), with the file's 1.5x margin.
BOUND = bounds_mod.Bound("spring", "ref:semi_implicit_euler", 0.1, 2000, 0.079)


#: The timings the module's nightlies record instead of the clock's (``HARNESS_INJECT_TIMINGS``),
#: the smoke methods' as measured here: the verdicts these tests read (no slowdown on an unchanged
#: rerun) depend on no clock, so on no neighbour.
TIMINGS = {
    "s_per_step": {
        "ref:explicit_euler": 3.9e-9,
        "ref:semi_implicit_euler": 7.6e-9,
        "ref:leapfrog": 8.5e-9,
        "ref:rk4": 1.6e-8,
        "ref:implicit_euler": 1.4e-8,
        "mujoco:euler": 1.2e-6,
        "pymunk:applied_force": 3.1e-6,
        "drake:runge_kutta3": 5.5e-6,
        "drake:discrete_sap": 4.1e-6,
        "*": 1e-6,
    },
    "jitter": [1.0, 1.03, 0.98],
    "calibration": {"python": 5e-8, "compiled": 4e-9},
}


@pytest.fixture(scope="module", autouse=True)
def injected_timings(tmp_path_factory):
    path = tmp_path_factory.mktemp("timings") / "timings.json"
    path.write_text(json.dumps(TIMINGS))
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HARNESS_INJECT_TIMINGS", str(path))
        yield path


def nightly(tmp, *extra, bounds):
    argv = [
        "nightly",
        "--suite",
        "smoke",
        "--out",
        str(tmp / "out"),
        "--db",
        str(tmp / "h.sqlite"),
        "--jobs",
        "2",
        "--bounds",
        str(bounds),
    ]
    return main(argv + list(extra))


def compare(tmp, bounds):
    return main(["compare", "--db", str(tmp / "h.sqlite"), "--bounds", str(bounds)])


@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("nightly")
    bounds = tmp / "bounds.csv"
    bounds_mod.save([BOUND], bounds)
    code = nightly(tmp, bounds=bounds)
    return tmp, bounds, code


@pytest.fixture(scope="module")
def killed_then_rerun(first_run):
    """A nightly started in its own session, SIGKILLed with its process group once it has stored
    cells, then the next nightly on the same history and report directory."""
    tmp, bounds, _ = first_run
    report = tmp / "out" / "report.md"
    before = report.read_text()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "harness",
            "nightly",
            "--suite",
            "smoke",
            "--out",
            str(tmp / "out"),
            "--db",
            str(tmp / "h.sqlite"),
            "--bounds",
            str(bounds),
            "--jobs",
            "2",
        ],
        cwd=ROOT,
        env=env,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    stored = 0
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:  # kill once its cells are being stored
        with sqlite3.connect(tmp / "h.sqlite") as con:
            stored = con.execute(
                "SELECT COUNT(*) FROM cells WHERE run_id IN (SELECT run_id FROM runs WHERE complete = 0)"
            ).fetchone()[0]
        if stored:
            break
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    seen = {
        "stored_before_kill": stored,
        "returncode": proc.returncode,
        "report_unchanged": report.read_text() == before,
        "charts_present": all((tmp / "out" / name).stat().st_size > 0 for name in _chart_links(before)),
        "integrity": History(tmp / "h.sqlite").integrity_ok(),
        "complete": list(History(tmp / "h.sqlite").runs().run_id),
        "all": list(History(tmp / "h.sqlite").runs(complete_only=False).run_id),
    }
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(
            [
                "nightly",
                "--suite",
                "smoke",
                "--out",
                str(tmp / "out"),
                "--db",
                str(tmp / "h.sqlite"),
                "--jobs",
                "2",
                "--bounds",
                str(bounds),
                "--json",
            ]
        )
    seen["summary"] = json.loads(out.getvalue())
    return seen, code


def _chart_links(report: str) -> list[str]:
    return [line.split("](", 1)[1].rstrip(")") for line in report.splitlines() if line.startswith("![")]


def test_smoke_nightly_writes_every_section_and_charts(first_run):
    tmp, _, code = first_run
    assert code == 0
    report = (tmp / "out" / "report.md").read_text()
    positions = [report.index(section) for section in SECTIONS]
    assert positions == sorted(positions)  # the verdict first, the appendix last
    charts = list((tmp / "out" / "charts").glob("*.png"))
    assert {c.name.split("-")[-1] for c in charts} == {
        "energy.png",
        "workprecision.png",
        "stability.png",
        "advise60hz.png",
        "tolerance.png",
    }
    assert all(c.stat().st_size > 1000 for c in charts)
    assert sorted(_chart_links(report)) == sorted(f"charts/{c.name}" for c in charts)
    # The trade-off table shows explicit Euler as `grows`, with the textbook agreeing.
    row = next(line for line in report.splitlines() if line.startswith("| `ref:explicit_euler`"))
    assert "grows [grows] ✓" in row
    assert "| `mujoco:euler` | spring | `ref:semi_implicit_euler` | 0.00e+00 |" in report  # bitwise
    scene_table = report.split("### `spring`")[1].split("![")[0]
    for method in SUITES["smoke"].methods:  # every method has its row, measured in full
        assert f"| `{method}` | ok |" in scene_table
    advice = report.split("## At 60 Hz")[1].split("## Findings")[0]
    # The games default needs 16 substeps for 1e-3 (its energy error is h*omega/2); leapfrog
    # meets it at 1 and explicit Euler at none (spectral radius > 1 at every h).
    assert "**Advised: `ref:leapfrog`, 1 substep" in advice or "**Advised: `ref:rk4`, 1 substep" in advice
    assert "| `ref:semi_implicit_euler` | 16 | 0.00104 |" in advice
    # The 60 Hz cells judge where the positions end too, by default (issue 42).
    assert "Position tolerance here: 0.05 (5% of the scene's length scale 1)." in advice
    assert "| converged |" in advice
    assert "`ref:explicit_euler`: unstable: spectral radius > 1 at every h" in advice
    findings = report.split("## Findings")[1].split("## Failures")[0]
    assert "`pymunk:applied_force` on `spring` is **explicit Euler**" in findings
    appendix = report.split("## Appendix")[1]
    assert "| mujoco | " in appendix and "- `mujoco:euler` on `spring` (" in appendix and "timestep=" in appendix
    footer = report.split("\n---\n")[1]
    for part in (
        "Wall time",
        "CPU time in the workers",
        "of it numba compiling",
        "Worker seconds by measure: ",
        "By family: ",
        "Slowest tasks: cell spring ",
    ):
        assert part in footer
    # Families in order of their worker seconds: which comes first depends on the smoke's methods.
    assert "ref " in footer.split("By family: ")[1].splitlines()[0]


def test_smoke_nightly_stores_a_valid_complete_run(first_run):
    tmp, _, _ = first_run
    h = History(tmp / "h.sqlite")
    assert h.integrity_ok()
    run = h.runs().iloc[0]
    assert run.run_id == 1 and run.complete == 1
    assert run.suite == "smoke" and run.versions["numpy"] and run.machine["cpus"]
    cells = h.cells(1)
    assert set(cells.measure) == {
        "energy",
        "error",
        "order",
        "stability",
        "cost",
        "identity",
        "bound",
        "advise",
        "tolerance",
    }
    assert not cells.duplicated(["scene", "method", "measure", "dt"]).any()
    assert set(cells.status) == {"ok"}
    # Every cost figure is the injected one, and says so: no verdict of this module reads a clock.
    cost = cells[cells.measure == "cost"]
    assert {d["clock"] for d in cost.data} == {"injected"} and run.settings["injected_timings"]["s_per_step"]
    assert all(v == TIMINGS["s_per_step"][m] * 0.98 for m, v in zip(cost.method, cost.value))  # the least repeat
    timing = run.timing
    # Where the time went adds up: worker seconds by measure and by family are two splits of one sum.
    assert sum(timing["worker_seconds_by_measure"].values()) == pytest.approx(
        sum(timing["worker_seconds_by_family"].values()), rel=1e-9
    )
    assert len(timing["task_s"]) == timing["tasks"] == 10  # 9 methods on the spring (two of them Drake's), 1 bound
    assert timing["tasks_without_cpu"] == 0
    # Two single-threaded workers cannot spend more CPU than twice the wall time they ran in
    # (5% for the clocks' granularity), and compiling is part of that CPU time. Each worker
    # compiles a (scheme, scene) pair's kernels or loads them from the disk cache (which of the
    # two depends on what ran on this machine before), at least once per scheme on the spring.
    assert 0 <= timing["numba_compile_s"] < timing["worker_cpu_s"] <= 2 * timing["cells_s"] * 1.05
    assert timing["kernels_compiled"] + timing["kernels_loaded"] >= 5
    assert (timing["numba_compile_s"] > 0) == (timing["kernels_compiled"] > 0)
    assert timing["cells_s"] < timing["total_s"] < timing["finished_s"]


def _write_stored_report(tmp: Path, out: Path, jobs: int) -> str:
    """The smoke run's report written again from its stored cells, its charts drawn by ``jobs``
    processes."""
    h = History(tmp / "h.sqlite")
    cells = h.cell_records(1)
    return write_report(h.run(1), cells, judge(cells), out, timing=h.run(1)["timing"], jobs=jobs).read_text()


def _broken_energy_chart(cells, scene, path, styles=None):
    raise RuntimeError("energy series unreadable")


def test_charts_drawn_in_worker_processes_make_the_same_report(first_run, tmp_path):
    tmp, _, _ = first_run
    serial = _write_stored_report(tmp, tmp_path / "serial", jobs=1)
    parallel = _write_stored_report(tmp, tmp_path / "parallel", jobs=2)
    assert parallel == serial  # the markdown, byte for byte
    links = _chart_links(serial)
    assert len(links) == 5  # the spring's energy, work-precision, stability, 60 Hz advice and tolerance charts
    for folder in ("serial", "parallel"):
        assert sorted(p.name for p in (tmp_path / folder / "charts").iterdir()) == sorted(Path(n).name for n in links)
    for name in links:  # the same drawing code on the same cells: the same pixels
        a, b = imread(tmp_path / "serial" / name), imread(tmp_path / "parallel" / name)
        assert a.shape == b.shape and np.array_equal(a, b), name


def test_a_chart_that_raises_in_a_worker_leaves_the_report_whole(first_run, tmp_path, monkeypatch):
    """The broken chart is left out as a chart with nothing to draw is, and named in a warning;
    the rest of the report is as it was."""
    tmp, _, _ = first_run
    whole = _write_stored_report(tmp, tmp_path / "whole", jobs=1)
    monkeypatch.setattr(charts, "energy_chart", _broken_energy_chart)
    with pytest.warns(ChartNotDrawn, match=r"run1-spring-energy\.png .*RuntimeError: energy series unreadable"):
        report = _write_stored_report(tmp, tmp_path / "out", jobs=2)
    energy_link = "![Energy against time on spring](charts/run1-spring-energy.png)\n\n"
    assert energy_link in whole
    assert report == whole.replace(energy_link, "")
    assert sorted(p.name for p in (tmp_path / "out" / "charts").iterdir()) == [
        "run1-spring-advise60hz.png",
        "run1-spring-stability.png",
        "run1-spring-tolerance.png",
        "run1-spring-workprecision.png",
    ]


def test_a_killed_nightly_leaves_report_and_history_whole_and_the_next_run_succeeds(killed_then_rerun, first_run):
    seen, code = killed_then_rerun
    assert seen["stored_before_kill"] > 0 and seen["returncode"] == -signal.SIGKILL
    assert seen["report_unchanged"] and seen["charts_present"] and seen["integrity"]
    assert seen["complete"] == [1] and seen["all"] == [1, 2]  # the killed run is stored, not complete
    assert code == 0
    summary = seen["summary"]
    assert summary["run_id"] == 3 and summary["previous"] == 1  # compared with the complete run only
    tmp, _, _ = first_run
    assert list(History(tmp / "h.sqlite").runs().run_id)[:2] == [1, 3]


def test_unchanged_rerun_exits_0_and_a_tightened_bound_exits_1(killed_then_rerun, first_run, capsys):
    _, code = killed_then_rerun
    assert code == 0  # the rerun after the kill changed nothing: no regression, slowdowns included
    tmp, bounds, _ = first_run
    capsys.readouterr()
    assert compare(tmp, bounds) == 0
    assert "no regressions" in capsys.readouterr().out
    tight = tmp / "tight.csv"
    bounds_mod.save([bounds_mod.Bound(BOUND.scene, BOUND.method, BOUND.dt, BOUND.steps, 1e-6)], tight)
    assert compare(tmp, tight) == 1
    named = "energy bound: ref:semi_implicit_euler on spring at dt=0.1"
    assert named in capsys.readouterr().out
    assert nightly(tmp, bounds=tight) == 1
    assert f"REGRESSION {named}" in capsys.readouterr().out
    verdict = (tmp / "out" / "report.md").read_text().split("## The trade-off")[0]
    assert named in verdict


def test_a_perturbed_method_is_named_by_compare(killed_then_rerun, first_run, tmp_path, capsys):
    tmp, bounds, _ = first_run
    shutil.copy(tmp / "h.sqlite", tmp_path / "h.sqlite")
    h = History(tmp_path / "h.sqlite")
    last = int(h.runs().run_id.iloc[-1])
    cells = h.cells(last)

    def perturb(method, measure, **change):
        row = cells[(cells.method == method) & (cells.measure == measure)].iloc[0].to_dict()
        h.add_cell(last, {**row, **change})

    value = lambda method, measure: float(cells[(cells.method == method) & (cells.measure == measure)].value.iloc[0])
    perturb("ref:rk4", "order", value=value("ref:rk4", "order") - 1.0)  # its observed order drops by one
    perturb("ref:leapfrog", "stability", value=value("ref:leapfrog", "stability") * 0.95)
    perturb("mujoco:euler", "energy", status="crashed", detail="worker killed by SIGSEGV")
    capsys.readouterr()
    assert compare(tmp_path, bounds) == 1
    out = capsys.readouterr().out
    assert "order: ref:rk4 on spring" in out
    assert "stability: ref:leapfrog on spring" in out
    assert "new failure: mujoco:euler on spring" in out and "SIGSEGV" in out
    assert len([line for line in out.splitlines() if "REGRESSION" in line]) == 3


def test_bounds_update_proposes_from_a_run_and_never_loosens_silently(first_run, tmp_path, capsys):
    tmp, _, _ = first_run
    measured = History(tmp / "h.sqlite").cells(1)
    measured = float(measured[measured.measure == "bound"].value.iloc[0])
    proposed = bounds_mod.round_up_2sig(measured * bounds_mod.MARGIN)
    assert measured < proposed <= measured * bounds_mod.MARGIN * 1.1  # two digits round up by < 10%
    loose, tight = tmp_path / "loose.csv", tmp_path / "tight.csv"
    bounds_mod.save([bounds_mod.Bound(BOUND.scene, BOUND.method, BOUND.dt, BOUND.steps, 0.5)], loose)
    bounds_mod.save([bounds_mod.Bound(BOUND.scene, BOUND.method, BOUND.dt, BOUND.steps, 1e-6)], tight)
    db = ["--db", str(tmp / "h.sqlite"), "--run", "1"]
    capsys.readouterr()
    assert main(["bounds", "--update", "--write", "--file", str(loose), *db]) == 0
    assert capsys.readouterr().out.startswith("tighten ")
    assert bounds_mod.load(loose)[0].bound == proposed
    assert main(["bounds", "--update", "--write", "--file", str(tight), *db]) == 0
    out = capsys.readouterr().out
    assert out.startswith("loosen ") and "1 bound(s) would loosen: not written without --allow-loosen" in out
    assert bounds_mod.load(tight)[0].bound == 1e-6  # flagged, not applied
    assert main(["bounds", "--update", "--write", "--allow-loosen", "--file", str(tight), *db]) == 0
    assert bounds_mod.load(tight)[0].bound == proposed


def test_bounds_proposal_rule():
    current = [
        bounds_mod.Bound("spring", "m", 0.1, 10, 1e-3),
        bounds_mod.Bound("spring", "n", 0.1, 10, 1e-3),
        bounds_mod.Bound("spring", "k", 0.1, 10, 1e-3),
    ]
    props = {
        p.bound.method: p
        for p in bounds_mod.propose(
            current,
            {
                ("spring", "m", 0.1, 10): 1e-5,
                ("spring", "n", 0.1, 10): 5e-3,
                ("spring", "k", 0.1, 10): 9e-4,
                ("spring", "z", 0.1, 10): 1e-20,
            },
        )
    }
    assert props["m"].action == "tighten" and props["m"].bound.bound == 1.5e-5  # 1e-5 * 1.5, not 1.6e-5
    assert props["n"].action == "loosen" and props["n"].bound.bound == 7.5e-3
    assert props["k"].action == "keep" and props["k"].bound.bound == 1e-3  # 1.35e-3 > 1e-3 but 9e-4 holds
    assert props["z"].action == "add" and props["z"].bound.bound == bounds_mod.FLOOR
    kept = {b.method: b.bound for b in bounds_mod.apply(current, list(props.values()))}
    assert kept == {"m": 1.5e-5, "n": 1e-3, "k": 1e-3, "z": bounds_mod.FLOOR}
    assert [bounds_mod.round_up_2sig(x) for x in (1.23e-5, 0.079, 9.99e-3, 1.5e-5)] == [1.3e-5, 0.079, 0.01, 1.5e-5]


#: The reviewed bounds on reference schemes (engine bounds run in the nightly, in worker processes).
COMMITTED_REF_BOUNDS = [b for b in bounds_mod.load() if b.method.startswith("ref:")]


def test_the_bounds_file_has_reference_bounds_to_check():
    """The parametrised test below cannot pass by having nothing to check."""
    assert len(COMMITTED_REF_BOUNDS) >= 10


@pytest.mark.parametrize(
    "b", COMMITTED_REF_BOUNDS, ids=[f"{b.method}-{b.scene}-dt{b.dt:g}" for b in COMMITTED_REF_BOUNDS]
)
def test_committed_bounds_hold(energy_bound, b):
    """The reviewed bounds file, run through the pytest plugin: one test per bound."""
    energy_bound(b.method, b.scene, dt=b.dt, steps=b.steps, bound=b.bound)


def test_a_crashing_and_a_hanging_engine_are_recorded_and_reported(tmp_path, monkeypatch):
    """Engine modes from a HARNESS_PLUGINS module (tests/faulty_plugin.py) that abort and hang in
    their first step: the run completes, the cells say crashed / timed_out, the report says where
    and why."""
    monkeypatch.setenv("HARNESS_PLUGINS", "tests.faulty_plugin")
    # The limit is CPU seconds: a neighbour's load does not bring it nearer, so the aborting worker
    # reaches its first step whatever the machine does; the hang spends it twice (one retry).
    suite = Suite("faults", scenes={"spring": SceneSpec(periods=1)}, methods=(), bounds=False, cell_timeout=4.0)
    result = run_nightly(suite, tmp_path / "out", tmp_path / "h.sqlite", jobs=2)
    assert result["timing"]["retried"] == ["cell spring faulty:hang"]  # the hang cost two tries of its limit
    assert [r.method for r in result["not_measured"]] == ["faulty:hang"] * 6 and result["regressions"] == []
    h = History(tmp_path / "h.sqlite")
    assert list(h.runs().run_id) == [result["run_id"]]  # complete
    cells = h.cells(result["run_id"])
    measures = {"identity", "energy", "error", "order", "stability", "cost"}
    abort, hang = cells[cells.method == "faulty:abort"], cells[cells.method == "faulty:hang"]
    assert set(abort.measure) == set(hang.measure) == measures
    assert set(abort.status) == {"crashed"} and set(hang.status) == {"timed_out"}
    first = lambda df: df[df.measure == "identity"].detail.iloc[0]  # identity runs first
    assert first(abort).startswith("worker killed by SIGABRT")
    why = first(hang)
    assert why.startswith("spent 4") and "CPU s, its limit 4 (" in why and why.endswith("worker killed")
    assert set(hang[hang.measure != "identity"].detail) == {f"not reached: the worker was lost in identity ({why})"}
    report = (tmp_path / "out" / "report.md").read_text()
    verdict = report.split("## The trade-off")[0]
    assert "`faulty:abort` on `spring`" in verdict and "`faulty:hang` on `spring`" in verdict
    table = report.split("### `spring`")[1].split("## Findings")[0]
    assert "| `faulty:abort` | crashed |" in table and "| `faulty:hang` | timed_out |" in table
    failures = report.split("## Failures")[1].split("## ")[0]
    assert "| `faulty:abort` | spring | **crashed** | identity | worker killed by SIGABRT" in failures
    assert f"| `faulty:hang` | spring | **timed_out** | identity | {why} |" in failures
    assert "6 cell(s) not measured this run" in verdict


def test_a_bad_plugin_is_one_line_exit_2(monkeypatch, capsys):
    monkeypatch.setenv("HARNESS_PLUGINS", "no_such_plugin_module")
    assert main(["nightly", "--suite", "smoke"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "HARNESS_PLUGINS: plugin module 'no_such_plugin_module' cannot be imported" in err


def test_long_tasks_are_scheduled_first_and_new_ones_before_all():
    tasks = [Task("cell", "spring", m, "ref") for m in ("a", "b", "c")]
    expected = {"cell spring a": 1.0, "cell spring b": 9.0}
    assert [t.method for t in schedule(tasks, expected)] == ["c", "b", "a"]


def test_new_cells_that_crash_are_new_failures_and_new_unstable_ones_are_not():
    def frame(*rows):
        return pd.DataFrame(
            [
                {
                    "scene": "s",
                    "method": m,
                    "measure": "energy",
                    "dt": 0.1,
                    "status": st,
                    "detail": "",
                    "value": 1.0,
                    "data": {},
                }
                for m, st in rows
            ]
        )

    regs = compare_cells(frame(("a", "ok")), frame(("a", "ok"), ("b", "crashed"), ("c", "unstable")), [])
    assert [(r.kind, r.method) for r in regs] == [("new failure", "b")]


def test_a_cell_that_timed_out_is_not_measured_this_run_never_a_regression():
    """Measured before and timed out now, or new and timed out: not measured this run, counted
    apart (the run tried the task once more first); a crash after an ok is still a new failure."""
    from harness.history.compare import not_measured, regression_lines

    def frame(*rows):
        return pd.DataFrame(
            [
                {"scene": "s", "method": m, "measure": "energy", "dt": 0.1, "status": st, "detail": "why", "value": 1.0}
                for m, st in rows
            ]
        )

    a = frame(("a", "ok"), ("b", "ok"))
    b = frame(("a", "timed_out"), ("b", "crashed"), ("c", "timed_out"))
    assert [(r.kind, r.method) for r in compare_cells(a, b, [])] == [("new failure", "b")]
    gone = not_measured(b, a)
    assert [(r.kind, r.method, r.before) for r in gone] == [
        ("not measured", "a", "ok"),
        ("not measured", "c", "absent"),
    ]
    lines = regression_lines([], gone)
    assert lines[0] == "no regressions" and lines[1].startswith("2 cell(s) not measured this run")


def test_a_slowdown_is_flagged_beyond_repeat_and_process_spread_only():
    def frame(ratio, spread):
        return pd.DataFrame(
            [
                {
                    "scene": "s",
                    "method": "m",
                    "family": "f",
                    "measure": "cost",
                    "dt": 0.1,
                    "status": "ok",
                    "detail": "",
                    "value": 1.0,
                    "data": {"ratio_to_explicit_euler": ratio, "ratio_spread": spread},
                }
            ]
        )

    # Unchanged code moved a ratio by up to 1.34x between processes (compare.PROCESS_SPREAD).
    assert compare_cells(frame(4.0, 0.05), frame(5.6, 0.05), []) == []  # 1.40x < 1 + 0.05 + 0.05 + 0.5
    regs = compare_cells(frame(4.0, 0.05), frame(6.5, 0.05), [])  # 1.63x
    assert [(r.kind, r.method) for r in regs] == [("slowdown", "m")]


def test_runs_of_different_suites_are_not_compared(tmp_path, capsys):
    h = History(tmp_path / "h.sqlite")
    for suite in ("smoke", "standard"):
        run = h.start_run(started="t", suite=suite, git_commit=None, versions={}, machine={}, settings={})
        h.finish_run(run, finished="t", wall_s=0.0, timing={}, regressions=0)
    assert h.previous_complete(2) is None
    assert main(["compare", "1", "2", "--db", str(tmp_path / "h.sqlite")]) == 2
    assert "ran different suites (smoke vs standard): not comparable" in capsys.readouterr().err


def test_bad_suite_and_bad_timeout_are_one_line_exit_2(capsys):
    assert main(["nightly", "--suite", "huge"]) == 2
    assert "valid: smoke, standard, full" in capsys.readouterr().err
    assert main(["nightly", "--suite", "smoke", "--cell-timeout", "0"]) == 2
    assert "--cell-timeout=0 is out of range" in capsys.readouterr().err


def test_every_chart_keeps_its_legend_off_the_data_and_each_method_its_colour(first_run, monkeypatch, tmp_path):
    """Each chart of the smoke report drawn again, its figure caught before it is saved: the legend
    lies outside the axes, and a method has one colour and one marker in every chart it is in,
    no two methods of the report the same pair."""
    tmp, _, _ = first_run
    h = History(tmp / "h.sqlite")
    cells = h.cell_records(1)
    seen, save = [], charts._save

    def keep(fig, path):
        fig.canvas.draw()
        seen.append((path.name, fig))
        for ax in fig.axes:
            legend = ax.get_legend()
            if legend is not None:
                box, axes = legend.get_window_extent(), ax.get_window_extent()
                assert box.x0 >= axes.x1 or box.y0 >= axes.y1, f"{path.name}: legend over the axes"
        styles = {}
        for line in fig.axes[0].get_lines():
            method = line.get_label().split(" ")[0]
            if method.startswith(("ref:", "mujoco:", "pymunk:", "pybullet:", "rebound:")) and line.get_marker():
                styles[method] = (matplotlib.colors.to_hex(line.get_color()), line.get_marker())
        seen[-1] = (path.name, styles)
        return save(fig, path)

    monkeypatch.setattr(charts, "_save", keep)
    import reports.markdown as markdown

    todo, _ = markdown.report_charts(1, cells)
    from reports.drawing import draw_charts

    drawn = draw_charts(todo, tmp_path, jobs=1)
    assert len(drawn) >= 4 and len(seen) == len(drawn)
    by_method: dict[str, set] = {}
    for _, styles in seen:
        for method, style in styles.items():
            by_method.setdefault(method, set()).add(style)
    assert len(by_method) >= 7
    assert all(len(s) == 1 for s in by_method.values()), by_method  # the same in every chart
    pairs = [next(iter(s)) for s in by_method.values()]
    assert len(set(pairs)) == len(pairs) and len({c for c, _ in pairs}) == len(pairs)  # no two alike


def test_harness_energy_says_what_the_nightlys_energy_cell_says(first_run, capsys):
    """One rule for both (``harness.measures.energy.energy_figures``): for every energy cell of the
    smoke run, ``harness energy --json`` at the cell's dt, steps and recording gives the same max
    and final |dE/E| and the same class, bit for bit."""
    from harness.nightly.cell_kit import energy_run
    from scenarios import make_scene

    tmp, _, _ = first_run
    suite = SUITES["smoke"]
    cells = [c for c in History(tmp / "h.sqlite").cell_records(1) if c.measure == "energy"]
    assert len(cells) >= 7
    for c in cells:
        scene = make_scene(c.scene)
        _, every = energy_run(scene, c.dt, suite.scenes[c.scene], suite)
        assert (
            main(
                [
                    "energy",
                    c.scene,
                    "--method",
                    c.method,
                    "--dt",
                    repr(c.dt),
                    "--steps",
                    str(c.steps),
                    "--every",
                    str(every),
                    "--json",
                ]
            )
            == 0
        )
        res = json.loads(capsys.readouterr().out)
        assert res["max_rel_error"] == c.value, c.method
        assert res["final_rel_error"] == c.figures.final_rel_error, c.method
        assert res["classification"] == c.figures.energy_class and res["rule"] == c.figures.rule, c.method


@pytest.mark.parametrize("method", SUITES["smoke"].methods)
def test_each_command_says_what_the_nightlys_cell_says(first_run, method, capsys):
    """One code path per measure: ``harness order``, ``stability`` and ``cost`` with the smoke
    suite's settings give the figures of the smoke run's cells, bit for bit (cost: the counted
    evaluations, and the figures of the module's injected timings)."""
    tmp, _, _ = first_run
    suite, spec = SUITES["smoke"], SUITES["smoke"].scenes["spring"]
    cells = {c.measure: c for c in History(tmp / "h.sqlite").cell_records(1) if c.method == method}

    def command(*argv):
        assert main([*argv, "spring", "--method", method, "--json"]) == 0
        return json.loads(capsys.readouterr().out)

    order = command(
        "order",
        "--points",
        str(spec.order_points),
        "--span",
        repr(spec.order_span),
        "--periods",
        repr(spec.order_periods),
    )
    assert order["order"] == cells["order"].value and order["points"] == cells["order"].figures.points
    stab = command("stability", "--steps", str(suite.stability_steps), "--hi", repr(suite.stability_homega_max))
    assert (math.inf if stab["verdict"] == "unbounded" else stab["omega_dt_max"]) == cells["stability"].value
    cost = command("cost", "--dt", repr(cells["cost"].dt), "--repeats", str(suite.cost_repeats))
    assert cost["force_evals_per_step"] == cells["cost"].figures.force_evals_per_step
    assert cost["s_per_step"] == cells["cost"].value and cost["clock"] == "injected"
    assert cost["ratio_to_explicit_euler"] == cells["cost"].figures.ratio_to_explicit_euler


def test_the_standard_suite_bisects_stability_to_its_own_width(monkeypatch):
    """The standard suite's stability cells bisect to STANDARD_STABILITY_RTOL (a scene's own width
    wins, as a model file's 1e-4 does); the measure's default stays 1e-6 elsewhere."""
    from harness.measures import stability
    from harness.methods import get_method
    from harness.nightly import cells
    from harness.nightly.run import Task
    from harness.nightly.suites import STANDARD_STABILITY_RTOL, SUITES
    from scenarios import make_scene

    seen = []
    real = stability.largest_stable_dt
    monkeypatch.setattr(stability, "largest_stable_dt", lambda *a, **k: seen.append(k.get("rtol")) or real(*a, **k))
    suite, spec = SUITES["standard"], SUITES["standard"].scenes["spring"]
    task = Task("cell", "spring", "ref:leapfrog", "ref", {}, "standard")
    cell = cells._stability(task, get_method("ref:leapfrog"), make_scene("spring"), suite, spec)
    assert seen == [STANDARD_STABILITY_RTOL] == [1e-4] and SUITES["full"].stability_rtol is None
    assert cell.value == pytest.approx(2.0, rel=2e-4)  # leapfrog's h*omega = 2, to the bisection's width


def test_a_method_at_options_of_its_own_is_one_more_task_of_its_scene():
    """``SceneSpec.with_options``: XPBD at one pass a step is a method of its own on the cloth and
    the rope (its own cells, its own history series), resolved in the task with those options."""
    from harness.nightly.cells import context
    from harness.nightly.run import build_tasks
    from harness.nightly.suites import SUITES

    tasks, _ = build_tasks(SUITES["standard"])
    small = [t for t in tasks if t.method == "ref:xpbd?iterations=1"]
    assert sorted(t.scene for t in small) == ["cloth", "rope"]
    ctx = context(small[0])
    assert ctx.method.options == {"iterations": 1} and ctx.method.id == "ref:xpbd?iterations=1"
    assert any(t.method == "ref:xpbd" and t.scene == "cloth" for t in tasks)


def test_a_mode_the_scene_cannot_pose_gives_that_reason_not_the_suites_selection():
    """The standard suite leaves most Drake modes out of the cloth, which Drake does not pose: the
    skipped list says Drake's reason; a mode the suite leaves out where it could run says so."""
    from harness.nightly.run import build_tasks
    from harness.nightly.suites import SUITES

    _, skipped = build_tasks(SUITES["standard"])
    why = {(s["scene"], s["method"]): s["reason"] for s in skipped}
    if ("cloth", "drake:runge_kutta3") in why:  # Drake installed or not, never "left out"
        assert "left out" not in why[("cloth", "drake:runge_kutta3")]
    from harness.methods import get_method

    if get_method("drake:runge_kutta3").available()[0]:
        assert (
            why[("chain", "drake:runge_kutta3")]
            == "left out on chain in the standard suite (harness/nightly/suites.py)"
        )
