"""``harness nightly --resume``: a nightly killed (SIGKILL, no handler runs) during a task, during a
task's store and during its report, each resumed to exactly the cells of a run never killed.

Every run here records injected timings (``HARNESS_INJECT_TIMINGS``), so that the cost cells
(and the advice drawn from them) are as deterministic as the accuracy figures, and a cell of the
resumed run can be held to its unkilled twin bit for bit. The suite is the least that has every
kind of task: a reference scheme and an engine mode on the spring (each with its energy, error,
order, cost, identity, advice and stability cells) and one reviewed energy bound.
"""

import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.cli import main
from harness.history import bounds as bounds_mod
from harness.history.storage import History
from harness.nightly.run import run_nightly
from harness.nightly.suites import SUITES, SceneSpec, Suite

ROOT = Path(__file__).resolve().parents[1]
SUITE = Suite(
    "resume-smoke",
    scenes={"spring": SceneSpec(periods=2, order_span=2.0, advise=SUITES["smoke"].scenes["spring"].advise)},
    methods=("ref:semi_implicit_euler", "mujoco:euler"),
    cost_repeats=3,
    bounds=True,
    identify=True,
    cell_timeout=120.0,
    frame_rates=SUITES["smoke"].frame_rates,
)
BOUND = bounds_mod.Bound("spring", "ref:semi_implicit_euler", 0.1, 2000, 0.079)
TIMINGS = {
    "s_per_step": {
        "ref:explicit_euler": 3.9e-9,
        "ref:semi_implicit_euler": 7.6e-9,
        "ref:rk4": 1.6e-8,
        "mujoco:euler": 1.2e-6,
        "pymunk:applied_force": 3.1e-6,
    },
    "jitter": [1.0, 1.03, 0.98],
    "calibration": {"python": 5e-8, "compiled": 4e-9},
}
#: What a run spent rather than what it measured, which differs between any two runs: seconds, the
#: kernels a worker compiled or loaded (which worker ran what first), and the steps a timing ran
#: (from a pilot read off the clock).
CLOCKED = {
    "wall_s",
    "warmup_s",
    "setup_s",
    "kernels",
    "time_steps",
    *(f"{p}_{k}" for p in ("baseline", "as_stepped") for k in ("warmup_s", "setup_s", "time_steps")),
}

#: One nightly of ``SUITE`` in a process of its own (so that it can be killed), its arguments the
#: output directory, the history, the bounds file and whether to resume.
NIGHTLY = (
    "import sys; from pathlib import Path; from harness.nightly.run import run_nightly; "
    "from tests.test_resume import SUITE; "
    "run_nightly(SUITE, Path(sys.argv[1]), Path(sys.argv[2]), jobs=2, bounds_path=Path(sys.argv[3]), "
    "resume=sys.argv[4] == 'resume')"
)


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("resume")
    bounds = tmp / "bounds.csv"
    bounds_mod.save([BOUND], bounds)
    timings = tmp / "timings.json"
    timings.write_text(json.dumps(TIMINGS))
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HARNESS_INJECT_TIMINGS", str(timings))
        yield tmp, bounds


def env(**extra) -> dict:
    return {
        **os.environ,
        **extra,
        "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
    }


def start(tmp: Path, bounds: Path, mode: str = "new", **extra) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", NIGHTLY, str(tmp / "out"), str(tmp / "h.sqlite"), str(bounds), mode],
        cwd=ROOT,
        env=env(**extra),
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def tasks_stored(db: Path) -> int:
    if not db.exists():
        return 0
    with sqlite3.connect(db) as con:
        try:
            return con.execute("SELECT COUNT(*) FROM tasks").fetchone()[0]
        except sqlite3.OperationalError:
            return 0


def cells_of(db: Path, run_id: int = 1) -> dict:
    """{(scene, method, measure, dt): (status, detail, value, data less what the clock read)}."""
    out = {}
    for c in History(db).cells(run_id).to_dict("records"):
        data = {k: v for k, v in (c["data"] or {}).items() if k not in CLOCKED}
        dt = None if c["dt"] is None or (isinstance(c["dt"], float) and math.isnan(c["dt"])) else c["dt"]
        value = c["value"]
        value = "nan" if isinstance(value, float) and math.isnan(value) else value
        out[(c["scene"], c["method"], c["measure"], dt)] = (
            c["status"],
            c["detail"],
            value,
            json.dumps(data, sort_keys=True, default=str),
        )
    return out


