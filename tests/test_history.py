"""The nightly as a history: step detection, ``harness history``, cost judged over the history in
``harness compare`` and the nightly, the report's History section, histories across schema changes.

The end-to-end runs use the smallest matrix that shows it: the spring with one engine mode from
``tests/slow_plugin.py`` (about 5 s a nightly here), three nights as they are, then one with its
step slowed; each nightly in a process of its own, as ``harness nightly`` runs.
"""

import contextlib
import io
import json
import math
import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from harness.history import step_detect
from harness.cli import main
from harness.history.compare import compare_cells
from harness.history.series import what_differs
from harness.history.storage import MEASUREMENT_VERSION, History
from harness.nightly.suites import SceneSpec, Suite
from tests.shared_fixture import built_once
from tests.slow_plugin import SLOWDOWN_VAR

ROOT = Path(__file__).resolve().parents[1]
SLOW = "slowtest:semi_implicit"
SUITE = Suite(
    "history-smoke",
    scenes={"spring": SceneSpec(periods=2, order_span=2.0, stability=False)},
    methods=(),
    cost_repeats=3,
    bounds=False,
    identify=False,
    cell_timeout=60.0,
)

# ----------------------------------------------------------------------------- synthetic series
#: Nights in a synthetic history, and the seeds each kind of series is drawn with.
NIGHTS, SEEDS = 12, range(25)
#: Night-to-night noise of a cost ratio: lognormal, 2% (explicit Euler's process-to-process
#: spread, harness.history.compare); each night's repeats spread 3-8% (the smoke suite's: 0.4-14%).
NOISE, SPREAD = 0.02, (0.03, 0.08)


