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


def test_committed_bounds_hold(energy_bound):
    """The reviewed bounds file, run through the pytest plugin: one line per bound."""
    for b in bounds_mod.load():
        if b.method.startswith("ref:"):
            energy_bound(b.method, b.scene, dt=b.dt, steps=b.steps, bound=b.bound)


def test_bad_suite_is_one_line_exit_2(capsys):
    assert main(["nightly", "--suite", "huge"]) == 2
    assert "valid: smoke, standard, full" in capsys.readouterr().err