@pytest.fixture(scope="module")
def unkilled(setup):
    tmp, bounds = setup
    run = tmp / "unkilled"
    run.mkdir()
    run_nightly(SUITE, run / "out", run / "h.sqlite", jobs=2, bounds_path=bounds)
    return cells_of(run / "h.sqlite")


def killed_and_resumed(tmp: Path, bounds: Path, where: str) -> dict:
    """A nightly killed at ``where`` ("task": from outside, its first task stored; "store",
    "report": at that kill point), then ``--resume``d in a process of its own."""
    if where == "task":
        proc = start(tmp, bounds)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None and not tasks_stored(tmp / "h.sqlite"):
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGKILL)
    else:
        proc = start(tmp, bounds, HARNESS_KILL_AT="store:2" if where == "store" else "report")
    proc.wait(timeout=300)
    h = History(tmp / "h.sqlite")
    seen = {
        "returncode": proc.returncode,
        "complete_after_kill": list(h.runs().run_id),
        "tasks_after_kill": len(h.done_tasks(1)),
        "integrity": h.integrity_ok(),
    }
    resumed = start(tmp, bounds, "resume")
    seen["resume_stderr"] = resumed.communicate(timeout=300)[1]
    seen["resume_returncode"] = resumed.returncode
    seen["runs"] = list(History(tmp / "h.sqlite").runs(complete_only=False).run_id)
    seen["complete"] = list(History(tmp / "h.sqlite").runs().run_id)
    seen["cells"] = cells_of(tmp / "h.sqlite")
    report = tmp / "out" / "report.md"
    assert report.is_file(), (
        "the resumed run wrote no report",
        seen["resume_returncode"],
        seen["resume_stderr"][-3000:],
    )
    seen["report"] = report.read_text()
    return seen


@pytest.mark.parametrize("where", ["task", "store", "report"])
def test_a_killed_nightly_resumes_to_the_cells_of_an_unkilled_one(setup, unkilled, where, tmp_path):
    _, bounds = setup
    seen = killed_and_resumed(tmp_path, bounds, where)
    assert seen["returncode"] == -signal.SIGKILL and seen["integrity"]
    assert seen["complete_after_kill"] == []  # the killed run is stored, never complete
    if where == "store":
        assert seen["tasks_after_kill"] == 1  # the second task's store was killed: not half stored
    if where == "report":
        assert seen["tasks_after_kill"] == len(SUITE.methods) + 1  # every task (a cell a method, 1 bound) stored,
        # the report not written
    assert seen["resume_returncode"] == 0, seen["resume_stderr"][-2000:]
    assert seen["runs"] == seen["complete"] == [1]  # the same run, now complete: no second run
    assert seen["cells"].keys() == unkilled.keys()
    for key, cell in unkilled.items():
        assert seen["cells"][key] == cell, key  # bitwise: values and every figure but the clocks'
    footer = seen["report"].split("\n---\n")[1]
    assert "Resumed: this run was killed and continued 1 time(s)" in footer


def test_resume_refuses_a_complete_run_and_a_run_measured_otherwise(setup, tmp_path, capsys):
    tmp, bounds = setup
    db = tmp_path / "h.sqlite"
    argv = ["nightly", "--suite", "smoke", "--out", str(tmp_path / "out"), "--db", str(db), "--resume"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--resume: no smoke run in" in err and "run without --resume" in err
    h = History(db)
    run = h.start_run(
        started="2026-11-25T02:00:00+00:00",
        suite="smoke",
        git_commit="a" * 40,
        versions={},
        machine={},
        settings={"cell_timeout": 1.0},
    )
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--resume: run {run} was measured otherwise (commit: " in err
    h.finish_run(run, finished="t", wall_s=1.0, timing={}, regressions=0)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"run {run}, is complete: nothing to resume" in err
    assert list(History(db).runs(complete_only=False).run_id) == [run]  # nothing added
