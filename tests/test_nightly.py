"""The nightly run: smoke suite end to end, regressions, a killed run, failing cells."""
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness import bounds as bounds_mod
from harness.cli import main
from harness.storage import History

SECTIONS = ["## Verdict", "## The trade-off, measured", "## Which scheme each engine mode is", "## Per scene",
            "## Findings", "## Appendix: versions and settings"]


def nightly(tmp, *extra, bounds=None):
    argv = ["nightly", "--suite", "smoke", "--out", str(tmp / "out"), "--db", str(tmp / "h.sqlite"), "--jobs", "2"]
    if bounds:
        argv += ["--bounds", str(bounds)]
    return main(argv + list(extra))


@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("nightly")
    bounds = tmp / "bounds.csv"
    bounds_mod.save([bounds_mod.Bound("spring", "ref:semi_implicit_euler", 0.1, 2000, 0.079)], bounds)
    code = nightly(tmp, bounds=bounds)
    return tmp, bounds, code


def test_smoke_nightly_writes_every_section_and_charts(first_run):
    tmp, _, code = first_run
    assert code == 0
    report = (tmp / "out" / "report.md").read_text()
    for section in SECTIONS:
        assert section in report
    charts = list((tmp / "out" / "charts").glob("*.png"))
    assert {c.name.split("-")[-1] for c in charts} == {"energy.png", "workprecision.png", "stability.png"}
    assert all(c.stat().st_size > 1000 for c in charts)
    for c in charts:
        assert f"charts/{c.name}" in report
    # The trade-off table shows explicit Euler as `grows`, with the textbook agreeing.
    row = next(line for line in report.splitlines() if line.startswith("| `ref:explicit_euler`"))
    assert "grows [grows] ✓" in row


def test_smoke_nightly_stores_a_valid_complete_run(first_run):
    tmp, _, _ = first_run
    h = History(tmp / "h.sqlite")
    assert h.integrity_ok()
    runs = h.runs()
    assert len(runs) == 1 and runs.complete.iloc[0] == 1
    run = runs.iloc[0]
    assert run.suite == "smoke" and run.versions["numpy"] and run.machine["cpus"]
    cells = h.cells(int(run.run_id))
    assert set(cells.measure) >= {"energy", "error", "order", "stability", "cost", "identity", "bound"}
    assert not cells.duplicated(["scene", "method", "measure", "dt"]).any()


def test_unchanged_rerun_exits_0_and_a_tightened_bound_exits_1(first_run):
    tmp, bounds, _ = first_run
    assert nightly(tmp, bounds=bounds) == 0
    assert main(["compare", "--db", str(tmp / "h.sqlite"), "--bounds", str(bounds)]) == 0
    tight = tmp / "tight.csv"
    bounds_mod.save([bounds_mod.Bound("spring", "ref:semi_implicit_euler", 0.1, 2000, 1e-6)], tight)
    assert main(["compare", "--db", str(tmp / "h.sqlite"), "--bounds", str(tight)]) == 1
    assert nightly(tmp, bounds=tight) == 1
    report = (tmp / "out" / "report.md").read_text()
    verdict = report.split("## The trade-off")[0]
    assert "energy bound: ref:semi_implicit_euler on spring" in verdict


def test_a_perturbed_method_is_named_by_compare(first_run, capsys):
    tmp, bounds, _ = first_run
    h = History(tmp / "h.sqlite")
    last = int(h.runs().run_id.iloc[-1])
    cells = h.cells(last)
    row = cells[(cells.method == "ref:rk4") & (cells.measure == "order")].iloc[0].to_dict()
    row["value"] = row["value"] - 1.0  # a method perturbed: its observed order drops by one
    h.add_cell(last, row)
    capsys.readouterr()
    assert main(["compare", "--db", str(tmp / "h.sqlite"), "--bounds", str(bounds)]) == 1
    assert "order: ref:rk4 on spring" in capsys.readouterr().out


def test_bounds_update_never_loosens_silently(tmp_path):
    current = [bounds_mod.Bound("spring", "m", 0.1, 10, 1e-3), bounds_mod.Bound("spring", "n", 0.1, 10, 1e-3)]
    props = {p.bound.method: p for p in bounds_mod.propose(current, {("spring", "m", 0.1, 10): 1e-5,
                                                                    ("spring", "n", 0.1, 10): 5e-3})}
    assert props["m"].action == "tighten" and props["m"].bound.bound == 1.5e-5
    assert props["n"].action == "loosen"
    kept = {b.method: b.bound for b in bounds_mod.apply(current, list(props.values()))}
    assert kept == {"m": 1.5e-5, "n": 1e-3}


def test_committed_bounds_hold(energy_bound):
    """The reviewed bounds file, run through the pytest plugin: one line per bound."""
    for b in bounds_mod.load():
        if b.method.startswith("ref:"):
            energy_bound(b.method, b.scene, dt=b.dt, steps=b.steps, bound=b.bound)


def test_nightly_killed_mid_run_leaves_history_and_report_intact(first_run, tmp_path):
    tmp, bounds, _ = first_run
    work = tmp_path / "k"
    work.mkdir()
    (work / "h.sqlite").write_bytes((tmp / "h.sqlite").read_bytes())
    import shutil

    shutil.copytree(tmp / "out", work / "out")
    before = (work / "out" / "report.md").read_text()
    runs_before = len(History(work / "h.sqlite").runs())
    proc = subprocess.Popen([sys.executable, "-m", "harness", "nightly", "--suite", "smoke", "--out", str(work / "out"),
                             "--db", str(work / "h.sqlite"), "--bounds", str(bounds), "--jobs", "2"],
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline:  # kill once cells are being written
        with sqlite3.connect(work / "h.sqlite") as con:
            if con.execute("SELECT COUNT(*) FROM runs WHERE complete = 0").fetchone()[0]:
                n = con.execute("SELECT COUNT(*) FROM cells WHERE run_id = (SELECT MAX(run_id) FROM runs)").fetchone()[0]
                if n > 0:
                    break
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    h = History(work / "h.sqlite")
    assert h.integrity_ok()
    assert len(h.runs()) == runs_before  # the killed run is not complete
    assert len(h.runs(complete_only=False)) == runs_before + 1
    assert (work / "out" / "report.md").read_text() == before
    code = main(["nightly", "--suite", "smoke", "--out", str(work / "out"), "--db", str(work / "h.sqlite"),
                 "--bounds", str(bounds), "--jobs", "2"])
    assert code == 0 and len(History(work / "h.sqlite").runs()) == runs_before + 1


def test_bad_suite_is_one_line_exit_2(capsys):
    assert main(["nightly", "--suite", "huge"]) == 2
    assert "valid: smoke, standard, full" in capsys.readouterr().err