def synthetic(kind: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A cost ratio of 4 over ``NIGHTS`` nights with noise: ``flat``; ``drift`` (3% a night);
    ``step`` (25% from night 7 on); ``noisy`` (night 6 alone 35% up, its repeats spread 35%);
    ``noisy_quiet`` (the same night, its repeats spread as any other's)."""
    rng = np.random.default_rng(seed)
    y = 4.0 * np.exp(rng.normal(0.0, NOISE, NIGHTS))
    spread = rng.uniform(*SPREAD, NIGHTS)
    if kind == "drift":
        y *= 1.03 ** np.arange(NIGHTS)
    elif kind == "step":
        y[7:] *= 1.25
    elif kind in ("noisy", "noisy_quiet"):
        y[6] *= 1.35
        if kind == "noisy":
            spread[6] = 0.35
    return y, spread


def test_the_detector_flags_a_drift_and_a_step_and_not_a_noisy_night():
    for seed in SEEDS:
        drift = step_detect.detect_steps(*synthetic("drift", seed))
        assert drift.steps and all(s.after > s.before for s in drift.steps), seed
        found = drift.regression()
        assert found is not None, seed
        # 11 nights of 3% is +38%; the staircase's first and last levels are medians of several
        # nights each, so they span part of it: +25% on average over 200 seeds, +12% at least.
        assert found[2] / found[1] - 1 > 0.10, seed

        step = step_detect.detect_steps(*synthetic("step", seed))
        assert [s.index for s in step.steps] == [7], seed
        # The levels are weighted medians of 5 and 7 noisy nights: over 200 seeds the size's
        # standard deviation is 0.018; 4 of them.
        assert step.steps[0].size == pytest.approx(0.25, abs=0.075), seed
        assert step.steps[0].confidence > 0.999, seed
        assert step.regression() is not None and step.regression()[0] == 7, seed

        for kind in ("noisy", "noisy_quiet", "flat"):
            fit = step_detect.detect_steps(*synthetic(kind, seed))
            assert fit.steps == () and fit.regression() is None, (kind, seed)


def test_a_step_down_is_not_a_regression_and_a_falling_order_is():
    y, spread = synthetic("step", 0)
    faster = step_detect.detect_steps(1.0 / y, spread)
    assert [s.index for s in faster.steps] == [7] and faster.steps[0].size < -0.15
    assert faster.regression() is None  # cost fell
    assert faster.regression(worse_if_higher=False) is not None  # a figure where lower is worse


def test_the_latest_night_weighs_by_its_spread():
    """A last night 30% up is a step when its repeats agree (5%), and not when they spread as
    much as the jump (35%): asv's weighting by each point's measured noise."""
    y, spread = synthetic("flat", 3)
    y[-1] *= 1.30
    spread[-1] = 0.05
    assert [s.index for s in step_detect.detect_steps(y, spread).steps] == [NIGHTS - 1]
    spread[-1] = 0.35
    assert step_detect.detect_steps(y, spread).steps == ()


def test_a_short_history_uses_the_prior_noise():
    # 3 nights: the noise is not estimated from 2 differences but taken as PRIOR_NOISE (7%):
    # a last night 20% up (2.6 units) is not a step, one 3x up is.
    assert step_detect.detect_steps([4.0, 4.1, 4.8]).steps == ()
    fit = step_detect.detect_steps([4.0, 4.1, 12.0])
    assert fit.noise == step_detect.PRIOR_NOISE and [s.index for s in fit.steps] == [2]
    with pytest.raises(ValueError):
        step_detect.detect_steps([4.0, 0.0, 4.0])


def test_the_prior_and_the_floor_are_policy_and_set_what_a_history_reports():
    """Issue 52: PRIOR_NOISE and NOISE_FLOOR are policy (step_detect's docstring), and what they set
    holds: a young series reports the newest night as a level from exp(PENALTY x PRIOR_NOISE) on; a
    series that agrees exactly is credited NOISE_FLOOR, never zero noise, the newest night a level
    from exp(PENALTY x NOISE_FLOOR) on and a level held over nights a regression from
    exp(REGRESSION_NOISE x NOISE_FLOOR) on."""
    young = math.exp(step_detect.PENALTY * step_detect.PRIOR_NOISE)
    assert step_detect.detect_steps([4.0, 4.0, 4.0 * young * 0.98]).steps == ()
    fit = step_detect.detect_steps([4.0, 4.0, 4.0 * young * 1.02])
    assert fit.noise == step_detect.PRIOR_NOISE and [s.index for s in fit.steps] == [2]
    lone = math.exp(step_detect.PENALTY * step_detect.NOISE_FLOOR)
    assert step_detect.detect_steps([4.0] * 9).noise == step_detect.NOISE_FLOOR
    assert step_detect.detect_steps([4.0] * 8 + [4.0 * lone * 0.98]).steps == ()
    assert [s.index for s in step_detect.detect_steps([4.0] * 8 + [4.0 * lone * 1.02]).steps] == [8]
    held = math.exp(step_detect.REGRESSION_NOISE * step_detect.NOISE_FLOOR)
    assert step_detect.detect_steps([4.0] * 6 + [4.0 * held * 0.99] * 6).regression() is None
    assert step_detect.detect_steps([4.0] * 6 + [4.0 * held * 1.01] * 6).regression() is not None


# ----------------------------------------------------------------------------- compare, synthetic history
def stored_history(path, ratios, spreads=None, commits=None) -> History:
    """A history of one cost cell (``ref:rk4`` on the spring), one complete smoke run a night."""
    h = History(path)
    for i, ratio in enumerate(ratios):
        run = h.start_run(
            started=f"2026-11-{i + 1:02d}T02:00:00+00:00",
            suite="smoke",
            git_commit=(commits or [f"{i:040x}"] * len(ratios))[i],
            versions={"mujoco": "4.0.0"},
            machine={"system": "Linux"},
            settings={},
        )
        h.add_cell(
            run,
            {
                "scene": "spring",
                "method": "ref:rk4",
                "family": "ref",
                "measure": "cost",
                "dt": 0.1,
                "steps": 1000,
                "status": "ok",
                "value": 1e-7 * ratio,
                "data": {
                    "ratio_to_explicit_euler": float(ratio),
                    "ratio_spread": float(spreads[i]) if spreads is not None else 0.05,
                },
            },
        )
        h.add_cell(
            run,
            {
                "scene": "spring",
                "method": "ref:rk4",
                "family": "ref",
                "measure": "energy",
                "dt": 0.1,
                "steps": 1000,
                "status": "ok",
                "value": 2.5e-6,
                "data": {},
            },
        )
        h.finish_run(run, finished="t", wall_s=1.0, timing={}, regressions=0)
    return h


def run_cli(*argv) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def test_compare_judges_a_drift_over_the_history_that_the_last_two_rule_misses(tmp_path):
    y, spread = synthetic("drift", 0)
    h = stored_history(tmp_path / "h.sqlite", y, spread)
    last_two = compare_cells(h.cells(NIGHTS - 1), h.cells(NIGHTS), [])
    assert last_two == []  # 3% a night never crosses a night-to-night threshold
    code, out, _ = run_cli("compare", "--db", str(tmp_path / "h.sqlite"))
    assert code == 1 and f"against run {NIGHTS - 1} (cost over the last {NIGHTS} runs)" in out
    assert "REGRESSION slowdown: ref:rk4 on spring at dt=0.1: cost ratio to explicit Euler level" in out


def test_compare_passes_a_noisy_night_once_the_history_has_moved_on(tmp_path):
    y, spread = synthetic("noisy_quiet", 0)
    y[6] *= 1.6 / 1.35  # 1.6x: the last-two rule flags it on its night (1.6 > 1 + 0.05 + 0.05 + 0.5)
    h = stored_history(tmp_path / "h.sqlite", y, spread)
    assert [r.kind for r in compare_cells(h.cells(6), h.cells(7), [])] == ["slowdown"]
    assert run_cli("compare", "--db", str(tmp_path / "h.sqlite"))[0] == 0
    code, out, _ = run_cli("history", "--db", str(tmp_path / "h.sqlite"), "--measure", "cost", "--json")
    cell = json.loads(out)["cells"][0]
    assert code == 0 and cell["steps"] == [] and cell["regression"] is None and len(cell["points"]) == NIGHTS


def test_before_three_runs_the_last_two_rule_judges(tmp_path):
    stored_history(tmp_path / "h.sqlite", [4.0, 6.5])  # 1.63x, beyond the last-two rule's 1.6x
    code, out, _ = run_cli("compare", "--db", str(tmp_path / "h.sqlite"), "--json")
    result = json.loads(out)
    assert code == 1 and result["judged_by_history"] is False
    assert [r["kind"] for r in result["regressions"]] == ["slowdown"]


def test_an_accuracy_figure_that_changes_is_reported_at_once_with_its_commits(tmp_path):
    commits = [f"{c}" * 40 for c in "aab"]
    h = stored_history(tmp_path / "h.sqlite", [4.0, 4.0, 4.0], commits=commits)
    cells = h.cells(3)
    row = cells[cells.measure == "energy"].iloc[0].to_dict()
    h.add_cell(3, {**row, "value": 2.5e-6 * (1 + 1e-12)})  # the last bits of a deterministic figure
    code, out, _ = run_cli("compare", "--db", str(tmp_path / "h.sqlite"))
    assert code == 0  # a change is reported; the regression rules for accuracy are compare's own
    assert "CHANGE energy: ref:rk4 on spring: 2.5e-06 -> 2.5e-06 (worse); code aaaaaaaaaa..bbbbbbbbbb" in out
    code, out, _ = run_cli("history", "--db", str(tmp_path / "h.sqlite"), "--measure", "energy", "--json")
    (change,) = json.loads(out)["cells"][0]["steps"]
    assert change["run"] == 3 and change["previous_run"] == 2 and change["confidence"] is None
    assert change["commits"] == "aaaaaaaaaa..bbbbbbbbbb" and change["worse"] is True


def calibrated_history(path, ratios, calibrations, commits) -> History:
    """``stored_history`` with the calibration timed beside each night's cost cell."""
    h = stored_history(path, ratios, commits=commits)
    for run, cal in enumerate(calibrations, start=1):
        row = h.cells(run).query("measure == 'cost'").iloc[0].to_dict()
        h.add_cell(run, {**row, "data": {**row["data"], "calibration": cal}})
    return h


def test_a_cost_step_where_nothing_changed_is_the_machines_never_a_confident_regression(tmp_path):
    # Six nights of one commit, the last three with a neighbour: the ratio up 38%. The fit finds
    # the step; nothing the cell depends on differs across it, so it is the machine's.
    calibrated_history(tmp_path / "h.sqlite", [4.0, 4.04, 3.98, 5.5, 5.52, 5.49], [50.0] * 6, ["a" * 40] * 6)
    code, out, _ = run_cli("history", "--db", str(tmp_path / "h.sqlite"), "--measure", "cost", "--json")
    (cell,) = json.loads(out)["cells"]
    assert code == 0 and cell["steps"] == [] and cell["regression"] is None
    (step,) = cell["machine_steps"]
    assert step["run"] == 4 and step["confidence"] is None
    assert step["cause"] == "same code, engine versions and platform: the machine's noise"
    assert run_cli("compare", "--db", str(tmp_path / "h.sqlite"))[0] == 0
    # The last-two rule alike: 4.0 -> 6.5 is beyond 1.6x, but nothing differs.
    h2 = calibrated_history(tmp_path / "h2.sqlite", [4.0, 6.5], [50.0] * 2, ["a" * 40] * 2)
    assert compare_cells(h2.cells(1), h2.cells(2), []) != []
    assert run_cli("compare", "--db", str(tmp_path / "h2.sqlite"))[0] == 0


def test_a_cost_step_is_credited_with_the_calibrations_move(tmp_path):
    commits = [f"{c}" * 40 for c in "aaabbb"]
    ratios = [4.0, 4.04, 3.98, 5.5, 5.52, 5.49]  # +38% with the code changed at run 4
    # The calibration moved +35% with it (a neighbour since run 4): what remains is within noise.
    calibrated_history(tmp_path / "moved.sqlite", ratios, [50.0] * 3 + [67.5] * 3, commits)
    (cell,) = json.loads(run_cli("history", "--db", str(tmp_path / "moved.sqlite"), "--measure", "cost", "--json")[1])[
        "cells"
    ]
    assert cell["steps"] == [] and cell["regression"] is None
    (step,) = cell["machine_steps"]
    assert step["cause"] == "within the machine's noise: the calibration moved +35% across it"
    assert step["confidence"] < 0.95
    # The calibration steady: the same step is the method's, with its commits, and a regression.
    calibrated_history(tmp_path / "steady.sqlite", ratios, [50.0] * 6, commits)
    code, out, _ = run_cli("history", "--db", str(tmp_path / "steady.sqlite"), "--measure", "cost", "--json")
    (cell,) = json.loads(out)["cells"]
    (step,) = cell["steps"]
    assert code == 1 and step["run"] == 4 and step["commits"] == "aaaaaaaaaa..bbbbbbbbbb" and step["confidence"] > 0.99
    assert cell["regression"]["kind"] == "slowdown" and cell["machine_steps"] == []


def test_what_differs_between_two_runs():
    a = {
        "run_id": 1,
        "suite": "smoke",
        "started": "t",
        "measurement_version": MEASUREMENT_VERSION,
        "git_commit": "a" * 40,
        "versions": {"mujoco": "3.3.0", "numpy": "2.4.6"},
        "machine": {"system": "Linux"},
    }
    b = {**a, "versions": {"mujoco": "4.0.0", "numpy": "2.4.6"}}
    assert what_differs(a, b, "mujoco") == "mujoco 3.3.0 -> 4.0.0"
    assert what_differs(a, b, "ref") == "same code, engine versions and platform: the figure is not deterministic"
    c = {**a, "git_commit": "b" * 40, "machine": {"system": "Darwin"}}
    assert what_differs(a, c, "ref", deterministic=False) == (
        "code aaaaaaaaaa..bbbbbbbbbb; platform system Linux -> Darwin"
    )
    # A dirty tree's commit says nothing of its code: the code digest does, where both runs have it.
    d = {**a, "git_commit": "a" * 40 + "+dirty"}
    assert what_differs(d, d, "ref", deterministic=False).startswith("code ")
    d1, d2 = ({**d, "settings": {"code_digest": x}} for x in ("1234", "5678"))
    assert what_differs(d1, d1, "ref", deterministic=False) == "same code, engine versions and platform"
    assert what_differs(d1, d2, "ref", deterministic=False) == (
        "code aaaaaaaaaa+dirty (same commit), its uncommitted changes differ"
    )
    # A plugin's version is one more package every family depends on.
    p1, p2 = ({**a, "versions": {**a["versions"], "plugin my.modes": v}} for v in ("1", "2"))
    assert what_differs(p1, p2, "ref", deterministic=False) == "plugin my.modes 1 -> 2"


# ----------------------------------------------------------------------------- end to end
#: One nightly of ``SUITE`` in a process of its own, as ``harness nightly`` runs: the environment
#: it is given (``HARNESS_TEST_SLOWDOWN``) reaches its workers. Prints its run id and regressions.
NIGHTLY = (
    "import json, sys; from pathlib import Path; from harness.nightly.run import run_nightly; "
    "from tests.test_history import SUITE; "
    "r = run_nightly(SUITE, Path(sys.argv[1]), Path(sys.argv[2]), jobs=1); "
    "print(json.dumps({'run_id': r['run_id'], 'regressions': [g.as_dict() for g in r['regressions']]}))"
)


#: The timings the end-to-end nightlies record instead of the clock's (``HARNESS_INJECT_TIMINGS``):
#: no test's outcome may depend on the machine's load. The plugin's step at 4.8 us (48x explicit
#: Euler, as measured here), 20 us slowed by 300 updates a step (about 4x); repeats 1-2% apart;
#: the calibration pair the same every night.
def timings(slowdown: int) -> dict:
    return {
        "s_per_step": {"ref:explicit_euler": 1e-7, SLOW: 4.8e-6 if slowdown == 1 else 2.0e-5},
        "jitter": [1.0, 1.02, 0.99],
        "calibration": {"python": 5e-7, "compiled": 1e-8},
    }


def nightly_process(tmp, slowdown: int) -> dict:
    injected = tmp / f"timings-{slowdown}.json"
    injected.write_text(json.dumps(timings(slowdown)))
    env = {
        **os.environ,
        "HARNESS_PLUGINS": "tests.slow_plugin",
        SLOWDOWN_VAR: str(slowdown),
        "HARNESS_INJECT_TIMINGS": str(injected),
        "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
    }
    done = subprocess.run(
        [sys.executable, "-c", NIGHTLY, str(tmp / "out"), str(tmp / "h.sqlite")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _four_nights(tmp):
    seen = {"results": [nightly_process(tmp, 1) for _ in range(3)]}
    seen["report3"] = (tmp / "out" / "report.md").read_text()
    seen["history3"] = run_cli("history", "--db", str(tmp / "h.sqlite"), "--json")
    seen["results"].append(nightly_process(tmp, 300))
    seen["report4"] = (tmp / "out" / "report.md").read_text()
    return tmp, seen


@pytest.fixture(scope="module")
def nights(tmp_path_factory):
    """Three nightlies of the small suite as they are, then one with the plugin's step slowed
    (once per test run: its tests read the history, or copy it to change it)."""
    return built_once(tmp_path_factory, "history-nights", _four_nights)


def _section(report: str, title: str) -> str:
    return report.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]


def test_three_nightlies_give_three_points_per_cell_and_an_unchanged_history(nights):
    _, seen = nights
    assert [r["regressions"] for r in seen["results"][:3]] == [[], [], []]
    code, out, _ = seen["history3"]
    trend = json.loads(out)
    assert code == 0 and [r["run"] for r in trend["runs"]] == [1, 2, 3] and trend["judged_by_history"]
    assert {c["measure"] for c in trend["cells"]} == {"energy", "error", "order", "cost"}
    for cell in trend["cells"]:
        assert [p["run"] for p in cell["points"]] == [1, 2, 3] and cell["steps"] == []
    cost = next(c for c in trend["cells"] if c["measure"] == "cost")
    assert cost["unit"] == "x explicit Euler" and [p["value"] for p in cost["points"]] == [pytest.approx(48.0)] * 3
    assert all(p["calibration"] == pytest.approx(50.0) for p in cost["points"])
    section = [line for line in _section(seen["report3"], "History").splitlines() if line.strip()]
    assert len(section) == 1 and "**Unchanged**" in section[0] and "runs 1, 2, 3" in section[0]


def test_a_slowed_method_is_flagged_as_a_step_on_the_run_after_it_slows(nights):
    tmp, seen = nights
    (reg,) = seen["results"][3]["regressions"]
    assert (reg["kind"], reg["method"], reg["measure"]) == ("slowdown", SLOW, "cost")
    assert "since run 4" in reg["detail"] and reg["after"] / reg["before"] == pytest.approx(2.0e-5 / 4.8e-6)
    code, out, _ = run_cli("history", "--db", str(tmp / "h.sqlite"), "--method", SLOW, "--measure", "cost", "--json")
    (cell,) = json.loads(out)["cells"]
    assert code == 1 and [p["run"] for p in cell["points"]] == [1, 2, 3, 4]
    (step,) = cell["steps"]
    assert step["run"] == 4 and step["worse"] and step["size"] > 1.0 and step["confidence"] > 0.999
    assert step["cause"] == "plugin tests.slow_plugin 1.0+repeat1 -> 1.0+repeat300" and cell["machine_steps"] == []
    assert cell["regression"]["kind"] == "slowdown"
    # The accuracy figures did not move: the slowed step computes the same update.
    code, out, _ = run_cli("history", "--db", str(tmp / "h.sqlite"), "--measure", "energy", "--json")
    assert json.loads(out)["cells"][0]["steps"] == []
    history = _section(seen["report4"], "History")
    assert f"| `{SLOW}` on spring | cost |" in history and "| 4 |" in history and "**regression**" in history
    chart = history.split("](", 1)[1].split(")", 1)[0]
    assert chart == "charts/run4-history-0.png" and (tmp / "out" / chart).stat().st_size > 1000
    verdict = _section(seen["report4"], "Verdict")
    assert f"slowdown: {SLOW} on spring at dt=0.1" in verdict and "cost judged over the last 4 runs" in verdict
    code, out, _ = run_cli("compare", "--db", str(tmp / "h.sqlite"))
    assert code == 1 and f"REGRESSION slowdown: {SLOW} on spring" in out


@pytest.mark.parametrize(
    "argv, says",
    [
        (["--scene", "moon"], "unknown --scene 'moon' in the history-smoke history of"),
        (["--method", "ref:nope"], "unknown --method 'ref:nope' in the history-smoke history of"),
        (["--measure", "speed"], "unknown --measure 'speed' (valid: energy, error, order, stability, cost)"),
        (["--last", "0"], "--last=0 is out of range (allowed: integer from 1 to 1000000000)"),
        (["--last", "-2"], "--last=-2 is out of range (allowed: integer from 1 to 1000000000)"),
        (["--suite", "huge"], "unknown --suite 'huge' in"),
    ],
)
def test_bad_history_input_is_one_line_exit_2(nights, argv, says):
    tmp, _ = nights
    code, out, err = run_cli("history", "--db", str(tmp / "h.sqlite"), *argv)
    assert code == 2 and out == "" and err.count("\n") == 1 and says in err
    if argv[0] in ("--scene", "--method"):
        assert ("valid: spring)" if argv[0] == "--scene" else f"valid: {SLOW})") in err


def test_a_missing_history_is_one_line_exit_2(tmp_path):
    code, _, err = run_cli("history", "--db", str(tmp_path / "none.sqlite"))
    assert code == 2 and err.count("\n") == 1 and "no such history" in err


def test_runs_of_an_older_measurement_version_are_refused_or_read_never_mixed(nights, tmp_path):
    tmp, _ = nights
    db = tmp_path / "old.sqlite"
    shutil.copy(tmp / "h.sqlite", db)
    with sqlite3.connect(db) as con:
        con.execute("UPDATE runs SET measurement_version = 1")
    code, out, err = run_cli("history", "--db", str(db))
    assert code == 2 and err.count("\n") == 1
    assert "holds history-smoke runs of measurement version 1 only" in err and "--measurement-version 1" in err
    code, out, _ = run_cli("history", "--db", str(db), "--measurement-version", "1", "--json")
    assert [r["run"] for r in json.loads(out)["runs"]] == [1, 2, 3, 4]
    with sqlite3.connect(db) as con:  # two old runs and two new ones: the new ones only
        con.execute("UPDATE runs SET measurement_version = ? WHERE run_id > 2", (MEASUREMENT_VERSION,))
    code, out, _ = run_cli("history", "--db", str(db), "--json")
    trend = json.loads(out)
    assert [r["run"] for r in trend["runs"]] == [3, 4] and not trend["judged_by_history"]
    assert trend["left_out"] == (
        f"2 history-smoke run(s) of measurement version 1 left out: not comparable with version {MEASUREMENT_VERSION}"
    )
    assert all([p["run"] for p in c["points"]] == [3, 4] for c in trend["cells"])


def test_a_database_of_an_older_schema_is_refused_in_one_line(tmp_path):
    db = tmp_path / "old.sqlite"
    with sqlite3.connect(db) as con:
        con.execute("CREATE TABLE runs (run_id INTEGER PRIMARY KEY, started TEXT, suite TEXT, git_commit TEXT)")
        con.execute("INSERT INTO runs VALUES (1, '2025-01-01', 'smoke', 'abc')")
    for command in ("history", "compare"):
        code, _, err = run_cli(command, "--db", str(db))
        assert code == 2 and err.count("\n") == 1
        assert "was written by an older harness (runs lacks complete, finished, machine," in err
        assert "not read, never mixed with new runs" in err


def test_segment_medians_are_numpys_weighted_medians():
    from harness.history.step_detect import _segment_costs

    rng = np.random.default_rng(7)
    x, w = rng.normal(size=40), rng.uniform(0.1, 2.0, 40)
    x[5] = x[9]  # ties
    for start in (0, 13, 39):
        medians, costs = _segment_costs(x, w, start)
        for r in range(len(x) - start):
            seg, sw = x[start : start + r + 1], w[start : start + r + 1]
            assert medians[r] == np.quantile(seg, 0.5, weights=sw, method="inverted_cdf")
            assert costs[r] == pytest.approx(np.sum(sw * np.abs(seg - medians[r])), rel=1e-12)


# ----------------------------------------------------------------------------- re-measured before the verdict
def _cost_cell(ratio: float):
    from records.cell import Cell

    return Cell.from_row(
        {
            "scene": "spring",
            "method": "ref:rk4",
            "family": "ref",
            "measure": "cost",
            "dt": 0.1,
            "steps": 1000,
            "status": "ok",
            "value": 1e-7 * ratio,
            "data": {"ratio_to_explicit_euler": ratio, "ratio_spread": 0.02},
        }
    )


#: ``ref:rk4`` on the projectile in six standard nightlies of one commit on this machine (three
#: with a CPU-bound neighbour), judged as if each night were a new commit: runs 1-3 happened to
#: land low, runs 4-6 high, and the fit saw a +14% step; measured again in three fresh processes
#: while the report was being written, 4.91, 5.50, 5.19.
MEASURED = [4.74, 4.61, 4.58, 5.36, 5.26, 4.86]


@pytest.mark.parametrize(
    "nights, again, regressed",
    [
        ([4.0, 4.04, 3.98, 4.02, 4.0, 4.8], (4.0, 4.1, 3.9), False),
        ([4.0, 4.04, 3.98, 4.02, 4.0, 4.8], (4.8, 4.75, 4.85), True),
        (MEASURED, (4.91, 5.50, 5.19), False),
    ],
)
def test_a_slowdown_is_measured_again_in_fresh_processes_before_it_is_reported(
    tmp_path, monkeypatch, nights, again, regressed
):
    """Six nights, each a new commit, the last up in one process: flagged. Measured again in
    three fresh processes: where they fall back, or spread as far as the step (process-to-process
    noise), the night's point is their median, their range the cell's least noise, and no
    slowdown is reported; where they confirm it, it is."""
    from harness.execution import isolation
    from harness.history.compare import compare_runs
    from harness.nightly import run as nightly_run

    h = stored_history(tmp_path / "h.sqlite", nights)
    _, _, regressions = compare_runs(h, None, 6)
    assert [(r.kind, r.method) for r in regressions] == [("slowdown", "ref:rk4")]
    calls = []

    def fake_worker(fn, args, timeout=None):
        (task,) = args
        calls.append((task.kind, task.scene, task.method))
        return [_cost_cell(again[len(calls) - 1])]

    monkeypatch.setattr(isolation, "run_in_worker", fake_worker)
    task = nightly_run.Task("cell", "spring", "ref:rk4", "ref", {}, "smoke")
    got = nightly_run.remeasure_slowdowns(h, 6, [task], regressions, timeout=10.0, jobs=1)
    assert calls == [("cost", "spring", "ref:rk4")] * nightly_run.REMEASURES
    ratios = [nights[-1], *again]
    assert got == {task.label: ratios}
    data = h.cells(6).query("measure == 'cost'").iloc[0].data
    assert data["first_ratio"] == nights[-1] and data["remeasured_ratios"] == list(again)
    assert data["ratio_to_explicit_euler"] == float(np.median(ratios))
    assert data["ratio_spread"] == pytest.approx(max(0.05, (max(ratios) - min(ratios)) / min(ratios)))
    assert data["process_noise"] == pytest.approx(np.log(max(ratios) / min(ratios)) / 2.059)
    _, _, regressions = compare_runs(h, None, 6)
    assert bool(regressions) == regressed


def test_a_run_stored_without_a_commit_is_compared_as_an_unknown_commit():
    """A run whose history row has no commit (made outside a git checkout) reads back from the
    DataFrame as NaN: it is an unknown commit, never a crash of ``harness compare``."""
    from harness.history.series import commit_range

    run = {"run_id": 1, "suite": "standard", "started": "2026-11-28T00:00:00", "measurement_version": 7}
    assert commit_range({**run, "git_commit": float("nan")}, {**run, "git_commit": "a" * 40}) == "unknown..aaaaaaaaaa"
